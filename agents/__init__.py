"""Training and evaluation of learning agents on the CE-PAM envs (``cepam-gym train`` / ``eval``),
and the main job (``cepam-gym run``).

Installed as ``cepam_gym_agents`` (the folder stays ``agents/`` in the repository); its configs
(``configs/``) as the package data ``cepam_gym_agents.configs``. ``cepam_gym`` reaches it only
through the entry points it declares (the ``run``, ``train`` and ``eval`` commands, the ``agent``
loader of trained agents as controllers): never by an import.

Needs the ``[train]`` extra (stable-baselines3, torch). Importing this package imports nothing
heavy; the modules do. The top level holds the commands (``cepam-gym run``, ``train``, ``eval``,
``export``; ``python -m cepam_gym_agents.<command>``) and the ``agent`` loader of trained agents;
the subpackages hold what they are made of. What the agent sees and sends (the baseline
residual, target shifts, history, plant features) is the library's :mod:`cepam_gym.policies`.

| module of ``cepam_gym_agents`` | what |
|---|---|
| ``train`` | ``cepam-gym train --config configs/<name>.yaml`` (the command line) |
| ``evaluate`` | ``cepam-gym eval --run DIR``: the agent beside the baseline |
| ``export`` | ``cepam-gym export --run DIR``: a trained agent as one ONNX file |
| ``main_job``, ``main_summary`` | ``cepam-gym run``: the main job, its default config; its ``summary.md`` |
| ``policy`` | ``load_policy(run_dir, env)``: a trained agent as a benchmark controller |
| ``compare`` | agents against the model-based controllers over training seeds |
| ``curves`` | the reference learning curves (``python -m cepam_gym_agents.curves``) |
| ``reference`` | the recommended version's reference results (``python -m cepam_gym_agents.reference``) |
| ``bc`` | behaviour cloning (``python -m cepam_gym_agents.bc``) |
| ``config/`` | the YAML training config: files, schema, the ``agent`` section, checks |
| ``learners/`` | the SB3 algorithms, the native learners, the asymmetric policy, the student, the BC policy |
| ``session/`` | one training session and its run directory: trainer, envs, callbacks, checkpoints |
| ``grid/`` | where a grid's trials run; the reference grid's cells, scoring and page |
| ``asymmetric`` | the policy class path saved privileged-critic models name (see the module) |
"""
