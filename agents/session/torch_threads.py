"""torch's thread count in training: fixed (``torch_threads: 2``) or chosen while the run goes on
(``torch_threads: auto``).

On a quiet 2-core machine two torch threads make the gradient steps a little faster than one;
beside a second busy process they make them several times slower, because each parallel
operation waits for the thread that shares its core (``benchmarks/learner_under_load.py``
measures it). The env's step kernel already picks its numba thread count by timing itself
(:class:`cepam_gym.envs.threads.ThreadChoice`); ``auto`` gives the learner's gradient steps the
same chooser, so a run started on a quiet machine keeps its speed when the machine gets busy,
and the other way round. The count changes the speed, and the numbers at most in float32's last
places, at the shipped configs' layer sizes: their forward and backward passes agree to 1e-4 at 1
and 2 threads, bit for bit on the AMD CPUs measured, not on an Intel Emerald Rapids
(``tests/agents/test_torch_threads.py``). torch does not promise more; a run that must repeat bit
for bit sets an integer.
"""

from __future__ import annotations

import os

from cepam_gym.envs.threads import ThreadChoice, thread_counts

AUTO = "auto"


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


class TorchThreads:
    """torch's intra-op thread count for a training session."""

    def __init__(self, setting: int | str):
        self.choice = ThreadChoice(thread_counts(cores())) if setting == AUTO else None
        self.fixed = None if setting == AUTO else int(setting)
        self.apply(self.now())

    def now(self) -> int:
        """The count in use between timed calls (the policy's forward passes while collecting)."""
        return self.fixed if self.choice is None else self.choice.current

    @staticmethod
    def apply(count: int) -> None:
        import torch

        if torch.get_num_threads() != count:
            torch.set_num_threads(count)

    def run(self, fn):
        """``fn()`` on the chosen count (timed, when chosen); afterwards the count in use is the
        best one so far."""
        if self.choice is None:
            return fn()
        out = []

        def call(count: int) -> None:
            self.apply(count)
            out.append(fn())

        self.choice.timed(call)
        self.apply(self.now())
        return out[0]


class ChosenThreadsTrain:
    """Mixed into a training class: its ``train()`` (the gradient steps) runs under the model's
    :class:`TorchThreads` when the trainer gave it one (``model.torch_threads``)."""

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "torch_threads"]

    def train(self, *args, **kwargs):
        threads = getattr(self, "torch_threads", None)
        if threads is None:
            return super().train(*args, **kwargs)
        return threads.run(lambda: super(ChosenThreadsTrain, self).train(*args, **kwargs))


def with_chosen_threads(cls):
    """``cls`` with :class:`ChosenThreadsTrain` mixed in (same name: logs and errors read alike)."""
    if issubclass(cls, ChosenThreadsTrain):
        return cls
    return type(cls.__name__, (ChosenThreadsTrain, cls), {"__module__": cls.__module__})


def inference_threads(setting: int | str) -> int:
    """The fixed count for loading and running a policy (evaluation, deployment): ``auto`` is one
    thread, since a single observation's forward pass gains nothing from two."""
    return 1 if setting == AUTO else max(1, int(setting))
