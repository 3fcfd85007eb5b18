"""Tasks: what the agent is asked (targets, loads), what it sees, how it is scored."""

from .spec import LOAD_KINDS, TASKS, RewardWeights, TaskSpec

__all__ = ["LOAD_KINDS", "TASKS", "RewardWeights", "TaskSpec"]
