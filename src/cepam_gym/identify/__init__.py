"""Fit the plant's dynamics to a rig's logs (``cepam-gym identify``), and the excitation to log
(``cepam-gym excite``); docs/identify.md, "From your rig to the simulator".

* :mod:`.logs`: the log CSV, its checks (one-line errors) and its resampling onto the plant's grid;
* :mod:`.excite`: excitation schedules, and the log a simulated rig writes from one;
* :mod:`.simulate`: a recording replayed on the plant's kernel, many parameter rows at once, and
  the sensor model (delay, gain, bias);
* :mod:`.dynamic_params`: what can be fitted per action mode, with physical bounds;
* :mod:`.fit`: the output-error least squares on the fitting core of :mod:`cepam_gym.validation`;
* :mod:`.run`: one identification end to end, its scores and verdicts; :mod:`.report`: text,
  YAML, JSON, figures; :mod:`.selfcheck`: a known truth identified; :mod:`.cli`: the commands.
"""

from .logs import Recording, read_log, write_log
from .run import Identification, identify

__all__ = ["Identification", "Recording", "identify", "read_log", "write_log"]
