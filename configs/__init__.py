"""The shipped training configs: installed as the package data ``cepam_gym_agents.configs`` and
read with :mod:`importlib.resources`, so ``--config quick`` works from any directory."""
