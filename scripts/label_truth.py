"""Hand labels for a video: rough points, snapped to the centre of the paint, row by row.

    python scripts/label_truth.py VIDEO ANCHORS -o TRUTH.jsonl [--check DIR]

ANCHORS is a text file written by a person looking at the frames (a pixel grid helps: `--grid
DIR` writes each named frame with one).  One line per line of paint of the car's own lane:

    # frame side  y:x y:x ...      (side L or R; frame pixels, any order)
    1005 L 672:450 640:560 600:700 570:800
    1044                          (a frame where no line of the lane is seen)

A line is labelled on the TuSimple rows (`lanefinder.telemetry.h_samples`) within its points'
span, and nowhere else: the labeller puts points where the line is seen to run.  It is placed
by its paint, nearest row first: each row's guess is the previous row's result moved as the
points bend, and the paint is found within 22 px of it, as the centroid of the strongest ridge
across the row (brighter than the road on both sides: white paint by brightness, yellow by Lab
b; both strips of a double line when they lie in the window).  A row whose ridge is weaker than
10 levels (a dashed line's gap, glare, shade) is filled in, as TuSimple's labels run on through
a dashed line's gaps: the points' shape, moved by the nearest rows' offsets from it where the
paint was found (blended between two).  A line with no row of paint found is not labelled.
The car's hood hides the last 30-40 rows of the Udacity videos: a line whose lowest point is at
row 665 or lower runs on under the hood to the frame's bottom, straight on from its last 30 px,
as TuSimple's lines run to the bottom of the frame.

TRUTH.jsonl has one row per frame with `frame`, `h_samples`, `lanes` (the lines seen, as
`lanefinder eval --gt` reads them) and `left_x`/`right_x` (-2 where not labelled).  With `--check
DIR`, every frame is written with its labels (green: found; cyan: filled in; red circle:
a row guessed but not found), to be checked by eye before the labels are used.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

import cv2
import numpy as np

from lanefinder.errors import LaneFinderError
from lanefinder.io import atomic_write_text, check_outputs
from lanefinder.telemetry import h_samples
from lanefinder.video import VideoInfo, frames

# At 720 rows (scaled with the frame's height): the window about a guess, and the row from which
# a line's lowest point is at the car's hood (the Udacity videos' hood hides rows 686-719).
HALF_PX = 22
HOOD_ROW = 665
MIN_RIDGE = 10.0


def read_anchors(path: Path) -> dict[int, dict[str, list[tuple[int, float]]]]:
    """Read the anchors file: {frame: {"L"/"R": [(y, x), ...] by y}}; a ValueError names a bad line."""
    out: dict[int, dict[str, list[tuple[int, float]]]] = {}
    for n, raw in enumerate(path.read_text().splitlines(), 1):
        text = raw.split("#", 1)[0].split()
        if not text:
            continue
        if len(text) == 1 and text[0].isdigit():  # a frame to label where no line of the lane is seen
            out.setdefault(int(text[0]), {})
            continue
        try:
            frame, side = int(text[0]), text[1]
            pts = sorted((int(y), float(x)) for y, x in (p.split(":") for p in text[2:]))
            if frame < 0 or not all(math.isfinite(x) for _, x in pts):
                raise ValueError
        except (ValueError, IndexError):
            raise ValueError(f"{path}:{n}: expected 'FRAME L|R y:x y:x ...', got {raw.strip()!r}") from None
        if side not in ("L", "R") or len(pts) < 2:
            raise ValueError(f"{path}:{n}: a side L or R and two points or more are needed")
        if side in out.setdefault(frame, {}):
            raise ValueError(f"{path}:{n}: frame {frame} side {side} is given twice")
        out[frame][side] = pts
    return out


def ridges(image: np.ndarray) -> np.ndarray:
    """Give how much each pixel stands above the road on both sides of it, as paint does: white or yellow.

    The road is sampled 5-10, 10-20 and 15-30 px to each side at 720 rows (scaled with the
    frame's height; paint is 3 to 30 px wide across these frames); a pixel counts by its rise over
    the brighter side, at the best of the three.  So the edge of a shadow or of a dark seam,
    bright on one side only, is no ridge.
    """
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY).astype(np.float32)
    yellow = cv2.cvtColor(image, cv2.COLOR_BGR2LAB)[:, :, 2].astype(np.float32)
    best = np.full(grey.shape, -np.inf, np.float32)
    k = image.shape[0] / 720
    for near in sorted({max(1, round(n * k)) for n in (5, 10, 15)}):
        width = near
        for plane, gain in ((grey, 1.0), (yellow, 2.0)):
            side = cv2.blur(plane, (width, 1))  # centred means; shifted below to either side
            shift = near + width // 2
            left = np.empty_like(side)
            right = np.empty_like(side)
            left[:, shift:] = side[:, :-shift]
            left[:, :shift] = side[:, :1]
            right[:, :-shift] = side[:, shift:]
            right[:, -shift:] = side[:, -1:]
            best = np.maximum(best, gain * (plane - np.maximum(left, right)))
    return cv2.blur(best, (3, 3))


def snap(ridge_row: np.ndarray, guess: float, half_px: int = HALF_PX) -> float | None:
    """Give the paint's centre within ``half_px`` of ``guess`` on one row (None when no ridge is strong enough)."""
    x = guess
    for _ in range(2):  # once more about the first answer, so the window sits on the paint
        lo, hi = max(0, round(x) - half_px), min(ridge_row.shape[0], round(x) + half_px + 1)
        if hi - lo < 5:
            return None
        seg = ridge_row[lo:hi]
        peak = float(seg.max())
        if peak < MIN_RIDGE:
            return None
        w = np.where(seg > 0.4 * peak, seg, 0.0)
        x = lo + float((w * np.arange(hi - lo)).sum() / w.sum())
    return x


def follow(ridge: np.ndarray, rows: list[int], pts: list[tuple[int, float]]) -> tuple[list[float], list]:
    """Follow one line between its points; give x per row (-2 unlabelled) and what was tried (for the check image)."""
    h, w = ridge.shape
    k = h / 720
    half, hood = max(3, round(HALF_PX * k)), HOOD_ROW * k
    ay, ax = [p[0] for p in pts], [p[1] for p in pts]
    xs, tried = [-2.0] * len(rows), []
    prev: tuple[int, float] | None = None
    for i in range(len(rows) - 1, -1, -1):  # nearest row first
        y = rows[i]
        if not ay[0] - 3 * k <= y <= ay[-1] + 3 * k:
            continue
        guess = float(np.interp(y, ay, ax))
        if prev is not None and prev[0] - y <= 30 * k:  # the paint as last found, moved as the points bend
            guess = prev[1] + guess - float(np.interp(prev[0], ay, ax))
        x = snap(ridge[y], guess, half)
        tried.append((y, guess, x))
        if x is not None:
            xs[i] = round(x, 1)
            prev = (y, x)
    # Where the paint was not found within the points' span (a dashed line's gap, a patch of
    # glare) the line runs on: the points' shape, moved by the nearest found rows' offsets from it
    # (blended between two).  Beyond the span nothing is labelled.
    found = [i for i, x in enumerate(xs) if x >= 0]
    if not found:
        return xs, tried
    offset = {i: xs[i] - float(np.interp(rows[i], ay, ax)) for i in found}
    for i, y in enumerate(rows):
        if xs[i] >= 0 or not ay[0] - 3 * k <= y <= ay[-1] + 3 * k:
            continue
        below = [j for j in found if j > i]  # nearer the car
        above = [j for j in found if j < i]
        if below and above:
            j0, j1 = above[-1], below[0]
            t = (y - rows[j0]) / (rows[j1] - rows[j0])
            d = offset[j0] + t * (offset[j1] - offset[j0])
        else:
            d = offset[below[0]] if below else offset[above[-1]]
        xs[i] = round(float(np.interp(y, ay, ax)) + d, 1)
        tried.append((y, xs[i], "filled"))
    # A line whose lowest point is at the hood (HOOD_ROW or lower, at 720 rows) runs on under it to
    # the frame's bottom, straight on from its last 30 px, as TuSimple's lines run to the bottom.
    low = [i for i, x in enumerate(xs) if x >= 0]
    if ay[-1] >= hood and len(low) >= 4:
        i1, i0 = low[-1], low[-4]
        slope = (xs[i1] - xs[i0]) / (rows[i1] - rows[i0])
        for i in range(i1 + 1, len(rows)):
            xs[i] = round(xs[i1] + slope * (rows[i] - rows[i1]), 1)
            tried.append((rows[i], xs[i], "filled"))
    # (filled in or run on past the frame's side: not labelled there)
    return [x if 0 <= x < w else -2.0 for x in xs], tried


def check_image(image: np.ndarray, tried: list, frame: int) -> np.ndarray:
    """Draw what was found (green), filled in (cyan) and guessed but not found (red), with a 100 px scale."""
    out = image.copy()
    for x in range(0, out.shape[1], 100):
        cv2.putText(out, str(x), (x + 2, out.shape[0] - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 255, 255), 1)
        cv2.line(out, (x, out.shape[0] - 1), (x, out.shape[0] - 20), (0, 255, 255), 1)
    for y, guess, x in tried:
        if not -1e5 < guess < 1e5:
            continue
        if x is None:
            cv2.circle(out, (round(guess), y), 4, (0, 0, 255), 1)
        elif x == "filled":
            cv2.circle(out, (round(guess), y), 3, (255, 255, 0), -1)
        else:
            cv2.circle(out, (round(x), y), 3, (0, 255, 0), -1)
    cv2.putText(out, f"frame {frame}", (20, 40), cv2.FONT_HERSHEY_SIMPLEX, 1.0, (0, 0, 255), 2)
    return out


def grid_image(image: np.ndarray, frame: int) -> np.ndarray:
    """Draw a pixel grid for writing anchors: ticks every 20 px across, dashed rows every 20 px from 430."""
    out = image.copy()
    h, w = out.shape[:2]
    for x in range(0, w, 20):
        for y0, y1 in ((0, 16 if x % 100 == 0 else 8), (h - 1, h - (16 if x % 100 == 0 else 8))):
            cv2.line(out, (x, y0), (x, y1), (0, 255, 255), 1)
        if x % 100 == 0:
            for y in (30, h - 20):
                cv2.putText(out, str(x), (x + 2, y), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 255, 255), 1)
    for y in range(round(430 * h / 720), h, 20):
        out[y, ::6] = (255, 0, 255)
        cv2.putText(out, str(y), (2, y - 2), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 0, 255), 1)
    cv2.putText(out, f"frame {frame}", (w // 2 - 60, h - 40), cv2.FONT_HERSHEY_SIMPLEX, 0.9, (0, 0, 255), 2)
    return out


def check_points(anchors: dict[int, dict[str, list[tuple[int, float]]]], size: tuple[int, int]) -> None:
    """Refuse points outside a frame of ``size`` (w, h), or not finite; a ValueError names the first."""
    w, h = size
    for frame, sides in anchors.items():
        for side, pts in sides.items():
            for y, x in pts:
                if not (0 <= y < h and math.isfinite(x) and 0 <= x < w):
                    raise ValueError(f"frame {frame} side {side}: the point {y}:{x:g} is outside the "
                                     f"{w}x{h} frame (y:x, 0 <= y < {h}, 0 <= x < {w})")


def label(a: argparse.Namespace, anchors: dict) -> list[dict]:
    """Decode the frames named in ``anchors`` and label them (and draw the --check and --grid images)."""
    rows_out, last = [], max(anchors)
    for f in frames(a.video):
        if f.index > last:
            break
        if f.index not in anchors:
            continue
        if a.grid is not None:
            _write_image(a.grid / f"{f.index:05d}.png", grid_image(f.image, f.index))
        rows = h_samples(f.image.shape[0])
        ridge = ridges(f.image)
        lines, drawn = {}, []
        for side in ("L", "R"):
            pts = anchors[f.index].get(side)
            xs, tried = follow(ridge, rows, pts) if pts else ([-2.0] * len(rows), [])
            if pts and not any(x >= 0 for x in xs):
                print(f"label_truth: warning: frame {f.index} side {side}: no paint found along the points; "
                      "not labelled", file=sys.stderr)
            lines[side] = xs
            drawn += tried
        rows_out.append({"frame": f.index, "h_samples": rows,
                         "lanes": [xs for xs in lines.values() if any(x >= 0 for x in xs)],
                         "left_x": lines["L"], "right_x": lines["R"]})
        if a.check is not None:
            _write_image(a.check / f"{f.index:05d}.png", check_image(f.image, drawn, f.index))
    missing = sorted(set(anchors) - {r["frame"] for r in rows_out})
    if missing:
        raise ValueError(f"frames not in the video: {missing}")
    return rows_out


def _write_image(path: Path, image: np.ndarray) -> None:
    if not cv2.imwrite(str(path), image):
        raise OSError(f"cannot write {path}")


def _writable_folder(folder: Path, what: str) -> None:
    """Make the folder (and its parents), or refuse it with a ValueError before any work."""
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"{what} {folder} is a file, not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ValueError(f"cannot make the folder {folder}: {e.strerror or e}") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ValueError(f"cannot write in {folder}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("video", type=Path)
    ap.add_argument("anchors", type=Path, help="the rough points (see above)")
    ap.add_argument("-o", "--out", type=Path, help="the truth to write (JSON Lines)")
    ap.add_argument("--check", type=Path, help="a folder for the frames drawn with their labels")
    ap.add_argument("--grid", type=Path, help="a folder for the frames drawn with a pixel grid (to write anchors)")
    a = ap.parse_args()
    if a.out is None and a.grid is None:
        ap.error("give -o TRUTH.jsonl, or --grid DIR to draw the frames for writing anchors")
    try:
        for p in (a.video, a.anchors):
            if not p.exists():
                raise ValueError(f"not found: {p}")
            if not p.is_file():
                raise ValueError(f"not a file: {p}")
        anchors = read_anchors(a.anchors)
        if not anchors:
            raise ValueError(f"{a.anchors}: no frames listed (a line 'FRAME L|R y:x y:x ...' or 'FRAME')")
        check_points(anchors, VideoInfo.from_path(a.video).size)
        for folder, what in ((a.check, "--check"), (a.grid, "--grid"),
                             (None if a.out is None else a.out.parent, "the folder of -o")):
            if folder is not None:
                _writable_folder(folder, what)
        if a.out is not None and a.out.is_dir():
            raise ValueError(f"-o {a.out} is a folder: name the file to write")
        if a.out is not None:
            check_outputs([a.out], [a.video, a.anchors])  # never written over what it reads
        rows_out = label(a, anchors)
        if a.out is not None:
            atomic_write_text(a.out, "".join(json.dumps(r) + "\n" for r in rows_out))
            seen = sum(x >= 0 for r in rows_out for x in r["left_x"] + r["right_x"])
            print(f"wrote {a.out}: {len(rows_out)} frames, {seen} labelled points")
    except (ValueError, LaneFinderError) as e:
        print(f"label_truth: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"label_truth: error: {e.strerror or e}{f': {e.filename}' if e.filename else ''}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
