"""The static parameters ``calibrate`` fits: their physical bounds and how each maps onto
:class:`~cepam_gym.plant.params.PlantParams` (the table of :mod:`.fitcore`), and plant v1's calibration
set (docs/calibration.md, "Plant v1").

Parameters that only enter through a combination cannot be told apart: the bladder and sleeve
thicknesses enter only as ``t_a = t_s + t_b`` (Eq. 35), so the default set fits ``wall_thickness``
(``t_a``, keeping the base ratio ``t_b : t_s``); ``kr_scale`` scales both ``K_r`` of Eq. 27.
"""

from __future__ import annotations

from ..plant.params import PlantParams
from ..units import from_si, to_si
from .fitcore import FitParam, field_accessors

# ------------------------------------------------------------------ the parameters that can be fitted
KR_HIGH_PAPER = 2.0e6  # Pa/m, Eq. 27
KR_LOW_PAPER = 5.0e5


def _split_wall(p: PlantParams, ta_mm: float) -> dict:
    ta = to_si(ta_mm, "mm")
    total = p.bladder_thickness + p.sleeve_thickness
    frac = p.bladder_thickness / total if total > 0 else 0.5
    return {"bladder_thickness": ta * frac, "sleeve_thickness": ta * (1.0 - frac)}


FIT_PARAMS: dict[str, FitParam] = {
    fp.name: fp
    for fp in (
        FitParam(
            "cpam_rest_angle",
            "deg",
            5.0,
            50.0,
            "braid angle of the CPAM at rest: a contractor's braid is below 54.7 deg; commercial "
            "sleeves are woven at about 15-45 deg",
            *field_accessors("cpam_rest_angle"),
            ("cpam_rest_angle",),
        ),
        FitParam(
            "epam_sleeve_free_angle",
            "deg",
            5.0,
            50.0,
            "braid angle of the EPAM sleeve before it is compressed (the same kind of sleeve)",
            *field_accessors("epam_sleeve_free_angle"),
            ("epam_sleeve_free_angle",),
        ),
        FitParam(
            "wall_thickness",
            "mm",
            0.1,
            1.5,
            "t_a = t_s + t_b (Eq. 35): a balloon wall of a few tenths of a mm (< 1 mm, sections "
            "I-II) plus a braid of nylon threads; a wall cannot be thinner than 0.1 mm; the base "
            "ratio t_b : t_s is kept",
            lambda p: from_si(p.bladder_thickness + p.sleeve_thickness, "mm"),
            _split_wall,
            ("bladder_thickness", "sleeve_thickness"),
        ),
        FitParam(
            "bladder_thickness",
            "mm",
            0.0,
            1.0,
            "t_b (Eq. 35): the balloon is thinner than the 1 mm tube",
            *field_accessors("bladder_thickness"),
            ("bladder_thickness",),
        ),
        FitParam(
            "sleeve_thickness",
            "mm",
            0.0,
            1.0,
            "t_s (Eq. 35): a braid of nylon threads",
            *field_accessors("sleeve_thickness"),
            ("sleeve_thickness",),
        ),
        FitParam(
            "kr_scale",
            "",
            0.0,
            4.0,
            "factor on both K_r of Eq. 27 (2000 and 500 kPa/m, measured by Tsagarakis and "
            "Caldwell on another muscle); 4 lets a balloon lose up to 80 kPa to inflation",
            lambda p: p.kr_high / KR_HIGH_PAPER,
            lambda p, v: {"kr_high": v * KR_HIGH_PAPER, "kr_low": v * KR_LOW_PAPER},
            ("kr_high", "kr_low"),
        ),
        FitParam(
            "elastic_stiffness",
            "n_per_m",
            0.0,
            400.0,
            "axial stiffness of the two bladders (not in the paper): latex E of 1-2 MPa, wall "
            "<= 1 mm, 5 and 10 mm diameter, 15-20 cm long gives at most a few hundred N/m",
            *field_accessors("elastic_stiffness"),
            ("elastic_stiffness",),
        ),
        FitParam(
            "elastic_rest_length",
            "cm",
            15.0,
            19.5,
            "rest length of that elasticity: between the EPAM bladder (15 cm) and the CPAM (19.5 cm)",
            *field_accessors("elastic_rest_length"),
            ("elastic_rest_length",),
        ),
        FitParam(
            "bladder_shear_modulus",
            "kpa",
            50.0,
            3000.0,
            "neo-Hookean shear modulus of the balloon rubber (natural latex: about 0.3-0.6 MPa "
            "in small strain; wide bounds because only mu t_b is seen by most data)",
            *field_accessors("bladder_shear_modulus"),
            ("bladder_shear_modulus",),
        ),
        FitParam(
            "tube_shear_modulus",
            "kpa",
            50.0,
            3000.0,
            "neo-Hookean shear modulus of the rubber-tube bladders (natural or silicone rubber: "
            "about 0.2-1 MPa)",
            *field_accessors("tube_shear_modulus"),
            ("tube_shear_modulus",),
        ),
        FitParam(
            "friction_mu",
            "",
            0.0,
            1e-3,
            "plant v2 contact-area friction coefficient (F_b = mu (Pc+ S_c + Pe+ S_e)); up to 1e-3 "
            "lets friction hold up to about 2 N at the paper's highest pair, more than half the "
            "heaviest weight",
            *field_accessors("friction_mu"),
            ("friction_mu",),
        ),
        FitParam(
            "collapse_seal_diameter",
            "mm",
            0.0,
            5.0,
            "plant v2: seal of the collapsed CPAM on the end cap, at most its 5 mm bladder",
            *field_accessors("collapse_seal_diameter"),
            ("collapse_seal_diameter",),
        ),
        FitParam(
            "friction_presliding",
            "mm",
            0.1,
            2.0,
            "presliding displacement of the slowest Maxwell-slip element: PAM hysteresis loops "
            "show stick over a few tenths of a mm to about a mm",
            *field_accessors("friction_presliding"),
            ("friction_presliding",),
        ),
        FitParam(
            "epam_thread_compliance",
            "per_kn",
            0.0,
            1.5,
            "plant v2: strain of the EPAM braid's threads per kN of their total tension; generous: 1.5 "
            "per kN stretches them by about half at the tube's 500 kPa, where Chambers and Wereley (2022) "
            "measured PAM diameters up to 30 % above the inelastic braid's",
            *field_accessors("epam_thread_compliance"),
            ("epam_thread_compliance",),
        ),
        FitParam(
            "cpam_thread_compliance",
            "per_kn",
            0.0,
            1.5,
            "plant v2: the same for the CPAM's braid (loaded by P_ac - P_ae): the same kind of sleeve",
            *field_accessors("cpam_thread_compliance"),
            ("cpam_thread_compliance",),
        ),
        FitParam(
            "thread_compliance",
            "per_kn",
            0.0,
            1.5,
            "plant v2: one thread compliance for both braids (the same kind of sleeve; strain per kN "
            "of total thread tension), bounded as epam_thread_compliance",
            lambda p: from_si(p.epam_thread_compliance, "per_kn"),
            lambda p, v: {
                "epam_thread_compliance": to_si(v, "per_kn"),
                "cpam_thread_compliance": to_si(v, "per_kn"),
            },
            ("epam_thread_compliance", "cpam_thread_compliance"),
        ),
        FitParam(
            "end_mass",
            "g",
            5.0,
            100.0,
            "the hanging end cap (3D printed)",
            *field_accessors("end_mass"),
            ("end_mass",),
        ),
    )
}
DEFAULT_FIT = ("cpam_rest_angle", "epam_sleeve_free_angle", "wall_thickness", "kr_scale", "elastic_stiffness")

# ------------------------------------------------------------------ plant v1: one fit across all data
# The braid angles' lower bounds keep each sleeve within twice its nominal diameter over the stroke
# (docs/calibration.md, "Plant v1"): a braid of free length L_f, angle theta_0, pressed to L has
# D / D_0 = sin(theta) / sin(theta_0) with cos(theta) = (L / L_f) cos(theta_0); D / D_0 <= 2 at the
# shortest length (15 cm) needs theta_0 >= 20.3 deg (CPAM, L_f = 19.5 cm) and >= 26.6 deg (EPAM
# sleeve, L_f = 30 cm). Moduli: rubber in small strain, 0.2-1 MPa (latex, natural and silicone
# rubber); walls: a balloon of 0.05-0.5 mm, a braid of 0.05-0.5 mm.
# K_r of Eq. 27 stays the paper's (fitting its scale moves the mean error by 0.3 %).
V1_FIT = (
    "cpam_rest_angle",
    "epam_sleeve_free_angle",
    "bladder_thickness",
    "sleeve_thickness",
    "bladder_shear_modulus",
    "tube_shear_modulus",
)
V1_BOUNDS = {
    "cpam_rest_angle": (20.3, 50.0),
    "epam_sleeve_free_angle": (26.6, 50.0),
    "bladder_thickness": (0.05, 0.5),
    "sleeve_thickness": (0.05, 0.5),
    "bladder_shear_modulus": (200.0, 1000.0),
    "tube_shear_modulus": (200.0, 1000.0),
}
V1_STARTS = (
    [21.0, 35.0, 0.2, 0.1, 500.0, 300.0],
    [22.0, 40.0, 0.3, 0.1, 300.0, 600.0],
    [30.0, 45.0, 0.1, 0.2, 800.0, 200.0],
)  # edge units, in V1_FIT order
