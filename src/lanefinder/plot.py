"""Telemetry plots with matplotlib."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import LaneFinderError
from .io import atomic_path
from .telemetry import MAX_ABS_VALUE

__all__ = ["PLOT_FORMATS", "plot_telemetry"]

#: The files a plot is written as (by the name's suffix).
PLOT_FORMATS = ("png", "pdf", "svg")
#: The telemetry columns plotted.
_PLOTTED = ("radius_m", "offset_m", "width_m", "left_conf", "right_conf")


def plot_telemetry(rows: list[dict], path: str | Path) -> None:
    """Plot radius, offset, width and line confidences over time, one panel each, as a PNG.

    Parameters
    ----------
    rows : list of dict
        Telemetry rows (see :func:`lanefinder.telemetry.read_telemetry`); missing values may be
        None.  Frames whose ``state`` is ``lost`` are shaded in the confidence panel.
    path : str or Path
        The image to write (atomically: never half-written): ``.png``, ``.pdf`` or ``.svg``.

    Raises
    ------
    LaneFinderError
        When ``rows`` is empty or is not lanefinder telemetry (no ``time_s``, or none of the
        plotted columns), or ``path`` is not a .png, .pdf or .svg file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> rows = [{"time_s": t / 25, "radius_m": 900.0, "offset_m": 0.1, "width_m": 3.7,
    ...          "left_conf": 0.9, "right_conf": 0.8, "state": "tracking"} for t in range(50)]
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "plot.png"
    >>> plot_telemetry(rows, out)
    >>> out.read_bytes()[1:4]
    b'PNG'
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fmt = Path(path).suffix.lower().lstrip(".")
    if fmt not in PLOT_FORMATS:
        kinds = ", ".join("." + f for f in PLOT_FORMATS)
        raise LaneFinderError(f"a plot is written as {kinds}: not {Path(path).name or path}")
    if not rows:
        raise LaneFinderError("the telemetry file has no rows")
    if "time_s" not in rows[0] or not any(k in rows[0] for k in _PLOTTED):
        raise LaneFinderError(f"not lanefinder telemetry: it needs time_s and some of {', '.join(_PLOTTED)}; "
                              f"it has {', '.join(list(rows[0])[:8])}")

    def col(key: str) -> np.ndarray:
        try:
            v = np.array([np.nan if r.get(key) is None else float(r[key]) for r in rows])
        except (TypeError, ValueError, OverflowError):
            raise LaneFinderError(f"{key} is not a number in every row of the telemetry") from None
        if (big := np.flatnonzero(np.abs(v) > MAX_ABS_VALUE)).size:  # matplotlib cannot scale an axis to 1e308
            raise LaneFinderError(f"{key} is beyond +-{MAX_ABS_VALUE:g} in row {big[0] + 1} of the telemetry "
                                  f"({v[big[0]]:g})")
        return v

    t = col("time_s")
    if not np.isfinite(t).any():
        raise LaneFinderError("time_s is not a number in any row of the telemetry: nothing to plot against")
    fig, axes = plt.subplots(4, 1, figsize=(11, 9), sharex=True)
    radius = col("radius_m")
    radius[radius <= 0] = np.nan  # no radius is 0 or less: not drawn (a log axis has no place for it)
    if np.isfinite(radius).any():
        axes[0].semilogy(t, radius, lw=1)
    axes[0].set_ylabel("radius (m)")
    axes[1].plot(t, col("offset_m"), lw=1)
    axes[1].axhline(0, color="grey", lw=0.5)
    axes[1].set_ylabel("offset (m)\n+ = right of centre")
    axes[2].plot(t, col("width_m"), lw=1)
    axes[2].set_ylabel("lane width (m)")
    axes[3].plot(t, col("left_conf"), lw=1, label="left")
    axes[3].plot(t, col("right_conf"), lw=1, label="right")
    lost = np.array([r.get("state") == "lost" for r in rows])
    if lost.any():
        axes[3].fill_between(t, 0, 1, where=lost, color="red", alpha=0.2, label="lost", step="mid")
    axes[3].set_ylim(0, 1.05)
    axes[3].set_ylabel("confidence")
    axes[3].legend(loc="lower right")
    axes[3].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    with atomic_path(path, suffix="." + fmt) as tmp:
        fig.savefig(tmp, dpi=90, format=fmt)
    plt.close(fig)
