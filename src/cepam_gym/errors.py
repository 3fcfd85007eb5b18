"""The project's user-error types.

:class:`InputError` is bad input from a user: an env kwarg, a reset option, an action, a config
value, the content of a file they named. It subclasses ``ValueError``, so ``except ValueError``
still catches it; the command line reports it (and only it, with the file errors of
:mod:`cepam_gym.cli_errors`) as one line naming the input, while any other exception is a bug
and keeps its traceback.
"""

from __future__ import annotations


class InputError(ValueError):
    """Bad user input; the message names the input and what is expected."""


class UnexpectedKwargError(InputError, TypeError):
    """An unknown constructor argument. Worded as Python's own ``TypeError`` ("X.__init__() got an
    unexpected keyword argument 'k'") and a ``TypeError``, because clients try optional arguments
    and retry without them on exactly that error (TorchRL's ``GymEnv`` passes ``frameskip`` to
    ``gym.make``); an :class:`InputError` too, so the command line reports it as one line."""

    @classmethod
    def naming(cls, owner: str, unknown: list[str], valid: list[str]) -> UnexpectedKwargError:
        """The error for the ``unknown`` kwargs of class ``owner``, listing the ``valid`` ones.
        (Built from one message like every exception: Gymnasium's ``make`` re-raises a
        ``TypeError`` as ``type(e)(message)``.)"""
        first, rest = unknown[0], unknown[1:]
        also = f" (and {', '.join(map(repr, rest))})" if rest else ""
        return cls(f"{owner}.__init__() got an unexpected keyword argument {first!r}{also}; valid: {valid}")
