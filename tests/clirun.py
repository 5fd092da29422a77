"""Run ``lanefinder ARGS`` in a process of its own without starting Python again.

Most command-line tests give the command bad input and check its exit status and its one line.
Started as ``python -m lanefinder``, each spent about 0.5 s importing NumPy, OpenCV, PyAV and
pydantic before the first check (about 140 such runs: a quarter of the suite's time on two
cores). Here a fork server (:mod:`multiprocessing`'s "forkserver": a process started afresh, not
a fork of pytest's) imports them once, and each command runs in a fork of it:

- its own process: its exit status, and all it writes to file descriptors 1 and 2 (Python's or
  a C library's, whose buffers are flushed at the end), are the command's;
- run as ``python -m lanefinder`` runs it (:func:`runpy.run_module` on ``lanefinder``, the same
  ``sys.argv[0]`` and program name), in the caller's working folder and environment;
- it ends as Python ends: ``SystemExit`` gives the status (a text is printed, status 1); an
  exception that escapes goes to ``sys.excepthook`` (its traceback) and gives status 1, an
  escaped ``KeyboardInterrupt`` death by SIGINT; the ``atexit`` functions run, and the threads
  that are not daemons are waited for.

What differs from a fresh interpreter: the modules in ``PRELOAD`` are already imported (an
import-order fault would not show), ``sys.path`` is pytest's (a script's folder put first),
stdin is empty, and the server's threads at the fork are OpenBLAS's and OpenCV's, which both
handle a fork. Python's start and the imports themselves are covered by the tests that start
``python -m lanefinder`` (those that stop or kill a run, the image command's) and the doctest
of :func:`lanefinder._entry.main`.
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
#: fork does: it then imports this small module to find its target). Not ``lanefinder.batch``:
#: pyarrow starts a memory-allocator thread as it loads.
PRELOAD = [f"lanefinder.{m}" for m in ("_entry", "cli", "evaluate", "imagejob", "synth", "videojob")]

_CONTEXT = multiprocessing.get_context("forkserver")
_CONTEXT.set_forkserver_preload(PRELOAD)


def _exit_status(code: object) -> int:
    """The status Python gives ``SystemExit(code)`` (a code that is not a number is printed)."""
    if code is None:
        return 0
    if isinstance(code, int):
        return code & 0xFF
    print(code, file=sys.stderr)
    return 1


def _command(script: str | None, args: list[str], cwd: str | None, env: dict[str, str], out_path: str,
             err_path: str) -> None:
    """In the fork: send descriptors 1 and 2 to the files, run the command, and end as Python does."""
    import atexit
    import ctypes
    import runpy
    import signal
    import threading

    for fd, path in ((1, out_path), (2, err_path)):
        f = os.open(path, os.O_WRONLY | os.O_TRUNC)
        os.dup2(f, fd)
        os.close(f)
    os.environ.clear()
    os.environ.update(env)
    if cwd is not None:
        os.chdir(cwd)
    interrupted = False
    try:
        if script is not None:
            sys.argv = [script, *args]
            sys.path.insert(0, str(Path(script).resolve().parent))
            runpy.run_path(script, run_name="__main__")
        else:
            sys.argv = ["lanefinder", *args]  # run_module sets argv[0] to lanefinder/__main__.py, as `python -m` does
            runpy.run_module("lanefinder", run_name="__main__", alter_sys=True)
        status = 0
    except SystemExit as e:
        status = _exit_status(e.code)
    except BaseException:
        sys.excepthook(*sys.exc_info())
        interrupted, status = isinstance(sys.exc_info()[1], KeyboardInterrupt), 1
    for t in threading.enumerate():
        if t is not threading.current_thread() and not t.daemon:
            t.join()
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    ctypes.CDLL(None).fflush(None)  # the C library's buffered output
    if interrupted:  # as Python does after an escaped KeyboardInterrupt
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        os.kill(os.getpid(), signal.SIGINT)
    os._exit(status)


def _text(data: bytes) -> str:
    """Decode as ``subprocess.run(..., text=True)`` does: strictly, with universal newlines."""
    return data.decode().replace("\r\n", "\n").replace("\r", "\n")


def _run(script: str | None, args: tuple[str | Path, ...], cwd: str | Path | None,
         timeout: float) -> subprocess.CompletedProcess:
    argv = [str(a) for a in args]
    shown = [script or "lanefinder", *argv]
    with tempfile.TemporaryDirectory(prefix="lanefinder-cli-") as d:
        out, err = Path(d) / "stdout", Path(d) / "stderr"
        out.touch()
        err.touch()
        proc = _CONTEXT.Process(target=_command, args=(script, argv, None if cwd is None else str(cwd),
                                                       dict(os.environ), str(out), str(err)))
        proc.start()
        try:
            proc.join(timeout)
            if proc.exitcode is None:
                raise subprocess.TimeoutExpired(shown, timeout, out.read_bytes(), err.read_bytes())
        finally:  # timed out, or the caller interrupted: the command does not outlive the call
            if proc.exitcode is None:
                proc.kill()
                proc.join(10)
        stdout, stderr = _text(out.read_bytes()), _text(err.read_bytes())
    return subprocess.CompletedProcess(shown, proc.exitcode, stdout, stderr)


def run_lanefinder(*args: str | Path, cwd: str | Path | None = None,
                   timeout: float = 120.0) -> subprocess.CompletedProcess:
    """Run ``lanefinder ARGS`` in a forked process, bounded in time, as :func:`subprocess.run` would.

    Returns a :class:`subprocess.CompletedProcess` with the exit status (negative: the signal that
    ended it) and the text written to stdout and stderr; raises :class:`subprocess.TimeoutExpired`
    (after killing it) when the command runs over ``timeout`` seconds.
    """
    return _run(None, args, cwd, timeout)


def run_script(script: str | Path, *args: str | Path, cwd: str | Path | None = None,
               timeout: float = 120.0) -> subprocess.CompletedProcess:
    """Run ``python SCRIPT ARGS`` (one of scripts/) the same way: see :func:`run_lanefinder`."""
    return _run(str(script), args, cwd, timeout)
