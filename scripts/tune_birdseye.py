"""Derive the default bird's-eye set-up from straight_lines1/2 (reproduces the config defaults).

    python scripts/tune_birdseye.py [--top 460] [--bottom 675]

1. Threshold each straight-road image in a first bird's-eye view, map the marking pixels of
   both lines back to undistorted pixels, and fit a straight line x = m*y + c to each.
2. Average the two images' lines; the src trapezoid is where they cross rows --top and
   --bottom; dst puts them at x = 125 and 275 of a 400x300 view.
3. xm_per_px: the lane (3.7 m between line centres) spans 150 px.
4. ym_per_px: camera geometry.  With the vanishing point row y_v and focal length f_y, a
   ground point seen at row y lies Z = f_y * H / (y - y_v) ahead, and the lane (width W)
   spans w(y) = f_y * W / Z pixels, so the camera height is H = W * (y - y_v) / w(y).  The
   300 rows cover Z(bottom) .. Z(top); ym = (Z_top - Z_bottom) / 300.  The dash period in
   straight_lines1 (12 ft dashes + 36 ft gaps = 14.6 m, Caltrans) is printed as a check.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from lanefinder.config import Config
from lanefinder.pipeline import LaneFinder
from lanefinder.threshold import threshold

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--top", type=float, default=460.0)
    ap.add_argument("--bottom", type=float, default=675.0)
    a = ap.parse_args()
    finder = LaneFinder(Config())
    be = finder.birdseye((1280, 720))
    fits = []
    for name in ("straight_lines1", "straight_lines2"):
        img = cv2.imread(str(ROOT / "data" / "test_images" / f"{name}.jpg"))
        mask = threshold(be.warp(img), Config().threshold, be.xm_per_px)
        lines = []
        for x0 in (125, 275):
            ys, xs = np.nonzero(mask[:, x0 - 20:x0 + 20])
            pts = be.to_undistorted(np.column_stack([xs + x0 - 20, ys]).astype(float))
            lines.append(np.polyfit(pts[:, 1], pts[:, 0], 1))
        (m1, c1), (m2, c2) = lines
        yv = (c2 - c1) / (m1 - m2)
        print(f"{name}: vanishing point ({m1 * yv + c1:.1f}, {yv:.1f})")
        fits.append(lines)
    left = np.mean([f[0] for f in fits], axis=0)
    right = np.mean([f[1] for f in fits], axis=0)
    top, bot = a.top, a.bottom
    src = [(np.polyval(left, top), top), (np.polyval(right, top), top),
           (np.polyval(right, bot), bot), (np.polyval(left, bot), bot)]
    yv = (right[1] - left[1]) / (left[0] - right[0])
    fy = be.camera.camera_matrix[1, 1]
    width_px = np.polyval(right, bot) - np.polyval(left, bot)
    height_m = 3.7 * (bot - yv) / width_px
    z_bot, z_top = fy * height_m / (bot - yv), fy * height_m / (top - yv)
    print("src =", [(round(float(x), 1), y) for x, y in src])
    print(f"vanishing row {yv:.1f}; camera height {height_m:.3f} m; view covers {z_bot:.2f}-{z_top:.2f} m ahead")
    print(f"xm_per_px = 3.7 / 150 = {3.7 / 150:.6f}")
    print(f"ym_per_px = {(z_top - z_bot) / 300:.5f}")
    # Check: dash period of the right line in straight_lines1.
    img = cv2.imread(str(ROOT / "data" / "test_images" / "straight_lines1.jpg"))
    col = threshold(be.warp(img), Config().threshold, be.xm_per_px)[:, 265:285].max(axis=1).astype(float)
    col -= col.mean()
    ac = np.correlate(col, col, "full")[col.size - 1:]
    lag = int(np.argmax(ac[75:250])) + 75
    print(f"check: dash period {lag} px in straight_lines1 -> {14.63 / lag:.5f} m/px if 14.63 m (12 ft + 36 ft)")


if __name__ == "__main__":
    main()
