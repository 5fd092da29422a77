"""Lane events from per-frame telemetry: departure warnings, lane changes and lost-lane stretches.

The events are found in the telemetry rows alone (``frame``, ``time_s``, ``state``,
``offset_m``, ``width_m``, and ``misses`` when present), so they can be computed after a run,
from a telemetry file, or from the rows of a batch job.  A frame *measures* the lane when its
state is not ``lost``, its offset and width are known and, where the rows say, ``misses`` is 0
(with misses the tracker only held the last lane, so its offset is stale); rows without
``misses`` count every shown lane as measured.  Every tunable is in
:class:`lanefinder.config.EventsConfig` (``[events]`` in the config file).

Geometry (signs as in docs/conventions.md: ``offset_m`` positive when the car is right of the
lane centre; both are measured where the pipeline measures them, at the bird's-eye bottom
row).  With lane width w, car width c and offset o, the outer edge of each wheel is this far
inside the line's centre (negative: over it)::

    left:  w/2 - c/2 + o        right:  w/2 - c/2 - o

Kinds of event:

``departure-left`` / ``departure-right``
    A lane departure warning in the spirit of ISO 17361: it starts on the first frame where a
    wheel's distance to the line is at or below ``warning_margin_m`` and ends on the last frame
    before it is back above ``warning_margin_m + release_m``.  ``lateral_speed_mps`` is the
    speed towards that line at the start (a least-squares slope of the offset over
    ``speed_window_s``, centred); ``ttlc_s`` the time to line crossing then,
    max(distance, 0) / speed, None when the car is not moving towards the line faster than
    ``min_speed_mps``; ``min_distance_m`` the closest the wheel came (negative: over the line).
    A departure that overlaps a lane change is part of it and is not reported.  The tracker
    holds a lane while the car is inside it (``tracking.max_offset_m`` applies only to a lane
    found blind), so a wheel can be seen reaching and crossing the line.

``lane-change-left`` / ``lane-change-right``
    The ego lane switches: between two measured frames at most ``lane_change_max_gap_s`` apart
    the offset changes sign, by at least ``lane_change_min_jump`` lane widths.  Moving into the
    lane to the right, the car's offset grows towards +w/2 and then, in the new lane whose centre
    is now right of the car, restarts near -w/2: the offset *drops* by about a lane width (a
    change to the left raises it).  Such a drop is often bridged by a few ``re-detect`` or
    ``lost`` frames, or frames whose lane was only held (``misses`` > 0).  The lateral speed is
    measured in each lane on its own (no window reaches across the switch).  The change starts
    on the first frame of the run of frames moving towards the new lane faster than
    ``lane_change_speed_mps`` that leads up to the switch, and ends on the first frame after
    the switch where that speed has fallen below it again (each looked for at most
    ``lane_change_max_s`` from the switch).  ``lateral_speed_mps`` is the peak speed towards
    the new lane, ``ttlc_s`` is None, ``min_distance_m`` the closest either wheel came to a
    line of the lane it was in.  A switch undone within ``lane_change_flip_s`` (the tracker
    wavering between the two lanes while the car straddles the line) is not a change.

``lost``
    A maximal run of rows with state ``lost`` (rows at most ``max_gap_s`` apart) covering at
    least ``min_lost_frames`` frames.

Frames are inclusive: an event covers ``start_frame`` to ``end_frame``, and ``start_s``/``end_s``
are those frames' times.
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import math
import numbers
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .config import EventsConfig
from .errors import LaneFinderError
from .io import OutputSet, atomic_path, atomic_write_text, json_lines

__all__ = [
    "EVENT_FIELDS",
    "EVENT_KINDS",
    "EVENT_SUFFIXES",
    "LaneEvent",
    "detect_events",
    "event_row",
    "lateral_speed",
    "read_events",
    "write_events",
]

#: The kinds of event, in the order they are counted.
EVENT_KINDS = ("departure-left", "departure-right", "lane-change-left", "lane-change-right", "lost")
#: The columns of an event row, in order.
EVENT_FIELDS = ("kind", "start_frame", "end_frame", "start_s", "end_s", "lateral_speed_mps", "ttlc_s",
                "min_distance_m")
#: The event file formats, by suffix.
EVENT_SUFFIXES = (".csv", ".jsonl", ".parquet")
_STATES = ("tracking", "re-detect", "lost")
# Cells of the (rows, window) arrays of one block of the lateral-speed fit.
_WINDOW_CELLS = 1 << 20
_INT_FIELDS = ("start_frame", "end_frame")


@dataclass(frozen=True, kw_only=True)
class LaneEvent:
    """One lane event (see the module docstring for each kind).

    Attributes
    ----------
    kind : str
        One of :data:`EVENT_KINDS`.
    start_frame, end_frame : int
        First and last frame of the event (inclusive).
    start_s, end_s : float
        Their times, s.
    lateral_speed_mps : float or None
        Departure: speed towards the line at the start; lane change: peak speed towards the new
        lane; m/s.  None for ``lost`` or when it cannot be measured.
    ttlc_s : float or None
        Departure: time to line crossing at the start, s; None when not moving towards the line
        and for the other kinds.
    min_distance_m : float or None
        Closest distance of a wheel's outer edge to a line's centre, m (negative: over it);
        None for ``lost``.

    Examples
    --------
    >>> e = LaneEvent(kind="lost", start_frame=10, end_frame=14, start_s=0.4, end_s=0.56,
    ...               lateral_speed_mps=None, ttlc_s=None, min_distance_m=None)
    >>> e.end_frame - e.start_frame + 1
    5
    """

    kind: str
    start_frame: int
    end_frame: int
    start_s: float
    end_s: float
    lateral_speed_mps: float | None = None
    ttlc_s: float | None = None
    min_distance_m: float | None = None


# -- reading the rows ------------------------------------------------------------------------
@dataclass(frozen=True)
class _Series:
    """The rows as arrays: frame, time (s), lost, measured (a fresh lane), offset and width (NaN elsewhere)."""

    frame: np.ndarray
    t: np.ndarray
    lost: np.ndarray
    measured: np.ndarray
    offset: np.ndarray
    width: np.ndarray


def _number(row: Mapping[str, Any], key: str, i: int) -> float:
    v = row.get(key)
    if v is None:
        return math.nan
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise LaneFinderError(f"event rows: row {i}: {key} is not a number ({v!r})")
    return float(v)


def _series(rows: Iterable[Mapping[str, Any]], fps: float) -> _Series:
    """Check the rows and turn them into arrays."""
    frame, t, lost, fresh, offset, width = [], [], [], [], [], []
    for i, row in enumerate(rows, 1):
        if not isinstance(row, Mapping):
            raise LaneFinderError(f"event rows: row {i} is not a record of named fields")
        f = row.get("frame")
        if isinstance(f, bool) or not isinstance(f, (int, np.integer)):
            raise LaneFinderError(f"event rows: row {i}: frame is not a whole number ({f!r})")
        if frame and f <= frame[-1]:
            raise LaneFinderError(f"event rows: row {i}: frame {f} does not follow frame {frame[-1]} "
                                  "(rows must be in frame order)")
        ts = _number(row, "time_s", i)
        ts = ts if math.isfinite(ts) else int(f) / fps
        if t and ts <= t[-1]:
            raise LaneFinderError(f"event rows: row {i}: time_s {ts} does not follow the previous row's {t[-1]}")
        o, w = _number(row, "offset_m", i), _number(row, "width_m", i)
        state = row.get("state")
        if state is not None and state not in _STATES:
            raise LaneFinderError(f"event rows: row {i}: unknown state {state!r} (tracking, re-detect or lost)")
        misses = row.get("misses")
        is_lost = state == "lost"
        ok = (not is_lost and math.isfinite(o) and math.isfinite(w) and w > 0
              and (misses is None or misses == 0))
        frame.append(int(f))
        t.append(ts)
        lost.append(is_lost)
        fresh.append(ok)
        offset.append(o if ok else math.nan)
        width.append(w if ok else math.nan)
    return _Series(np.array(frame, np.int64), np.array(t, np.float64), np.array(lost, bool), np.array(fresh, bool),
                   np.array(offset, np.float64), np.array(width, np.float64))


# -- lateral speed ---------------------------------------------------------------------------
def lateral_speed(t: np.ndarray, x: np.ndarray, window_s: float, min_points: int = 3) -> np.ndarray:
    """Give the smoothed rate of change of a signal: the least-squares slope over a centred window.

    Parameters
    ----------
    t : (N,) ndarray
        Times, s, increasing.
    x : (N,) ndarray
        The signal (a lateral position, m); NaN where unknown (left out of the fits).
    window_s : float
        Width of the window centred on each sample, s.
    min_points : int, optional
        Known samples a window needs; fewer give NaN.

    Returns
    -------
    (N,) ndarray
        dx/dt at each sample (m/s for a position in m); NaN where it cannot be measured.

    Examples
    --------
    >>> t = np.arange(10) / 25.0
    >>> np.round(lateral_speed(t, 0.5 * t, 0.2), 3)[:4]
    array([0.5, 0.5, 0.5, 0.5])
    >>> lateral_speed(t[:2], np.array([0.0, np.nan]), 0.2)
    array([nan, nan])
    """
    t = np.asarray(t, np.float64)
    x = np.asarray(x, np.float64)
    n = t.size
    if n == 0:
        return np.zeros(0)
    half = window_s / 2
    lo = np.searchsorted(t, t - half, "left")
    hi = np.searchsorted(t, t + half, "right")
    k = int((hi - lo).max())
    out = np.full(n, np.nan)
    step = max(1, _WINDOW_CELLS // k)  # rows per block: the (rows, k) arrays stay small
    for a in range(0, n, step):
        b = min(n, a + step)
        idx = lo[a:b, None] + np.arange(k)[None, :]
        inside = idx < hi[a:b, None]
        idx = np.minimum(idx, n - 1)
        dt = t[idx] - t[a:b, None]  # relative to each window's centre: well conditioned
        xx = x[idx]
        m = inside & np.isfinite(xx)
        dt, xx = np.where(m, dt, 0.0), np.where(m, xx, 0.0)
        cnt = m.sum(axis=1)
        st, sx = dt.sum(axis=1), xx.sum(axis=1)
        stt, stx = (dt * dt).sum(axis=1), (dt * xx).sum(axis=1)
        den = cnt * stt - st * st
        good = (cnt >= min_points) & (den > 1e-12 * np.maximum(cnt, 1) ** 2)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[a:b] = np.where(good, (cnt * stx - st * sx) / den, np.nan)
    return out


# -- runs ------------------------------------------------------------------------------------
def _gap_breaks(t: np.ndarray, max_gap_s: float) -> np.ndarray:
    """Mark the samples that start a new stretch: more than ``max_gap_s`` after the one before."""
    return np.concatenate([[True], np.diff(t) > max_gap_s]) if t.size else np.zeros(0, bool)


def _event(kind: str, s: _Series, a: int, b: int, speed: float | None = None, ttlc: float | None = None,
           dist: float | None = None) -> LaneEvent:
    def num(v: float | None, nd: int) -> float | None:
        return None if v is None or not math.isfinite(v) else round(float(v), nd)

    return LaneEvent(kind=kind, start_frame=int(s.frame[a]), end_frame=int(s.frame[b]),
                     start_s=round(float(s.t[a]), 4), end_s=round(float(s.t[b]), 4),
                     lateral_speed_mps=num(speed, 3), ttlc_s=num(ttlc, 3), min_distance_m=num(dist, 3))


# -- lane changes ----------------------------------------------------------------------------
@dataclass(frozen=True)
class _Switch:
    """A switch of the ego lane between rows ``i`` and ``j``: direction +1 right, -1 left."""

    i: int
    j: int
    direction: int


def _switches(s: _Series, cfg: EventsConfig) -> list[_Switch]:
    """Find the ego-lane switches (see the module docstring), wavering removed."""
    idx = np.flatnonzero(s.measured)
    if idx.size < 2:
        return []
    i, j = idx[:-1], idx[1:]
    oi, oj = s.offset[i], s.offset[j]
    w = (s.width[i] + s.width[j]) / 2
    near = (s.t[j] - s.t[i]) <= cfg.lane_change_max_gap_s
    m, jump = cfg.lane_change_min_offset_m, cfg.lane_change_min_jump * w
    right = near & (oi >= m) & (oj <= -m) & (oi - oj >= jump)
    left = near & (oi <= -m) & (oj >= m) & (oj - oi >= jump)
    found: list[_Switch] = []
    for k in np.flatnonzero(right | left).tolist():
        sw = _Switch(int(i[k]), int(j[k]), 1 if right[k] else -1)
        if found and found[-1].direction == -sw.direction and s.t[sw.j] - s.t[found[-1].j] <= cfg.lane_change_flip_s:
            found.pop()  # back to the lane it left: the tracker wavered, no change
            continue
        found.append(sw)
    return found


def _speeds(s: _Series, switches: Sequence[_Switch], window_s: float) -> np.ndarray:
    """Give the lateral speed of the car, m/s (right positive), each lane's stretch on its own.

    No window reaches across a switch of lane, where the offset changes its reference.
    """
    cuts = [0, *(sw.j for sw in switches), s.offset.size]
    return np.concatenate([lateral_speed(s.t[a:b], s.offset[a:b], window_s)
                           for a, b in itertools.pairwise(cuts)])


def _lane_change(s: _Series, sw: _Switch, towards: np.ndarray, dist: np.ndarray, cfg: EventsConfig) -> LaneEvent:
    """Find the lane change around one switch: its start, end, peak speed and closest approach."""
    idx = np.flatnonzero(s.measured)
    thr = cfg.lane_change_speed_mps
    before = idx[(idx <= sw.i) & (s.t[idx] >= s.t[sw.i] - cfg.lane_change_max_s)]
    moving = towards[before] > thr  # (NaN: not known to be moving)
    start = sw.i
    if moving.any():
        last = int(np.flatnonzero(moving)[-1])
        still = np.flatnonzero(~moving[:last])
        # The run of moving frames that ends at ``last``, gaps in the measurements bridged.
        start = int(before[still[-1] + 1 if still.size else 0])
    after = idx[(idx >= sw.j) & (s.t[idx] <= s.t[sw.j] + cfg.lane_change_max_s)]
    # Past the tracker's settling on the new lane (its first frames may even move back): from
    # the first frame moving towards the new lane, to the first that no longer is.
    moving_after = np.flatnonzero(towards[after] > thr)
    end = sw.j
    if moving_after.size:
        settled = np.flatnonzero(towards[after][moving_after[0]:] <= thr)
        end = int(after[moving_after[0] + settled[0]]) if settled.size else int(after[-1])
    span = slice(start, end + 1)
    speeds = towards[span][np.isfinite(towards[span])]
    peak = float(speeds.max()) if speeds.size else None
    d = dist[span][np.isfinite(dist[span])]
    return _event("lane-change-right" if sw.direction > 0 else "lane-change-left", s, start, end, peak, None,
                  float(d.min()) if d.size else None)


# -- departures ------------------------------------------------------------------------------
def _departures(s: _Series, side: str, d: np.ndarray, towards: np.ndarray, cfg: EventsConfig) -> list[LaneEvent]:
    """Find the warnings on one side, from each measured frame's wheel-to-line distance ``d``."""
    idx = np.flatnonzero(s.measured)
    if not idx.size:
        return []
    dm = d[idx]
    on_at, off_above = cfg.warning_margin_m, cfg.warning_margin_m + cfg.release_m
    # Hysteresis: on at or below the margin, off above margin + release, unchanged between.
    flag = np.where(dm <= on_at, 1, np.where(dm > off_above, 0, -1))
    breaks = _gap_breaks(s.t[idx], cfg.max_gap_s)
    flag[breaks & (flag < 0)] = 0  # a stretch after a long gap starts with no warning
    last_set = np.maximum.accumulate(np.where(flag >= 0, np.arange(flag.size), 0))
    on = flag[last_set] == 1
    # Runs of warning frames; a long gap ends a warning (the next stretch starts its own).
    prev_on = np.concatenate([[False], on[:-1]])
    next_on = np.concatenate([on[1:], [False]])
    next_break = np.concatenate([breaks[1:], [True]])
    starts = np.flatnonzero(on & (~prev_on | breaks))
    ends = np.flatnonzero(on & (~next_on | next_break))
    out = []
    for a, b in zip(idx[starts].tolist(), idx[ends].tolist(), strict=True):
        if s.t[b] - s.t[a] < cfg.min_warning_s:
            continue
        v = float(towards[a])
        ttlc = max(float(d[a]), 0.0) / v if math.isfinite(v) and v > cfg.min_speed_mps else None
        out.append(_event(f"departure-{side}", s, a, b, v, ttlc, float(np.nanmin(d[a:b + 1]))))
    return out


# -- lost stretches --------------------------------------------------------------------------
def _lost(s: _Series, cfg: EventsConfig) -> list[LaneEvent]:
    idx = np.flatnonzero(s.lost)
    if not idx.size:
        return []
    # Rows next to each other (no row between them) and at most max_gap_s apart are one stretch.
    new = np.concatenate([[True], (np.diff(idx) > 1) | (np.diff(s.t[idx]) > cfg.max_gap_s)])
    starts = np.flatnonzero(new)
    ends = np.concatenate([starts[1:], [idx.size]]) - 1
    out = []
    for a, b in zip(idx[starts].tolist(), idx[ends].tolist(), strict=True):
        if s.frame[b] - s.frame[a] + 1 >= cfg.min_lost_frames:
            out.append(_event("lost", s, a, b))
    return out


def detect_events(rows: Iterable[Mapping[str, Any]], fps: float, config: EventsConfig | None = None) -> list[LaneEvent]:
    """Find the lane events in per-frame telemetry rows (see the module docstring for the rules).

    Parameters
    ----------
    rows : iterable of mapping
        Telemetry rows in frame order (as :func:`lanefinder.telemetry.make_row` gives them or
        :func:`lanefinder.telemetry.read_telemetry` reads them); only ``frame`` is required,
        and ``time_s`` (s), ``state``, ``offset_m`` (m), ``width_m`` (m) and ``misses`` are
        used.  Missing or None values are allowed; frame numbers may start anywhere and skip.
    fps : float
        Frame rate, frames/s (any real number, a ``Fraction`` too): gives a row without
        ``time_s`` its time, frame / fps.
    config : EventsConfig, optional
        The rules' settings (``Config().events`` when omitted).

    Returns
    -------
    list of LaneEvent
        The events, by start frame.

    Raises
    ------
    LaneFinderError
        For a bad frame rate, rows out of frame order, or a value that is not a number.

    Examples
    --------
    >>> rows = [{"frame": i, "state": "tracking", "offset_m": 0.02 * i, "width_m": 3.7} for i in range(60)]
    >>> [(e.kind, e.start_frame, e.end_frame, e.lateral_speed_mps) for e in detect_events(rows, 25.0)]
    [('departure-right', 48, 59, 0.5)]
    >>> detect_events([], 25.0)
    []
    """
    if isinstance(fps, bool) or not isinstance(fps, numbers.Real) or not (math.isfinite(fps) and fps > 0):
        raise LaneFinderError(f"events: the frame rate must be a positive number (got {fps!r})")
    if rows is None or isinstance(rows, (str, bytes, Mapping)) or not isinstance(rows, Iterable):
        raise LaneFinderError(f"events: rows must be a list of telemetry rows (got {type(rows).__name__})")
    cfg = config if config is not None else EventsConfig()
    s = _series(rows, float(fps))
    if not s.frame.size:
        return []
    switches = _switches(s, cfg)
    v = _speeds(s, switches, cfg.speed_window_s)
    edge = s.width / 2 - cfg.car_width_m / 2
    d_left, d_right = edge + s.offset, edge - s.offset
    nearest = np.fmin(d_left, d_right)
    changes = [_lane_change(s, sw, sw.direction * v, nearest, cfg) for sw in switches]
    departures = _departures(s, "left", d_left, -v, cfg) + _departures(s, "right", d_right, v, cfg)
    departures = [e for e in departures
                  if not any(e.start_frame <= c.end_frame and c.start_frame <= e.end_frame for c in changes)]
    events = changes + departures + _lost(s, cfg)
    return sorted(events, key=lambda e: (e.start_frame, EVENT_KINDS.index(e.kind)))


# -- rows and files --------------------------------------------------------------------------
def event_row(event: LaneEvent) -> dict[str, Any]:
    """Give an event as a row of plain JSON-able values, keyed by :data:`EVENT_FIELDS`.

    Parameters
    ----------
    event : LaneEvent
        The event.

    Returns
    -------
    dict
        Its fields in :data:`EVENT_FIELDS` order (frames int, times s, speeds m/s, distances m;
        None where absent).

    Examples
    --------
    >>> event_row(LaneEvent(kind="lost", start_frame=3, end_frame=9, start_s=0.12, end_s=0.36))
    {'kind': 'lost', 'start_frame': 3, 'end_frame': 9, 'start_s': 0.12, 'end_s': 0.36, 'lateral_speed_mps': None, \
'ttlc_s': None, 'min_distance_m': None}
    """
    return {k: getattr(event, k) for k in EVENT_FIELDS}


def _suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in EVENT_SUFFIXES:
        raise LaneFinderError(f"events file must end in .csv, .jsonl or .parquet: {path}")
    return suffix


def _csv_text(rows: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(EVENT_FIELDS), lineterminator="\n")
    w.writeheader()
    w.writerows({k: ("" if v is None else v) for k, v in r.items()} for r in rows)
    return buf.getvalue()


def _arrow_table(rows: list[dict]):
    import pyarrow as pa

    types = {"kind": pa.string(), "start_frame": pa.int64(), "end_frame": pa.int64()}
    schema = pa.schema([pa.field(k, types.get(k, pa.float64())) for k in EVENT_FIELDS])
    return pa.Table.from_pylist(rows, schema=schema)


def write_events(path: str | Path, events: Iterable[LaneEvent], outputs: OutputSet | None = None) -> None:
    """Write events to a ``.csv``, ``.jsonl`` or ``.parquet`` file, atomically.

    CSV has a header of :data:`EVENT_FIELDS` and empty cells for None; JSON Lines one object per
    event; Parquet typed columns (``kind`` string, frames int64, the rest float64, null for None).

    Parameters
    ----------
    path : str or Path
        The file; its suffix picks the format.
    events : iterable of LaneEvent
        The events.
    outputs : OutputSet, optional
        Write it as part of this set (put in place when the set commits).

    Raises
    ------
    LaneFinderError
        For another suffix, or when the file cannot be written.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "events.csv"
    >>> write_events(out, [LaneEvent(kind="lost", start_frame=3, end_frame=9, start_s=0.12, end_s=0.36)])
    >>> print(out.read_text(), end="")
    kind,start_frame,end_frame,start_s,end_s,lateral_speed_mps,ttlc_s,min_distance_m
    lost,3,9,0.12,0.36,,,
    >>> write_events(out.with_suffix(".txt"), [])
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: events file must end in .csv, .jsonl or .parquet: .../events.txt
    """
    dest = Path(path)
    suffix = _suffix(dest)
    rows = [event_row(e) for e in events]
    if suffix == ".csv":
        atomic_write_text(dest, _csv_text(rows), outputs=outputs)
        return
    if suffix == ".jsonl":
        atomic_write_text(dest, "".join(json.dumps(r) + "\n" for r in rows), outputs=outputs)
        return
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise LaneFinderError(f"writing {dest.name} needs pyarrow (pip install pyarrow)") from None
    table = _arrow_table(rows)

    def put(tmp: Path) -> None:
        try:
            pq.write_table(table, tmp)
        except OSError as e:
            raise LaneFinderError(f"cannot write {dest}: {e}".splitlines()[0]) from None

    if outputs is not None:
        put(outputs.add(dest))
        return
    with atomic_path(dest) as tmp:
        put(tmp)


def read_events(path: str | Path) -> list[dict[str, Any]]:
    """Read an events file written by :func:`write_events` (or ``events_gt.jsonl`` from ``lanefinder synth``).

    Parameters
    ----------
    path : str or Path
        A ``.csv``, ``.jsonl`` or ``.parquet`` events file.

    Returns
    -------
    list of dict
        One row per event, keyed by :data:`EVENT_FIELDS` (frames int, the other numbers float,
        None where empty).

    Raises
    ------
    LaneFinderError
        When the file is missing or is not an events file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "e.jsonl"
    >>> write_events(out, [LaneEvent(kind="lost", start_frame=3, end_frame=9, start_s=0.12, end_s=0.36)])
    >>> read_events(out)[0]["end_frame"]
    9
    """
    p = Path(path)
    suffix = _suffix(p)
    if not p.is_file():
        raise LaneFinderError(f"events file not found: {p}")
    try:
        if suffix == ".parquet":
            import pyarrow.parquet as pq

            rows = pq.read_table(p).to_pylist()
        elif suffix == ".jsonl":
            rows = json_lines(p.read_text(), p)
        else:
            rows = list(csv.DictReader(io.StringIO(p.read_text())))
    except LaneFinderError:
        raise
    except Exception as e:  # the readers' own errors, in one line
        raise LaneFinderError(f"{p}: not an events file ({e})".splitlines()[0]) from None
    out = []
    for i, row in enumerate(rows, 1):
        if not isinstance(row, dict) or set(EVENT_FIELDS) - set(row) or row.get("kind") not in EVENT_KINDS:
            raise LaneFinderError(f"{p}: row {i} is not an event (fields {', '.join(EVENT_FIELDS)})")
        try:
            out.append({k: _parse(k, row[k]) for k in EVENT_FIELDS})
        except (TypeError, ValueError):
            raise LaneFinderError(f"{p}: row {i} has a value that is not a number") from None
    return out


def _parse(key: str, v: Any) -> Any:
    if key == "kind":
        return v
    if v is None or v == "":
        return None
    if isinstance(v, bool):
        raise ValueError(key)
    return int(v) if key in _INT_FIELDS else float(v)
