"""The version table: every registered id, what it runs, how it is scored, and its status.

What a version number promises. As Gymnasium's rule has it, the ``-vN`` of an id changes whenever
anything that affects learning changes: the task (targets, references, loads, reward, termination),
the plant preset, the observation (its columns, the preview) or the episode's length. An id never
changes once published: a figure measured on ``cepam_gym/CEPAM-v1`` reproduces on it for as long
as the id exists. One number covers the whole env, so the steps do not all change the same thing:

* ``v0``: the set-point tasks on plant v0 (preset ``balloon_v0``): targets jump unannounced;
* ``v1``: the planned-reference tasks, announced ``preview_steps`` ahead, on plant v1 (the default
  plant, preset ``balloon``): a new task, a new observation and a new plant;
* ``v2``: the v1 tasks unchanged on plant v2 (preset ``balloon_v2``): only the plant changed;
* ``v3``: the v1 tasks on plant v2 with the reward that is the score's per-step form (task
  version 2, :mod:`cepam_gym.tasks.contract`, "Reward and score") and observations with a rig's
  sensor noise by default (:data:`RIG_SENSOR_NOISE`; ``sensor_noise=None`` for ideal sensors).

Each row says which: :attr:`Version.task_version` and :attr:`Version.plant_version`.

Status. ``recommended``: the id to start from (the newest plant, the best calibrated: docs/
calibration.md "Plant v2"); Gymnasium's notice on ``make`` that an id "is out of date" names it
(it shows on the v0 and v1 ids). ``supported``: kept and benchmarked, its suites and stored
references maintained. ``legacy``: kept so published figures reproduce.

Everything that depends on the version reads this table rather than guessing it from an id's
suffix, a preview count or a plant's friction law: the registration (:mod:`cepam_gym.registration`),
the benchmark's scoring (:func:`cepam_gym.control.objective.spec_of_core`), the oracle's settings
(:func:`cepam_gym.control.oracle.oracle_config`), the controller registry's joint variants, the
default suites of ``cepam-gym eval`` and the defaults of the command line. docs/versions.md prints
the table; ``tests/project/test_versions.py`` checks it against the registry, the suites and the docs.
This module imports nothing heavy (it is read on ``import cepam_gym``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Status = Literal["recommended", "supported", "legacy"]
STATUSES: tuple[str, ...] = ("recommended", "supported", "legacy")

# plant presets of the plant versions; PlantParams() (no preset given) is plant v1
PLANT_PRESETS: dict[int, str] = {0: "balloon_v0", 1: "balloon", 2: "balloon_v2"}
DEFAULT_PRESET = PLANT_PRESETS[1]
# reference points announced by the v1 and v2 ids: 0.2 s at 50 Hz
PREVIEW_STEPS = 10
MAX_EPISODE_STEPS = 500  # 10 s at 50 Hz
# The v3 ids observe through a rig's sensors: the emulated rig's default noise
# (cepam_gym.rig.emulator.RigImperfections: 0.2 kPa on every pressure, 0.03 mm on the length) and the
# length rate's noise of the deploy loop's filtered difference of those readings at 50 Hz
# (cepam_gym.rig.observation; tests/envs/test_v3.py measures it); the 50 Pa and 10 um
# quantisation steps add 14 Pa and 3 um rms, below the noise, and are left out
RIG_SENSOR_NOISE = (("length_mm", 0.03), ("velocity_mm_s", 1.2), ("pressure_kpa", 0.2))
# the hinge reads its angle from the same length sensor through its 2.5 cm lever arm (tasks.joint):
# 0.03 mm / 25 mm = 1.2 mrad, 1.2 mm/s / 25 mm = 48 mrad/s
JOINT_SENSOR_NOISE = (("angle_mrad", 1.2), ("angular_velocity_mrad_s", 48.0), ("pressure_kpa", 0.2))

NAMESPACE = "cepam_gym"
_RIG = ("cepam_gym.envs.cepam:CEPAMEnv", "cepam_gym.envs.cepam:CEPAMVectorEnv")
_JOINT = ("cepam_gym.envs.joint:CEPAMJointKernelEnv", "cepam_gym.envs.joint:CEPAMJointVectorEnv")
_MUJOCO_JOINT = ("cepam_gym.envs.joint_mujoco:CEPAMJointEnv", None)


@dataclass(frozen=True)
class Version:
    """One registered id.

    ``task`` is the task name the id passes to its env (``fixed_task``: the entry point runs that
    task only and takes no ``task`` kwarg); ``plant`` the preset it passes (None: the default
    plant, :data:`DEFAULT_PRESET`); ``observation`` names the observation layout (ids with the
    same name observe the same columns); ``suites`` are its headline benchmark suites (the
    default of ``cepam-gym eval`` for an agent trained on it; empty: none measures it),
    ``other_suites`` the other suites that run on it: :mod:`cepam_gym.bench.suites` makes each
    suite from the row that names it, so a suite's env id is its row's;
    ``oracle`` names the oracle's shipped setting on it (:data:`cepam_gym.control.oracle.ORACLE_CONFIGS`;
    None: the oracle cannot drive it); ``extra`` is the pip extra it needs."""

    family: str
    version: int
    task: str
    task_version: int
    plant_version: int
    preview_steps: int
    mechanism: Literal["rig", "hinge"]
    observation: str
    suites: tuple[str, ...]
    oracle: str | None
    status: Status
    entry_point: str
    vector_entry_point: str | None
    fixed_task: bool = False
    extra: str = ""
    sensor_noise: tuple[tuple[str, float], ...] = ()  # the default sensor_noise kwarg (v3: a rig's)
    other_suites: tuple[str, ...] = ()

    @property
    def name(self) -> str:
        """The id without its namespace (``CEPAM-v1``)."""
        return f"{self.family}-v{self.version}"

    @property
    def env_id(self) -> str:
        return f"{NAMESPACE}/{self.name}"

    @property
    def plant(self) -> str | None:
        """The preset the id passes as ``plant`` (None: the default plant, plant v1)."""
        preset = PLANT_PRESETS[self.plant_version]
        return None if preset == DEFAULT_PRESET else preset

    @property
    def plant_preset(self) -> str:
        return PLANT_PRESETS[self.plant_version]

    @property
    def kwargs(self) -> dict:
        """The default kwargs the id registers (a user's own kwargs win)."""
        out: dict = {} if self.fixed_task else {"task": self.task}
        if self.preview_steps:
            out["preview_steps"] = self.preview_steps
        if self.plant is not None:
            out["plant"] = self.plant
        if self.sensor_noise:
            out["sensor_noise"] = dict(self.sensor_noise)
        return out


def _rig(family, version, task, observation, suites, status, other_suites=()) -> Version:
    task_version = min(version, 1) if version < 3 else 2
    return Version(
        family,
        version,
        task,
        task_version,
        plant_version=min(version, 2),
        preview_steps=0 if task_version == 0 else PREVIEW_STEPS,
        mechanism="rig",
        observation=observation if task_version == 0 else f"{observation}+preview",
        suites=suites,
        oracle=f"v{min(version, 2)}",  # v3 runs plant v2: the oracle plans as on v2
        status=status,
        entry_point=_RIG[0],
        vector_entry_point=_RIG[1],
        sensor_noise=RIG_SENSOR_NOISE if version >= 3 else (),
        other_suites=other_suites,
    )


def _joint(version, suites, status) -> Version:
    return Version(
        "CEPAMJoint",
        version,
        "joint_v1" if version < 3 else "joint_v3",
        1 if version < 3 else 2,
        plant_version=min(version, 2),
        preview_steps=PREVIEW_STEPS,
        mechanism="hinge",
        observation="hinge+preview",
        suites=suites,
        oracle="joint",
        status=status,
        entry_point=_JOINT[0],
        vector_entry_point=_JOINT[1],
        sensor_noise=JOINT_SENSOR_NOISE if version >= 3 else (),
    )


_ROWS = (
    _rig("CEPAM", 0, "cepam", "rig", ("nominal", "randomized"), "legacy", ("stress",)),
    _rig("CEPAMLength", 0, "length", "length", (), "legacy"),
    _rig("CEPAMStiffness", 0, "stiffness", "rig", ("stiffness-at-fixed-length",), "legacy"),
    # the v0 hinge in MuJoCo (the [mujoco] extra): no batched kernel, so no oracle or agent
    Version(
        "CEPAMJoint",
        0,
        "joint",
        0,
        plant_version=0,
        preview_steps=0,
        mechanism="hinge",
        observation="hinge",
        suites=("joint",),
        oracle=None,
        status="legacy",
        entry_point=_MUJOCO_JOINT[0],
        vector_entry_point=_MUJOCO_JOINT[1],
        fixed_task=True,
        extra="mujoco",
    ),
    _rig(
        "CEPAM",
        1,
        "cepam_v1",
        "rig",
        ("nominal-v1", "randomized-v1"),
        "supported",
        ("tracking-v1", "stress-v1"),
    ),
    _rig("CEPAMLength", 1, "length_v1", "length", ("length-v1",), "supported"),
    _rig("CEPAMStiffness", 1, "stiffness_v1", "rig", ("stiffness-at-fixed-length-v1",), "supported"),
    _joint(1, ("joint-v1",), "supported"),
    _rig(
        "CEPAM",
        2,
        "cepam_v1",
        "rig",
        ("nominal-v2", "randomized-v2"),
        "supported",
        ("tracking-v2", "stress-v2", "randomized-id-v2"),
    ),
    _rig("CEPAMLength", 2, "length_v1", "length", ("length-v2",), "supported"),
    _rig("CEPAMStiffness", 2, "stiffness_v1", "rig", ("stiffness-at-fixed-length-v2",), "supported"),
    _joint(2, ("joint-v2",), "supported"),
    _rig(
        "CEPAM",
        3,
        "cepam_v3",
        "rig",
        ("nominal-v3", "randomized-v3", "randomized-id-v3"),
        "recommended",
        ("tracking-v3", "stress-v3"),
    ),
    _rig("CEPAMLength", 3, "length_v3", "length", ("length-v3",), "recommended"),
    _rig("CEPAMStiffness", 3, "stiffness_v3", "rig", ("stiffness-at-fixed-length-v3",), "recommended"),
    _joint(3, ("joint-v3",), "recommended"),
)
VERSIONS: dict[str, Version] = {row.env_id: row for row in _ROWS}
# the id a new user starts from: the defaults of the integrations and of `cepam-gym video`
RECOMMENDED_ID = "cepam_gym/CEPAM-v3"


def get(env_id: str) -> Version:
    """The row of ``env_id``; ``ValueError`` naming the registered ids otherwise."""
    from .errors import InputError

    try:
        return VERSIONS[env_id]
    except KeyError:
        raise InputError(f"{env_id!r} is not a cepam_gym id; registered: {list(VERSIONS)}") from None


def short_name(env_id: str) -> str:
    """``env_id`` without its namespace (for file names and tables): a registered id's name in the
    table (``CEPAM-v1``); any other id's as Gymnasium reads it, not guessed here."""
    row = VERSIONS.get(env_id)
    if row is not None:
        return row.name
    from gymnasium.envs.registration import get_env_id, parse_env_id

    _, name, version = parse_env_id(env_id)
    return get_env_id(None, name, version)


def id_of(family: str, version: int) -> str:
    """The registered id of ``family`` at ``version`` (``ValueError`` naming the ids otherwise)."""
    from .errors import InputError

    for row in _ROWS:
        if (row.family, row.version) == (family, version):
            return row.env_id
    raise InputError(f"no cepam_gym id {family}-v{version}; registered: {list(VERSIONS)}")


def task_version(task) -> int | None:
    """The task version of a task name (None for a name no id runs, or a Task object)."""
    if not isinstance(task, str):
        return None
    found = {row.task_version for row in _ROWS if row.task == task}
    return found.pop() if len(found) == 1 else None


def plant_version(plant) -> int | None:
    """The plant version of an env's ``plant`` argument given by name: None (the default plant) or
    a preset name; None for anything else (a plant of one's own)."""
    if plant is None:
        return 1
    return next((v for v, name in PLANT_PRESETS.items() if name == plant), None)


def of_kwargs(task, plant=None) -> Version | None:
    """The id whose env these constructor arguments build (its task name, its plant preset),
    whatever the other kwargs (randomization, noise, preview count); None for a task or plant of
    one's own."""
    if not isinstance(task, str):
        return None
    pv = plant_version(plant)
    return next(
        (row for row in _ROWS if row.task == task and row.plant_version == pv and not row.fixed_task), None
    )


def ids(status: str | None = None, mechanism: str | None = None, version: int | None = None) -> list[str]:
    """The registered ids, in the table's order, optionally of one status, mechanism or version."""
    return [
        row.env_id
        for row in _ROWS
        if (status is None or row.status == status)
        and (mechanism is None or row.mechanism == mechanism)
        and (version is None or row.version == version)
    ]


def same_observation(env_id: str) -> list[str]:
    """The ids of ``env_id``'s version and mechanism that observe what it observes (an agent
    trained on one acts on all): the ids whose suites ``cepam-gym eval --suite all`` scores."""
    me = get(env_id)
    return [
        row.env_id
        for row in _ROWS
        if (row.version, row.mechanism, row.observation) == (me.version, me.mechanism, me.observation)
    ]


def markdown_table() -> str:
    """The table as docs/versions.md prints it (a test checks the doc holds exactly this)."""
    head = (
        "| id | status | task (version) | plant (version) | preview | observation | headline suites "
        "| oracle setting | entry points |\n|---|---|---|---|---|---|---|---|---|\n"
    )
    lines = []
    for r in _ROWS:
        entries = f"`{r.entry_point}`" + (f", `{r.vector_entry_point}`" if r.vector_entry_point else "")
        lines.append(
            f"| `{r.env_id}` | {r.status} | `{r.task}` ({r.task_version}) | `{r.plant_preset}` "
            f"({r.plant_version}) | {r.preview_steps} | {r.observation} | "
            f"{', '.join(f'`{s}`' for s in r.suites) or 'none'} | {r.oracle or 'none'} | {entries} |"
        )
    return head + "\n".join(lines) + "\n"
