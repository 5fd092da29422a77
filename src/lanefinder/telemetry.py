"""Per-frame telemetry: one row per frame, as CSV or JSON Lines, in one row format shared by the jobs.

Fields (stable names; list-valued fields are JSON arrays, also inside CSV cells): frame,
time_s, state, left_found, right_found, left_inferred, right_inferred, left_conf, right_conf,
radius_m, curvature_per_m, offset_m, width_m, misses, left_fit_m, right_fit_m, left_fit_px,
right_fit_px, h_samples, left_x, right_x, left_range_m, right_range_m, left_x_conf, right_x_conf,
setup (config, default, first-frame, lines, estimated, or for a still horizon and lines: see
:mod:`lanefinder.selfcal`), horizon_px and camera_height_m (the set-up in use: its horizon row and
the camera height it implies), and checks
(the named checks that refused a line or a lane that frame, comma-separated, empty when none:
:attr:`lanefinder.lane.LaneResult.checks`; files written before it have no such column).

The per-line fields (``left_*``/``right_*``) come from each side's
:class:`~lanefinder.lane.Line` through one table, :data:`LINE_FIELDS`.  ``left_x``/``right_x``
give each line's x in the original (distorted) frame at the rows ``h_samples`` (400, 410, ...
710 for 720-row video: the TuSimple benchmark rows), or -2 where the line is absent or the
frame is blown out across it (glare: see :class:`BlownOut`; its ``*_x_conf`` is then 0).  Missing
numbers are empty (CSV) or null (JSONL).  The image job's ``results.jsonl`` rows hold the same
fields after its own ``image``, ``output`` and ``ms``.
"""

from __future__ import annotations

import contextlib
import csv
import functools
import io
import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .birdseye import BirdsEye, setup_of
from .config import FarConfig
from .errors import LaneFinderError
from .farfield import far_rows, row_confidence
from .geometry import poly_x
from .io import OutputSet, json_lines
from .lane import SIDES, LaneResult, Line
from .threshold import BLOWN_OUT_LEVEL, blown_out

__all__ = [
    "BLOWN_OUT_HALF_M",
    "BLOWN_OUT_LEVEL",
    "BOOL_FIELDS",
    "FIELDS",
    "LINE_FIELDS",
    "LIST_FIELDS",
    "MAX_ABS_VALUE",
    "TELEMETRY_SUFFIXES",
    "TEXT_FIELDS",
    "BlownOut",
    "TelemetryWriter",
    "h_samples",
    "is_number",
    "is_number_list",
    "lane_row",
    "line_x_at_rows",
    "make_row",
    "read_telemetry",
]


#: No pixel, distance or time in telemetry (or its truth) is this large: readers refuse larger
#: numbers (sums, fits and plots of them overflow, and a frame cannot be drawn at them).
MAX_ABS_VALUE = 1e9


def is_number(v: object) -> bool:
    """Tell whether a telemetry value is a number within +-``MAX_ABS_VALUE`` (not a bool, not NaN).

    Parameters
    ----------
    v : object
        The value.

    Returns
    -------
    bool
        True for such a number.

    Examples
    --------
    >>> is_number(3), is_number(2.5), is_number(True), is_number(float("nan")), is_number(1e308)
    (True, True, False, False, False)
    """
    return isinstance(v, (int, float)) and not isinstance(v, bool) and abs(v) <= MAX_ABS_VALUE  # NaN fails too


def is_number_list(v: object) -> bool:
    """Tell whether a telemetry value is a list of numbers (:func:`is_number`), as ``left_x`` is.

    Parameters
    ----------
    v : object
        The value.

    Returns
    -------
    bool
        True for such a list (an empty one too).

    Examples
    --------
    >>> is_number_list([1, 2.5]), is_number_list(["a"]), is_number_list(5)
    (True, False, False)
    """
    if not isinstance(v, list):
        return False
    if not set(map(type, v)) <= _PLAIN_NUMBERS:  # bools, text, None, or numbers of other types
        return all(is_number(x) for x in v)
    try:  # (at C speed: a truth file holds millions of these)
        values = np.fromiter(v, np.float64, len(v))
    except OverflowError:  # an int beyond any float
        return False
    return bool(np.all(np.abs(values) <= MAX_ABS_VALUE))  # NaN fails too


#: The types :func:`is_number_list` checks in one pass (a bool's type is bool, not int).
_PLAIN_NUMBERS = frozenset({int, float})


def _paired(name: str) -> list[str]:
    return [f"{side}_{name}" for side in SIDES]


#: Per-line columns: the suffix of ``left_<name>``/``right_<name>``, in column order.
LINE_FIELDS = ("found", "inferred", "conf", "fit_m", "fit_px", "x", "range_m", "x_conf")
FIELDS = ["frame", "time_s", "state", *_paired("found"), *_paired("inferred"), *_paired("conf"),
          "radius_m", "curvature_per_m", "offset_m", "width_m", "misses", *_paired("fit_m"), *_paired("fit_px"),
          "h_samples", *_paired("x"), *_paired("range_m"), *_paired("x_conf"),
          "setup", "horizon_px", "camera_height_m", "checks"]
#: Columns that hold text.
TEXT_FIELDS = {"state", "setup", "checks"}
LIST_FIELDS = {*_paired("fit_m"), *_paired("fit_px"), "h_samples", *_paired("x"), *_paired("x_conf")}
_DEFAULT_DECAY_M = FarConfig().confidence_decay_m
BOOL_FIELDS = {*_paired("found"), *_paired("inferred")}
#: The telemetry formats, by file suffix.
TELEMETRY_SUFFIXES = (".csv", ".jsonl", ".parquet")


#: The set-up's horizon, camera height and focal length, once per set-up (not per row).
_setup_numbers = functools.lru_cache(maxsize=8)(setup_of)


#: A line is not reported at a row where the frame is blown out across it (glare): where every
#: pixel of the row within ``BLOWN_OUT_HALF_M`` of the line is at least ``BLOWN_OUT_LEVEL`` in
#: every channel, no paint can be seen.  (Tuning seeds 0-10, glare: 0.725 -> 0.770 at 245 and
#: 0.3 m, 0.763 at 0.6 m, 0.753 at 1 m; every other scenario unchanged.  On the harder challenge
#: video it leaves out 1583 of 59677 points, on 237 frames of washed-out road; none on the
#: other two videos.)
BLOWN_OUT_HALF_M = 0.3


@dataclass(frozen=True, eq=False)
class BlownOut:
    """Where a frame is blown out (every channel at least ``BLOWN_OUT_LEVEL``), on some of its rows.

    Made before anything is drawn on the frame; :func:`lane_row` leaves a line's x out at the
    rows where it is blown out across the line (no paint can be seen there): every pixel within
    ``BLOWN_OUT_HALF_M`` of it on that row, and at least 3 px either side.

    Attributes
    ----------
    rows : tuple of int
        The frame rows looked at.
    lit : (len(rows), W + 1) int32 ndarray
        Per row, the running count of pixels that are not blown out (0 first); read-only.

    Examples
    --------
    >>> frame = np.zeros((720, 1280, 3), np.uint8); frame[400:500, 600:900] = 255
    >>> b = BlownOut.of(frame, [450, 600])
    >>> b.across([700.0, 700.0], [20, 20]).tolist(), b.across([590.0, 700.0], [20, 20]).tolist()
    ([True, False], [False, False])
    """

    rows: tuple[int, ...]
    lit: np.ndarray

    @classmethod
    def of(cls, frame: np.ndarray, rows: list[int]) -> BlownOut:
        """Look at a frame's rows.

        Parameters
        ----------
        frame : (H, W, 3) uint8 ndarray
            The frame, BGR, as read (nothing drawn on it yet).
        rows : list of int
            The rows (``h_samples``); rows outside the frame count as not blown out.

        Returns
        -------
        BlownOut
            The rows' running counts.

        Examples
        --------
        >>> BlownOut.of(np.full((720, 1280, 3), 255, np.uint8), [400, 710]).lit[:, -1].tolist()
        [0, 0]
        """
        if not (isinstance(frame, np.ndarray) and frame.ndim == 3 and frame.shape[2] == 3
                and frame.dtype == np.uint8 and 0 not in frame.shape):
            raise LaneFinderError("a frame must be a BGR uint8 image of shape (height, width, 3)")
        h, w = frame.shape[:2]
        inside = [min(max(int(r), 0), h - 1) for r in rows]
        blown = blown_out(np.ascontiguousarray(frame[inside]))  # 255 where blown out
        if not blown.any():  # the common case: every pixel lit, the counts are 0..W on every row (read-only)
            return cls(tuple(int(r) for r in rows), np.broadcast_to(np.arange(w + 1, dtype=np.int32),
                                                                    (len(rows), w + 1)))
        lit = np.zeros((len(rows), w + 1), np.int32)
        np.cumsum(blown == 0, axis=1, out=lit[:, 1:])
        for i, r in enumerate(rows):
            if not 0 <= r < h:
                lit[i, 1:] = np.arange(1, w + 1)
        lit.flags.writeable = False
        return cls(tuple(int(r) for r in rows), lit)

    def across(self, xs: list[float], half_px: list[int]) -> np.ndarray:
        """Tell, per row, whether the frame is blown out all across ``xs`` +- ``half_px``.

        Parameters
        ----------
        xs : list of float
            A line's x at :attr:`rows`, frame pixels (negative: absent).
        half_px : list of int
            Half the width looked at on each row, pixels.

        Returns
        -------
        (len(rows),) bool ndarray
            True where every pixel looked at is blown out (never where the line is absent, not
            finite, or outside the frame).

        Raises
        ------
        ValueError
            When ``xs`` or ``half_px`` does not give one value per row.

        Examples
        --------
        >>> b = BlownOut.of(np.full((720, 1280, 3), 255, np.uint8), [400, 710])
        >>> b.across([640.0, -2.0], [10, 10]).tolist()
        [True, False]
        """
        w = self.lit.shape[1] - 1
        x = np.asarray(xs, np.float64)
        half = np.asarray(half_px, np.int64)
        if x.shape != (len(self.rows),) or half.shape != x.shape:
            raise ValueError(f"one x and one half-width per row are needed ({len(self.rows)} rows)")
        seen = np.isfinite(x) & (x >= 0) & (x < w)
        c = np.clip(np.rint(np.where(seen, x, 0.0)).astype(np.int64), 0, w - 1)
        lo, hi = np.clip(c - half, 0, w), np.clip(c + half + 1, 0, w)
        k = np.arange(len(self.rows))
        return seen & (self.lit[k, hi] - self.lit[k, lo] == 0)


def h_samples(frame_height: int) -> list[int]:
    """Return the TuSimple benchmark rows for a frame height.

    Parameters
    ----------
    frame_height : int
        Frame height, pixels.

    Returns
    -------
    list of int
        Rows 400, 410, ... 710 for 720-row frames, scaled for other heights.

    Examples
    --------
    >>> h_samples(720)[:3], h_samples(360)[:3]
    ([400, 410, 420], [200, 205, 210])
    """
    return [round(r * frame_height / 720) for r in range(400, 720, 10)]


def line_x_at_rows(fit_px: np.ndarray | None, be: BirdsEye, rows: list[int], far_fit_px: np.ndarray | None = None,
                   far_end_px: float = math.nan) -> list[float]:
    """Map a bird's-eye line fit onto the original frame and sample its x at given rows.

    The fit is followed from the bird's-eye top down past its bottom edge (the road plane goes
    on towards the car), mapped through the exact inverse warp, and interpolated per row.

    Parameters
    ----------
    fit_px : (3,) ndarray or None
        (a, b, c) of the line in bird's-eye pixels; None for no line.
    be : BirdsEye
        The set-up.
    rows : list of int
        Rows of the original frame.
    far_fit_px : (3,) ndarray, optional
        The line beyond the view's top edge (``Line.far_fit_px``), followed up to
        ``far_end_px`` (negative bird's-eye y).
    far_end_px : float, optional
        Where the far part ends.

    Returns
    -------
    list of float
        x in original (distorted) frame pixels at each row, 0.1 px; -2 where the line is absent.

    Examples
    --------
    >>> from lanefinder import Config, LaneFinder
    >>> be = LaneFinder(Config()).birdseye((1280, 720))
    >>> line_x_at_rows(np.array([0.0, 0.0, 125.0]), be, [460, 700])
    [581.3, 244.7]
    """
    return _x_at_rows([(fit_px, far_fit_px, far_end_px)], be, rows)[0]


def _x_at_rows(lines: list[tuple[np.ndarray | None, np.ndarray | None, float]], be: BirdsEye,
               rows: list[int]) -> list[list[float]]:
    """:func:`line_x_at_rows` for several lines (fit, far fit, far end), their points mapped together."""
    absent = [-2.0] * len(rows)
    h = be.size[1]
    w_f, h_f = be.frame_size
    parts: list[tuple[np.ndarray, np.ndarray] | None] = []
    for fit_px, far_fit_px, far_end_px in lines:
        if fit_px is None:
            parts.append(None)
            continue
        y = np.linspace(0, 2.0 * h, 160)
        x = poly_x(fit_px, y)
        if far_fit_px is not None and far_end_px < 0:
            y_far = far_rows(far_end_px, 120)  # dense in the frame's rows, far apart on the road there
            y, x = np.concatenate([y_far, y]), np.concatenate([poly_x(far_fit_px, y_far), x])
        parts.append((x, y))
    given = [p for p in parts if p is not None]
    if not given:
        return [absent for _ in lines]
    # Every point is mapped in one call each way (the maps work point by point).
    und_all = be.to_undistorted(np.vstack([np.column_stack(p) for p in given]))
    kept: list[tuple[np.ndarray, np.ndarray] | None] = []
    for (x, y), und in zip(given, np.split(und_all, np.cumsum([len(p[0]) for p in given])[:-1]), strict=True):
        # Only where the undistorted point is (nearly) in view: the lens polynomial is not
        # monotonic far outside the calibrated field, and the road behind the camera is not seen.
        ok = (und[:, 0] > -0.1 * w_f) & (und[:, 0] < 1.1 * w_f) & (und[:, 1] > -0.1 * h_f) & (und[:, 1] < 1.1 * h_f)
        ok &= np.logical_and.accumulate(np.concatenate([[True], np.diff(und[:, 1]) > 0]))
        kept.append((x[ok], y[ok]) if ok.sum() >= 2 else None)
    mapped = [k for k in kept if k is not None]
    frame_all = be.to_frame(np.vstack([np.column_stack(k) for k in mapped])) if mapped else np.empty((0, 2))
    in_frame = iter(np.split(frame_all, np.cumsum([len(k[0]) for k in mapped])[:-1]) if mapped else [])
    r = np.asarray(rows, np.float64)
    out_given = []
    for k in kept:
        if k is None:
            out_given.append(absent)
            continue
        pts = next(in_frame)
        fy, fx = pts[:, 1], pts[:, 0]
        keep = np.logical_and.accumulate(np.concatenate([[True], np.diff(fy) > 0]))
        fy, fx = fy[keep], fx[keep]
        if fy.size < 2:
            out_given.append(absent)
            continue
        xv = np.interp(r, fy, fx)
        ok = (r >= fy[0]) & (r <= fy[-1]) & (xv >= 0) & (xv < w_f)
        out_given.append([round(float(v), 1) if g else -2.0 for v, g in zip(xv.tolist(), ok.tolist(), strict=True)])
    it = iter(out_given)
    return [absent if p is None else next(it) for p in parts]


def _num(v: float | None, nd: int = 6) -> float | None:
    if v is None or not math.isfinite(v):
        return None
    return round(float(v), nd)


def _coeffs(c: np.ndarray | None) -> list[float] | None:
    return None if c is None else [float(f"{v:.8g}") for v in c]


def _line_fields(line: Line, be: BirdsEye, rows: list[int], decay_m: float, xs: list[float]) -> dict[str, Any]:
    """One line's telemetry values, keyed by :data:`LINE_FIELDS` (``xs``: its x at the rows)."""
    return {"found": line.found, "inferred": line.inferred, "conf": round(line.confidence, 4),
            "fit_m": _coeffs(line.fit_m), "fit_px": _coeffs(line.fit_px),
            "x": xs, "range_m": _num(line.range_m, 2), "x_conf": _row_confidences(line, be, rows, xs, decay_m)}


def _row_confidences(line: Line, be: BirdsEye, rows: list[int], xs: list[float], decay_m: float) -> list[float]:
    """Give the line's confidence at each row: as measured in the view, falling beyond; 0 where absent."""
    x = np.asarray(xs, np.float64)
    seen = x >= 0
    if not seen.any() or line.confidence <= 0:
        return [0.0] * len(rows)
    h = be.size[1]
    d = (h - be.from_frame(np.column_stack([x[seen], np.asarray(rows, np.float64)[seen]]))[:, 1]) * be.ym_per_px
    it = iter(d.tolist())
    top_m = h * be.ym_per_px
    return [round(row_confidence(line.confidence, next(it), top_m, decay_m), 3) if k else 0.0
            for k in seen.tolist()]


def lane_row(r: LaneResult, be: BirdsEye, decay_m: float = _DEFAULT_DECAY_M,
             blown: BlownOut | None = None) -> dict[str, Any]:
    """Return the row fields of one result, without the frame's number and time.

    The image job writes these after its own fields; :func:`make_row` puts the frame number
    and time in front.

    Parameters
    ----------
    r : LaneResult
        The frame's result.
    be : BirdsEye
        The set-up it was found with (to map the lines back onto the frame).
    decay_m : float, optional
        ``far.confidence_decay_m`` of the run's config: how fast the per-row confidence
        (``*_x_conf``) falls beyond the view.
    blown : BlownOut, optional
        Where the frame is blown out on the rows (:meth:`BlownOut.of` on the frame as read): a
        line's x is left out (-2, its ``x_conf`` 0) at a row where every pixel within
        ``BLOWN_OUT_HALF_M`` of it (at least 3 px) is blown out, as in glare, where no paint can
        be seen.  Ignored when it was made for other rows or another frame width, or when the
        set-up gives no horizon.

    Returns
    -------
    dict
        The fields of :data:`FIELDS` but ``frame`` and ``time_s``, in that order; numbers
        rounded, NaN as None.

    Examples
    --------
    >>> import cv2
    >>> from lanefinder import LaneFinder
    >>> finder = LaneFinder()
    >>> r = finder.process(cv2.imread("data/test_images/test3.jpg"))
    >>> row = lane_row(r, finder.birdseye((1280, 720)))
    >>> row["state"], row["left_found"], row["h_samples"][:3], len(row["left_x"])
    ('re-detect', True, [400, 410, 420], 32)
    """
    rows = h_samples(be.frame_size[1])
    xs = _x_at_rows([(line.fit_px, line.far_fit_px, line.far_end_px) for line in r.lines], be, rows)
    horizon, height, _ = _setup_numbers(be)
    fits = blown is not None and blown.rows == tuple(rows) and blown.lit.shape[1] - 1 == be.frame_size[0]
    if blown is not None and fits and math.isfinite(horizon) and height > 0:
        # Half a window of BLOWN_OUT_HALF_M across the road at each row (pinhole: px per m = (row - horizon) / height).
        half = [max(3, round(BLOWN_OUT_HALF_M * (y - horizon) / height)) for y in rows]
        xs = [[-2.0 if out else v for v, out in zip(x, blown.across(x, half).tolist(), strict=True)] for x in xs]
    per_line = {side: _line_fields(line, be, rows, decay_m, x)
                for side, line, x in zip(SIDES, r.lines, xs, strict=True)}
    out: dict[str, Any] = {"state": r.state}
    for key in FIELDS[3:]:
        side, _, name = key.partition("_")
        if side in per_line and name in LINE_FIELDS:
            out[key] = per_line[side][name]
    out.update({"radius_m": _num(r.radius_m, 2), "curvature_per_m": _num(r.curvature_per_m, 7),
                "offset_m": _num(r.offset_m, 4), "width_m": _num(r.width_m, 4), "misses": r.misses,
                "h_samples": rows, "setup": r.setup, "horizon_px": _num(horizon, 1),
                "camera_height_m": _num(height, 3), "checks": ",".join(r.checks)})
    return {k: out[k] for k in FIELDS[2:]}


def make_row(index: int, time_s: float, r: LaneResult, be: BirdsEye,
             decay_m: float = _DEFAULT_DECAY_M, blown: BlownOut | None = None) -> dict[str, Any]:
    """Return the telemetry row of one frame.

    Parameters
    ----------
    index : int
        Frame number in the video.
    time_s : float
        Time of the frame from the start of the video, seconds.
    r : LaneResult
        The frame's result.
    be : BirdsEye
        The set-up it was found with.
    decay_m : float, optional
        ``far.confidence_decay_m`` of the run's config.
    blown : BlownOut, optional
        Where the frame is blown out (see :func:`lane_row`).

    Returns
    -------
    dict
        The fields of :data:`FIELDS`, in order.

    Examples
    --------
    >>> import numpy as np
    >>> from lanefinder import LaneFinder
    >>> finder = LaneFinder()
    >>> r = finder.process(np.zeros((720, 1280, 3), np.uint8))
    >>> row = make_row(7, 0.28, r, finder.birdseye((1280, 720)))
    >>> row["frame"], row["state"], row["width_m"], row["left_x"][0]
    (7, 'lost', None, -2.0)
    """
    return {"frame": index, "time_s": round(time_s, 4), **lane_row(r, be, decay_m, blown)}


class TelemetryWriter:
    """Write telemetry rows to a hidden file beside ``path``; :meth:`close` moves it into place.

    Rows are flushed one by one; :meth:`discard` removes the hidden file instead, so an
    existing file at ``path`` is replaced only by a complete one.

    Parameters
    ----------
    path : str or Path
        The telemetry file: ``.csv``, ``.jsonl`` or ``.parquet`` (typed columns, see
        :mod:`lanefinder.tables`).
    outputs : OutputSet, optional
        Write the file as part of this set: :meth:`close` then finishes it and the set puts
        it in place together with the command's other outputs.

    Attributes
    ----------
    path : Path
        Where the file goes.
    rows : int
        Rows written so far.

    Raises
    ------
    LaneFinderError
        For another suffix, or when the file cannot be written.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     with TelemetryWriter(f"{d}/t.jsonl") as w:
    ...         w.write({"frame": 0, "state": "lost"})
    ...     read_telemetry(f"{d}/t.jsonl")
    [{'frame': 0, 'state': 'lost'}]
    """

    def __init__(self, path: str | Path, outputs: OutputSet | None = None):
        self.path = Path(path)
        suffix = self.path.suffix.lower()
        if suffix not in TELEMETRY_SUFFIXES:
            raise LaneFinderError(f"telemetry file must end in .csv, .jsonl or .parquet: {self.path}")
        self.csv = suffix == ".csv"
        self._own = outputs is None
        self._outputs = outputs if outputs is not None else OutputSet()
        self.tmp = self._outputs.add(self.path)
        self._pq = None
        if suffix == ".parquet":
            from .tables import ParquetRowWriter  # pyarrow is loaded only when asked for

            self._f = io.StringIO()
            self._guard(lambda: setattr(self, "_pq", ParquetRowWriter(self.tmp)))
        else:
            self._f = self.tmp.open("w", newline="")
        self._csv = csv.DictWriter(self._f, fieldnames=FIELDS) if self.csv else None
        self.rows = 0
        self._guard(lambda: self._csv.writeheader() if self._csv else None)

    def _guard(self, write: Callable[[], object]) -> None:
        """Run a write; a failing disk becomes a LaneFinderError and drops the file."""
        try:
            write()
        except OSError as e:
            self.discard()
            raise LaneFinderError(f"cannot write the telemetry {self.path}: {e.strerror or e}") from None

    def write(self, row: dict) -> None:
        """Append one row.

        Parameters
        ----------
        row : dict
            Fields of :data:`FIELDS` (lists as lists, missing numbers as None).
        """
        def put() -> None:
            if self._pq is not None:
                self._pq.write(row)
                return
            if self._csv:
                self._csv.writerow({k: (json.dumps(v) if k in LIST_FIELDS and v is not None else
                                        ("" if v is None else v)) for k, v in row.items()})
            else:
                self._f.write(json.dumps(row) + "\n")
            self._f.flush()

        self._guard(put)
        self.rows += 1

    def close(self) -> None:
        """Finish the file and move it into place (once), unless it belongs to a set.

        Raises
        ------
        LaneFinderError
            When the file cannot be finished; nothing is put in place.
        """
        if self._f.closed:
            return
        if self._pq is not None:
            self._guard(self._pq.close)
        self._guard(self._f.close)
        if self._own:
            self._outputs.commit()

    def discard(self) -> None:
        """Drop the hidden file; whatever was at ``path`` stays as it was."""
        if not self._f.closed:
            if self._pq is not None:
                self._pq.abort()
            with contextlib.suppress(OSError):
                self._f.close()
        if self._own:
            self._outputs.discard()
        else:
            self.tmp.unlink(missing_ok=True)

    def __enter__(self) -> TelemetryWriter:
        return self

    def __exit__(self, exc_type, *exc) -> None:
        if exc_type is None:
            self.close()
        else:
            self.discard()


_NUMBER_FIELDS = [f for f in FIELDS if f not in LIST_FIELDS and f not in BOOL_FIELDS and f not in TEXT_FIELDS]


def _parse_csv_value(key: str, v: str):
    if v == "":
        return "" if key == "checks" else None  # no check fired: empty text, as in JSONL and Parquet
    if key in TEXT_FIELDS:
        return v
    if key in LIST_FIELDS:
        return json.loads(v)
    if key in BOOL_FIELDS:
        return v == "True"
    if key in ("frame", "misses"):
        return int(v)
    try:
        return float(v)
    except ValueError:
        return v


def read_telemetry(path: str | Path) -> list[dict]:
    """Read the rows of a telemetry file (CSV, JSONL or Parquet), with lists and numbers parsed.

    Parameters
    ----------
    path : str or Path
        A file written by ``--telemetry``.

    Returns
    -------
    list of dict
        One dict per row; missing numbers are None.

    Raises
    ------
    LaneFinderError
        When the file is missing or is not telemetry.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "t.jsonl"
    >>> _ = path.write_text('{"frame": 0, "state": "tracking", "offset_m": 0.12}')
    >>> read_telemetry(path)
    [{'frame': 0, 'state': 'tracking', 'offset_m': 0.12}]
    """
    p = Path(path)
    if not p.is_file():
        raise LaneFinderError(f"telemetry file not found: {p}")
    rows = _read_parquet(p) if p.suffix.lower() == ".parquet" else _read_text_rows(p)
    for i, row in enumerate(rows, 1):
        if not isinstance(row, dict) or None in row:
            raise LaneFinderError(f"{p}: row {i} is not a record of named fields (or has more values than the header)")
        for k in _NUMBER_FIELDS:
            v = row.get(k)
            if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))):
                raise LaneFinderError(f"{p}: row {i}: {k} is not a number ({v!r})")
    return rows


def _read_parquet(p: Path) -> list:
    from .tables import read_parquet_rows  # pyarrow is loaded only when asked for

    return read_parquet_rows(p)


def _json_first_line(text: str) -> bool:
    """Tell whether a text's first non-blank line is a JSON record or list (a JSON Lines file)."""
    first = text.lstrip().split("\n", 1)[0].strip()
    if first[:1] not in ("{", "["):
        return False
    try:
        return isinstance(json.loads(first), (dict, list))
    except (ValueError, RecursionError):
        return False


def _read_text_rows(p: Path) -> list:
    try:
        text = p.read_text()
    except (UnicodeDecodeError, OSError) as e:
        raise LaneFinderError(f"{p}: not a lanefinder telemetry file ({e})") from None
    try:
        if p.suffix.lower() == ".csv":
            text = text.removeprefix("\ufeff")  # (a BOM would be part of the first column's name)
            if _json_first_line(text):  # its "header" would be the first record
                raise LaneFinderError(f"{p}: holds JSON, not CSV: name it .jsonl")
            raw = list(csv.DictReader(io.StringIO(text)))
            for i, row in enumerate(raw, 1):
                if None in row.values():  # (an empty value is "", a missing one None)
                    raise LaneFinderError(f"{p}: row {i} has fewer values than the header")
            rows = [{k: _parse_csv_value(k, v) if isinstance(k, str) and isinstance(v, str) else v
                     for k, v in row.items()} for row in raw]
        else:
            rows = json_lines(text, p)
    except ValueError as e:
        raise LaneFinderError(f"{p}: not a lanefinder telemetry file ({e})") from None
    return rows
