"""Observation layouts: which named quantity each observation column holds and how it is scaled.

An env measures a fixed tuple of SI quantities (its *fields*, e.g. :data:`OBS_FIELDS` of the rig
envs); its task picks and scales them into the observation with an :class:`ObsLayout`::

    obs[j] = clip((value[source_j] - offset_j) / scale_j, -clip, clip)
    value  = obs[j] * scale_j + offset_j                       (decode; exact up to the clip)

The rig envs encode in their compiled step kernel (:func:`cepam_gym.envs.step_kernel.write_obs`,
which reads the layout from the task vector); the joint env with :meth:`ObsLayout.encode`.
Controllers and agent code read columns by name (:meth:`ObsLayout.column`,
:meth:`ObsLayout.decode`), never by number.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

# the quantities the rig envs measure, in the order the step kernel computes them
OBS_FIELDS = (
    "length",
    "velocity",
    "pressure_c",
    "pressure_e",
    "supply_pressure",
    "target_length",
    "target_stiffness",
    "previous_action_c",
    "previous_action_e",
)


@dataclass(frozen=True)
class ObsColumn:
    """One observation column: ``(value - offset) / scale``, value in ``unit``."""

    name: str
    scale: float = 1.0
    offset: float = 0.0
    unit: str = ""

    def __post_init__(self):
        if not (np.isfinite(self.scale) and self.scale > 0 and np.isfinite(self.offset)):
            raise InputError(
                f"observation column {self.name!r}: scale must be finite and > 0 and "
                f"offset finite, got {self.scale!r}, {self.offset!r}"
            )


@dataclass(frozen=True)
class ObsLayout:
    """The columns of an observation, in order, over the quantities ``fields`` an env measures."""

    columns: tuple[ObsColumn, ...]
    fields: tuple[str, ...] = OBS_FIELDS
    clip: float = 10.0
    # the last columns announce the targets of the next ``preview_steps`` control steps
    # (:func:`preview_fields`, position ``preview_of``): the count is kept here, never parsed back
    preview_steps: int = 0
    preview_of: str = "length"

    def __post_init__(self):
        names = self.names
        if len(set(names)) != len(names):
            raise InputError(f"observation columns must have distinct names, got {names}")
        unknown = [n for n in names if n not in self.fields]
        if unknown:
            raise InputError(f"observation columns {unknown} are not among the measured fields {self.fields}")
        if not self.clip > 0:
            raise InputError(f"observation clip must be > 0, got {self.clip!r}")
        tail = names[len(names) - self.n_preview :] if self.n_preview else ()
        want = preview_fields(self.preview_steps, "target_stiffness" in names, self.preview_of)
        if tail != want:
            raise InputError(f"the last observation columns must be the preview columns {want}, got {tail}")

    @property
    def n_preview(self) -> int:
        """Number of preview columns (``preview_steps`` per tracked target)."""
        per_step = 1 + ("target_stiffness" in self.names)
        return self.preview_steps * per_step

    @property
    def n_measured(self) -> int:
        """Number of columns before the preview."""
        return self.size - self.n_preview

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.columns)

    @property
    def size(self) -> int:
        return len(self.columns)

    def column(self, name: str) -> int:
        """Index of the column holding ``name`` (``KeyError`` naming the columns if absent)."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no observation column {name!r}; columns: {self.names}") from None

    def has(self, name: str) -> bool:
        return name in self.names

    def scale(self, name: str) -> float:
        return self.columns[self.column(name)].scale

    def sources(self) -> np.ndarray:
        """For each column, the index of its quantity in ``fields`` (what the kernel reads)."""
        return np.array([self.fields.index(c.name) for c in self.columns], dtype=float)

    def offsets(self) -> np.ndarray:
        return np.array([c.offset for c in self.columns])

    def scales(self) -> np.ndarray:
        return np.array([c.scale for c in self.columns])

    def encode(self, values) -> np.ndarray:
        """float32 observation(s) from SI ``values`` in ``fields`` order (last axis); NaN -> 0."""
        v = np.asarray(values, dtype=float)[..., self.sources().astype(int)]
        o = (v - self.offsets()) / self.scales()
        return np.clip(np.nan_to_num(o), -self.clip, self.clip).astype(np.float32)

    def decode(self, obs) -> dict[str, np.ndarray]:
        """``{column name: SI values}`` of observation(s) ``(..., size)`` (exact inside the clip)."""
        o = np.asarray(obs, dtype=float)
        if o.shape[-1] != self.size:
            raise InputError(f"observation has {o.shape[-1]} columns, the layout {self.size}: {self.names}")
        return {c.name: o[..., j] * c.scale + c.offset for j, c in enumerate(self.columns)}

    def value(self, obs, name: str) -> np.ndarray:
        """SI value of one named column of observation(s) ``(..., size)``."""
        c = self.column(name)
        col = self.columns[c]
        return np.asarray(obs, dtype=float)[..., c] * col.scale + col.offset


def preview_fields(steps: int, track_stiffness: bool, position: str = "length") -> tuple[str, ...]:
    """Names of the preview columns: the target position (``length`` on the rig, ``angle`` on the
    joint) of each of the next ``steps`` control steps after the one the ``target_*`` columns
    show, then (if tracked) their stiffnesses."""
    names = tuple(f"target_{position}_+{j}" for j in range(1, steps + 1))
    if track_stiffness:
        names += tuple(f"target_stiffness_+{j}" for j in range(1, steps + 1))
    return names


def rig_layout(spec, nominal, preview_steps: int = 0) -> ObsLayout:
    """The rig envs' layout for task ``spec`` (:class:`~cepam_gym.tasks.spec.TaskSpec`) and the
    nominal plant (:class:`~cepam_gym.plant.params.PlantParams`): lengths about the middle of the end
    stops, pressures per nominal supply; the stiffness target only when the task tracks it; then
    ``preview_steps`` preview columns per tracked target (:func:`preview_fields`)."""
    s = spec.scales
    lo, hi = nominal.min_length, nominal.max_length
    center, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    ps = nominal.supply_pressure
    cols = [
        ObsColumn("length", half, center, "m"),
        ObsColumn("velocity", s.velocity_scale, 0.0, "m/s"),
        ObsColumn("pressure_c", ps, 0.0, "Pa"),
        ObsColumn("pressure_e", ps, 0.0, "Pa"),
        ObsColumn("supply_pressure", ps, 0.0, "Pa"),
        ObsColumn("target_length", half, center, "m"),
    ]
    if spec.track_stiffness:
        cols.append(ObsColumn("target_stiffness", s.stiffness_scale, 0.0, "N/m"))
    cols += [ObsColumn("previous_action_c"), ObsColumn("previous_action_e")]
    names = preview_fields(preview_steps, spec.track_stiffness)
    for name in names:  # preview columns scale like the target they announce
        src = cols[5] if name.startswith("target_length") else cols[6]
        cols.append(ObsColumn(name, src.scale, src.offset, src.unit))
    return ObsLayout(tuple(cols), OBS_FIELDS + names, s.obs_clip, preview_steps)
