"""The ``lanefinder`` command's entry: a Ctrl-C while the command line loads is one line too."""

import sys

__all__ = ["main"]


def main() -> None:
    """Load the command line and run it; Ctrl-C while it loads ends in one line, exit status 130.

    The ``lanefinder`` command and ``python -m lanefinder`` start here.

    Returns
    -------
    None
        It exits: with the command's status (see :mod:`lanefinder.cli`).

    Examples
    --------
    >>> import subprocess, sys
    >>> subprocess.run([sys.executable, "-m", "lanefinder", "--version"], capture_output=True,
    ...                text=True).stdout.split()[0]
    'lanefinder,'
    """
    try:
        from .cli import main as run
    except KeyboardInterrupt:
        _interrupted()
    except Exception as e:
        # A Ctrl-C while a class is made (the standard library's, as it loads) comes wrapped:
        # "RuntimeError: Error calling __set_name__ ...", caused by the KeyboardInterrupt.
        if not _caused_by_ctrl_c(e):
            raise
        _interrupted()
    run()


def _interrupted() -> None:
    sys.stderr.write("lanefinder: error: interrupted\n")
    raise SystemExit(130) from None


def _caused_by_ctrl_c(e: BaseException) -> bool:
    """Tell whether an exception was caused by a KeyboardInterrupt (somewhere down its chain)."""
    seen = set()
    cause: BaseException | None = e
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return True
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return False
