"""Finding the pixels of each lane line in the bird's-eye binary.

Five searches, all over the same sorted list of set pixels:
- :func:`sliding_windows`: a histogram of the lower image, then windows stepping up;
- :func:`segment_search`: a histogram per horizontal segment, implausible peaks rejected;
- :func:`heading_search`: sliding windows for lines that cross the view at an angle (the car
  heading off the lane, as in a hairpin): histograms taken along a set of slopes;
- :func:`search_around`: a band around a previous fit (video tracking);
- :func:`bend_search`: short pieces of line bent on by the curvature that finds them more paint.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from .config import MAX_BEND_STEPS, SearchConfig
from .geometry import poly_x

__all__ = [
    "EMPTY",
    "LinePixels",
    "Piece",
    "Pixels",
    "SearchParams",
    "SearchResult",
    "Window",
    "base_histogram",
    "bend_search",
    "blind_search",
    "find_bases",
    "heading_search",
    "histogram",
    "search_around",
    "search_params",
    "segment_search",
    "sheared_histogram",
    "sliding_windows",
]

#: A search window: (x_lo, y_lo, x_hi, y_hi) in bird's-eye pixels, and whether it held enough pixels.
Window = tuple[int, int, int, int, bool]

# Fewest pixels a window may ask for, whatever the scale (a window of 3 pixels is noise).
_MIN_WINDOW_PIXELS = 3
_FULL_WINDOW = 3  # a window with this many times min_pixels is trusted fully when recentring
# Width (columns) of the box filter on a segment's histogram; a peak's sum is its mean times this.
_SEGMENT_BLUR_PX = 5
# Rows the paint a bend catches beyond a piece must span before its heading is judged (fewer: a speck).
_MIN_TURN_ROWS = 5


@dataclass(frozen=True)
class SearchParams:
    """Search settings in bird's-eye pixels, from :class:`~lanefinder.config.SearchConfig`.

    Attributes
    ----------
    method : str
        ``windows`` or ``segments``.
    n_windows : int
        Windows up the view.
    margin_px : float
        Half-width of a window, pixels.
    min_pixels : int
        Pixels a window needs to count as found.
    histogram_fraction : float
        Lower fraction of the view summed for the line bases.
    around_margin_px : float
        Half-width of the band around a tracked line, pixels.
    expected_width_px : float
        Expected lane width, pixels.
    width_tolerance : float
        Relative tolerance on the lane width when pairing bases.
    upper_histogram_weight, centre_preference, momentum, empty_window_decay : float
        As in the config.
    pair_max_offset_px : float
        Farthest a pair of bases' centre may be off the car, pixels (0: no limit beyond half
        the expected width either way).
    inner_preference : float
        As in the config.
    peak_smoothing_px : int
        Box filter width on the base histogram, pixels.
    max_peaks : int
        Peaks paired into bases.
    base_min_count : float
        Least peak height, pixels.
    segment_reach, segment_max_shift, segment_band, segment_min_fraction : float
        The segment search, as in the config.
    shears_px : tuple of float
        Slopes the angled search tries: pixels right per pixel up.
    heading_band_px : float
        Half-width of the band the angled search keeps around each window's ridge, pixels.
    bend_px : tuple of float
        Bends :func:`bend_search` tries: the ``a`` of x = a*y^2 + ..., bird's-eye pixels, from
        the sharpest one way to the sharpest the other, straight (0) in the middle; () is off.
    bend_band_px : float
        Half-width of :func:`bend_search`'s band, pixels.
    bend_min_gain : float
        Paint a bend must catch, in multiples of the straight continuation's.
    bend_max_turn_px : float
        Largest heading difference between the paint caught beyond a piece and the bend,
        pixels across per pixel along.

    Examples
    --------
    >>> from lanefinder.config import SearchConfig
    >>> sp = search_params(SearchConfig(), 3.7 / 150, 0.0985)
    >>> round(sp.margin_px, 1), sp.min_pixels, len(sp.shears_px)
    (24.3, 12, 10)
    """

    method: str
    n_windows: int
    margin_px: float
    min_pixels: int
    histogram_fraction: float
    around_margin_px: float
    expected_width_px: float
    width_tolerance: float
    upper_histogram_weight: float
    peak_smoothing_px: int
    max_peaks: int
    base_min_count: float
    centre_preference: float
    momentum: float
    empty_window_decay: float
    segment_reach: float
    segment_max_shift: float
    segment_band: float
    segment_min_fraction: float
    # Slopes tried by :func:`heading_search`: bird's-eye pixels right per pixel up.
    shears_px: tuple[float, ...] = ()
    # Half-width of the band around each window's ridge that :func:`heading_search` keeps.
    heading_band_px: float = 0.0
    pair_max_offset_px: float = 0.0
    inner_preference: float = 0.0
    bend_px: tuple[float, ...] = ()
    bend_band_px: float = 0.0
    bend_min_gain: float = 2.0
    bend_max_turn_px: float = 0.0


def search_params(cfg: SearchConfig, xm_per_px: float, ym_per_px: float) -> SearchParams:
    """Turn the metre settings of a search config into pixels for a bird's-eye scale.

    Parameters
    ----------
    cfg : SearchConfig
        The settings, metres.
    xm_per_px, ym_per_px : float
        Metres per bird's-eye pixel across and along the road.

    Returns
    -------
    SearchParams
        The settings in pixels.

    Examples
    --------
    >>> from lanefinder.config import SearchConfig
    >>> round(search_params(SearchConfig(), 3.7 / 150, 0.0985).expected_width_px)
    150
    """
    per_m = cfg.marking_width_m / (xm_per_px * ym_per_px)  # marking pixels per metre of line
    n = int(cfg.max_heading_deg // cfg.heading_step_deg) if cfg.heading_step_deg > 0 else 0
    angles = [k * cfg.heading_step_deg for k in range(-n, n + 1) if k != 0]
    # A line heading at angle a moves tan(a) metres sideways per metre ahead.
    shears = tuple(float(np.tan(np.radians(a)) * ym_per_px / xm_per_px) for a in angles)
    min_pixels = max(_MIN_WINDOW_PIXELS, round(cfg.min_window_marking_m * per_m))
    # A curvature k (1/m) bends a line by k/2 * d^2 metres d ahead: a = k/2 * ym^2 / xm in pixels.
    steps = min(MAX_BEND_STEPS, math.floor(cfg.bend_max_per_m / cfg.bend_step_per_m + 1e-9))
    bends = tuple(float(k * cfg.bend_step_per_m / 2 * ym_per_px**2 / xm_per_px) for k in range(-steps, steps + 1))
    return SearchParams(
        method=cfg.method,
        n_windows=cfg.n_windows,
        margin_px=cfg.margin_m / xm_per_px,
        min_pixels=min_pixels,
        histogram_fraction=cfg.histogram_fraction,
        around_margin_px=cfg.around_margin_m / xm_per_px,
        expected_width_px=cfg.lane_width_m / xm_per_px,
        width_tolerance=cfg.width_tolerance,
        upper_histogram_weight=cfg.upper_histogram_weight,
        peak_smoothing_px=max(1, round(cfg.peak_smoothing_m / xm_per_px)),
        max_peaks=cfg.max_peaks,
        base_min_count=min_pixels * cfg.base_min_fraction,
        centre_preference=cfg.centre_preference,
        pair_max_offset_px=cfg.pair_max_offset_m / xm_per_px,
        inner_preference=cfg.inner_preference,
        momentum=cfg.momentum,
        empty_window_decay=cfg.empty_window_decay,
        segment_reach=cfg.segment_reach,
        segment_max_shift=cfg.segment_max_shift,
        segment_band=cfg.segment_band,
        segment_min_fraction=cfg.segment_min_fraction,
        shears_px=shears,
        heading_band_px=cfg.heading_band_m / xm_per_px,
        bend_px=bends if steps > 0 else (),
        bend_band_px=cfg.bend_band_m / xm_per_px,
        bend_min_gain=cfg.bend_min_gain,
        bend_max_turn_px=cfg.bend_max_turn * ym_per_px / xm_per_px,
    )


@dataclass(frozen=True, eq=False)
class LinePixels:
    """Pixels attributed to one line, in bird's-eye pixels.

    Attributes
    ----------
    x, y : ndarray
        The pixels' columns and rows (float32).
    windows : tuple of Window
        The search windows used, for drawing: (x_lo, y_lo, x_hi, y_hi, found).

    Examples
    --------
    >>> LinePixels(np.array([5.0, 6.0]), np.array([10.0, 11.0])).count
    2
    """

    x: np.ndarray
    y: np.ndarray
    windows: tuple[Window, ...] = ()

    @property
    def count(self) -> int:
        """Number of pixels."""
        return int(self.x.size)


@dataclass(frozen=True, eq=False)
class SearchResult:
    """What a search found: each line's pixels, and what to draw it with.

    Attributes
    ----------
    left, right : LinePixels
        Each line's pixels.
    method : str
        The search that found them (``windows``, ``segments``, ``heading``, ``around``, ``bend``),
        and what followed it joined by ``+`` (``windows+heading``: each line kept another
        search's pixels; ``+partner``, ``+bend``, ``+inner``: the measurer's later steps).
    histogram : ndarray or None
        The column histogram the bases came from.
    bases_px : tuple of (float or None)
        The left and right line's x at the bottom, pixels.
    band_px : int
        Half-width of the band of a search around the track, pixels (0 otherwise).
    extra : dict
        Search-specific details (``shear_px`` of the angled search, ``bend_px`` of the bend probe).

    Examples
    --------
    >>> SearchResult(EMPTY, EMPTY, "windows").left.count
    0
    """

    left: LinePixels
    right: LinePixels
    method: str
    histogram: np.ndarray | None = None
    bases_px: tuple[float | None, float | None] = (None, None)
    band_px: int = 0
    extra: dict = field(default_factory=dict)


#: A line with no pixels.
EMPTY = LinePixels(np.empty(0, np.float32), np.empty(0, np.float32))


@dataclass(frozen=True, eq=False)
class Pixels:
    """All set pixels of a binary, sorted by row (as np.nonzero gives them).

    Every search works on this one list, made once per frame.

    Attributes
    ----------
    x, y : ndarray
        Columns and rows of the set pixels (int32), sorted by row.
    shape : tuple of int
        (height, width) of the binary.

    Examples
    --------
    >>> px = Pixels.of(np.eye(4, dtype=np.uint8))
    >>> px.x.tolist(), px.rows(1, 3)
    ([0, 1, 2, 3], slice(1, 3, None))
    """

    x: np.ndarray
    y: np.ndarray
    shape: tuple[int, int]

    @classmethod
    def of(cls, binary: np.ndarray) -> Pixels:
        """Collect the set pixels of a binary.

        Parameters
        ----------
        binary : (H, W) uint8 ndarray
            0/1 (or 0/255) image.

        Returns
        -------
        Pixels
            Its set pixels, sorted by row.
        """
        pts = cv2.findNonZero(binary)
        if pts is None:
            e = np.empty(0, np.int32)
            return cls(e, e, binary.shape[:2])
        pts = pts.reshape(-1, 2)
        return cls(pts[:, 0], pts[:, 1], binary.shape[:2])

    def rows(self, y_lo: int, y_hi: int) -> slice:
        """Return the slice of pixels with y_lo <= y < y_hi.

        Parameters
        ----------
        y_lo, y_hi : int
            Rows, pixels.

        Returns
        -------
        slice
            Into ``x`` and ``y``.
        """
        return slice(int(np.searchsorted(self.y, y_lo)), int(np.searchsorted(self.y, y_hi)))


def histogram(binary: np.ndarray, fraction: float = 0.5) -> np.ndarray:
    """Sum the columns of the lower part of a binary.

    Parameters
    ----------
    binary : (H, W) uint8 ndarray
        The bird's-eye binary, 0/1.
    fraction : float
        Lower fraction of the rows to sum.

    Returns
    -------
    (W,) float32 ndarray
        Set pixels per column.

    Examples
    --------
    >>> histogram(np.eye(4, dtype=np.uint8), 0.5).tolist()
    [0.0, 0.0, 1.0, 1.0]
    """
    h = binary.shape[0]
    return cv2.reduce(binary[int(h * (1 - fraction)):], 0, cv2.REDUCE_SUM, dtype=cv2.CV_32S).ravel().astype(np.float32)


def _smooth(hist: np.ndarray, width: int) -> np.ndarray:
    return cv2.blur(hist.reshape(1, -1), (max(1, width), 1)).ravel()


def _local_maxima(h: np.ndarray, min_count: float, most: int) -> np.ndarray:
    """Return the indices of the ``most`` highest local maxima of ``h`` at or above ``min_count``."""
    if h.size < 3:
        return np.empty(0, int)
    inner = (h[1:-1] >= h[:-2]) & (h[1:-1] > h[2:]) & (h[1:-1] >= min_count)
    idx = np.flatnonzero(inner) + 1
    return idx[np.argsort(h[idx])[::-1][:most]]


def find_bases(hist: np.ndarray, car_x: float, cfg: SearchParams) -> tuple[float | None, float | None]:
    """Find the left and right line's x at the bottom from a column histogram.

    Of all pairs of peaks, one left and one right of the car, whose spacing is the expected
    lane width within the tolerance and whose centre is within ``pair_max_offset_px`` of the
    car, the pair with the most support wins.  With no such pair, the strongest peak is kept
    alone on its side of the car.

    Parameters
    ----------
    hist : (W,) ndarray
        Column support.
    car_x : float
        The car's column, pixels.
    cfg : SearchParams
        Expected width, tolerance, smoothing and peak settings.

    Returns
    -------
    tuple of (float or None)
        Left and right base x, pixels; None where there is none.

    Examples
    --------
    >>> from lanefinder.config import SearchConfig
    >>> sp = search_params(SearchConfig(), 3.7 / 150, 0.0985)
    >>> b = np.zeros((300, 400), np.uint8); b[:, 122:128] = 1; b[:, 272:278] = 1
    >>> find_bases(histogram(b, 0.5), 200.0, sp)
    (126.0, 276.0)

    Two strong lines left of the car (a double yellow line and the far kerb) do not make the
    lane; the yellow line and the fainter white one the car is between do:

    >>> b = np.zeros((300, 400), np.uint8); b[:, 20:30] = 1; b[:, 145:155] = 1; b[:, 292:296] = 1
    >>> find_bases(histogram(b, 0.5), 200.0, sp)
    (150.0, 296.0)
    """
    left, right, _ = _scored_bases(hist, car_x, cfg)
    return left, right


def _scored_bases(hist: np.ndarray, car_x: float, cfg: SearchParams) -> tuple[float | None, float | None, float]:
    """:func:`find_bases` and the support of its answer (a lone peak counts half)."""
    expected_width_px, tolerance = cfg.expected_width_px, cfg.width_tolerance
    hs = _smooth(hist, cfg.peak_smoothing_px)
    peaks = _local_maxima(hs, cfg.base_min_count, cfg.max_peaks)
    if peaks.size == 0:
        return None, None, 0.0
    lo_w, hi_w = expected_width_px * (1 - tolerance), expected_width_px * (1 + tolerance)
    # Pairs: every left candidate with every right candidate at a plausible spacing.
    li, ri = np.meshgrid(peaks, peaks, indexing="ij")
    gap, off_centre = ri - li, np.abs((li + ri) / 2 - car_x)
    valid = (gap >= lo_w) & (gap <= hi_w) & (li < car_x + expected_width_px / 2) & (ri > car_x - expected_width_px / 2)
    if cfg.pair_max_offset_px > 0:
        valid &= off_centre <= cfg.pair_max_offset_px
    if valid.any():
        # Support of both peaks, and a mild preference for a lane around the car.
        centre_penalty = off_centre / expected_width_px
        score = np.where(valid, (hs[li] + hs[ri]) * (1 - cfg.centre_preference * centre_penalty), -np.inf)
        i, j = np.unravel_index(int(np.argmax(score)), score.shape)
        if cfg.inner_preference > 0:
            # A lane is bounded by the first marking out from the car on each side: a kerb, rail
            # or the next line beyond it may be stronger.  A pair inside the best one, nearer the
            # expected width, that scores at least inner_preference of the best wins; of those, the
            # best-scoring (the narrowest took a speck of texture inside the true line: a dashed
            # line with a solid edge line beyond it, synthetic hills seed 5), and again inside
            # that one (a kerb beyond the line but inside a rail).  Each step nears the expected
            # width, so it ends.
            miss = np.abs(gap - expected_width_px)
            enough = score >= cfg.inner_preference * score[i, j]
            while (inner := enough & (li >= li[i, j]) & (ri <= ri[i, j]) & (miss < miss[i, j])).any():
                i, j = np.unravel_index(int(np.argmax(np.where(inner, score, -np.inf))), gap.shape)
        return float(li[i, j]), float(ri[i, j]), float(score[i, j])
    best = int(peaks[0])
    side = (float(best), None) if best < car_x else (None, float(best))
    return (*side, 0.5 * float(hs[best]))


def base_histogram(binary: np.ndarray, fraction: float, upper_weight: float) -> np.ndarray:
    """Sum columns for line bases: the lower ``fraction`` counts fully, the rest ``upper_weight``.

    A line with a gap at the bottom (between dashes) still gets a base from higher up.

    Parameters
    ----------
    binary : (H, W) uint8 ndarray
        The bird's-eye binary, 0/1.
    fraction : float
        Lower fraction of the rows that counts fully.
    upper_weight : float
        Weight of the other rows.

    Returns
    -------
    (W,) float32 ndarray
        Column support.

    Examples
    --------
    >>> base_histogram(np.eye(4, dtype=np.uint8), 0.5, 0.5).tolist()
    [0.5, 0.5, 1.0, 1.0]
    """
    h = binary.shape[0]
    cut = int(h * (1 - fraction))
    lower = histogram(binary, fraction)
    if cut <= 0:
        return lower
    upper = cv2.reduce(binary[:cut], 0, cv2.REDUCE_SUM, dtype=cv2.CV_32S).ravel().astype(np.float32)
    return lower + upper_weight * upper


def _take(px: Pixels, parts: list[np.ndarray]) -> LinePixels:
    if not parts:
        return EMPTY
    idx = np.concatenate(parts)
    return LinePixels(px.x[idx].astype(np.float32), px.y[idx].astype(np.float32))


def _ridge(xs: np.ndarray, ys: np.ndarray, sel: np.ndarray, x_c: float, lean: float, y_mid: float,
           margin: float, band: float) -> np.ndarray:
    """Of the window's pixels ``sel``, those within ``band`` px of its strongest ridge along ``lean``.

    Pixels are moved along the lean (px right per px up) to the window's middle row and
    counted per column; the peak column is the ridge.
    """
    u = xs[sel] + lean * (ys[sel] - y_mid) - (x_c - margin)
    n_bins = int(2 * margin) + 1
    inside = (u >= 0) & (u < n_bins)
    counts = np.bincount(u[inside].astype(np.intp), minlength=n_bins)
    counts = _smooth(counts.astype(np.float32), max(1, round(band)))
    peak = float(np.argmax(counts))
    return sel[np.abs(u - peak) <= band]


def _windows_for(px: Pixels, base: float | None, cfg: SearchParams, shear: float = 0.0,
                 band_px: float = 0.0) -> LinePixels:
    """Windows up from ``base`` (x at the bottom row), first heading ``shear`` px right per px up.

    With ``band_px``, a window keeps only its pixels within that distance of its strongest ridge.
    """
    if base is None:
        return EMPTY
    h, w = px.shape
    win_h = h / cfg.n_windows
    step = shear * win_h
    x_c = float(base) + step / 2
    last_x: float | None = None
    parts: list[np.ndarray] = []
    windows: list[Window] = []
    for i in range(cfg.n_windows):
        y_hi = round(h - i * win_h)
        y_lo = round(h - (i + 1) * win_h)
        sl = px.rows(y_lo, y_hi)
        xs = px.x[sl]
        sel = np.flatnonzero(np.abs(xs - x_c) < cfg.margin_px)
        if band_px > 0 and sel.size >= cfg.min_pixels:
            sel = _ridge(xs, px.y[sl], sel, x_c, step / win_h, (y_lo + y_hi) / 2, cfg.margin_px, band_px)
        found = sel.size >= cfg.min_pixels
        windows.append((int(x_c - cfg.margin_px), y_lo, int(x_c + cfg.margin_px), y_hi, bool(found)))
        if found:
            parts.append(sel + sl.start)
            # A window barely over the minimum (a fleck of clutter) moves the centre only
            # in part; a well-filled one sets it.
            trust = min(1.0, sel.size / (_FULL_WINDOW * cfg.min_pixels))
            new_x = x_c + trust * (float(xs[sel].mean()) - x_c)
            # Follow a bend: the drift between consecutive found windows carries on upwards.
            # Until two windows in a row have been found, the starting slope stands; after a
            # gap (a found window before this one, but not just below it), the drift restarts.
            if last_x is not None:
                step = cfg.momentum * step + (1 - cfg.momentum) * (new_x - last_x)
            elif len(parts) > 1:
                step = 0.0
            last_x = new_x
            x_c = new_x + step
        else:
            last_x = None
            step *= cfg.empty_window_decay  # an empty window: keep going, less and less sure of the bend
            x_c += step
        if not -cfg.margin_px < x_c < w + cfg.margin_px:
            break
    lp = _take(px, parts)
    return LinePixels(lp.x, lp.y, tuple(windows))


def _blind(binary: np.ndarray, cfg: SearchParams, car_x: float, pixels: Pixels | None, method: str) -> SearchResult:
    """Line bases from the column histogram, then each line followed up by ``method``."""
    px = pixels or Pixels.of(binary)
    hist = base_histogram(binary, cfg.histogram_fraction, cfg.upper_histogram_weight)
    bases = find_bases(hist, car_x, cfg)
    if method == "segments":
        left, right = _segments_for(binary, px, bases[0], cfg), _segments_for(binary, px, bases[1], cfg)
    else:
        left, right = _windows_for(px, bases[0], cfg), _windows_for(px, bases[1], cfg)
    return SearchResult(left, right, method, hist, bases)


def sliding_windows(binary: np.ndarray, cfg: SearchParams, car_x: float,
                    pixels: Pixels | None = None) -> SearchResult:
    """Find line bases in a histogram of the lower view, then follow each line up with windows.

    Parameters
    ----------
    binary : (H, W) uint8 ndarray
        The bird's-eye binary, 0/1.
    cfg : SearchParams
        Settings in pixels.
    car_x : float
        The car's column, pixels.
    pixels : Pixels, optional
        The set pixels of ``binary``, when already extracted.

    Returns
    -------
    SearchResult
        Each line's pixels and windows.

    Examples
    --------
    >>> from lanefinder.config import SearchConfig
    >>> sp = search_params(SearchConfig(), 3.7 / 150, 0.0985)
    >>> b = np.zeros((300, 400), np.uint8); b[:, 122:128] = 1; b[:, 272:278] = 1
    >>> found = sliding_windows(b, sp, 200.0)
    >>> found.left.count, found.right.count
    (1800, 1800)
    """
    return _blind(binary, cfg, car_x, pixels, "windows")


def _segments_for(binary: np.ndarray, px: Pixels, base: float | None, cfg: SearchParams) -> LinePixels:
    if base is None:
        return EMPTY
    h, w = binary.shape
    seg_h = h / cfg.n_windows
    x_c, step = float(base), 0.0
    last_x: float | None = None
    parts: list[np.ndarray] = []
    windows: list[Window] = []
    reach = cfg.segment_reach * cfg.margin_px
    band = cfg.segment_band * cfg.margin_px
    min_sum = cfg.min_pixels * cfg.segment_min_fraction
    for i in range(cfg.n_windows):
        y_hi = round(h - i * seg_h)
        y_lo = round(h - (i + 1) * seg_h)
        x_lo, x_hi = int(max(0, x_c - reach)), int(min(w, x_c + reach))
        found = False
        if x_hi - x_lo > 4:
            hist = _smooth(cv2.reduce(binary[y_lo:y_hi, x_lo:x_hi], 0, cv2.REDUCE_SUM, dtype=cv2.CV_32S)
                           .ravel().astype(np.float32), _SEGMENT_BLUR_PX)
            j = int(np.argmax(hist))
            peak_x = float(x_lo + j)
            # Reject a peak that is weak, or far from where the line is heading.
            found = hist[j] * _SEGMENT_BLUR_PX >= min_sum and abs(peak_x - x_c) <= cfg.segment_max_shift * cfg.margin_px
            if found:
                sl = px.rows(y_lo, y_hi)
                sel = np.flatnonzero(np.abs(px.x[sl] - peak_x) < band)
                found = sel.size >= min_sum
                if found:
                    parts.append(sel + sl.start)
                    step = cfg.momentum * step + (1 - cfg.momentum) * (peak_x - last_x) if last_x is not None else 0.0
                    last_x = peak_x
                    x_c = peak_x + step
        windows.append((int(x_c - band), y_lo, int(x_c + band), y_hi, bool(found)))
        if not found:
            last_x = None
            step *= cfg.empty_window_decay
            x_c += step
    lp = _take(px, parts)
    return LinePixels(lp.x, lp.y, tuple(windows))


def segment_search(binary: np.ndarray, cfg: SearchParams, car_x: float,
                   pixels: Pixels | None = None) -> SearchResult:
    """Follow each line up segment by segment, by histograms, rejecting implausible peaks.

    Parameters
    ----------
    binary : (H, W) uint8 ndarray
        The bird's-eye binary, 0/1.
    cfg : SearchParams
        Settings in pixels.
    car_x : float
        The car's column, pixels.
    pixels : Pixels, optional
        The set pixels of ``binary``, when already extracted.

    Returns
    -------
    SearchResult
        Each line's pixels and segments.

    Examples
    --------
    >>> from lanefinder.config import SearchConfig
    >>> sp = search_params(SearchConfig(), 3.7 / 150, 0.0985)
    >>> b = np.zeros((300, 400), np.uint8); b[:, 122:128] = 1; b[:, 272:278] = 1
    >>> segment_search(b, sp, 200.0).method
    'segments'
    """
    return _blind(binary, cfg, car_x, pixels, "segments")


def blind_search(binary: np.ndarray, cfg: SearchParams, car_x: float, pixels: Pixels | None = None) -> SearchResult:
    """Search without a previous fit, with the configured method (windows or segments).

    Parameters
    ----------
    binary : (H, W) uint8 ndarray
        The bird's-eye binary, 0/1.
    cfg : SearchParams
        Settings in pixels (``method``).
    car_x : float
        The car's column, pixels.
    pixels : Pixels, optional
        The set pixels of ``binary``, when already extracted.

    Returns
    -------
    SearchResult
        Each line's pixels.

    Examples
    --------
    >>> from lanefinder.config import SearchConfig
    >>> sp = search_params(SearchConfig(), 3.7 / 150, 0.0985)
    >>> b = np.zeros((300, 400), np.uint8); b[:, 122:128] = 1; b[:, 272:278] = 1
    >>> blind_search(b, sp, 200.0).bases_px
    (126.0, 276.0)
    """
    return _blind(binary, cfg, car_x, pixels, cfg.method)


def sheared_histogram(px: Pixels, shear: float, fraction: float) -> np.ndarray:
    """Sum the lower view along a slope: column support at the bottom row for leaning lines.

    Each set pixel of the lower ``fraction`` is moved back along the lean to the bottom row;
    a line at that lean piles up in one column.

    Parameters
    ----------
    px : Pixels
        The set pixels of the binary.
    shear : float
        The lean, pixels right per pixel up.
    fraction : float
        Lower fraction of the rows used.

    Returns
    -------
    (W,) float32 ndarray
        Support per bottom-row column.

    Examples
    --------
    >>> b = np.zeros((10, 10), np.uint8); b[np.arange(10), np.arange(9, -1, -1)] = 1
    >>> int(sheared_histogram(Pixels.of(b), 1.0, 1.0).argmax())
    0
    """
    h, w = px.shape
    sl = px.rows(int(h * (1 - fraction)), h)
    x0 = np.rint(px.x[sl] - shear * (h - px.y[sl])).astype(np.intp)
    return np.bincount(x0[(x0 >= 0) & (x0 < w)], minlength=w).astype(np.float32)


def heading_search(binary: np.ndarray, cfg: SearchParams, car_x: float, pixels: Pixels | None = None) -> SearchResult:
    """Sliding windows for lines that cross the view at an angle.

    For each slope in ``cfg.shears_px`` the lower image is summed along that slope; the slope
    whose histogram gives the best-supported pair of bases (see :func:`find_bases`) is followed
    up with windows that start at that slope; each window keeps only its pixels within
    ``cfg.heading_band_px`` of its strongest ridge.  ``extra["shear_px"]`` holds the slope chosen.

    Parameters
    ----------
    binary : (H, W) uint8 ndarray
        The bird's-eye binary, 0/1.
    cfg : SearchParams
        Settings in pixels (``shears_px``, ``heading_band_px``).
    car_x : float
        The car's column, pixels.
    pixels : Pixels, optional
        The set pixels of ``binary``, when already extracted.

    Returns
    -------
    SearchResult
        Each line's pixels and windows; ``method`` is ``heading``.

    Examples
    --------
    >>> from lanefinder.config import SearchConfig
    >>> sp = search_params(SearchConfig(), 3.7 / 150, 0.0985)
    >>> b = np.zeros((300, 400), np.uint8); b[:, 122:128] = 1; b[:, 272:278] = 1
    >>> heading_search(b, sp, 200.0).method
    'heading'
    """
    px = pixels or Pixels.of(binary)
    best: tuple[float, float, tuple[float | None, float | None], np.ndarray | None] = (0.0, 0.0, (None, None), None)
    for shear in cfg.shears_px:
        hist = sheared_histogram(px, shear, cfg.histogram_fraction)
        left, right, score = _scored_bases(hist, car_x, cfg)
        if score > best[0]:
            best = (score, shear, (left, right), hist)
    _, shear, bases, hist = best
    band = cfg.heading_band_px
    left, right = _windows_for(px, bases[0], cfg, shear, band), _windows_for(px, bases[1], cfg, shear, band)
    return SearchResult(left, right, "heading", hist, bases, extra={"shear_px": shear})


def _around(px: Pixels, fit: np.ndarray | None, margin: float) -> LinePixels:
    if fit is None or px.x.size == 0:
        return EMPTY
    y = px.y.astype(np.float32)
    pred = poly_x(fit, y)
    sel = np.flatnonzero(np.abs(px.x - pred) < margin)
    return LinePixels(px.x[sel].astype(np.float32), y[sel])


def search_around(binary: np.ndarray, left_fit: np.ndarray | None, right_fit: np.ndarray | None,
                  margin_px: float, pixels: Pixels | None = None) -> SearchResult:
    """Collect the pixels within a band around previous fits x = a*y^2 + b*y + c.

    Parameters
    ----------
    binary : (H, W) uint8 ndarray
        The bird's-eye binary, 0/1.
    left_fit, right_fit : (3,) ndarray or None
        The previous fits, bird's-eye pixels.
    margin_px : float
        Half-width of the band, pixels.
    pixels : Pixels, optional
        The set pixels of ``binary``, when already extracted.

    Returns
    -------
    SearchResult
        Each line's pixels; ``method`` is ``around``.

    Examples
    --------
    >>> b = np.zeros((300, 400), np.uint8); b[:, 122:128] = 1
    >>> search_around(b, np.array([0.0, 0.0, 125.0]), None, 10.0).left.count
    1800
    """
    px = pixels or Pixels.of(binary)
    return SearchResult(_around(px, left_fit, margin_px), _around(px, right_fit, margin_px), "around",
                        band_px=int(margin_px))


#: A short piece of line for :func:`bend_search`: its fit (a, b, c) and its top and bottom rows.
Piece = tuple[np.ndarray, float, float]


def _tangent(piece: Piece) -> tuple[float, float, float]:
    """Give a piece's middle row y0, its x there and its slope (px across per px along)."""
    fit, top, bottom = piece
    y0 = 0.5 * (top + bottom)
    return y0, float(poly_x(fit, y0)), float(2.0 * fit[0] * y0 + fit[1])


def _bent(piece: Piece, a: float) -> np.ndarray:
    """Bend a piece's tangent at its middle row by ``a``: give (a, b, c) of x = a*y^2 + b*y + c."""
    y0, x0, s = _tangent(piece)
    return np.array([a, s - 2.0 * a * y0, x0 - s * y0 + a * y0 * y0])


def _beyond(px: Pixels, piece: Piece) -> tuple[np.ndarray, np.ndarray]:
    """Give the set pixels above and below a piece's rows (2 px clear of them), float64."""
    _, top, bottom = piece
    y = px.y.astype(np.float64)
    out = (y < top - 2) | (y > bottom + 2)
    return px.x[out].astype(np.float64), y[out]


def _catch(x: np.ndarray, y: np.ndarray, piece: Piece, bends: np.ndarray, band: float) -> np.ndarray:
    """Count the pixels (beyond a piece) within ``band`` of its tangent bent by each of ``bends`` (ascending).

    A pixel r off the straight continuation, d rows from the tangent's row, is caught by the
    bends a with (r - band)/d^2 < a < (r + band)/d^2: a run of ``bends``, counted with a
    difference array (memory in the pixels, not pixels times bends).
    """
    y0, x0, s = _tangent(piece)
    r = x - (x0 + s * (y - y0))  # off the straight continuation
    d2 = (y - y0) ** 2  # > 0: the pixels lie 2 rows or more beyond the piece
    lo = np.searchsorted(bends, (r - band) / d2, side="right")
    hi = np.searchsorted(bends, (r + band) / d2, side="left")
    k = bends.size
    runs = np.bincount(lo, minlength=k + 1) - np.bincount(np.maximum(hi, lo), minlength=k + 1)
    return np.cumsum(runs)[:k]


def _heads_along(x: np.ndarray, y: np.ndarray, piece: Piece, a: float, cfg: SearchParams) -> bool:
    """Tell whether the paint a bend catches beyond a piece heads along the bend (or is too short to tell).

    The bend is taken out of the paint caught, and the straight line fitted to what is left must
    head as the piece's tangent does: exact for paint on the bend, wherever along it it lies.
    """
    y0, _, s = _tangent(piece)
    sel = np.abs(x - poly_x(_bent(piece, a), y)) < cfg.bend_band_px
    if sel.sum() < 2 or np.ptp(y[sel]) < _MIN_TURN_ROWS:
        return True
    ys = y[sel]
    slope = float(np.polyfit(ys, x[sel] - a * (ys - y0) ** 2, 1)[0])
    return abs(slope - s) <= cfg.bend_max_turn_px


def bend_search(binary: np.ndarray, pieces: tuple[Piece | None, Piece | None], cfg: SearchParams,
                min_pixels: int, pixels: Pixels | None = None) -> SearchResult | None:
    """Bend short pieces of line on by the curvature that finds them the most paint beyond.

    A dash near the car gives a line's place and heading, not its bend; on a tight curve the
    next dashes lie off its straight continuation by more than any band around it.  Each
    piece's tangent at its middle row is bent by each of ``cfg.bend_px`` and the set pixels
    beyond the piece within ``cfg.bend_band_px`` of it are counted; with two pieces (a lane's
    two lines share the bend) the fewer of the two counts.  The best bend is taken when it
    catches at least ``min_pixels``, more than ``cfg.bend_min_gain`` times what the straight
    continuation catches, and the paint it catches beyond each piece heads along it (within
    ``cfg.bend_max_turn_px``): a marking crossing at a slant, or specks at the view's edge, are
    not the next dash.

    Parameters
    ----------
    binary : (H, W) uint8 ndarray
        The bird's-eye binary, 0/1.
    pieces : tuple of (Piece or None)
        The left and right pieces: each its fit (a, b, c) in bird's-eye pixels and its top and
        bottom rows; None for a line not found.
    cfg : SearchParams
        Settings in pixels (``bend_px`` () turns the probe off).
    min_pixels : int
        Least paint the best bend must catch, pixels.
    pixels : Pixels, optional
        The set pixels of ``binary``, when already extracted.

    Returns
    -------
    SearchResult or None
        The pixels within ``cfg.bend_band_px`` of each bent piece (``method`` ``bend``,
        ``extra["bend_px"]`` the bend), or None when no bend is taken.

    Examples
    --------
    >>> from lanefinder.config import SearchConfig
    >>> sp = search_params(SearchConfig(), 3.7 / 150, 0.0985)
    >>> y = np.arange(300.0)
    >>> x = 125 + 0.002 * (300 - y) ** 2  # a line bending right, seen as a dash near the car and one far off
    >>> b = np.zeros((300, 400), np.uint8)
    >>> for lo, hi in ((250, 300), (90, 140)):
    ...     for row in range(lo, hi):
    ...         b[row, int(x[row]) - 2:int(x[row]) + 3] = 1
    >>> near = (np.array([0.0, -0.095, 152.3]), 250.0, 299.0)  # the dash's own straight fit
    >>> found = bend_search(b, (near, None), sp, 31)
    >>> found.method, found.left.count, round(found.extra["bend_px"], 4)
    ('bend', 500, 0.0021)
    """
    given = [p for p in pieces if p is not None]
    if not cfg.bend_px or not given:
        return None
    px = pixels or Pixels.of(binary)
    if px.x.size == 0:
        return None
    bends = np.asarray(cfg.bend_px, np.float64)
    beyond = [_beyond(px, p) for p in given]
    counts = [_catch(x, y, p, bends, cfg.bend_band_px) for (x, y), p in zip(beyond, given, strict=True)]
    caught = np.minimum(*counts) if len(counts) == 2 else counts[0]
    order = np.argsort(np.abs(bends), kind="stable")  # of equal catches, the gentlest bend
    best = int(order[np.argmax(caught[order])])
    straight = len(bends) // 2
    if best == straight or caught[best] < min_pixels or caught[best] <= cfg.bend_min_gain * caught[straight]:
        return None
    a = float(bends[best])
    if not all(_heads_along(x, y, p, a, cfg) for (x, y), p in zip(beyond, given, strict=True)):
        return None
    lines = [EMPTY if p is None else _around(px, _bent(p, a), cfg.bend_band_px) for p in pieces]
    return SearchResult(lines[0], lines[1], "bend", band_px=int(cfg.bend_band_px), extra={"bend_px": a})
