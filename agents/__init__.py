"""Training and evaluation of learning agents on the CE-PAM envs (``cepam-gym train`` / ``eval``).

Needs the ``[train]`` extra (stable-baselines3, torch). Importing this package imports nothing
heavy; the modules do:

| module | what |
|---|---|
| :mod:`agents.config` | YAML training config as frozen dataclasses, validated |
| :mod:`agents.features` | what the agent sees and sends (optional baseline residual, history) |
| :mod:`agents.train` | ``cepam-gym train --config configs/<name>.yaml`` |
| :mod:`agents.policy` | ``load_policy(run_dir, env)``: a trained agent as a benchmark controller |
| :mod:`agents.evaluate` | ``cepam-gym eval --run DIR``: the agent beside the baseline |
"""
