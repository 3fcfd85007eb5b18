"""The project's user-error type.

:class:`InputError` is bad input from a user: an env kwarg, a reset option, an action, a config
value, the content of a file they named. It subclasses ``ValueError``, so ``except ValueError``
still catches it; the command line reports it (and only it, with the file errors of
:mod:`cepam_gym._cli_errors`) as one line naming the input, while any other exception is a bug
and keeps its traceback.
"""


class InputError(ValueError):
    """Bad user input; the message names the input and what is expected."""
