"""Tasks: what the agent is asked (targets, loads), what it sees (observation layouts, named
columns), how it is scored (reward terms, termination reasons)."""

from .layout import OBS_FIELDS, ObsColumn, ObsLayout, rig_layout
from .spec import LOAD_KINDS, TASKS, TERMINATION_REASONS, RewardWeights, TaskScales, TaskSpec, check_kwargs

__all__ = [
    "LOAD_KINDS",
    "OBS_FIELDS",
    "TASKS",
    "TERMINATION_REASONS",
    "ObsColumn",
    "ObsLayout",
    "RewardWeights",
    "TaskScales",
    "TaskSpec",
    "check_kwargs",
    "rig_layout",
]
