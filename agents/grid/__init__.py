"""Grids of training runs: where their trials run, and the reference grid of
``python -m cepam_gym_agents.reference``.

| module | what |
|---|---|
| ``trials`` | processes on this machine or Ray tasks (also for ``python -m cepam_gym_agents.compare``) |
| ``cells`` | the reference grid's cells: learner, shipped config, id, suite, run directory |
| ``report`` | scoring the reference grid's runs and the controllers beside them |
| ``page`` | the reference grid's page ``reference.md`` and its figures |
"""
