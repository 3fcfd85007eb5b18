"""What learns: the SB3 algorithm a config names, the native learners that collect from the
batched env as arrays, the privileged critic's policy, the DAgger student and the
behaviour-cloning policy.

| module | what |
|---|---|
| ``algorithm`` | the SB3 algorithm a config names: class, policy, checks, constructor arguments |
| ``native_collection`` | what the native learners share: the vector env stepped as arrays |
| ``native_ppo``, ``native_recurrent``, ``native_offpolicy`` | ``learner: native``: PPO, SAC, TD3, ... |
| ``offpolicy_updates`` | SAC's and TD3's gradient steps in fewer Python calls |
| ``asymmetric`` | the privileged critic's policy (``agent.privileged_critic``) |
| ``student`` | a student distilled from a privileged teacher (DAgger; ``cepam-gym train --config student``) |
| ``bc_policy`` | the behaviour-cloning MLP, its files, a BC run as a controller |
"""
