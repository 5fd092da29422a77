"""Per-frame telemetry: one row per frame, as CSV or JSON Lines.

Fields (stable names; list-valued fields are JSON arrays, also inside CSV cells):
frame, time_s, state, left_found, right_found, left_inferred, right_inferred, left_conf,
right_conf, radius_m, curvature_per_m, offset_m, width_m, misses, left_fit_m, right_fit_m,
left_fit_px, right_fit_px, h_samples, left_x, right_x.

``left_x``/``right_x`` give each line's x in the original (distorted) frame at the rows
``h_samples`` (400, 410, ... 710 for 720-row video: the TuSimple benchmark rows), or -2
where the line is absent.  Missing numbers are empty (CSV) or null (JSONL).
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np

from .birdseye import BirdsEye
from .errors import LaneFinderError
from .io import publish
from .pipeline import LaneResult

FIELDS = ["frame", "time_s", "state", "left_found", "right_found", "left_inferred", "right_inferred",
          "left_conf", "right_conf", "radius_m", "curvature_per_m", "offset_m", "width_m", "misses",
          "left_fit_m", "right_fit_m", "left_fit_px", "right_fit_px", "h_samples", "left_x", "right_x"]
LIST_FIELDS = {"left_fit_m", "right_fit_m", "left_fit_px", "right_fit_px", "h_samples", "left_x", "right_x"}
BOOL_FIELDS = {"left_found", "right_found", "left_inferred", "right_inferred"}


def h_samples(frame_height: int) -> list[int]:
    """TuSimple rows 400, 410, ... 710 for 720-row frames, scaled for other heights."""
    return [round(r * frame_height / 720) for r in range(400, 720, 10)]


def line_x_at_rows(fit_px: np.ndarray | None, be: BirdsEye, rows: list[int]) -> list[float]:
    """x (original frame pixels) of a bird's-eye line fit at frame ``rows``; -2 where absent.

    The fit is followed from the bird's-eye top down past its bottom edge (the road plane goes
    on towards the car), mapped through the exact inverse warp, and interpolated per row.
    """
    if fit_px is None:
        return [-2.0] * len(rows)
    h = be.size[1]
    w_f, h_f = be.frame_size
    y = np.linspace(0, 2.0 * h, 160)
    x = (fit_px[0] * y + fit_px[1]) * y + fit_px[2]
    und = be.to_undistorted(np.column_stack([x, y]))
    # Only where the undistorted point is (nearly) in view: the lens polynomial is not
    # monotonic far outside the calibrated field, and the road behind the camera is not seen.
    ok = (und[:, 0] > -0.1 * w_f) & (und[:, 0] < 1.1 * w_f) & (und[:, 1] > -0.1 * h_f) & (und[:, 1] < 1.1 * h_f)
    ok &= np.logical_and.accumulate(np.concatenate([[True], np.diff(und[:, 1]) > 0]))
    if ok.sum() < 2:
        return [-2.0] * len(rows)
    pts = be.to_frame(np.column_stack([x[ok], y[ok]]))
    fy, fx = pts[:, 1], pts[:, 0]
    keep = np.logical_and.accumulate(np.concatenate([[True], np.diff(fy) > 0]))
    fy, fx = fy[keep], fx[keep]
    w = be.frame_size[0]
    out = []
    for r in rows:
        if fy.size < 2 or r < fy[0] or r > fy[-1]:
            out.append(-2.0)
            continue
        xv = float(np.interp(r, fy, fx))
        out.append(round(xv, 1) if 0 <= xv < w else -2.0)
    return out


def _num(v: float | None, nd: int = 6) -> float | None:
    if v is None or not math.isfinite(v):
        return None
    return round(float(v), nd)


def _coeffs(c: np.ndarray | None) -> list[float] | None:
    return None if c is None else [float(f"{v:.8g}") for v in c]


def make_row(index: int, time_s: float, r: LaneResult, be: BirdsEye) -> dict:
    """One telemetry row for a frame's result."""
    rows = h_samples(be.frame_size[1])
    return {
        "frame": index, "time_s": round(time_s, 4), "state": r.state,
        "left_found": r.left_found, "right_found": r.right_found,
        "left_inferred": r.left_inferred, "right_inferred": r.right_inferred,
        "left_conf": round(r.left_conf, 4), "right_conf": round(r.right_conf, 4),
        "radius_m": _num(r.radius_m, 2), "curvature_per_m": _num(r.curvature_per_m, 7),
        "offset_m": _num(r.offset_m, 4), "width_m": _num(r.width_m, 4), "misses": r.misses,
        "left_fit_m": _coeffs(r.left_fit_m), "right_fit_m": _coeffs(r.right_fit_m),
        "left_fit_px": _coeffs(r.left_fit_px), "right_fit_px": _coeffs(r.right_fit_px),
        "h_samples": rows, "left_x": line_x_at_rows(r.left_fit_px, be, rows),
        "right_x": line_x_at_rows(r.right_fit_px, be, rows),
    }


class TelemetryWriter:
    """Writes rows to a hidden file beside ``path``, flushed per row; :meth:`close` moves it into place."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        suffix = self.path.suffix.lower()
        if suffix not in (".csv", ".jsonl"):
            raise LaneFinderError(f"telemetry file must end in .csv or .jsonl: {self.path}")
        self.csv = suffix == ".csv"
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{self.path.stem}.", suffix=suffix, dir=self.path.parent)
        self.tmp = Path(tmp)
        self._f = os.fdopen(fd, "w", newline="")
        self._csv = csv.DictWriter(self._f, fieldnames=FIELDS) if self.csv else None
        if self._csv:
            self._csv.writeheader()
        self.rows = 0

    def write(self, row: dict) -> None:
        if self._csv:
            self._csv.writerow({k: (json.dumps(v) if k in LIST_FIELDS and v is not None else
                                    ("" if v is None else v)) for k, v in row.items()})
        else:
            self._f.write(json.dumps(row) + "\n")
        self._f.flush()
        self.rows += 1

    def close(self) -> None:
        if self._f.closed:
            return
        self._f.close()
        publish(self.tmp, self.path)

    def __enter__(self) -> TelemetryWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _parse_csv_value(key: str, v: str):
    if v == "":
        return None
    if key in LIST_FIELDS:
        return json.loads(v)
    if key in BOOL_FIELDS:
        return v == "True"
    if key in ("frame", "misses"):
        return int(v)
    if key == "state":
        return v
    try:
        return float(v)
    except ValueError:
        return v


def read_telemetry(path: str | Path) -> list[dict]:
    """Rows of a telemetry file (CSV or JSONL), with lists and numbers parsed."""
    p = Path(path)
    if not p.is_file():
        raise LaneFinderError(f"telemetry file not found: {p}")
    text = p.read_text()
    try:
        if p.suffix.lower() == ".csv":
            return [{k: _parse_csv_value(k, v) for k, v in row.items()} for row in csv.DictReader(io.StringIO(text))]
        return [json.loads(line) for line in text.splitlines() if line.strip()]
    except (ValueError, json.JSONDecodeError) as e:
        raise LaneFinderError(f"{p}: not a lanefinder telemetry file ({e})") from None
