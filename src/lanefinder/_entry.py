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
        sys.stderr.write("lanefinder: error: interrupted\n")
        raise SystemExit(130) from None
    run()
