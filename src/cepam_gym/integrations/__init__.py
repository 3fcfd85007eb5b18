"""Adapters to other RL libraries, each needing its own extra and imported only when used:

* :mod:`cepam_gym.integrations.sb3`: stable-baselines3 ``VecEnv`` over the native batched env
  (``make_sb3_vec_env``; the ``[train]`` extra);
* :mod:`cepam_gym.integrations.rllib`: Ray RLlib env creator with per-runner seeding
  (``register_env``, ``make_env``; the ``[distributed]`` extra).

The old path ``cepam_gym.rllib`` still imports (the same module).
"""
