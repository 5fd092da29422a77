"""Drawing: the lane on the original frame, the HUD, debug views and figures.

Annotators are plain functions that draw onto a frame and return it.
"""

from __future__ import annotations

import cv2
import numpy as np

from .birdseye import BirdsEye
from .config import RenderConfig
from .pipeline import LaneResult
from .search import SearchResult

FONT = cv2.FONT_HERSHEY_SIMPLEX
N_SAMPLES = 24


def lane_polylines(result: LaneResult, be: BirdsEye, n: int = N_SAMPLES) -> tuple[np.ndarray, np.ndarray] | None:
    """Left and right lines as Nx2 points on the original (distorted) frame, or None."""
    if not result.lane_found:
        return None
    y = np.linspace(0, be.size[1], n)
    a, b, c = result.left_fit_px
    left = np.column_stack([(a * y + b) * y + c, y])
    a, b, c = result.right_fit_px
    right = np.column_stack([(a * y + b) * y + c, y])
    pts = be.to_frame(np.vstack([left, right]))
    return pts[:n], pts[n:]


def draw_lane(frame: np.ndarray, result: LaneResult, be: BirdsEye, cfg: RenderConfig) -> np.ndarray:
    """Fill the lane and draw both lines on ``frame`` (in place); returns the frame."""
    lines = lane_polylines(result, be)
    if lines is None:
        return frame
    left, right = lines
    poly = np.vstack([left, right[::-1]])
    h, w = frame.shape[:2]
    x0, y0 = np.floor(poly.min(axis=0)).astype(int)
    x1, y1 = np.ceil(poly.max(axis=0)).astype(int) + 1
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
    if x1 > x0 and y1 > y0:
        roi = frame[y0:y1, x0:x1]
        layer = roi.copy()
        cv2.fillPoly(layer, [np.round(poly - (x0, y0)).astype(np.int32)], cfg.lane_color, cv2.LINE_8)
        cv2.addWeighted(layer, cfg.alpha, roi, 1 - cfg.alpha, 0, dst=roi)
    t = cfg.line_thickness
    for pts, color, inferred in ((left, cfg.left_color, result.left_inferred),
                                 (right, cfg.right_color, result.right_inferred)):
        p = np.round(pts).astype(np.int32)
        if inferred:  # dashed: drawn from the other line, not seen
            for i in range(0, len(p) - 1, 2):
                cv2.line(frame, tuple(p[i]), tuple(p[i + 1]), color, max(1, t // 2), cv2.LINE_AA)
        else:
            cv2.polylines(frame, [p], False, color, t, cv2.LINE_AA)
    return frame


def hud_lines(result: LaneResult) -> list[str]:
    """The HUD text for a result."""
    if not result.lane_found:
        return ["lane lost"]
    if result.straight:
        radius = "straight"
    else:
        side = "right" if result.curvature_per_m > 0 else "left"
        radius = f"{result.radius_m:,.0f} m ({side})"
    side = "right" if result.offset_m > 0 else "left"
    return [
        f"Radius: {radius}",
        f"Offset: {abs(result.offset_m):.2f} m {side} of centre",
        f"Width: {result.width_m:.2f} m",
    ]


def draw_hud(frame: np.ndarray, lines: list[str], origin: tuple[int, int] = (20, 20),
             warn: bool = False) -> np.ndarray:
    """Text box in the top-left corner (in place); scales with the frame height."""
    h = frame.shape[0]
    scale = max(0.4, h / 720 * 0.9)
    thick = max(1, round(2 * h / 720))
    line_h = int(34 * scale / 0.9)
    width = max(cv2.getTextSize(s, FONT, scale, thick)[0][0] for s in lines) + 20
    x, y = origin
    box = frame[y:y + line_h * len(lines) + 14, x:x + width]
    cv2.convertScaleAbs(box, box, 0.35)
    color = (80, 80, 255) if warn else (255, 255, 255)
    for i, s in enumerate(lines):
        cv2.putText(frame, s, (x + 10, y + line_h * (i + 1)), FONT, scale, color, thick, cv2.LINE_AA)
    return frame


def annotate(frame: np.ndarray, result: LaneResult, be: BirdsEye, cfg: RenderConfig,
             extra: list[str] | None = None, inplace: bool = False) -> np.ndarray:
    """Lane and HUD on a copy of ``frame`` (or on ``frame`` itself with ``inplace``)."""
    out = frame if inplace else frame.copy()
    draw_lane(out, result, be, cfg)
    if cfg.hud:
        draw_hud(out, hud_lines(result) + (extra or []), warn=not result.lane_found)
    return out


def search_view(binary: np.ndarray, search: SearchResult | None, result: LaneResult | None,
                show_histogram: bool = True) -> np.ndarray:
    """Bird's-eye binary in colour with line pixels, windows or band, fits and histogram."""
    h, w = binary.shape
    view = cv2.cvtColor(binary * 255, cv2.COLOR_GRAY2BGR)
    if search is not None:
        for pix, color in ((search.left, (0, 0, 255)), (search.right, (255, 80, 0))):
            if pix.count:
                view[pix.y.astype(int), pix.x.astype(int)] = color
            for x0, y0, x1, y1, ok in pix.windows:
                cv2.rectangle(view, (x0, y0), (x1, y1 - 1), (0, 255, 0) if ok else (0, 120, 255), 2)
    y = np.arange(h, dtype=np.float64)
    if result is not None and result.lane_found:
        for fit in (result.left_fit_px, result.right_fit_px):
            x = (fit[0] * y + fit[1]) * y + fit[2]
            if search is not None and search.band_px:
                for dx in (-search.band_px, search.band_px):
                    p = np.column_stack([x + dx, y]).round().astype(np.int32)
                    cv2.polylines(view, [p], False, (0, 160, 0), 1)
            cv2.polylines(view, [np.column_stack([x, y]).round().astype(np.int32)], False, (0, 255, 255), 2)
    if show_histogram and search is not None and search.histogram is not None and search.histogram.max() > 0:
        hist = search.histogram
        ys = h - 1 - hist / hist.max() * (h * 0.3)
        cv2.polylines(view, [np.column_stack([np.arange(w), ys]).round().astype(np.int32)], False,
                      (255, 0, 255), 2)
    return view
