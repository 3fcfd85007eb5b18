"""Fixed, seeded scenario suites of the benchmark harness."""

from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

from ..errors import InputError
from .metrics import JOINT, JOINT_V1, RIG, RIG_V1, TraceSpec

# Plausible spread of a hand-made CE-PAM and its rig around the nominal (default, calibrated)
# parameters, in the keys' own units: centred on the nominal value except the Coulomb friction,
# which can only add (nominal 0). Braid angles +/- 1.5 deg (a quarter of the calibration's 1 sd),
# walls and elasticity about +/- 35 %, valve and volumes +/- 30-50 %. The baseline keeps using the
# nominal values.
RANDOMIZE: dict[str, list[float]] = {
    "cpam_rest_angle_deg": [27.4, 30.4],
    "epam_sleeve_free_angle_deg": [17.7, 20.7],
    "bladder_thickness_mm": [0.04, 0.09],
    "sleeve_thickness_mm": [0.02, 0.06],
    "valve_conductance_dm3_per_s_bar": [0.07, 0.13],
    "dead_volume_cpam_cm3": [1.0, 3.0],
    "dead_volume_epam_cm3": [1.0, 3.0],
    "end_mass_g": [15.0, 25.0],
    "damping_ns_per_m": [3.0, 7.0],
    "coulomb_friction_n": [0.0, 0.3],
    "elastic_stiffness_n_per_m": [110.0, 220.0],
}

# The same idea around the v1 plant (the default plant; presets/balloon.yaml), with what v1 adds:
# braid-bladder friction (Maxwell-slip: break-away per kPa and presliding), the rubber's modulus,
# wall heat transfer and the spool's speed. Angles +/- 1.5 deg (the CPAM's only upward: its
# fitted value sits on the sleeve-size bound), rubber and friction about +/- 40-60 %.
RANDOMIZE_V1: dict[str, list[float]] = {
    "cpam_rest_angle_deg": [20.3, 21.8],
    "epam_sleeve_free_angle_deg": [31.7, 34.7],
    "bladder_thickness_mm": [0.07, 0.14],
    "bladder_shear_modulus_kpa": [700.0, 1300.0],
    "friction_coefficient_n_per_kpa": [0.001, 0.004],
    "friction_presliding_mm": [0.3, 0.8],
    "valve_conductance_dm3_per_s_bar": [0.07, 0.13],
    "spool_time_constant_ms": [3.0, 8.0],
    "heat_transfer_coefficient_w_per_m2_k": [5.0, 20.0],
    "dead_volume_cpam_cm3": [1.0, 3.0],
    "dead_volume_epam_cm3": [1.0, 3.0],
    "end_mass_g": [15.0, 25.0],
    "damping_ns_per_m": [3.0, 7.0],
    "coulomb_friction_n": [0.0, 0.3],
}
# The same spread around the v2 plant (presets/balloon_v2.yaml). v2 uses the contact-area friction
# law, under which the v1 key friction_coefficient_n_per_kpa is not used (the kernel zeroes it), so
# randomizing it would change nothing: v2 spreads its counterpart friction_mu instead, over the
# same relative range as v1's coefficient (0.5-2 x nominal 2.08e-4). The angles are centred on
# v2's fitted values (+/- 1.5 deg), the balloon's modulus on its fitted 736 kPa (-40 / +35 %,
# within latex's 0.2-1 MPa), the braid threads' compliance on its fitted 0.89 per kN (+/- 2 sd of
# the fit, 0.6-1.2). Where the v2 fit sits at a physical bound the spread goes inward only:
# presliding 1.2-2 mm (bound 2 mm: PAM hysteresis loops stick over up to about a mm or two) and the
# collapsed CPAM's seal 3.5-5 mm (it cannot exceed the 5 mm bladder it seals). Noise and the other
# keys as v1's.
RANDOMIZE_V2: dict[str, list[float]] = {
    **{k: v for k, v in RANDOMIZE_V1.items() if k != "friction_coefficient_n_per_kpa"},
    "cpam_rest_angle_deg": [20.7, 23.7],
    "epam_sleeve_free_angle_deg": [28.35, 31.35],
    "bladder_shear_modulus_kpa": [450.0, 1000.0],
    "epam_thread_compliance_per_kn": [0.6, 1.2],
    "cpam_thread_compliance_per_kn": [0.6, 1.2],
    "friction_mu": [1.0e-4, 4.0e-4],
    "friction_presliding_mm": [1.2, 2.0],
    "collapse_seal_diameter_mm": [3.5, 5.0],
}
NOISE = {"length_mm": 0.2, "velocity_mm_s": 5.0, "pressure_kpa": 1.0}
# the stress suites' task: heavy loads, steps and random loads, targets near the pressure limits,
# fast target changes (the same on every version)
STRESS_TASK = {
    "load_range": [0.0, 0.45],
    "load_kinds": ["step", "random"],
    "pressure_margin": 0.95,
    "segment_duration": [1.0, 2.0],
}


@dataclass(frozen=True)
class Suite:
    name: str
    env_id: str
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    seed: int = 0
    episodes: int = 20
    doc: str = ""
    traces: TraceSpec = RIG  # what the trace columns hold and how they are scored
    extra: str = ""  # the pip extra the env needs ("mujoco"); left out of 'all' without it
    # the scenario the suite runs, the same on every version (``nominal`` of ``nominal-v2``): the
    # dataset ids' task (cepam_gym.offline.naming); empty for a suite made by hand (its name)
    stem: str = ""

    @property
    def reference(self) -> tuple[float, float] | None:
        """``(zero controller's score, oracle's score)`` on this suite at its default episodes, the
        ends of the normalized score (:mod:`cepam_gym.bench.references`), or None where not measured."""
        from .references import stored_ends

        return stored_ends(self.name, self.episodes, self.seed)


class Scenario(NamedTuple):
    """What a suite runs, before a version row places it on its id (the row gives the env id, the
    trace spec and the extra): kwargs, seed and a line of doc."""

    env_kwargs: dict[str, Any]
    seed: int
    doc: str


# the v0 ids' scenarios: the suites are named by the stem alone (they predate versioned names)
_V0: dict[str, Scenario] = {
    "nominal": Scenario(
        {"task_options": {"load_kinds": ["step"]}}, 1000, "default parameters, no noise, load steps"
    ),
    "randomized": Scenario(
        {
            "randomize": RANDOMIZE,
            "supply_drift_kpa": 5.0,
            "sensor_noise": {"length_mm": 0.2, "velocity_mm_s": 5.0, "pressure_kpa": 1.0},
        },
        2000,
        "domain-randomized plant, sensor noise, supply drift, all load profiles",
    ),
    "stiffness-at-fixed-length": Scenario({}, 3000, "paper section XII: 17.5 cm, changing stiffness"),
    "stress": Scenario(
        {"task_options": STRESS_TASK}, 4000, "large load steps, near-limit targets, fast target changes"
    ),
    "joint": Scenario(
        {}, 5000, "MuJoCo hinge driven by the CE-PAM: joint angle and joint stiffness under external torques"
    ),
}
# The planned-reference versions' scenarios (v1 and later), as on v1: references announced 0.2 s
# ahead; the headline error leaves out 0.5 s after a jump of the target (RIG_V1). Version N runs
# them on its own seeds (v1's + 10000 (N - 1)); a randomized scenario spreads its plant version's
# parameters (RANDOMIZE_BY_PLANT). The order is the stored references'.
_PLANNED: dict[str, Scenario] = {
    "nominal": Scenario(
        {"task_options": {"load_kinds": ["step"]}},
        11000,
        "v1 references with preview, default parameters, no noise, load steps",
    ),
    "randomized": Scenario(
        {"randomize": RANDOMIZE_V1, "supply_drift_kpa": 5.0, "sensor_noise": NOISE},
        12000,
        "v1 references with preview, domain-randomized plant, sensor noise, supply drift",
    ),
    "tracking": Scenario(
        {"task_options": {"references": ["sine", "chirp", "min_jerk"], "load_kinds": ["constant"]}},
        13000,
        "smooth references only (sines, chirps, minimum-jerk moves), constant load",
    ),
    "stiffness-at-fixed-length": Scenario({}, 14000, "paper section XII: 17.5 cm, stiffness ramps and moves"),
    "stress": Scenario(
        {"task_options": STRESS_TASK}, 15000, "v1 with large load steps, near-limit targets, fast changes"
    ),
    "length": Scenario(
        {"task_options": {"load_kinds": ["step"]}},
        16000,
        "the length-only v1 task: v1 length references with preview, load steps",
    ),
    "joint": Scenario(
        {}, 17000, "the batched hinge driven by the CE-PAM: v1 angle and joint-stiffness references, preview"
    ),
}
RANDOMIZE_BY_PLANT = {0: RANDOMIZE, 1: RANDOMIZE_V1, 2: RANDOMIZE_V2}
# how a version's suites describe themselves after v1's words; the randomized suites of plant v2
# say what their spread adds
_DOC_PREFIX = {1: "", 2: "v2 plant: "}
_RANDOMIZED_DOC = {2: "domain-randomized (contact-area friction included), sensor noise, supply drift"}
# the trace spec of a row's suites: its mechanism and whether its task plans references
_TRACES = {("rig", False): RIG, ("hinge", False): JOINT, ("rig", True): RIG_V1, ("hinge", True): JOINT_V1}
# the stem of a randomized scenario with an identification window in front (with_id_window)
ID_WINDOW_STEM = "id"


def suite_name(stem: str, version: int) -> str:
    """A suite's name: the stem alone on v0 (the names published first), ``<stem>-v<N>`` after."""
    return stem if version == 0 else f"{stem}-v{version}"


def _scenarios(row) -> dict[str, Scenario]:
    """The scenarios a version row can run, by stem: v0's as written, a planned-reference
    version's from v1's (its seeds, its plant's spread and doc)."""
    if row.task_version == 0:
        return _V0
    out = {}
    prefix = _DOC_PREFIX.get(row.version, f"v{row.version}: ")
    for stem, sc in _PLANNED.items():
        kwargs, doc = copy.deepcopy(sc.env_kwargs), f"{prefix}{sc.doc}"
        if "randomize" in kwargs:
            kwargs["randomize"] = RANDOMIZE_BY_PLANT[row.plant_version]
            doc = f"{prefix}{_RANDOMIZED_DOC.get(row.plant_version, sc.doc)}"
        if row.sensor_noise and "sensor_noise" not in kwargs:  # the id observes through a rig's sensors
            doc = doc.replace("no noise", "a rig's sensor noise")
        out[stem] = Scenario(kwargs, sc.seed + 10000 * (row.version - 1), doc)
    return out


def _suites_of_version(rows) -> list[Suite]:
    """The suites the version rows of one version name (``suites``, ``other_suites``): in the
    order of the scenarios, each on the row that names it, then those with an identification
    window. A name no scenario makes is an error (a typo in the table)."""
    out, windowed = [], []
    for row in rows:
        named = (*row.suites, *row.other_suites)
        traces = _TRACES[row.mechanism, row.task_version > 0]
        mine = [
            Suite(
                suite_name(stem, row.version),
                row.env_id,
                sc.env_kwargs,
                sc.seed,
                doc=sc.doc,
                traces=traces,
                extra=row.extra,
                stem=stem,
            )
            for stem, sc in _scenarios(row).items()
            if suite_name(stem, row.version) in named
        ]
        windowed += [w for w in map(with_id_window, mine) if w.name in named]
        missing = set(named) - {s.name for s in mine} - {w.name for w in windowed}
        if missing:
            raise ImportError(
                f"{row.env_id}: the version table names suites no scenario makes: {sorted(missing)}"
            )
        out += mine
    order = {stem: k for k, stem in enumerate(_scenarios(rows[0]))}
    return sorted(out, key=lambda s: order[s.stem]) + windowed


# The identification window's default length [s] (envs.id_window): the measured trade-off of
# docs/identify_then_control.md (the fitted braid angles' error against the window's length).
ID_WINDOW_S = 10.0


def with_id_window(suite: Suite, seconds: float = ID_WINDOW_S, name: str | None = None) -> Suite:
    """``suite`` with an unscored identification window of ``seconds`` before each episode's
    tracking (:mod:`cepam_gym.envs.id_window`), named ``name`` (default: ``<stem>-id-vN``, the stem
    and version of the suite's scenario and id). The same seed: its scored episodes are the suite's
    own plants, references and loads."""
    from .. import versions

    kwargs = copy.deepcopy(suite.env_kwargs)
    kwargs["task_options"] = {**kwargs.get("task_options", {}), "id_window_s": float(seconds)}
    stem = f"{suite.stem or suite.name}-{ID_WINDOW_STEM}"
    return replace(
        suite,
        name=name or suite_name(stem, versions.get(suite.env_id).version),
        env_kwargs=kwargs,
        doc=f"{suite.doc}; each episode starts with an unscored {seconds:g} s identification window",
        stem=stem,
    )


def _generate() -> dict[str, Suite]:
    """Every suite, from the version table, version by version."""
    from .. import versions

    by_version: dict[int, list] = {}
    for row in versions.VERSIONS.values():
        by_version.setdefault(row.version, []).append(row)
    return {s.name: s for rows in by_version.values() for s in _suites_of_version(rows)}


SUITES: dict[str, Suite] = _generate()


def headline_suites(env_id: str) -> list[str]:
    """The headline suites of a registered id (the version table's, :mod:`cepam_gym.versions`):
    what an agent trained on it is scored on by default. ``ValueError`` for an id that is not
    cepam_gym's or that no suite measures."""
    from .. import versions

    row = versions.get(env_id)
    if not row.suites:
        with_suites = [
            k for k, v in versions.VERSIONS.items() if v.suites and v.observation == row.observation
        ]
        raise InputError(
            f"{env_id} has no benchmark suite (its observation is its own); name suites yourself, or "
            f"train on an id that has them: {with_suites}"
        )
    return list(row.suites)


def version_suites(env_id: str) -> list[str]:
    """Every suite an agent trained on ``env_id`` can be scored on: those of the ids of its version
    and mechanism with the same observation (:func:`cepam_gym.versions.same_observation`)."""
    from .. import versions

    ids = set(versions.same_observation(env_id))
    return [name for name, s in SUITES.items() if s.env_id in ids]


def trace_spec_for(env_id: str) -> TraceSpec:
    """How the benchmark scores an env id: the trace spec of the first suite that runs it (the
    nominal one of its version), else the v0 rig's."""
    return next((s.traces for s in SUITES.values() if s.env_id == env_id), RIG)


def available(name: str) -> bool:
    """Whether the suite's extra (if any) is installed, without importing it."""
    import importlib.util

    extra = SUITES[name].extra
    return not extra or importlib.util.find_spec(extra) is not None


def __getattr__(name: str):
    """``REFERENCE_SCORES``: ``{suite: (zero controller's score, oracle's score)}`` at each suite's
    default episodes and seed, read from the stored file (:mod:`cepam_gym.bench.references`, which
    regenerates it), so it is never a stale copy in the source."""
    if name == "REFERENCE_SCORES":
        from .references import load

        return {k: (v["zero"], v["oracle"]) for k, v in load().items()}
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
