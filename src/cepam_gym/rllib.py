"""Old path of :mod:`cepam_gym.integrations.rllib` (kept so that existing imports work): importing
it gives that very module (one ``_instances`` counter, one ``make_env`` for pickling)."""

import sys

from .integrations import rllib as _rllib

sys.modules[__name__] = _rllib
