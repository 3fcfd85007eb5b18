"""The reset's planner: every episode's targets, loads, reference shapes and starting point, and the
plant parameters a randomized env draws, planned from a task's declaration
(:class:`~cepam_gym.tasks.spec.TaskSpec`) in compiled code (:mod:`cepam_gym.planning.episodes`)."""
