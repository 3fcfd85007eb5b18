"""Training and evaluation of learning agents on the CE-PAM envs (``cepam-gym train`` / ``eval``),
and the main job (``cepam-gym run``).

Installed as ``cepam_gym_agents`` (the folder stays ``agents/`` in the repository); its configs
(``configs/``) as the package data ``cepam_gym_agents.configs``. ``cepam_gym`` reaches it only
through the entry points it declares (the ``run``, ``train`` and ``eval`` commands, the ``agent``
loader of trained agents as controllers): never by an import.

Needs the ``[train]`` extra (stable-baselines3, torch). Importing this package imports nothing
heavy; the modules do:

| module of ``cepam_gym_agents`` | what |
|---|---|
| ``config`` | YAML training config: finding and reading the files; every config name |
| ``config_schema`` | the config's sections as frozen dataclasses, each checking its YAML |
| ``agent_config`` | the config's ``agent`` section: what the policy sees and sends beside the env's own |
| ``config_checks`` | ``ConfigError`` and the typed readers of YAML values |
| ``algorithm`` | the SB3 algorithm a config names: class, policy, checks, constructor arguments |
| ``features`` | what the agent sees and sends (baseline residual, history); the policies' input check |
| ``privileged``, ``asymmetric`` | the privileged critic's view and policy |
| ``train`` | ``cepam-gym train --config configs/<name>.yaml`` (the command line) |
| ``trainer`` | one training session: ``train()`` and the ``Trainer`` |
| ``envs`` | the training and evaluation envs a session builds |
| ``callbacks`` | the callback inside ``learn``: logging, evaluations, checkpoints, time limit |
| ``checkpoints`` | a run's saved models, ``checkpoints/`` and what a resume starts from |
| ``lock``, ``signals`` | one session per run directory; SIGTERM as Ctrl-C |
| ``provenance``, ``progress`` | ``run.json``; the progress bar |
| ``policy`` | ``load_policy(run_dir, env)``: a trained agent as a benchmark controller |
| ``evaluate`` | ``cepam-gym eval --run DIR``: the agent beside the baseline |
| ``main_job``, ``main_summary`` | ``cepam-gym run``: the main job, its default config; its ``summary.md`` |
| ``curves`` | the reference learning curves (``python -m cepam_gym_agents.curves``) |
| ``bc``, ``bc_policy`` | behaviour cloning (``python -m cepam_gym_agents.bc``); a BC run as a controller |
"""
