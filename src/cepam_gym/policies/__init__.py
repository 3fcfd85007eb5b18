"""What a learned policy sees and sends: the layer between the model-based controllers and
identification below and the rig's deployment above.

* :mod:`.spec`: :class:`FeatureSpec`, the choices (residual on the inverse-model baseline, target
  shift, set-point gaps, filters, history, plant features, privileged columns);
* :mod:`.features`: :class:`Features`, the observation-to-input and action-to-env arithmetic of a
  spec, the same in training, deployment and export; :func:`obs_batch`, the input check of every
  deployed policy;
* :mod:`.privileged`: what only the simulator knows, for an asymmetric critic.

Pure numpy: the training package (torch, SB3) builds on it, never the other way round.
"""

from .features import Features, obs_batch
from .spec import FeatureSpec

__all__ = ["FeatureSpec", "Features", "obs_batch"]
