"""Set-up run in each local Dask worker process that ``lanefinder batch`` starts.

A terminal's Ctrl-C goes to every process of the foreground group.  The batch's own process
handles it (it stops the run and closes the cluster in order); the local workers ignore it, so
that they do not each die printing a traceback, and log only what is critical (as the cluster
closes under them, a worker's heartbeat fails and distributed logs it as an error; a task's own
failure reaches the batch as its exception, and is reported per video).  Dask runs
:func:`dask_setup` as the worker's preload (``LocalCluster(preload=[__name__])``).
"""

from __future__ import annotations

import logging
import signal
import threading

__all__ = ["dask_setup"]


def dask_setup(worker: object) -> None:
    """Make this worker process ignore SIGINT (the client stops it) and log only critical messages.

    Parameters
    ----------
    worker : distributed.Worker
        The worker being started (unused).

    Returns
    -------
    None

    Examples
    --------
    >>> import logging, signal
    >>> before, level = signal.getsignal(signal.SIGINT), logging.getLogger("distributed").level
    >>> dask_setup(None)
    >>> signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    True
    >>> _ = signal.signal(signal.SIGINT, before)
    >>> logging.getLogger("distributed").setLevel(level)
    """
    logging.getLogger("distributed").setLevel(logging.CRITICAL)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
