"""Scoring predictions against ground truth: the TuSimple lane metric and errors in metres.

The TuSimple functions follow the official benchmark (tusimple-benchmark, evaluate/lane.py)
rule for rule:
- a point is correct when |x_pred - x_gt| < 20 px / cos(angle), the angle of the ground-truth
  lane from a least-squares line x(y) through its valid points; a missing value (< 0) is
  compared as -100, so a point absent from both counts as correct;
- a lane's accuracy is its correct points over all h_samples; a ground-truth lane is matched
  when its best prediction reaches 0.85; FP = predictions - matched, FN = unmatched truths;
- with more than 4 truth lanes one FN is forgiven and the worst lane is dropped; the frame's
  accuracy is the sum over at most 4 lanes; a frame with more than 2 extra predictions, or run
  time above 200 ms, scores (0, 0, 1);
- the dataset figures are plain means over the ground-truth frames.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .errors import LaneFinderError
from .io import iter_json_lines
from .telemetry import MAX_ABS_VALUE, is_number, is_number_list, read_telemetry

if TYPE_CHECKING:
    from .birdseye import BirdsEye

__all__ = [
    "BANDS_M",
    "PIXEL_THRESH",
    "PT_THRESH",
    "EvalReport",
    "bench_frame",
    "evaluate",
    "lane_angle",
    "line_accuracy",
    "read_ground_truth",
    "read_predictions",
    "road_errors_m",
    "setup_error",
]

#: Distance bands of the per-band accuracy, m ahead of the camera.
BANDS_M = ((0.0, 20.0), (20.0, 40.0), (40.0, 70.0), (70.0, math.inf))
PIXEL_THRESH = 20.0
PT_THRESH = 0.85


def lane_angle(xs: np.ndarray, y_samples: np.ndarray) -> float:
    """Give a lane's angle from the least-squares line x = k*y + b through its valid points.

    Parameters
    ----------
    xs : (N,) ndarray
        The lane's x at each sample row, pixels; negative where it is absent.
    y_samples : (N,) ndarray
        The sample rows, pixels.

    Returns
    -------
    float
        arctan(k), radians; 0.0 with fewer than two valid points.

    Examples
    --------
    >>> round(lane_angle(np.array([100.0, 110.0, -2.0]), np.array([700, 690, 680])), 4)
    -0.7854
    """
    valid = xs >= 0
    xs, ys = xs[valid], y_samples[valid]
    if len(xs) > 1:
        # np.polyfit, as the benchmark: a closed-form slope differs in the last bit, which moves
        # a point exactly on the threshold (and repeated rows give polyfit a slope, not 0)
        if np.ptp(ys) == 0:  # every point on one (repeated) row: polyfit warns that the fit is poor
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", np.exceptions.RankWarning)
                k = np.polyfit(ys.astype(float), xs.astype(float), 1)[0]
        else:
            k = np.polyfit(ys.astype(float), xs.astype(float), 1)[0]
        return float(np.arctan(k))
    return 0.0


def line_accuracy(pred: np.ndarray, gt: np.ndarray, thresh: float) -> float:
    """Give the fraction of samples where |pred - gt| < thresh, missing values (< 0) read as -100.

    Parameters
    ----------
    pred, gt : (N,) array_like
        x per sample row, pixels; negative where absent.
    thresh : float
        The pixel threshold.

    Returns
    -------
    float
        In [0, 1]; a row absent from both counts as correct.

    Examples
    --------
    >>> line_accuracy([100, 130, -2], [105, 100, -2], 20.0)
    0.6666666666666666
    """
    if len(gt) == 0:  # a lane with no sample rows has no point to hit
        return 0.0
    pred = np.where(np.asarray(pred, float) >= 0, pred, -100.0)
    gt = np.where(np.asarray(gt, float) >= 0, gt, -100.0)
    return float(np.sum(np.abs(pred - gt) < thresh) / len(gt))


def bench_frame(pred: list[list[float]], gt: list[list[float]], y_samples: list[int],
                running_time_ms: float = 0.0) -> tuple[float, float, float]:
    """Score one frame exactly as TuSimple's ``LaneEval.bench``.

    Parameters
    ----------
    pred, gt : list of list of float
        Lanes, each an x per sample row (pixels, negative where absent).
    y_samples : list of int
        The sample rows, pixels.
    running_time_ms : float, optional
        Time taken for the frame; above 200 ms the frame scores (0, 0, 1).

    Returns
    -------
    accuracy, fp, fn : float
        Accuracy over the truth lanes, and false-positive and false-negative rates.

    Raises
    ------
    LaneFinderError
        When a predicted lane does not have one x per sample row.

    Examples
    --------
    >>> ys = [700, 710, 720]
    >>> bench_frame([[100, 101, 102]], [[105, 106, 107], [300, 301, 302]], ys)
    (0.5, 0.0, 0.5)
    """
    n_rows = len(y_samples)
    if any(len(p) != n_rows for p in pred):
        raise LaneFinderError("format of lanes: every predicted lane needs one x per h_sample")
    if running_time_ms > 200 or len(gt) + 2 < len(pred):
        return 0.0, 0.0, 1.0
    line_accs = _best_accuracies(pred, gt, y_samples).tolist()
    fn = float(sum(a < PT_THRESH for a in line_accs))
    matched = len(line_accs) - fn
    fp = len(pred) - matched
    if len(gt) > 4 and fn > 0:
        fn -= 1
    s = sum(line_accs)
    if len(gt) > 4:
        s -= min(line_accs)
    return (s / max(min(4.0, len(gt)), 1.0), fp / len(pred) if pred else 0.0, fn / max(min(len(gt), 4.0), 1.0))


def _best_accuracies(pred: list, gt: list, y_samples) -> np.ndarray:
    """Give each truth lane's best :func:`line_accuracy` over the predictions (0 without any), all at once."""
    n_rows = len(y_samples)
    if not gt:
        return np.zeros(0)
    if any(len(g) != n_rows for g in gt):
        raise LaneFinderError("format of lanes: every truth lane needs one x per h_sample")
    ys = np.asarray(y_samples)
    if not pred or n_rows == 0:  # (a lane with no sample rows has no point to hit)
        return np.array([max((line_accuracy(p, g, _thresh(g, ys)) for p in pred), default=0.0) for g in gt])
    g = np.asarray(gt, float).reshape(len(gt), n_rows)
    p = np.asarray(pred, float).reshape(len(pred), n_rows)
    thresh = PIXEL_THRESH / np.cos(np.array([lane_angle(lane, ys) for lane in g]))
    g_cmp, p_cmp = np.where(g >= 0, g, -100.0), np.where(p >= 0, p, -100.0)
    hits = np.abs(p_cmp[None, :, :] - g_cmp[:, None, :]) < thresh[:, None, None]
    return (hits.sum(axis=2) / n_rows).max(axis=1)


def _thresh(lane, ys: np.ndarray) -> float:
    return PIXEL_THRESH / math.cos(lane_angle(np.asarray(lane, float), ys))


@dataclass(frozen=True)
class EvalReport:
    """The figures of an evaluation.

    Attributes
    ----------
    frames : int
        Ground-truth frames scored.
    accuracy, fp, fn : float
        TuSimple accuracy, false-positive and false-negative rates (means over the frames with
        a truth line; FP over all frames).
    offset_err_median_m, offset_err_p90_m : float or None
        Median and 90th percentile of |offset error|, metres.
    curvature_err_median : float or None
        Median |curvature error|, 1/m.
    radius_rel_err_median : float or None
        Median relative radius error where the true radius is below 1000 m.
    catastrophic_rate : float
        Fraction of the frames with a truth line that show no lane, a line off by over 50 px, or
        an offset off by over 0.5 m.
    missing_frames : int
        Ground-truth frames with no prediction at all.
    band_accuracy : dict of str to float or None
        Share of the truth points in each distance band (``0-20``, ``20-40``, ``40-70``,
        ``70+`` m ahead) that the best-matching prediction hits (TuSimple's per-point rule);
        None for a band without truth points or without ``row_distance_m`` in the truth.
    band_points : dict of str to int
        Truth points per band.
    lateral_err_6m_median, lateral_err_6m_p90, lateral_err_20m_median, lateral_err_20m_p90 : float or None
        Lateral error of the lines 6 m and 20 m ahead, m, where the truth gives ``lateral``
        and a prediction reaches that row; a line without paint in view (no row truth) is
        not scored.
    no_lane_rate : float or None
        Share of the frames whose truth shows at least one line where the prediction shows no
        lane at all ("lost" while paint is visible); None when no truth frame shows a line.

    Examples
    --------
    >>> gt = {"f": {"lanes": [[100, 101]], "h_samples": [700, 710], "offset_m": 0.1}}
    >>> pred = {"f": {"lanes": [[102, 103]], "offset_m": 0.15}}
    >>> report = evaluate(gt, pred)
    >>> report.accuracy, round(report.offset_err_median_m, 3)
    (1.0, 0.05)
    """

    frames: int
    accuracy: float
    fp: float
    fn: float
    offset_err_median_m: float | None
    offset_err_p90_m: float | None
    curvature_err_median: float | None
    radius_rel_err_median: float | None
    catastrophic_rate: float
    missing_frames: int
    band_accuracy: dict[str, float | None] = field(default_factory=dict)
    band_points: dict[str, int] = field(default_factory=dict)
    lateral_err_6m_median: float | None = None
    lateral_err_6m_p90: float | None = None
    lateral_err_20m_median: float | None = None
    lateral_err_20m_p90: float | None = None
    no_lane_rate: float | None = None

    def table(self, name: str = "") -> str:
        """Format the figures as a two-line table.

        Parameters
        ----------
        name : str, optional
            The row's label.

        Returns
        -------
        str
            A header line and one row.
        """

        def f(v: float | None, fmt: str) -> str:
            return "-" if v is None else format(v, fmt)

        head = f"{'sequence':<14} {'frames':>6} {'accuracy':>9} {'FP':>6} {'FN':>6} {'offset med':>10} " \
               f"{'offset p90':>10} {'1/R med':>9} {'R rel med':>9} {'catastr.':>8}"
        row = (f"{name:<14} {self.frames:>6} {self.accuracy:>9.4f} {self.fp:>6.3f} {self.fn:>6.3f} "
               f"{f(self.offset_err_median_m, '.3f'):>10} {f(self.offset_err_p90_m, '.3f'):>10} "
               f"{f(self.curvature_err_median, '.2e'):>9} {f(self.radius_rel_err_median, '.3f'):>9} "
               f"{self.catastrophic_rate:>8.3f}")
        return head + "\n" + row

    def band_table(self, name: str = "", header: bool = True) -> str:
        """Format the accuracy by distance band, the lateral errors and the no-lane rate as a table.

        Parameters
        ----------
        name : str, optional
            The row's label.
        header : bool, optional
            Start with the header line.

        Returns
        -------
        str
            The header (if asked) and one row.
        """

        def f(v: float | None, fmt: str) -> str:
            return "-" if v is None else format(v, fmt)

        bands = list(self.band_accuracy) or [_band_name(b) for b in BANDS_M]
        head = f"{'sequence':<14} " + " ".join(f"{'acc ' + b + ' m':>12}" for b in bands) + \
            f" {'lat 6m med':>10} {'lat 6m p90':>10} {'lat 20m med':>11} {'lat 20m p90':>11} {'no lane':>7}"
        row = f"{name:<14} " + " ".join(f"{f(self.band_accuracy.get(b), '.4f'):>12}" for b in bands) + \
            f" {f(self.lateral_err_6m_median, '.3f'):>10} {f(self.lateral_err_6m_p90, '.3f'):>10}" \
            f" {f(self.lateral_err_20m_median, '.3f'):>11} {f(self.lateral_err_20m_p90, '.3f'):>11}" \
            f" {f(self.no_lane_rate, '.3f'):>7}"
        return (head + "\n" + row) if header else row


def _read_jsonl(path: Path) -> Iterator[object]:
    """Give a JSON Lines file's values one at a time (the file is never held whole)."""
    if path.is_dir():
        raise LaneFinderError(f"{path} is a folder, not a file")
    if not path.is_file():
        raise LaneFinderError(f"not found: {path}")
    return _lines_of(path)


def _lines_of(path: Path) -> Iterator[object]:
    try:
        yield from iter_json_lines(path)
    except OSError as e:
        raise LaneFinderError(f"cannot read {path}: {e.strerror or e}") from None


#: What :func:`evaluate` reads of a row besides its lanes and h_samples (the rest is not kept).
_KEPT = ("raw_file", "frame", "offset_m", "curvature_per_m", "radius_m", "run_time", "lateral")


#: At most this many distinct h_samples and row-distance arrays are remembered for sharing.
_SHARED_MAX = 1024


def _compact(row: dict, lanes: list, shared: dict[tuple, np.ndarray], truth: bool) -> dict:
    """Keep what :func:`evaluate` reads of a checked row, its lists of numbers as arrays.

    A list of 56 Python numbers takes about 2 kB, as an array 0.5 kB; rows, h_samples and row
    distances that repeat (one camera's) share one array.  A truth file of 100,000 TuSimple
    frames (146 MB) took 2.3 GB as lists.
    """
    out = {k: row[k] for k in _KEPT if k in row}
    out["lanes"] = [np.asarray(lane, np.float64) for lane in lanes]
    for k in ("h_samples", "row_distance_m"):
        if row.get(k) is not None:
            values = np.asarray(row[k], np.float64)
            key = (k, values.tobytes())
            if key in shared:
                values = shared[key]
            elif len(shared) < _SHARED_MAX:  # (rows that never repeat are not all remembered)
                shared[key] = values
            out[k] = values
    for k in ("left_x", "right_x") if truth else ():  # (the truth's: whether the line has paint in view)
        if row.get(k) is not None:
            out[k] = np.asarray(row[k], np.float64)
    return out


_ROW_NUMBERS = ("offset_m", "curvature_per_m", "radius_m", "run_time")
def _check_lateral(lateral: object) -> bool:
    """Tell whether a truth row's ``lateral`` is ``{distance: {"x": [...], "y": row, "m_per_px": scale}}``."""
    return isinstance(lateral, dict) and all(
        isinstance(at, dict) and is_number_list(at.get("x")) and is_number(at.get("y"))
        and is_number(at.get("m_per_px")) for at in lateral.values())


def _check_row(row: object, path: Path | str, i: int) -> dict:
    """Refuse a row whose lanes, rows or figures are not numbers, naming the row."""
    if not isinstance(row, dict):
        raise LaneFinderError(f"{path}: row {i} is not a record of named fields")
    lanes = row.get("lanes", [])
    if not isinstance(lanes, list) or not all(
            is_number_list(lane) for lane in lanes):
        raise LaneFinderError(f"{path}: row {i}: lanes must be lists of numbers")
    ys = row.get("h_samples", [])
    if not is_number_list(ys):
        raise LaneFinderError(f"{path}: row {i}: h_samples must be a list of numbers")
    if any(b < a for a, b in itertools.pairwise(ys)) or (len(ys) > 1 and ys[0] == ys[-1]):
        # (frames under 72 rows repeat some of their 32 rows: telemetry.h_samples)
        raise LaneFinderError(f"{path}: row {i}: h_samples must be rows from top to bottom")
    for k in _ROW_NUMBERS:
        if row.get(k) is not None and not is_number(row[k]):
            raise LaneFinderError(f"{path}: row {i}: {k} is not a number within +-{MAX_ABS_VALUE:g} ({row[k]!r})")
    frame = row.get("frame")
    if "frame" in row and not (is_number(frame) and float(frame).is_integer() and frame >= 0):  # type: ignore[arg-type]
        raise LaneFinderError(f"{path}: row {i}: frame must be a whole number, 0 or more ({frame!r})")
    for k in ("left_x", "right_x", "row_distance_m"):
        if row.get(k) is not None and not is_number_list(row[k]):
            raise LaneFinderError(f"{path}: row {i}: {k} must be a list of numbers")
    if row.get("lateral") is not None and not _check_lateral(row["lateral"]):
        raise LaneFinderError(f"{path}: row {i}: lateral must map distances to x (numbers), y and m_per_px")
    return row


def _by_key(rows: Iterable[dict], path: Path | str) -> dict[str, dict]:
    """Give the rows by frame key, refusing a key given twice (one of the two would be dropped)."""
    out: dict[str, dict] = {}
    for i, r in enumerate(rows, 1):
        k = _key(r)
        if k in out:
            raise LaneFinderError(f"{path}: row {i}: frame {k!r} is given twice")
        out[k] = r
    return out


def _key(row: dict) -> str:
    if "raw_file" in row:
        return str(row["raw_file"])
    if "frame" in row:
        return f"frame/{int(row['frame']):06d}"
    raise LaneFinderError("each row needs raw_file (TuSimple) or frame (lanefinder telemetry)")


def read_ground_truth(path: str | Path) -> dict[str, dict]:
    """Read ground truth: our ``gt.jsonl`` or a TuSimple label file.

    Parameters
    ----------
    path : str or Path
        JSON Lines, each row with ``lanes`` and ``h_samples`` and a key: ``raw_file``
        (TuSimple) or ``frame`` (lanefinder).

    Returns
    -------
    dict of str to dict
        The rows by frame key, as :func:`evaluate` reads them: ``lanes`` (float arrays),
        ``h_samples`` and ``row_distance_m`` (arrays, shared by rows that repeat them), the
        truth's ``left_x``/``right_x`` (arrays), and ``offset_m``, ``curvature_per_m``,
        ``radius_m``, ``lateral`` and the key where given.  The file is read a line at a time.

    Raises
    ------
    LaneFinderError
        When the file is missing, is not JSON Lines, or rows lack lanes, h_samples or a key.

    Examples
    --------
    >>> read_ground_truth("no/gt.jsonl")
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: not found: no/gt.jsonl
    """
    return _by_key(_truth_rows(Path(path)), path)


def _truth_rows(path: Path) -> Iterator[dict]:
    """Check and keep the truth's rows as they are read (see :func:`read_ground_truth`)."""
    shared: dict[tuple, np.ndarray] = {}
    for i, r in enumerate(_read_jsonl(path), 1):
        _check_row(r, path, i)
        if r.get("radius_m") == 0:  # the relative radius error divides by it
            raise LaneFinderError(f"{path}: row {i}: radius_m is 0 (no road bends that tightly; leave it out, or "
                                  "null, for a straight road)")
        if "lanes" not in r or "h_samples" not in r:
            raise LaneFinderError(f"{path}: ground truth rows need lanes and h_samples")
        if any(len(lane) != len(r["h_samples"]) for lane in r["lanes"]):
            raise LaneFinderError(f"{path}: row {i}: every lane needs one x per h_sample")
        yield _compact(r, r["lanes"], shared, truth=True)


def read_predictions(path: str | Path) -> dict[str, dict]:
    """Read predictions: lanefinder telemetry (CSV, Parquet or JSONL) or TuSimple predictions.

    Parameters
    ----------
    path : str or Path
        Telemetry rows (their ``left_x``/``right_x`` become the lanes) or TuSimple rows
        (``raw_file``, ``lanes``, ``run_time``).

    Returns
    -------
    dict of str to dict
        The rows by frame key, each with ``lanes`` (float arrays; a telemetry row's
        ``left_x``/``right_x`` that show a line), ``h_samples`` and the figures
        :func:`evaluate` reads (``offset_m``, ``curvature_per_m``, ``radius_m``, ``run_time``).

    Raises
    ------
    LaneFinderError
        When the file is missing or unreadable.

    Examples
    --------
    >>> read_predictions("no/telemetry.jsonl")
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: not found: no/telemetry.jsonl
    """
    p = Path(path)
    rows = read_telemetry(p) if p.suffix.lower() in (".csv", ".parquet") else _read_jsonl(p)
    return _by_key(_prediction_rows(rows, p), p)


def _prediction_rows(rows: Iterable[object], p: Path) -> Iterator[dict]:
    """Check and keep the predictions' rows as they are read (see :func:`read_predictions`)."""
    shared: dict[tuple, np.ndarray] = {}
    for i, r in enumerate(rows, 1):
        r = _check_row(r, p, i)
        if "lanes" in r:
            lanes = r["lanes"]
        else:
            missing = [k for k in ("left_x", "right_x") if k not in r]
            if missing:
                raise LaneFinderError(f"{p}: row {i} has no lanes (TuSimple) and no {' or '.join(missing)} "
                                      "(lanefinder telemetry has left_x and right_x)")
            lanes = [lane for lane in (r.get("left_x"), r.get("right_x")) if lane and any(v >= 0 for v in lane)]
        yield _compact(r, lanes, shared, truth=False)


def evaluate(gt: dict[str, dict], pred: dict[str, dict]) -> EvalReport:
    """Score predictions: TuSimple figures over the ground-truth frames, and errors in metres.

    A frame with no prediction counts as predicting no lane.  Catastrophic: no lane
    predicted, a truth line whose mean error over the rows both have is above 50 px (or that
    has no prediction at all), or an offset error above 0.5 m.  A frame whose truth has no
    line (no paint visible: washed out by glare, say) counts only for FP (each line shown is
    one); accuracy, FN and the catastrophic rate are over the frames with a truth line.

    Parameters
    ----------
    gt : dict of str to dict
        From :func:`read_ground_truth`; ``offset_m``, ``curvature_per_m`` and ``radius_m``
        are used where present.
    pred : dict of str to dict
        From :func:`read_predictions`.

    Returns
    -------
    EvalReport
        The figures.

    Raises
    ------
    LaneFinderError
        When the ground truth has no frames.

    Examples
    --------
    >>> gt = {"f": {"lanes": [[100, 101]], "h_samples": [700, 710]}}
    >>> evaluate(gt, {}).catastrophic_rate
    1.0
    """
    if not gt:
        raise LaneFinderError("the ground truth has no frames")
    acc = fp = fn = 0.0
    off_err, k_err, r_rel = [], [], []
    lat: dict[str, list[float]] = {"6": [], "20": []}
    band_hits = np.zeros(len(BANDS_M)), np.zeros(len(BANDS_M))
    catastrophic = missing = no_lane = with_line = 0
    for key, g in gt.items():
        p = pred.get(key)
        if p is None:
            missing += 1
        lanes = p["lanes"] if p else []
        if any(len(lane) != len(g["h_samples"]) for lane in lanes):
            raise LaneFinderError(f"the prediction of frame {key!r} has a lane of other than one x per row of its "
                                  f"truth ({len(g['h_samples'])} h_samples)")
        a, f_p, f_n = bench_frame(lanes, g["lanes"], g["h_samples"], float(p.get("run_time", 0) or 0) if p else 0)
        fp += f_p
        if not g["lanes"]:  # nothing to find: only what is shown counts (as FP)
            continue
        with_line += 1
        no_lane += not lanes
        acc, fn = acc + a, fn + f_n
        bad = not lanes or _lines_far_off(g["lanes"], lanes)
        _count_bands(g, lanes, band_hits)
        for dist, errs in lat.items():
            errs.extend(_lateral_errors(g, lanes, dist))
        if p is not None and g.get("offset_m") is not None and p.get("offset_m") is not None:
            e = abs(float(p["offset_m"]) - float(g["offset_m"]))
            off_err.append(e)
            bad |= e > 0.5
        if p is not None and g.get("curvature_per_m") is not None and p.get("curvature_per_m") is not None:
            k_err.append(abs(float(p["curvature_per_m"]) - float(g["curvature_per_m"])))
            r_gt = g.get("radius_m")
            if r_gt is not None and abs(r_gt) < 1000 and p.get("radius_m") is not None:
                r_rel.append(abs(float(p["radius_m"]) - float(r_gt)) / abs(float(r_gt)))
        catastrophic += bad
    n, m = len(gt), max(1, with_line)
    hits, totals = band_hits
    return EvalReport(n, acc / m, fp / n, fn / m, _med(off_err), _p90(off_err), _med(k_err), _med(r_rel),
                      catastrophic / m, missing,
                      band_accuracy={_band_name(b): (float(h / t) if t else None)
                                     for b, h, t in zip(BANDS_M, hits, totals, strict=True)},
                      band_points={_band_name(b): int(t) for b, t in zip(BANDS_M, totals, strict=True)},
                      lateral_err_6m_median=_med(lat["6"]), lateral_err_6m_p90=_p90(lat["6"]),
                      lateral_err_20m_median=_med(lat["20"]), lateral_err_20m_p90=_p90(lat["20"]),
                      no_lane_rate=no_lane / with_line if with_line else None)


def _med(v: list[float]) -> float | None:
    return float(np.median(v)) if v else None


def _p90(v: list[float]) -> float | None:
    return float(np.percentile(v, 90)) if v else None


def _band_name(band: tuple[float, float]) -> str:
    return f"{band[0]:g}-{band[1]:g}" if math.isfinite(band[1]) else f"{band[0]:g}+"


def _lines_far_off(gt_lanes: list, lanes: list) -> bool:
    """Tell whether a truth line has no prediction within 50 px on average over the rows both have."""
    preds = [np.asarray(pl, float) for pl in lanes]
    for gl in gt_lanes:
        gl = np.asarray(gl, float)
        best = None
        for pl in preds:
            both = (gl >= 0) & (pl >= 0)
            if both.any():
                # (np.mean of the rows both have, as before: a sum in another order moves a mean of exactly 50)
                err = float(np.mean(np.abs(gl[both] - pl[both])))
                best = err if best is None else min(best, err)
        if best is None or best > 50:
            return True
    return False


def _count_bands(g: dict, lanes: list, band_hits: tuple[np.ndarray, np.ndarray]) -> None:
    """Add a frame's truth points, and those a prediction hits, to their distance bands.

    Each truth line is compared with its best-matching prediction (TuSimple's rule per point:
    within 20 px / cos(angle)); truth rows need ``row_distance_m`` to be placed in a band.
    """
    dists = g.get("row_distance_m")
    if dists is None or len(dists) == 0 or len(dists) != len(g["h_samples"]):
        return
    d = np.asarray(dists, float)
    ys = np.asarray(g["h_samples"], float)
    hits, totals = band_hits
    for gl in g["lanes"]:
        gl = np.asarray(gl, float)
        thresh = PIXEL_THRESH / math.cos(lane_angle(gl, ys))
        accs = [line_accuracy(pl, gl, thresh) for pl in lanes]
        best = np.asarray(lanes[int(np.argmax(accs))], float) if lanes else np.full_like(gl, -2.0)
        valid = gl >= 0
        ok = valid & (best >= 0) & (np.abs(best - gl) < thresh)
        for i, (lo, hi) in enumerate(BANDS_M):
            inside = valid & (d >= lo) & (d < hi)
            totals[i] += inside.sum()
            hits[i] += (ok & inside).sum()


def _lateral_errors(g: dict, lanes: list, dist: str) -> list[float]:
    """Give the lateral errors (m) of the predicted lines at the row ``dist`` m ahead, where both exist.

    A line of the truth's ``lateral`` whose row truth (``left_x``/``right_x``) is empty has no
    paint in view (a bare road edge, every dash missing): like the TuSimple points, it is not scored.
    """
    at = (g.get("lateral") or {}).get(dist)
    if not at or not lanes:
        return []
    ys = np.asarray(g["h_samples"], float)
    painted = [bool(np.any(np.asarray(g[k]) >= 0)) if k in g else True for k in ("left_x", "right_x")]
    if len(at["x"]) != len(painted):
        painted = [True] * len(at["x"])
    out = []
    for x_gt, has_paint in zip(at["x"], painted, strict=True):
        if not has_paint:
            continue
        best = None
        for pl in lanes:
            pl = np.asarray(pl, float)
            valid = pl >= 0
            if valid.sum() < 2 or not (ys[valid].min() <= at["y"] <= ys[valid].max()):
                continue
            x = float(np.interp(at["y"], ys[valid], pl[valid]))
            e = abs(x - x_gt) * at["m_per_px"]
            best = e if best is None else min(best, e)
        if best is not None:
            out.append(best)
    return out


def setup_error(estimate, truth) -> dict[str, float]:
    """Measure a bird's-eye set-up against the true one, on road points the truth knows.

    Points across the lane (3.7 m apart) at the truth's bottom row and 20 m further are
    carried through the raw frame into the estimate's view.

    Parameters
    ----------
    estimate, truth : BirdsEye
        The set-up to judge and the true one, for frames of the same size.

    Returns
    -------
    dict
        ``xm_pct`` and ``ym_pct``: the estimate's distances across and along over the true
        ones, minus 1, percent; ``car_m``: where the estimate places the true car line (the
        road under the camera) at the bottom row, m from its own car position.

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> be = LaneFinder().birdseye((1280, 720))
    >>> {k: round(v, 6) for k, v in setup_error(be, be).items()}
    {'xm_pct': 0.0, 'ym_pct': 0.0, 'car_m': 0.0}
    """
    t, e = truth, estimate
    h_t, h_e = t.size[1], e.size[1]
    road = np.array([[-1.85, 0.0], [1.85, 0.0], [0.0, 0.0], [0.0, 20.0]])
    view_t = np.column_stack([t.car_x_px + road[:, 0] / t.xm_per_px, h_t - road[:, 1] / t.ym_per_px])
    view_e = e.from_frame(t.to_frame(view_t))
    x_e = (view_e[:, 0] - e.car_x_px) * e.xm_per_px
    z_e = (h_e - view_e[:, 1]) * e.ym_per_px
    return {"xm_pct": float(100 * ((x_e[1] - x_e[0]) / 3.7 - 1)),
            "ym_pct": float(100 * ((z_e[3] - z_e[2]) / 20.0 - 1)),
            "car_m": float(x_e[2])}


def road_errors_m(be: BirdsEye, h_samples: list[int] | np.ndarray, truth_x: list[float] | np.ndarray,
                  drawn_x: list[float] | np.ndarray, max_range_m: float = 150.0) -> np.ndarray:
    """Measure how far a drawn line lies from its labelled marking on the road, row by row.

    Both lines' points on each row are carried onto the road plane of a set-up (raw frame to
    bird's-eye view) and their distance is taken there, so a pixel far ahead weighs as much as
    the road it covers.  This is how a hand-labelled real frame, which has no distances of its
    own, is judged in metres (issue 12: no drawn line more than 0.5 m off its marking).

    Parameters
    ----------
    be : BirdsEye
        The set-up whose road plane measures (for the Udacity videos, the default one).
    h_samples : (N,) array_like
        The rows, frame pixels.
    truth_x, drawn_x : (N,) array_like
        The marking's x and the drawn line's x on each row, frame pixels (negative: none).
    max_range_m : float
        Rows farther ahead than this on the road (or at or above the horizon) are not measured.

    Returns
    -------
    (N,) float64 ndarray
        The distance on the road, m; NaN on rows without both points, or out of range.

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> be = LaneFinder().birdseye((1280, 720))
    >>> e = road_errors_m(be, [700, 600, 500], [300.0, 400.0, -2.0], [320.0, 400.0, 530.0])
    >>> round(float(e[0]), 2), float(e[1]), bool(np.isnan(e[2]))
    (0.09, 0.0, True)
    """
    ys = np.asarray(h_samples, np.float64)
    t, d = np.asarray(truth_x, np.float64), np.asarray(drawn_x, np.float64)
    out = np.full(ys.shape, np.nan)
    both = (t >= 0) & (d >= 0)
    if not both.any():
        return out
    pts = be.from_frame(np.column_stack([np.concatenate([t[both], d[both]]), np.tile(ys[both], 2)]))
    n = int(both.sum())
    ahead = (be.size[1] - pts[:, 1]) * be.ym_per_px
    across = pts[:, 0] * be.xm_per_px
    dist = np.hypot(across[:n] - across[n:], ahead[:n] - ahead[n:])
    # Beyond range, or at the horizon (where the plane's distances swing past infinity), no measure.
    ok = np.isfinite(dist) & (ahead[:n] > -5.0) & (ahead[:n] < max_range_m) & (ahead[n:] < max_range_m)
    out[np.flatnonzero(both)[ok]] = dist[ok]
    return out
