"""The paper's reported numbers as experiments (``cepam_gym/data/reported.yaml``).

Each :class:`Experiment` says what was measured, on which device (CE-PAM, single CPAM or EPAM),
with which bladder and pressures; the model's value is computed by
:func:`cepam_gym.validation.equilibrium.simulate`. Edge units (kPa gauge, cm, g) as the paper
writes them; conversions through :mod:`cepam_gym.units` where they are used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError

REPORTED_PATH = Path(__file__).resolve().parent.parent / "data" / "reported.yaml"

MEASURED_UNITS = {
    "length": "cm",
    "contraction": "%",
    "extension": "%",
    "stiffness": "N/m",
    "force": "N",
    "mean_force_error": "%",
}
DEVICES = ("cepam", "cpam", "epam")
BLADDERS = ("balloon", "tube")


@dataclass(frozen=True)
class Experiment:
    """One measurement: what is measured, on which device, under which conditions.

    Pressures in kPa gauge, lengths in cm, weights in g (edge units; converted where used).
    """

    id: str
    name: str
    measured: str
    unit: str
    value: float
    device: str = "cepam"
    bladder: str = "balloon"
    pc_kpa: float = 0.0
    pe_kpa: float = 0.0
    load_g: float = 0.0  # hanging weight during a length measurement
    loads_g: tuple[float, ...] = ()  # weights of a stiffness measurement
    held_length_cm: float | None = None  # force / local stiffness at this length
    at_length_cm: float | None = None  # the length the paper reports (information only)
    bladder_thickness_mm: float | None = None
    section: str = ""
    figure: str = ""
    derived_from: str | None = None
    computable: bool = True
    model_level: str | None = None  # for the paper's own error numbers
    quote: str = ""
    note: str = ""

    @property
    def source(self) -> str:
        return f"sec. {self.section}" + (f", {self.figure}" if self.figure else "")


_YAML_KEYS = {
    "id",
    "name",
    "measured",
    "unit",
    "value",
    "section",
    "figure",
    "device",
    "bladder",
    "bladder_thickness_mm",
    "pc_kpa",
    "pe_kpa",
    "at_length_cm",
    "loads_g",
    "derived_from",
    "computable",
    "model_level",
    "quote",
    "note",
}


def load_experiments(path: str | Path | None = None) -> list[Experiment]:
    """Read the reported numbers (``data/reported.yaml`` by default); errors name the entry."""
    import yaml

    path = Path(path) if path is not None else REPORTED_PATH
    with path.open() as fh:
        doc = yaml.safe_load(fh)
    if not isinstance(doc, dict) or not isinstance(doc.get("experiments"), list):
        raise InputError(f"{path}: expected a mapping with a list 'experiments'")
    default_loads = tuple(float(x) for x in (doc.get("defaults") or {}).get("loads_g", ()))
    out: list[Experiment] = []
    seen: set[str] = set()
    for i, e in enumerate(doc["experiments"]):
        where = f"{path}: experiment {i + 1}" + (f" ({e.get('id')})" if isinstance(e, dict) else "")
        if not isinstance(e, dict):
            raise InputError(f"{where}: expected a mapping")
        unknown = set(e) - _YAML_KEYS
        if unknown:
            raise InputError(f"{where}: unknown key(s) {sorted(unknown)}")
        for key in ("id", "name", "measured", "unit", "value", "section", "device", "bladder"):
            if key not in e:
                raise InputError(f"{where}: missing key {key!r}")
        if e["id"] in seen:
            raise InputError(f"{where}: duplicate id {e['id']!r}")
        seen.add(e["id"])
        measured, device, bladder = e["measured"], e["device"], e["bladder"]
        if measured not in MEASURED_UNITS:
            raise InputError(f"{where}: measured must be one of {sorted(MEASURED_UNITS)}, got {measured!r}")
        if e["unit"] != MEASURED_UNITS[measured]:
            raise InputError(
                f"{where}: unit of a {measured} must be {MEASURED_UNITS[measured]!r}, got {e['unit']!r}"
            )
        if device not in DEVICES:
            raise InputError(f"{where}: device must be one of {DEVICES}, got {device!r}")
        if bladder not in BLADDERS:
            raise InputError(f"{where}: bladder must be one of {BLADDERS}, got {bladder!r}")
        if bladder == "tube" and "bladder_thickness_mm" not in e:
            raise InputError(f"{where}: a tube row needs bladder_thickness_mm")
        if measured == "contraction" and device != "cpam":
            raise InputError(f"{where}: contraction is defined for the cpam only")
        if measured == "extension" and device == "cpam":
            raise InputError(f"{where}: extension is defined for the epam and the cepam")
        value = float(e["value"])
        if not math.isfinite(value) or value <= 0:
            raise InputError(f"{where}: value must be a positive number, got {e['value']!r}")
        loads = tuple(float(x) for x in e.get("loads_g", default_loads)) if measured == "stiffness" else ()
        if measured == "stiffness" and (not loads or min(loads) <= 0):
            raise InputError(f"{where}: a stiffness needs positive loads_g")
        out.append(
            Experiment(
                id=str(e["id"]),
                name=str(e["name"]),
                measured=measured,
                unit=e["unit"],
                value=value,
                device=device,
                bladder=bladder,
                pc_kpa=float(e.get("pc_kpa", 0.0)),
                pe_kpa=float(e.get("pe_kpa", 0.0)),
                loads_g=loads,
                at_length_cm=float(e["at_length_cm"]) if "at_length_cm" in e else None,
                bladder_thickness_mm=float(e["bladder_thickness_mm"])
                if "bladder_thickness_mm" in e
                else None,
                section=str(e["section"]),
                figure=str(e.get("figure", "")),
                derived_from=e.get("derived_from"),
                computable=bool(e.get("computable", True)),
                model_level=e.get("model_level"),
                quote=str(e.get("quote", "")),
                note=str(e.get("note", "")),
            )
        )
    ids = {x.id for x in out}
    for x in out:
        if x.derived_from is not None and x.derived_from not in ids:
            raise InputError(f"{path}: experiment {x.id}: derived_from {x.derived_from!r} is not an id")
    return out
