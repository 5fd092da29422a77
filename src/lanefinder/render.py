"""Drawing: the lane on the original frame, the HUD, debug views and figures.

Annotators are plain functions that draw onto a frame and return it; they compose
(:func:`annotate` is :func:`draw_lane` then :func:`draw_hud`).
"""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np

from .birdseye import BirdsEye
from .config import RenderConfig
from .errors import LaneFinderError
from .farfield import far_rows
from .geometry import poly_x
from .lane import LaneResult, Line
from .search import SearchResult

__all__ = [
    "FONT",
    "N_SAMPLES",
    "annotate",
    "contact_sheet",
    "draw_debug",
    "draw_hud",
    "draw_lane",
    "far_polyline",
    "hud_lines",
    "lane_polylines",
    "search_view",
]

#: The HUD's font.
FONT = cv2.FONT_HERSHEY_SIMPLEX
#: Points per drawn line.
N_SAMPLES = 24


def lane_polylines(result: LaneResult, be: BirdsEye, n: int = N_SAMPLES) -> tuple[np.ndarray, np.ndarray] | None:
    """Map the lane's two lines onto the original (distorted) frame.

    Parameters
    ----------
    result : LaneResult
        The frame's result.
    be : BirdsEye
        The set-up it was found with.
    n : int
        Points per line, spread over the bird's-eye view's height.

    Returns
    -------
    tuple of (N, 2) ndarray, or None
        Left and right line points (x, y) in frame pixels; None when no lane is shown.

    Examples
    --------
    >>> import cv2
    >>> from lanefinder import LaneFinder
    >>> finder = LaneFinder()
    >>> r = finder.process(cv2.imread("data/test_images/test3.jpg"))
    >>> left, right = lane_polylines(r, finder.birdseye((1280, 720)))
    >>> left.shape, bool(left[-1, 0] < right[-1, 0])
    ((24, 2), True)
    """
    lines = _lane_points(result, be, n)
    if lines is None:
        return None
    pts = be.to_frame(np.vstack(lines))
    return pts[:n], pts[n:]


def _lane_points(result: LaneResult, be: BirdsEye, n: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Give the lane's two lines as bird's-eye points, n each over the view's height; None without a lane."""
    if not result.lane_found:
        return None
    y = np.linspace(0, be.size[1], n)
    left, right = (np.column_stack([poly_x(line.fit_px, y), y]) for line in result.lines)
    return left, right


def _far_points(line: Line, n: int) -> np.ndarray | None:
    """Give a line's far part as bird's-eye points, denser towards the far end; None without one."""
    if line.far_fit_px is None or not line.far_end_px < 0:
        return None
    y = far_rows(line.far_end_px, n)
    return np.column_stack([poly_x(line.far_fit_px, y), y])


def far_polyline(line: Line, be: BirdsEye, n: int = 16) -> np.ndarray | None:
    """Map a line's far part (beyond the bird's-eye view) onto the original frame.

    Parameters
    ----------
    line : Line
        A line with a far part (``far_fit_px``), or without.
    be : BirdsEye
        The set-up it was found with.
    n : int
        Points, denser towards the far end (where the frame's rows are far apart on the road).

    Returns
    -------
    (n, 2) ndarray or None
        Points (x, y) in frame pixels from the farthest marking followed to the view's top edge;
        None without a far part.

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> from lanefinder.lane import Line
    >>> be = LaneFinder().birdseye((1280, 720))
    >>> line = Line(fit_px=np.array([0.0, 0.0, 125.0]), fit_m=None, confidence=0.9, found=True, inferred=False,
    ...             far_fit_px=np.array([0.0, 0.0, 125.0]), far_end_px=-500.0)
    >>> pts = far_polyline(line, be)
    >>> pts.shape, bool(pts[0, 1] < pts[-1, 1] <= 461)
    ((16, 2), True)
    """
    pts = _far_points(line, n)
    return None if pts is None else be.to_frame(pts)


def draw_lane(frame: np.ndarray, result: LaneResult, be: BirdsEye, cfg: RenderConfig) -> np.ndarray:
    """Fill the lane and draw both lines on a frame, in place.

    A line that was inferred (not seen) is drawn dashed.

    Parameters
    ----------
    frame : (H, W, 3) uint8 ndarray
        The original frame, BGR; drawn on.
    result : LaneResult
        The frame's result.
    be : BirdsEye
        The set-up it was found with.
    cfg : RenderConfig
        Colours, opacity and line thickness.

    Returns
    -------
    ndarray
        ``frame``.

    Examples
    --------
    >>> import cv2
    >>> from lanefinder import Config, LaneFinder
    >>> finder, img = LaneFinder(), cv2.imread("data/test_images/test3.jpg")
    >>> out = draw_lane(img.copy(), finder.process(img), finder.birdseye((1280, 720)), Config().render)
    >>> bool((out != img).any())
    True
    """
    near = _lane_points(result, be, N_SAMPLES)
    if near is None:
        return frame
    # Every point drawn is mapped to the frame in one call (near lines, then each far part).
    fars = [_far_points(line, 16) for line in result.lines]
    parts = [*near, *(f for f in fars if f is not None)]
    mapped = np.split(be.to_frame(np.vstack(parts)), np.cumsum([len(q) for q in parts])[:-1])
    left, right = mapped[0], mapped[1]
    far_frame = iter(mapped[2:])
    far_lines = [None if f is None else next(far_frame) for f in fars]
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
    for pts, color, inferred in ((left, cfg.left_color, result.left.inferred),
                                 (right, cfg.right_color, result.right.inferred)):
        p = np.round(pts).astype(np.int32)
        if inferred:  # dashed: drawn from the other line, not seen
            for i in range(0, len(p) - 1, 2):
                cv2.line(frame, tuple(p[i]), tuple(p[i + 1]), color, max(1, t // 2), cv2.LINE_AA)
        else:
            cv2.polylines(frame, [p], False, color, t, cv2.LINE_AA)
    for far, color in zip(far_lines, (cfg.left_color, cfg.right_color), strict=True):
        if far is not None:  # beyond the view, as far as the marking was followed: thinner
            cv2.polylines(frame, [np.round(far).astype(np.int32)], False, color, max(1, t // 3), cv2.LINE_AA)
    return frame


def hud_lines(result: LaneResult) -> list[str]:
    """Return the HUD text for a result.

    Parameters
    ----------
    result : LaneResult
        The frame's result.

    Returns
    -------
    list of str
        Radius, offset and width lines, or ``["lane lost"]``.

    Examples
    --------
    >>> import numpy as np
    >>> from lanefinder import LaneFinder
    >>> hud_lines(LaneFinder().process(np.zeros((720, 1280, 3), np.uint8)))
    ['lane lost']
    """
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


#: Every digit has the same advance in the HUD's font: widths are measured with them as 0.
_DIGITS_AS_ZERO = str.maketrans("123456789", "000000000")


@lru_cache(maxsize=256)
def _text_width(text: str, scale: float, thick: int) -> int:
    """Give a HUD line's width in pixels (``cv2.getTextSize`` costs tens of microseconds a call)."""
    return int(cv2.getTextSize(text, FONT, scale, thick)[0][0])


def draw_hud(frame: np.ndarray, lines: list[str], origin: tuple[int, int] = (20, 20),
             warn: bool = False) -> np.ndarray:
    """Draw a text box in the top-left corner, in place; it scales with the frame height.

    Parameters
    ----------
    frame : (H, W, 3) uint8 ndarray
        The frame; drawn on.
    lines : list of str
        The text, one entry per line.
    origin : tuple of int
        Top-left corner of the box, pixels.
    warn : bool
        Draw the text in the warning colour.

    Returns
    -------
    ndarray
        ``frame``.

    Examples
    --------
    >>> import numpy as np
    >>> out = draw_hud(np.zeros((360, 640, 3), np.uint8), ["lane lost"], warn=True)
    >>> bool(out.any())
    True
    """
    h = frame.shape[0]
    scale = max(0.4, h / 720 * 0.9)
    thick = max(1, round(2 * h / 720))
    line_h = int(34 * scale / 0.9)
    width = max(_text_width(s.translate(_DIGITS_AS_ZERO), scale, thick) for s in lines) + 20
    x, y = origin
    box = frame[y:y + line_h * len(lines) + 14, x:x + width]
    cv2.convertScaleAbs(box, box, 0.35)
    color = (80, 80, 255) if warn else (255, 255, 255)
    for i, s in enumerate(lines):
        cv2.putText(frame, s, (x + 10, y + line_h * (i + 1)), FONT, scale, color, thick, cv2.LINE_AA)
    return frame


def annotate(frame: np.ndarray, result: LaneResult, be: BirdsEye, cfg: RenderConfig,
             extra: list[str] | None = None, inplace: bool = False) -> np.ndarray:
    """Draw the lane and the HUD on a copy of a frame (or on the frame itself).

    Parameters
    ----------
    frame : (H, W, 3) uint8 ndarray
        The original frame, BGR.
    result : LaneResult
        The frame's result.
    be : BirdsEye
        The set-up it was found with.
    cfg : RenderConfig
        Colours, opacity, thickness and whether to draw the HUD.
    extra : list of str, optional
        More HUD lines.
    inplace : bool
        Draw on ``frame`` itself.

    Returns
    -------
    ndarray
        The annotated frame.

    Examples
    --------
    >>> import cv2
    >>> from lanefinder import Config, LaneFinder
    >>> finder, img = LaneFinder(), cv2.imread("data/test_images/test3.jpg")
    >>> annotate(img, finder.process(img), finder.birdseye((1280, 720)), Config().render).shape
    (720, 1280, 3)
    """
    out = frame if inplace else frame.copy()
    draw_lane(out, result, be, cfg)
    if cfg.hud:
        draw_hud(out, hud_lines(result) + (extra or []), warn=not result.lane_found)
    return out


def search_view(binary: np.ndarray, search: SearchResult | None, result: LaneResult | None,
                show_histogram: bool = True) -> np.ndarray:
    """Draw the bird's-eye binary in colour with line pixels, windows or band, fits and histogram.

    Parameters
    ----------
    binary : (H, W) uint8 ndarray
        The bird's-eye binary, 0/1.
    search : SearchResult or None
        The search (pixels, windows or band, histogram).
    result : LaneResult or None
        The result whose shown lines are drawn.
    show_histogram : bool
        Draw the search's histogram along the bottom.

    Returns
    -------
    (H, W, 3) uint8 ndarray
        The picture.

    Examples
    --------
    >>> import numpy as np
    >>> search_view(np.zeros((300, 400), np.uint8), None, None).shape
    (300, 400, 3)
    """
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
        for line in result.lines:
            x = poly_x(line.fit_px, y)
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


def draw_debug(frame: np.ndarray, result: LaneResult) -> np.ndarray:
    """Draw a picture-in-picture of the bird's-eye search in the top-right corner, in place.

    Shows the binary with the windows or band and the fits, the state, each line's confidence
    and pixel count, and the checks that failed.  Needs a result made with ``keep_debug``.

    Parameters
    ----------
    frame : (H, W, 3) uint8 ndarray
        The frame; drawn on.
    result : LaneResult
        The frame's result, with ``binary`` and ``search`` kept.

    Returns
    -------
    ndarray
        ``frame`` (unchanged when the result kept no debug images).

    Examples
    --------
    >>> import cv2
    >>> from lanefinder import LaneFinder
    >>> img = cv2.imread("data/test_images/test3.jpg")
    >>> out = draw_debug(img.copy(), LaneFinder(keep_debug=True).process(img))
    >>> bool((out[10:100, -400:] != img[10:100, -400:]).any())
    True
    """
    if result.binary is None:
        return frame
    w = frame.shape[1]
    view = search_view(result.binary, result.search, result, show_histogram=True)
    pw = w // 3
    ph = round(view.shape[0] * pw / view.shape[1])
    pip = cv2.resize(view, (pw, ph), interpolation=cv2.INTER_AREA)
    text = [f"{result.state}  misses {result.misses}"]
    text += [f"{side[0].upper()} conf {line.confidence:.2f} px {line.n_pixels}"
             for side, line in zip(("left", "right"), result.lines, strict=True)]
    if result.checks:
        text.append("failed: " + ",".join(result.checks))
    for i, s in enumerate(text):
        cv2.putText(pip, s, (8, 20 + 20 * i), FONT, 0.5, (0, 255, 255), 1, cv2.LINE_AA)
    frame[10:10 + ph, w - pw - 10:w - 10] = pip
    return frame


def contact_sheet(thumbs: list[tuple[float, np.ndarray]], cols: int = 5) -> np.ndarray:
    """Lay out labelled thumbnails in a grid, each with its time as m:ss.ss.

    Parameters
    ----------
    thumbs : list of (float, ndarray)
        (time in seconds, BGR thumbnail) pairs, all of one size.
    cols : int
        Thumbnails per row (fewer when there are fewer thumbnails: the sheet is one row as wide as they are).

    Returns
    -------
    (H, W, 3) uint8 ndarray
        The sheet.

    Raises
    ------
    LaneFinderError
        When there are no thumbnails.

    Examples
    --------
    >>> tiles = [(t, np.zeros((90, 160, 3), np.uint8)) for t in (0.0, 1.5, 3.0)]
    >>> contact_sheet(tiles, cols=2).shape
    (192, 332, 3)
    >>> contact_sheet(tiles[:1]).shape  # one thumbnail: a sheet of one
    (98, 168, 3)
    """
    if not thumbs:
        raise LaneFinderError("no frames for a contact sheet")
    th, tw = thumbs[0][1].shape[:2]
    cols = max(1, min(cols, len(thumbs)))
    rows = (len(thumbs) + cols - 1) // cols
    sheet = np.full((rows * (th + 4) + 4, cols * (tw + 4) + 4, 3), 32, np.uint8)
    for i, (t, img) in enumerate(thumbs):
        r, c = divmod(i, cols)
        y, x = 4 + r * (th + 4), 4 + c * (tw + 4)
        tile = img.copy()
        label = f"{int(t // 60)}:{t % 60:05.2f}"
        cv2.rectangle(tile, (0, th - 24), (len(label) * 11 + 10, th), (0, 0, 0), -1)
        cv2.putText(tile, label, (5, th - 7), FONT, 0.5, (255, 255, 255), 1, cv2.LINE_AA)
        sheet[y:y + th, x:x + tw] = tile
    return sheet
