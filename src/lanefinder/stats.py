"""Figures of a whole run, from its telemetry rows: lane shares, width, offset jumps, curves, hand labels.

These are what ``make check-videos`` prints per video, and what the tests hold the full
videos to.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import LaneFinderError

if TYPE_CHECKING:
    from .birdseye import BirdsEye

__all__ = [
    "check_counts",
    "curves",
    "labelled_stats",
    "lane_shares",
    "unchecked_frames",
    "video_stats",
]


def curves(rows: list[dict], min_s: float = 2.0, straight_m: float = 3000.0) -> list[dict[str, Any]]:
    """Find the stretches of a run that bend one way, with their median radius.

    Parameters
    ----------
    rows : list of dict
        Telemetry rows (``time_s``, ``curvature_per_m``, ``radius_m``).
    min_s : float
        Shortest stretch, seconds.
    straight_m : float
        A radius at or above this (m) counts as straight.

    Returns
    -------
    list of dict
        Per stretch: ``side`` ("left"/"right"), ``from_s``, ``to_s`` (s) and
        ``median_radius_m`` (m).

    Examples
    --------
    >>> rows = [{"time_s": t / 10, "curvature_per_m": -1e-3, "radius_m": 1000.0} for t in range(30)]
    >>> curves(rows)
    [{'side': 'left', 'from_s': 0.0, 'to_s': 2.9, 'median_radius_m': 1000.0}]
    """
    out, cur = [], None
    for i, r in enumerate(rows, 1):
        k, rad = _number(r, "curvature_per_m", i), _number(r, "radius_m", i)
        side = None if k is None or rad is None or rad >= straight_m else ("right" if k > 0 else "left")
        if side is not None and _number(r, "time_s", i) is None:
            raise LaneFinderError(f"telemetry row {i}: time_s is missing, so its curve has no time")
        if cur and side == cur["side"]:
            cur["rows"].append(r)
            continue
        if cur and cur["rows"][-1]["time_s"] - cur["rows"][0]["time_s"] >= min_s:
            out.append(cur)
        cur = {"side": side, "rows": [r]} if side else None
    if cur and cur["rows"][-1]["time_s"] - cur["rows"][0]["time_s"] >= min_s:
        out.append(cur)
    return [{"side": c["side"], "from_s": c["rows"][0]["time_s"], "to_s": c["rows"][-1]["time_s"],
             "median_radius_m": float(np.median([r["radius_m"] for r in c["rows"]]))} for c in out]


def check_counts(rows: list[dict]) -> dict[str, dict[str, int]]:
    """Count, per named check, the frames it refused something on: why lines go unmeasured.

    Parameters
    ----------
    rows : list of dict
        Telemetry rows with their ``checks`` (comma-separated names; rows of files written
        before that column are left out), ``state`` and ``*_found``.

    Returns
    -------
    dict
        Per check name, most frames without both lines first: ``frames`` (every frame it
        fired on), ``not_both`` (of those, frames without both lines measured) and ``lost``
        (frames that show no lane).

    Examples
    --------
    >>> rows = [{"checks": "left-jump,offset", "state": "lost", "left_found": False, "right_found": False},
    ...         {"checks": "left-jump", "state": "tracking", "left_found": False, "right_found": True},
    ...         {"checks": "", "state": "tracking", "left_found": True, "right_found": True}]
    >>> check_counts(rows)
    {'left-jump': {'frames': 2, 'not_both': 2, 'lost': 1}, 'offset': {'frames': 1, 'not_both': 1, 'lost': 1}}
    """
    out: dict[str, dict[str, int]] = {}
    for i, r in enumerate(rows, 1):
        names = _record(r, i).get("checks")
        if not names:
            continue
        if not isinstance(names, str):
            raise LaneFinderError(f"telemetry row {i}: checks must be text, names separated by commas "
                                  f"(got {type(names).__name__})")
        both = _both(r)
        for name in dict.fromkeys(names.split(",")):
            c = out.setdefault(name, {"frames": 0, "not_both": 0, "lost": 0})
            c["frames"] += 1
            c["not_both"] += not both
            c["lost"] += r.get("state") == "lost"
    return dict(sorted(out.items(), key=lambda kv: (-kv[1]["not_both"], -kv[1]["frames"], kv[0])))


def unchecked_frames(rows: list[dict]) -> int | None:
    """Count the frames without both lines measured where no check fired: a line not there at all.

    Parameters
    ----------
    rows : list of dict
        Telemetry rows (``checks``, ``*_found``).

    Returns
    -------
    int or None
        The count; None when the rows have no ``checks`` (files written before that column).

    Examples
    --------
    >>> unchecked_frames([{"checks": "", "left_found": True, "right_found": False},
    ...                   {"checks": "left-jump", "left_found": False, "right_found": True}])
    1
    >>> unchecked_frames([{"left_found": True, "right_found": False}]) is None
    True
    """
    if not any("checks" in r for r in rows):
        return None
    return sum(1 for r in rows if not _both(r) and not r.get("checks"))


def _both(row: dict) -> bool:
    return bool(row.get("left_found")) and bool(row.get("right_found"))


def _record(row: object, i: int) -> dict:
    """Give a telemetry row, or refuse what is not a record of named fields, naming it."""
    if not isinstance(row, dict):
        raise LaneFinderError(f"telemetry row {i} is not a record of named fields")
    return row


def _number(row: object, key: str, i: int) -> float | None:
    """Give a row's number (None when absent, null or NaN), or refuse one that is not a number."""
    v = _record(row, i).get(key)
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise LaneFinderError(f"telemetry row {i}: {key} is not a number ({v!r})")
    return float(v) if math.isfinite(v) else None


def video_stats(rows: list[dict]) -> dict[str, Any]:
    """Summarise a run's telemetry rows.

    Parameters
    ----------
    rows : list of dict
        Telemetry rows, as :func:`lanefinder.telemetry.read_telemetry` gives them.

    Returns
    -------
    dict
        ``frames``; ``tracked_pct``, ``both_seen_pct`` and ``lost_pct`` (% of frames with a
        lane, with both lines measured, lost); ``width_mean_m`` and ``width_std_m`` (m);
        ``max_offset_jump_m`` (largest frame-to-frame change of the offset, m); ``curves``
        (see :func:`curves`); ``checks`` (see :func:`check_counts`).

    Examples
    --------
    >>> rows = [{"state": "tracking", "left_found": True, "right_found": True, "width_m": 3.7,
    ...          "offset_m": 0.1 * i, "time_s": i / 25, "curvature_per_m": 0.0, "radius_m": 10000.0}
    ...         for i in range(4)]
    >>> s = video_stats(rows)
    >>> s["tracked_pct"], s["width_mean_m"], round(s["max_offset_jump_m"], 2)
    (100.0, 3.7, 0.1)
    """
    n = len(rows)
    for i, r in enumerate(rows, 1):
        missing = [k for k in ("state", "left_found", "right_found") if k not in _record(r, i)]
        if missing:
            raise LaneFinderError(f"telemetry row {i} has no {', '.join(missing)}: not lanefinder telemetry")
        for key in ("width_m", "offset_m"):
            _number(r, key, i)
    shown = sum(1 for r in rows if r["state"] != "lost")
    seen_both = sum(1 for r in rows if r["left_found"] and r["right_found"])
    lost = n - shown
    width = np.array([r["width_m"] for r in rows if r.get("width_m") is not None])
    off = np.array([np.nan if r.get("offset_m") is None else r["offset_m"] for r in rows])
    jumps = np.abs(np.diff(off))
    return {
        "frames": n,
        "tracked_pct": 100.0 * shown / n if n else 0.0,
        "both_seen_pct": 100.0 * seen_both / n if n else 0.0,
        "lost_pct": 100.0 * lost / n if n else 0.0,
        "width_mean_m": float(width.mean()) if width.size else float("nan"),
        "width_std_m": float(width.std()) if width.size else float("nan"),
        "max_offset_jump_m": float(np.nanmax(jumps)) if np.isfinite(jumps).any() else float("nan"),
        "curves": curves(rows),
        "checks": check_counts(rows),
    }


def lane_shares(states: list[str | None], widths: list[float | None]) -> dict[str, Any]:
    """Give a run's share of frames with a lane, lost, and its mean lane width (summary figures).

    Parameters
    ----------
    states : list of str
        Each frame's ``state``.
    widths : list of float or None
        Each frame's ``width_m`` (None where there is none).

    Returns
    -------
    dict
        ``frames``; ``pct_lane`` and ``pct_lost`` (% of frames, 2 decimals); ``mean_width_m``
        (m, 4 decimals); None where there are no frames or widths.

    Examples
    --------
    >>> lane_shares(["tracking", "lost", "tracking", "re-detect"], [3.7, None, 3.5, 3.6])
    {'frames': 4, 'pct_lane': 75.0, 'pct_lost': 25.0, 'mean_width_m': 3.6}
    """
    n = len(states)
    lost = sum(s == "lost" for s in states)
    known = [w for w in widths if w is not None]
    return {"frames": n, "pct_lane": round(100 * (n - lost) / n, 2) if n else None,
            "pct_lost": round(100 * lost / n, 2) if n else None,
            "mean_width_m": round(sum(known) / len(known), 4) if known else None}


def labelled_stats(labels: list[dict], rows: dict[int, dict], be: BirdsEye, limit_m: float = 0.5) -> dict[str, Any]:
    """Judge a run's rows (or blind stills') against hand labels of its frames.

    Parameters
    ----------
    labels : list of dict
        Labelled frames (``data/truth/*.jsonl``, made by ``scripts/label_truth.py``): ``frame``,
        ``h_samples`` and ``left_x``/``right_x``, the car's lane's lines where they are labelled
        (negative elsewhere); these are the lines scored (a file's ``lanes`` holds the same).
    rows : dict of int to dict
        Telemetry rows (``state``, ``left_x``, ``right_x`` on the same rows) by frame; a
        labelled frame without a row counts as showing no lane.
    be : BirdsEye
        The set-up whose road plane measures distances (:func:`lanefinder.evaluate.road_errors_m`),
        for frames of the labels' size.
    limit_m : float
        A drawn line further than this from its marking on the road, at any labelled row, is off.

    Returns
    -------
    dict
        ``frames``; ``shown`` (frames with a lane); ``accuracy``, ``fp``, ``fn`` (TuSimple, as
        ``lanefinder eval``: :func:`lanefinder.evaluate.evaluate`; ``accuracy`` None when no frame
        has a labelled line); ``off_frames`` (frames with a line off, in order); ``lines_off``
        and ``lines_not_drawn`` (labelled lines drawn off, and not drawn at all while the frame
        shows a lane); ``per_frame``: ``frame``, ``state``, and per side the largest distance, m
        (None: no row where the line is both labelled and drawn, within range).

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> be = LaneFinder().birdseye((1280, 720))
    >>> label = {"frame": 3, "h_samples": [680, 690, 700], "left_x": [330.0, 320.0, 310.0],
    ...          "right_x": [-2.0, -2.0, -2.0]}
    >>> row = {"state": "tracking", "left_x": [332.0, 321.0, 311.0], "right_x": [990.0, 1000.0, 1010.0]}
    >>> s = labelled_stats([label], {3: row}, be)
    >>> s["shown"], s["accuracy"], s["off_frames"], s["per_frame"][0]["left_m"]
    (1, 1.0, [], 0.01)
    """
    from .evaluate import evaluate, road_errors_m

    gt, pred, per_frame, off = {}, {}, [], []
    lines_off = not_drawn = shown = 0
    for lab in labels:
        f = int(lab["frame"])
        hs = np.asarray(lab["h_samples"], np.float64)
        truth = {side: np.asarray(lab[f"{side}_x"], np.float64) for side in ("left", "right")}
        gt[f] = {"lanes": [x for x in truth.values() if (x >= 0).any()], "h_samples": hs}
        r = rows.get(f)
        lane = r is not None and r.get("state") != "lost"
        shown += lane
        drawn = {side: np.asarray(r[f"{side}_x"], np.float64) if lane else np.full(hs.shape, -2.0)
                 for side in ("left", "right")}
        pred[f] = {"lanes": [x for x in drawn.values() if (x >= 0).any()]}
        record: dict[str, Any] = {"frame": f, "state": r.get("state") if r else None}
        bad = False
        for side in ("left", "right"):
            err = road_errors_m(be, hs, truth[side], drawn[side])
            worst = float(np.nanmax(err)) if np.isfinite(err).any() else None
            record[f"{side}_m"] = None if worst is None else round(worst, 3)
            if worst is not None and worst > limit_m:
                lines_off += 1
                bad = True
            elif lane and (truth[side] >= 0).any() and not (drawn[side] >= 0).any():
                not_drawn += 1
        if bad:
            off.append(f)
        per_frame.append(record)
    rep = evaluate(gt, pred)
    with_line = any(g["lanes"] for g in gt.values())
    return {"frames": len(labels), "shown": shown, "accuracy": rep.accuracy if with_line else None,
            "fp": rep.fp, "fn": rep.fn,
            "off_frames": off, "lines_off": lines_off, "lines_not_drawn": not_drawn, "per_frame": per_frame}
