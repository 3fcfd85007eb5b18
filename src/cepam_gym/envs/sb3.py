"""Old path of :mod:`cepam_gym.integrations.sb3` (kept so that existing imports work): importing
it gives that very module, so ``from cepam_gym.envs.sb3 import make_sb3_vec_env`` is unchanged."""

import sys

from ..integrations import sb3 as _sb3

sys.modules[__name__] = _sb3
