"""The far field: each line followed beyond the bird's-eye view, as far as its marking is seen.

The bird's-eye view ends about 35 m ahead (the default set-up), while markings stay visible to
70-100 m at 720p.  The far view continues the bird's-eye plane beyond its top edge, with the
same columns (so the same x, the same metres per pixel across and the same threshold) and one
row per row of the frame (so it holds what the camera resolves, no more): about 30 rows at 720p.
One remap takes the raw frame to it.  It ends where the frame no longer resolves a marking (a
metre across the road under ``far.min_px_per_m`` frame pixels: about 62 m ahead at 640x360).

Each shown line is then followed from the top of the near view outwards: its fit, extended,
predicts the marking's column row by row; the marking pixels found in a window around the
prediction (the window widens with distance) correct it as the search goes; gaps up to
``far.max_gap_m`` (several dash periods: a far dash spans a row or two and is often missed)
are crossed.  A correction c1*s + c2*s^2 (s: bird's-eye pixels beyond the top edge, so it is
zero and smooth where the near fit ends) is fitted to what was found, together with one row
taken as found on the near fit's extension ``far.anchor_m`` beyond the top edge (so a stray
pixel in the first far rows, where a small offset is a steep slope, does not steer the search
off the line), and the line's far part is the near fit plus that correction, as far as the
farthest marking found.  A far part whose rows scatter about that curve by more than
``far.max_scatter_m`` is texture, not paint, and is dropped, unless enough of them lie that
close to a cubic, which takes most of the scatter away: a bend that changes along the road.
The near fit, and so the lane numbers at the car, are not changed.
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass

import cv2
import numpy as np

from .birdseye import BirdsEye
from .config import FarConfig
from .geometry import poly_x

__all__ = ["FarLine", "FarView", "far_rows", "follow_line", "make_farview", "row_confidence"]


@dataclass(frozen=True, eq=False)
class FarView:
    """The road beyond the bird's-eye view: its columns, one row per frame row.

    Attributes
    ----------
    v_px : (K,) float ndarray
        Bird's-eye y of each row (negative: beyond the top edge), farthest first.
    d_m : (K,) float ndarray
        Distance of each row ahead of the bird's-eye bottom row, m.
    map1, map2 : ndarray
        Where each far-view pixel is in the raw frame: ``cv2.remap``'s fixed-point tables
        ((K, width, 2) int16 and (K, width) uint16), from which a strip's tables are cut.
    width : int
        Columns: ``far.width_factor`` times the bird's-eye view's width, centred on it (lines
        that curve away leave the near view's width far ahead).
    u0_px : float
        Bird's-eye x of the first column.

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> from lanefinder.config import FarConfig
    >>> fv = make_farview(LaneFinder().birdseye((1280, 720)), FarConfig())
    >>> fv.width, fv.u0_px, len(fv.v_px), round(float(fv.d_m[-1]), 1), round(float(fv.d_m[0]), 1)
    (2400, -1000.0, 27, 30.4, 95.8)
    """

    v_px: np.ndarray
    d_m: np.ndarray
    map1: np.ndarray
    map2: np.ndarray
    width: int
    u0_px: float

    def warp(self, frame: np.ndarray) -> np.ndarray:
        """Map a raw frame to the far view, in one remap.

        Parameters
        ----------
        frame : (H, W, 3) uint8 ndarray
            A raw frame of the set-up's size.

        Returns
        -------
        (K, width, 3) uint8 ndarray
            The far view, farthest row first.
        """
        return cv2.remap(frame, self.map1, self.map2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

    def strip(self, frame: np.ndarray, centre_px: np.ndarray, half_px: int) -> tuple[np.ndarray, np.ndarray]:
        """Map strips of the far view around lines to one image, in one small remap.

        Parameters
        ----------
        frame : (H, W, 3) uint8 ndarray
            A raw frame of the set-up's size.
        centre_px : (K,) or (L, K) ndarray
            The strip's centre in each far row, far-view columns; one row of centres per line.
        half_px : int
            Half its width, columns.

        Returns
        -------
        image : (L * K, 2 * half_px + 1, 3) uint8 ndarray
            The strips (shifted inwards where they would leave the far view), one below the
            other (L = 1 for one line's centres).
        col0 : ndarray, the shape of ``centre_px``
            The far-view column of each row's first pixel.

        Examples
        --------
        >>> from lanefinder import LaneFinder
        >>> from lanefinder.config import FarConfig
        >>> fv = make_farview(LaneFinder().birdseye((1280, 720)), FarConfig())
        >>> centres = np.array([np.full(len(fv.v_px), 1100.0), np.full(len(fv.v_px), 1250.0)])
        >>> image, col0 = fv.strip(np.zeros((720, 1280, 3), np.uint8), centres, 60)
        >>> image.shape, col0.shape, int(col0[1, 0])
        ((54, 121, 3), (2, 27), 1190)
        """
        centre = np.asarray(centre_px, np.float64)
        n = min(2 * half_px + 1, self.width)
        col0 = np.clip(np.round(centre).astype(np.intp) - half_px, 0, self.width - n)
        # Each row's strip is a run of the flattened tables: one gather for every line's rows.
        first = (np.arange(centre.shape[-1]) * self.width + col0).reshape(-1, 1)
        idx = first + np.arange(n)
        map1 = np.take(self.map1.reshape(-1, 2), idx, axis=0)  # (take: a tenth of fancy indexing's cost here)
        image = cv2.remap(frame, map1, np.take(self.map2.reshape(-1), idx), cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_REPLICATE)
        return image, col0


def make_farview(be: BirdsEye, cfg: FarConfig) -> FarView | None:
    """Build the far view of a bird's-eye set-up.

    Parameters
    ----------
    be : BirdsEye
        The near set-up.
    cfg : FarConfig
        ``max_range_m`` bounds how far ahead the rows go (from the bird's-eye bottom row), and
        ``min_px_per_m`` how coarse the frame may be there.

    Returns
    -------
    FarView or None
        None when the frame shows nothing beyond the near view (its top edge is at the
        horizon, or ``far.enabled`` is off).

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> from lanefinder.config import FarConfig
    >>> fv = make_farview(LaneFinder().birdseye((1280, 720)), FarConfig())
    >>> bool(np.all(np.diff(fv.d_m) < 0))  # farthest row first
    True
    """
    if not cfg.enabled:
        return None
    w, h = be.size
    d_top = h * be.ym_per_px
    if cfg.max_range_m <= d_top:
        return None
    v_min = h - cfg.max_range_m / be.ym_per_px
    v = np.linspace(0.0, v_min, 4000)
    # Where the view's middle column meets each row of the (undistorted) frame.
    und = be.to_undistorted(np.column_stack([np.full_like(v, w / 2), v]))
    y = und[:, 1]
    ok = np.isfinite(y) & np.logical_and.accumulate(np.concatenate([[True], np.diff(y) < 0]))
    ok &= (y >= 0) & (y < be.frame_size[1])
    if ok.sum() < 2:
        return None
    v, y = v[ok], y[ok]
    # One far row per frame row: rows at whole-pixel steps up from the near view's top edge.
    steps = np.arange(1, int(y[0] - y[-1]) + 1)
    if steps.size < 2:
        return None
    v_rows = np.interp(y[0] - steps, y[::-1], v[::-1])[::-1]  # farthest first
    if cfg.min_px_per_m > 0:
        # Only as far as the frame resolves a marking: a metre across the road spans at least
        # min_px_per_m frame pixels (a 0.15 m line 1.5 px at 10).
        across = be.to_frame(np.column_stack([np.tile([w / 2, w / 2 + 1.0 / be.xm_per_px], v_rows.size),
                                              np.repeat(v_rows, 2)]))
        px_per_m = np.hypot(*(across[1::2] - across[::2]).T)
        v_rows = v_rows[px_per_m >= cfg.min_px_per_m]
        if v_rows.size < 2:
            return None
    width = round(w * cfg.width_factor)
    u0 = (w - width) / 2
    cols = u0 + np.arange(width, dtype=np.float64)
    grid_u, grid_v = np.meshgrid(cols, v_rows)
    frame_pts = be.to_frame(np.column_stack([grid_u.ravel(), grid_v.ravel()]))
    map_x = frame_pts[:, 0].reshape(grid_u.shape).astype(np.float32)
    map_y = frame_pts[:, 1].reshape(grid_u.shape).astype(np.float32)
    map1, map2 = cv2.convertMaps(map_x, map_y, cv2.CV_16SC2)
    return FarView(v_rows, (h - v_rows) * be.ym_per_px, map1, map2, width, float(u0))


@dataclass(frozen=True, eq=False)
class FarLine:
    """A line's far part: where its marking was followed beyond the near view.

    Attributes
    ----------
    fit_px : (3,) ndarray
        (a, b, c) of x = a*y^2 + b*y + c in bird's-eye pixels, for y from ``end_px`` to 0.
    end_px : float
        Bird's-eye y of the farthest marking found (negative).
    range_m : float
        Its distance ahead of the bird's-eye bottom row, m.
    n_rows : int
        Far rows where marking pixels were found.
    support : float
        Share of the far rows searched, up to ``end_px``, that held marking pixels.

    Examples
    --------
    >>> far = FarLine(fit_px=np.array([0.0, 0.0, 125.0]), end_px=-400.0, range_m=70.0, n_rows=9, support=0.6)
    >>> far.range_m
    70.0
    """

    fit_px: np.ndarray
    end_px: float
    range_m: float
    n_rows: int
    support: float


def follow_line(far_binary: np.ndarray, fv: FarView, fit_px: np.ndarray, xm_per_px: float,
                cfg: FarConfig, col0: np.ndarray | None = None) -> FarLine | None:
    """Follow a line's marking through the far view, starting from its near fit.

    Parameters
    ----------
    far_binary : (K, width) uint8 ndarray
        Marking pixels of the far view, 0/1.
    fv : FarView
        The far view.
    fit_px : (3,) ndarray
        The line's near fit, bird's-eye pixels.
    xm_per_px : float
        Metres per bird's-eye pixel across the road.
    cfg : FarConfig
        The search window, its growth, the gap allowed, the rows needed, the anchor
        (``anchor_m``) and the scatter allowed (``max_scatter_m``).
    col0 : (K,) int ndarray, optional
        When ``far_binary`` is a strip (:meth:`FarView.strip`): the far-view column of each
        row's first pixel; default 0 (the whole far view).

    Returns
    -------
    FarLine or None
        None when fewer than ``cfg.min_rows`` rows hold the marking, or when the rows found
        scatter about their curve by more than ``cfg.max_scatter_m`` (median) and do not lie
        on a cubic either (:data:`SMOOTH_MIN_ROWS`): texture.  A far part kept for its cubic
        is still the near fit plus the parabola correction (it strays from the marking far
        ahead: 0.5 m at 96 m on a bend that leaves the extension by 7 m).

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> from lanefinder.config import FarConfig
    >>> fv = make_farview(LaneFinder().birdseye((1280, 720)), FarConfig())
    >>> binary = np.zeros((len(fv.v_px), fv.width), np.uint8)
    >>> for k, v in enumerate(fv.v_px):  # a marking that drifts right beyond the view
    ...     col = round(125 - 0.02 * v - fv.u0_px)
    ...     binary[k, col - 1:col + 2] = 1
    >>> far = follow_line(binary, fv, np.array([0.0, 0.0, 125.0]), 0.0247, FarConfig())
    >>> far.n_rows, round(far.range_m), round(float(poly_x(far.fit_px, far.end_px)))
    (27, 96, 138)
    """
    k_rows, width = far_binary.shape
    offsets = [0] * k_rows if col0 is None else np.asarray(col0).tolist()
    # Running sums along each row: a window's pixel count and mean column in O(1).
    b = far_binary.astype(np.int32)
    count = np.zeros((k_rows, width + 1), np.int64)
    np.cumsum(b, axis=1, out=count[:, 1:])
    colsum = np.zeros((k_rows, width + 1), np.int64)
    np.cumsum(b * np.arange(width), axis=1, out=colsum[:, 1:])

    d_top = float(fv.d_m[-1] - (fv.d_m[-2] - fv.d_m[-1]))  # the near view's top edge
    u_fit = poly_x(fit_px, fv.v_px) - fv.u0_px  # in far-view columns
    s = -fv.v_px  # bird's-eye pixels beyond the top edge
    found_s, found_r, last_d = [], [], d_top
    ym_per_px = abs((fv.d_m[0] - fv.d_m[-1]) / (fv.v_px[0] - fv.v_px[-1]))
    anchor_s = cfg.anchor_m / ym_per_px  # the near fit's extension is taken as found there
    sums = _Sums(anchor_s)
    searched = 0
    d_rows, s_rows, u_rows = fv.d_m.tolist(), s.tolist(), u_fit.tolist()
    count_at, colsum_at = count.item, colsum.item  # (Python ints: the loop's indexing stays cheap)
    max_gap_m, window_m, growth = cfg.max_gap_m, cfg.window_m, cfg.window_growth
    for k in range(k_rows - 1, -1, -1):  # nearest row first
        d = d_rows[k]
        if d - last_d > max_gap_m:
            break
        predicted = u_rows[k] + sums.correction(s_rows[k])
        half = (window_m + growth * (d - d_top)) / xm_per_px
        lo, hi = math.floor(predicted - half), math.ceil(predicted + half) + 1
        if lo < 0 or hi > fv.width or lo < offsets[k] or hi > offsets[k] + width:
            break  # the line leaves the view (or its strip)
        searched += 1
        a_, b_ = lo - offsets[k], hi - offsets[k]
        n = count_at(k, b_) - count_at(k, a_)
        if n:
            r = offsets[k] + (colsum_at(k, b_) - colsum_at(k, a_)) / n - u_rows[k]
            found_s.append(s_rows[k])
            found_r.append(r)
            sums.add(s_rows[k], r)
            last_d = d
    if len(found_s) < cfg.min_rows:
        return None
    c1, c2, residuals = _fit_correction(found_s, found_r, anchor_s)
    scatter_px = statistics.median(residuals)
    if cfg.max_scatter_m > 0 and scatter_px * xm_per_px > cfg.max_scatter_m and \
            not _smooth_bend(found_s, found_r, anchor_s, scatter_px, cfg.max_scatter_m / xm_per_px):
        return None
    a, b, c = (float(v) for v in fit_px)
    far_fit = np.array([a + c2, b - c1, c])  # x(v) + c1*s + c2*s^2 with s = -v (bird's-eye x)
    end_s = max(found_s)
    rows_to_end = int(np.sum(s <= end_s))
    return FarLine(fit_px=far_fit, end_px=-end_s, range_m=float(fv.d_m[k_rows - rows_to_end]),
                   n_rows=len(found_s), support=len(found_s) / max(1, min(searched, rows_to_end)))


class _Sums:
    """Running sums for the least-squares correction r = c1*s + c2*s^2 while the search goes.

    They start with the anchor: a row with r = 0 at ``anchor_s`` (see :func:`follow_line`).
    """

    def __init__(self, anchor_s: float = 0.0) -> None:
        self.n = 0
        self.s_max = 0.0
        self.rs = self.rs2 = 0.0
        # The anchor: a row found on the near fit's extension (r = 0) at s = anchor_s.
        self.s2, self.s3, self.s4 = anchor_s ** 2, anchor_s ** 3, anchor_s ** 4

    def add(self, s: float, r: float) -> None:
        s2 = s * s
        self.n += 1
        self.s_max = max(self.s_max, s)
        self.s2 += s2
        self.s3 += s2 * s
        self.s4 += s2 * s2
        self.rs += r * s
        self.rs2 += r * s2

    def correction(self, s: float) -> float:
        """Give the residual expected at ``s`` from the rows found so far.

        A parabola extrapolated far beyond the points it was fitted on swings wildly, so the
        bend c2 is used only once the rows found reach half as far as ``s``; before, c1 alone.
        """
        if self.n == 0 or self.s2 <= 0:
            return 0.0
        det = self.s2 * self.s4 - self.s3 * self.s3
        if self.n < 3 or self.s_max < 0.5 * s or det <= 1e-9 * self.s2 * self.s4:
            return self.rs / self.s2 * s
        c1 = (self.rs * self.s4 - self.rs2 * self.s3) / det
        c2 = (self.s2 * self.rs2 - self.s3 * self.rs) / det
        return c1 * s + c2 * s * s


def _fit_correction(s: list[float], r: list[float], anchor_s: float = 0.0) -> tuple[float, float, list[float]]:
    """Least squares r = c1*s + c2*s^2, once more without the points off by over 3 MADs.

    A row at ``anchor_s`` with r = 0 is always part of the fit (0: none).  Returns c1, c2 and
    every point's distance from that curve (the points left out too).

    In plain floats: a line's far part has a few dozen points at most.
    """
    keep = list(range(len(s)))
    c1 = c2 = 0.0
    res = [abs(ri) for ri in r]
    for _ in range(2):
        if len(keep) < 2:
            break
        a11, a12, a22 = anchor_s ** 2, anchor_s ** 3, anchor_s ** 4  # the anchor row (r = 0)
        b1 = b2 = 0.0
        for i in keep:
            si, ri = s[i], r[i]
            s2 = si * si
            a11 += s2
            a12 += s2 * si
            a22 += s2 * s2
            b1 += ri * si
            b2 += ri * s2
        det = a11 * a22 - a12 * a12
        if det > 1e-9 * a11 * a22:
            c1, c2 = (b1 * a22 - b2 * a12) / det, (a11 * b2 - a12 * b1) / det
        else:
            c1, c2 = b1 / a11, 0.0
        res = [abs(c1 * si + c2 * si * si - ri) for si, ri in zip(s, r, strict=True)]
        limit = 3 * (statistics.median(res[i] for i in keep) + 0.5)
        keep = [i for i, e in enumerate(res) if e <= limit]
    return c1, c2, res


#: A far part that scatters about its parabola more than ``far.max_scatter_m`` is still a marking
#: (a bend that tightens or opens along the road) when, over at least SMOOTH_MIN_ROWS rows, a cubic
#: fits its rows within that limit and takes at least SMOOTH_SHARE of the scatter away.  Texture
#: scatters about any smooth curve: one more degree takes a little of it away, and over a few rows
#: a cubic fits anything.  (Random texture in the search window, 300 draws: kept 4% / 43% / 42% over
#: 27 / 6 / 4 rows with the parabola alone, 11% / 65% / 57% with a cubic and no such conditions,
#: 6% / 43% / 42% with them.)
SMOOTH_MIN_ROWS = 8
SMOOTH_SHARE = 0.5


def _smooth_bend(s: list[float], r: list[float], anchor_s: float, scatter_px: float, limit_px: float) -> bool:
    """Tell whether a far part's rows lie on a cubic (see :data:`SMOOTH_MIN_ROWS`): a changing bend, not texture."""
    if len(s) < SMOOTH_MIN_ROWS:
        return False
    cubic_px = float(np.median(_smooth_residuals(s, r, anchor_s)))
    return cubic_px <= limit_px and cubic_px <= (1 - SMOOTH_SHARE) * scatter_px


def _smooth_residuals(s: list[float], r: list[float], anchor_s: float) -> np.ndarray:
    """Give each point's distance from the least-squares r = c1*s + c2*s^2 + c3*s^3 (with the anchor row).

    A marking on a road whose bend changes along the view (a cubic, as seen from the near
    fit) is smooth but strays from the correction's parabola far ahead; texture scatters about
    any smooth curve.  (One more degree of freedom than the correction; a plain least-squares fit
    over every row, where the correction leaves rows over 3 MADs out.)
    """
    if not s:
        return np.empty(0)
    sa = np.asarray([*s, anchor_s], np.float64) if anchor_s > 0 else np.asarray(s, np.float64)
    ra = np.asarray([*r, 0.0], np.float64) if anchor_s > 0 else np.asarray(r, np.float64)
    t = sa / (float(sa.max()) or 1.0)
    basis = np.column_stack([t, t * t, t * t * t])
    coef = np.linalg.lstsq(basis, ra, rcond=None)[0]
    return np.abs(basis @ coef - ra)[: len(s)]


def far_rows(end_px: float, n: int) -> np.ndarray:
    """Give bird's-eye rows along a line's far part: from its end to half a pixel beyond the top edge.

    The steps are geometric, so they are dense far ahead, where the frame's rows are far apart
    on the road.

    Parameters
    ----------
    end_px : float
        Bird's-eye y of the far part's end (negative: beyond the view's top edge).
    n : int
        Rows.

    Returns
    -------
    (n,) ndarray
        Bird's-eye y, from ``end_px`` to -0.5.

    Examples
    --------
    >>> far_rows(-50.0, 3).round(2).tolist()
    [-50.0, -5.0, -0.5]
    """
    return end_px * np.exp(np.linspace(0.0, 1.0, n) * math.log(0.5 / -end_px))


def row_confidence(confidence: float, d_m: float, d_top_m: float, decay_m: float) -> float:
    """Give a line's confidence at a distance: as measured up to the view's top, then falling.

    Parameters
    ----------
    confidence : float
        The line's confidence, 0..1.
    d_m : float
        Distance ahead of the bird's-eye bottom row, m.
    d_top_m : float
        The near view's far end, m.
    decay_m : float
        Beyond it, the confidence falls by e every ``decay_m`` metres.

    Returns
    -------
    float
        0..1.

    Examples
    --------
    >>> round(row_confidence(0.9, 70.0, 30.0, 40.0), 3)
    0.331
    """
    return float(confidence * math.exp(-max(0.0, d_m - d_top_m) / decay_m))
