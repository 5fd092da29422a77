"""Run ``lanefinder ARGS`` in a process of its own without starting Python again.

Most command-line tests give the command bad input and check its exit status and its one line.
Started as ``python -m lanefinder``, each spent about 0.5 s importing NumPy, OpenCV, PyAV and
pydantic before the first check (about 140 such runs: a quarter of the suite's time on two
cores). Here a fork server (:mod:`multiprocessing`'s "forkserver": a fresh, single-threaded
process) imports them once, and each command runs in a fork of it:

- its own process: its exit status, and all it writes to file descriptors 1 and 2 (Python's or
  a C library's), is the command's;
- run as ``python -m lanefinder`` runs it (:func:`runpy.run_module` on ``lanefinder``, the same
  ``sys.argv[0]`` and program name);
- an exception that escapes is printed with its traceback and exits 1, as in a fresh interpreter.

What this does not cover, Python's start and the imports themselves, the tests that send signals
(which start ``python -m lanefinder`` with :class:`subprocess.Popen`) and the doctest of
:func:`lanefinder._entry.main` still do.
"""

from __future__ import annotations

import multiprocessing
import os
import subprocess
import sys
import tempfile
from pathlib import Path

__all__ = ["run_lanefinder", "run_script"]

#: What the commands import: the fork server imports them once (a fork then has them). They are
#: installed modules, since Python 3.11's fork server does not take the tests' sys.path (each
#: fork does: it then imports this small module to find its target).
PRELOAD = [f"lanefinder.{m}" for m in ("_entry", "batch", "cli", "evaluate", "imagejob", "synth", "videojob")]

_CONTEXT = multiprocessing.get_context("forkserver")
_CONTEXT.set_forkserver_preload(PRELOAD)


def _command(script: str | None, args: list[str], cwd: str | None, out_path: str, err_path: str) -> None:
    """In the fork: send descriptors 1 and 2 to the files, and run ``python -m lanefinder ARGS`` (or the script)."""
    import runpy

    for fd, path in ((1, out_path), (2, err_path)):
        f = os.open(path, os.O_WRONLY | os.O_TRUNC)
        os.dup2(f, fd)
        os.close(f)
    if cwd is not None:
        os.chdir(cwd)
    if script is not None:
        sys.argv = [script, *args]
        runpy.run_path(script, run_name="__main__")
        return
    sys.argv = ["lanefinder", *args]  # run_module sets argv[0] to lanefinder/__main__.py, as `python -m` does
    runpy.run_module("lanefinder", run_name="__main__", alter_sys=True)


def _run(script: str | None, args: tuple[str | Path, ...], cwd: str | Path | None,
         timeout: float) -> subprocess.CompletedProcess:
    argv = [str(a) for a in args]
    shown = [script or "lanefinder", *argv]
    with tempfile.TemporaryDirectory(prefix="lanefinder-cli-") as d:
        out, err = Path(d) / "stdout", Path(d) / "stderr"
        out.touch()
        err.touch()
        proc = _CONTEXT.Process(target=_command,
                                args=(script, argv, None if cwd is None else str(cwd), str(out), str(err)))
        proc.start()
        proc.join(timeout)
        if proc.exitcode is None:
            proc.kill()
            proc.join(10)
            raise subprocess.TimeoutExpired(shown, timeout, out.read_bytes(), err.read_bytes())
        text = {p: p.read_bytes().decode("utf-8", "replace") for p in (out, err)}
    return subprocess.CompletedProcess(shown, proc.exitcode, text[out], text[err])


def run_lanefinder(*args: str | Path, cwd: str | Path | None = None,
                   timeout: float = 120.0) -> subprocess.CompletedProcess:
    """Run ``lanefinder ARGS`` in a forked process, bounded in time, as :func:`subprocess.run` would.

    Returns a :class:`subprocess.CompletedProcess` with the exit status and the text written to
    stdout and stderr; raises :class:`subprocess.TimeoutExpired` (after killing it) when the
    command runs over ``timeout`` seconds.
    """
    return _run(None, args, cwd, timeout)


def run_script(script: str | Path, *args: str | Path, cwd: str | Path | None = None,
               timeout: float = 120.0) -> subprocess.CompletedProcess:
    """Run ``python SCRIPT ARGS`` (one of scripts/) the same way: see :func:`run_lanefinder`."""
    return _run(str(script), args, cwd, timeout)
