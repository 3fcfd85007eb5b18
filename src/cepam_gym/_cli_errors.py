"""The former name of :mod:`cepam_gym.cli_errors`, kept for code that imports it: the same module
object (its ``--debug`` state is one), not a copy."""

import sys

from . import cli_errors

sys.modules[__name__] = cli_errors
