"""The ``student.adaptation`` section: an adaptation module for a student told the plant."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .checks import ConfigError, as_float, as_int, as_mapping, as_widths, check_keys


@dataclass(frozen=True)
class AdaptationConfig:
    """RMA's second phase (Kumar et al. 2021) for a student told the plant (``agent.plant_features``):
    a network from the sensors' recent history to the plant's columns, fitted after the DAgger
    rounds on the student's own rollouts (``agents/learners/adaptation.py``), so the agent is told
    an estimate where no identification window runs.

    * ``history_s``: the seconds of history it reads, every ``stride``-th control step of them;
    * ``envs``: the plants of one round, split over ``student.suites`` in their proportions;
    * ``rounds``: round 0 is driven by the student told the true plant, later rounds by the
      student told the estimate (DAgger on the estimate: the histories it will meet);
    * ``gradient_steps`` (round 0; half in each later round), ``net_arch`` (ELU hidden layers)."""

    history_s: float = 5.0
    stride: int = 5
    envs: int = 1024
    rounds: int = 3
    gradient_steps: int = 4000
    net_arch: list = field(default_factory=lambda: [256, 256])

    @classmethod
    def parse(cls, data: Any) -> AdaptationConfig | None:
        if data is None:
            return None
        d = as_mapping(data, "student.adaptation")
        check_keys(d, cls, "student.adaptation")
        history = as_float(d.get("history_s", cls.history_s), "student.adaptation.history_s", 0.0)
        if history <= 0:
            raise ConfigError(f"student.adaptation.history_s must be > 0 s, got {history!r}")
        return cls(
            history,
            as_int(d.get("stride", cls.stride), "student.adaptation.stride", 1),
            as_int(d.get("envs", cls.envs), "student.adaptation.envs", 1),
            as_int(d.get("rounds", cls.rounds), "student.adaptation.rounds", 1),
            as_int(d.get("gradient_steps", cls.gradient_steps), "student.adaptation.gradient_steps", 1),
            as_widths(d.get("net_arch", cls().net_arch), "student.adaptation.net_arch"),
        )
