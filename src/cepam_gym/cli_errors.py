"""User errors of the command line: one line on stderr naming the problem, exit code 2, no
traceback (``--debug``, or ``CEPAM_GYM_DEBUG=1``, shows it).

A user error is bad input: a config, env kwarg, option or hyperparameter that is refused (the
project's :class:`~cepam_gym.errors.InputError`, the training code's ``ConfigError`` among them),
a missing or unreadable file (``OSError``), a corrupted one (a truncated or random zip, a garbage
pickle, broken YAML). Anything else, a plain ``ValueError`` included, is a bug and keeps its
traceback.
"""

from __future__ import annotations

import argparse
import os
import pickle
import sys
import zipfile

from .errors import InputError

EXIT_USER_ERROR = 2
_debug = False  # set by run_guarded: commands that report their own errors re-raise instead


class CommandParser(argparse.ArgumentParser):
    """argparse's parser with the command line's error format: a bad option or value is one line,
    ``prog: error: message (--help shows the options)``, and exit code 2 (argparse prints the whole
    usage block first, several lines for a command with many options). ``--help`` is unchanged."""

    def error(self, message: str):
        self.exit(
            EXIT_USER_ERROR, f"{self.prog}: error: {' '.join(message.split())} (--help shows the options)\n"
        )


def debug_on() -> bool:
    return _debug or os.environ.get("CEPAM_GYM_DEBUG", "") not in ("", "0")


def report(prog: str, e: BaseException) -> int:
    """Print the one-line report of user error ``e`` for command ``prog``; the exit code."""
    print(f"{prog}: error: {describe(e)} (--debug shows the traceback)", file=sys.stderr)
    return EXIT_USER_ERROR


def user_error_types() -> tuple[type[BaseException], ...]:
    types: list[type[BaseException]] = [
        InputError,
        OSError,
        EOFError,
        zipfile.BadZipFile,
        pickle.UnpicklingError,
    ]
    try:
        import yaml

        types.append(yaml.YAMLError)
    except ImportError:  # pragma: no cover - pyyaml is a dependency
        pass
    return tuple(types)


def describe(e: BaseException) -> str:
    """One line naming the problem."""
    if isinstance(e, OSError) and e.strerror and e.filename:
        msg = f"{e.strerror}: {e.filename}"
    else:
        msg = str(e) or type(e).__name__
        if not isinstance(e, (InputError, OSError)):
            msg = f"{type(e).__name__}: {msg}"
    return " ".join(msg.split())


def debug_requested(argv: list[str]) -> tuple[bool, list[str]]:
    """``(debug?, argv without --debug)``."""
    debug = "--debug" in argv or os.environ.get("CEPAM_GYM_DEBUG", "") not in ("", "0")
    return debug, [a for a in argv if a != "--debug"]


def run_guarded(prog: str, fn, argv: list[str], debug: bool) -> int:
    """``fn(argv)``, with user errors reported as one line and exit code 2 (re-raised if debug)."""
    global _debug
    _debug = debug
    try:
        return fn(argv) or 0
    except user_error_types() as e:
        if debug:
            raise
        return report(prog, e)


def load_error(path, e: BaseException, what: str = "file") -> InputError:
    """An :class:`~cepam_gym.errors.InputError` naming a ``what`` at ``path`` that could not be
    loaded (corrupted, truncated, or not what it should be), chained to the loader's exception."""
    reason = " ".join((str(e) or type(e).__name__).split())
    return InputError(
        f"cannot load the {what} {path}: {type(e).__name__}: {reason} "
        "(corrupted or truncated? re-create it or point at another)"
    )


def guarded_load(path, what: str, loader, *args, **kwargs):
    """``loader(*args, **kwargs)``; any failure but a missing file (a corrupted file can raise
    nearly anything: BadZipFile, UnpicklingError, EOFError, KeyError, a torch RuntimeError...)
    becomes an ``InputError`` naming the ``what`` at ``path``."""
    try:
        return loader(*args, **kwargs)
    except FileNotFoundError:
        raise
    except Exception as e:  # noqa: BLE001 - re-raised with the file named, chained
        raise load_error(path, e, what) from e
