"""One training session of one run directory, and the files a run directory holds.

| module | what |
|---|---|
| ``trainer`` | one training session: ``train()`` and the ``Trainer`` |
| ``envs`` | the training and evaluation envs a session builds |
| ``callbacks`` | the callback inside ``learn``: logging, evaluations, checkpoints, time limit |
| ``checkpoints`` | a run's saved models, ``checkpoints/`` and what a resume starts from |
| ``model_files`` | where a trained model's files are (run directories, RL Zoo3 runs, bare zips) |
| ``lock``, ``signals`` | one session per run directory; SIGTERM as Ctrl-C |
| ``provenance``, ``progress`` | ``run.json``; the progress bar |
| ``torch_threads`` | torch's thread count in training and inference |
"""
