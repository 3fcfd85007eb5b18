"""Task objects by name: :func:`make_task` builds the Task of an env's kwargs."""

from __future__ import annotations

from ..errors import InputError
from ..tasks.joint import JointTask
from ..tasks.spec import TASKS
from .hinge_task import JOINT_TASKS, HingeTask
from .rig_task import RigTask
from .task import Task, check_preview_steps


def make_task(task, task_options=None, reward_weights=None, preview_steps: int = 0, joint=None) -> Task:
    """The Task object of an env's kwargs: ``task`` a task name (rig or joint) or a Task object;
    ``task_options`` and ``reward_weights`` override its spec; ``joint`` the hinge geometry
    (joint tasks only)."""
    preview_steps = check_preview_steps(preview_steps)
    if isinstance(task, Task):
        if task_options or reward_weights or joint:
            raise InputError("task_options, reward_weights and joint apply to a task name, not a Task object")
        return task
    if (isinstance(task, str) and task in JOINT_TASKS) or isinstance(task, JointTask):
        return HingeTask.from_kwargs(task, task_options, reward_weights, preview_steps, joint)
    if joint:
        raise InputError(f"the joint kwarg applies to the joint tasks {sorted(JOINT_TASKS)}, not {task!r}")
    if isinstance(task, str) and task not in TASKS:
        raise InputError(f"unknown task {task!r}; available: {sorted(TASKS) + sorted(JOINT_TASKS)}")
    return RigTask.from_kwargs(task, task_options, reward_weights, preview_steps)
