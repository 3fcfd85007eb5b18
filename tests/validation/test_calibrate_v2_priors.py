"""Plant v2's maximum-a-posteriori fit: the prior residuals and the switch that turns them off
(cheap: a stand-in model instead of the protocols)."""

from __future__ import annotations

import numpy as np
import pytest

from cepam_gym.plant.params import preset
from cepam_gym.units import from_si
from cepam_gym.validation import calibrate_v2 as c2
from cepam_gym.validation.fit import FIT_PARAMS, apply, fit_residuals, relative_errors
from cepam_gym.validation.fitcore import Scaling


def _centres() -> np.ndarray:
    """Edge values of V2_FIT: the preset's, with each prior's parameter at its centre."""
    v2 = preset("balloon_v2")
    return np.array(
        [
            from_si(c2.PRIORS[n][0], FIT_PARAMS[n].unit) if n in c2.PRIORS else FIT_PARAMS[n].get(v2)
            for n in c2.V2_FIT
        ]
    )


def test_prior_residuals_vanish_at_the_centre_and_scale_with_the_departure_in_sd():
    x0 = _centres()
    assert set(c2.PRIORS) <= set(c2.V2_FIT)
    np.testing.assert_array_equal(c2.prior_residuals(c2.V2_FIT, x0), np.zeros(len(c2.PRIORS)))
    prior_names = [n for n in c2.V2_FIT if n in c2.PRIORS]
    for k in (-2.0, 0.5, 1.0):
        x = x0.copy()
        for j, n in enumerate(c2.V2_FIT):
            if n in c2.PRIORS:
                x[j] += k * from_si(c2.PRIORS[n][1], FIT_PARAMS[n].unit)  # k sd off
        r = c2.prior_residuals(c2.V2_FIT, x)
        assert r.shape == (len(prior_names),)
        np.testing.assert_allclose(r, k * c2.PRIOR_SCALE, rtol=1e-9)
    # the shipped preset's tube rubber, 359.6 kPa: (359.6e3 - 0.6e6) / 0.2e6 sd, times the scale
    tube = c2.prior_residuals(("tube_shear_modulus",), [359.6])
    np.testing.assert_allclose(tube, [c2.PRIOR_SCALE * (359.6e3 - 0.6e6) / 0.2e6])
    # parameters without a prior add nothing
    assert c2.prior_residuals(("friction_mu", "cpam_rest_angle"), [2e-4, 22.0]).size == 0


def _stand_in(exps, p):
    """A model that reads the fitted parameters, without running a protocol."""
    return np.array([e.value * (1.0 + p.tube_shear_modulus / 1e7 - p.epam_thread_compliance) for e in exps])


@pytest.mark.parametrize("priors", [False, True])
def test_priors_off_give_the_plain_residuals_and_on_append_the_prior(priors):
    exps = c2.v2_experiments()
    v2 = preset("balloon_v2")
    starts, kw = c2.fit_setup(v2, priors)
    assert len(starts) == (4 if priors else 3)  # with priors, one more start at their centres
    scale = Scaling([FIT_PARAMS[n] for n in c2.V2_FIT], c2.V2_BOUNDS)
    res = fit_residuals(exps, v2, c2.V2_FIT, scale, _stand_in, kw["prior"])
    for x in (starts[0], starts[1], _centres()):
        z = scale.to_z(np.array(x))
        x = scale.to_edge(z)
        plain = relative_errors(_stand_in(exps, apply(v2, c2.V2_FIT, x)), exps)
        r = res(z)
        np.testing.assert_array_equal(r[: len(exps)], plain)
        if priors:
            np.testing.assert_array_equal(r[len(exps) :], c2.prior_residuals(c2.V2_FIT, x))
        else:
            assert r.size == len(exps)
