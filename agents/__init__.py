"""Training and evaluation of learning agents on the CE-PAM envs (``cepam-gym train`` / ``eval``).

Installed as ``cepam_gym_agents`` (the folder stays ``agents/`` in the repository); its configs
(``configs/``) as the package data ``cepam_gym_agents.configs``. ``cepam_gym`` reaches it only
through the entry points it declares (the ``train`` and ``eval`` commands, the ``agent`` loader
of trained agents as controllers): never by an import.

Needs the ``[train]`` extra (stable-baselines3, torch). Importing this package imports nothing
heavy; the modules do:

| module | what |
|---|---|
| :mod:`cepam_gym_agents.config` | YAML training config as frozen dataclasses, validated |
| :mod:`cepam_gym_agents.features` | what the agent sees and sends (optional baseline residual, history) |
| :mod:`cepam_gym_agents.train` | ``cepam-gym train --config configs/<name>.yaml`` |
| :mod:`cepam_gym_agents.policy` | ``load_policy(run_dir, env)``: a trained agent as a benchmark controller |
| :mod:`cepam_gym_agents.evaluate` | ``cepam-gym eval --run DIR``: the agent beside the baseline |
"""
