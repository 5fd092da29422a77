"""Line fits and lane geometry in metres.

Conventions (also in docs/conventions.md, and tested):

- A pixel fit is x = a*y^2 + b*y + c in bird's-eye pixels, y down, origin top-left.
- A metre fit is x = A*d^2 + B*d + C where d >= 0 is the distance ahead of the
  bird's-eye bottom row (the nearest road seen) and x is lateral, metres, positive
  to the right of the camera centre line.
- Curvature is signed, 1/m: positive when the lane bends to the right.
  ``radius_m`` is 1/|curvature|, capped at ``max_radius_m``; never negative, NaN or inf.
- ``offset_m`` is the camera centre line minus the lane centre: positive means the
  car is right of the lane centre.
- ``width_m`` is the lane width between the line centres at d = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .config import FitConfig

__all__ = [
    "FitParams",
    "LaneGeometry",
    "LineFit",
    "Scale",
    "curvature_per_m",
    "fit_lane",
    "fit_line",
    "fit_params",
    "lane_geometry",
    "lane_width_m",
    "m_to_px",
    "poly_x",
    "px_to_m",
    "radius_from_curvature",
]


@dataclass(frozen=True, eq=False)
class LineFit:
    """One fitted line.

    Attributes
    ----------
    coeffs_px : (3,) ndarray
        (a, b, c) of x = a*y^2 + b*y + c, bird's-eye pixels.
    n_pixels : int
        Pixels fitted.
    residual_px : float
        Robust RMS residual, pixels.
    span : float
        Fraction of the view's height the pixels cover.
    confidence : float
        0..1: support, span and residual together.
    top_px : float
        The farthest row of the pixels fitted (the smallest y), bird's-eye pixels (NaN: not given).
    bottom_px : float
        The nearest row of the pixels fitted (the largest y), bird's-eye pixels (NaN: not given).

    Examples
    --------
    >>> LineFit(np.zeros(3), 500, 1.2, 0.8, 0.7).confidence
    0.7
    """

    coeffs_px: np.ndarray
    n_pixels: int
    residual_px: float
    span: float
    confidence: float
    top_px: float = math.nan
    bottom_px: float = math.nan


def poly_x(coeffs: np.ndarray, y: np.ndarray | float) -> np.ndarray | float:
    """Evaluate a second-order line fit x = a*y^2 + b*y + c.

    The one place the fit polynomial is written out: pixel fits take bird's-eye rows ``y``,
    metre fits take distances ``d`` ahead.

    Parameters
    ----------
    coeffs : (3,) array_like
        (a, b, c) of a pixel fit, or (A, B, C) of a metre fit.
    y : float or ndarray
        Rows (pixels) or distances ahead (m) to evaluate at.

    Returns
    -------
    float or ndarray
        x at each ``y``, in the fit's unit (pixels or metres).

    Examples
    --------
    >>> poly_x(np.array([0.001, -0.5, 200.0]), np.array([0.0, 100.0]))
    array([200., 160.])
    """
    return (coeffs[0] * y + coeffs[1]) * y + coeffs[2]


@dataclass(frozen=True)
class Scale:
    """How bird's-eye pixels map to metres (see the module docstring and docs/conventions.md).

    Attributes
    ----------
    xm_per_px, ym_per_px : float
        Metres per pixel across and along the road.
    height_px : int
        Height of the view, pixels (its bottom row is d = 0).
    car_x_px : float
        The car's column (the road point right below the camera), pixels.

    Examples
    --------
    >>> s = Scale(xm_per_px=3.7 / 150, ym_per_px=0.1, height_px=300, car_x_px=200.0)
    >>> s.height_px * s.ym_per_px
    30.0
    """

    xm_per_px: float
    ym_per_px: float
    height_px: int
    car_x_px: float


@dataclass(frozen=True)
class FitParams:
    """Fit settings in bird's-eye pixels, from :class:`~lanefinder.config.FitConfig`.

    Attributes
    ----------
    min_pixels : int
        Fewest pixels to fit a line.
    huber_px : float
        Huber threshold, pixels.
    support_pixels : float
        Pixels for full support.
    residual_scale_px : float
        Residual at which the quality halves, pixels.
    robust_iterations : int
        Reweighting rounds.
    min_span_fraction : float
        Below this span, a straight fit.
    parallel : float
        Pull of the weaker line's shape towards the shared one.
    full_span_fraction : float
        Span for full confidence.
    max_points : int
        Subsample bound.
    band_rows : int
        Rows of a band (see ``FitConfig.band_m``).
    band_min_pixels : int
        Pixels a band needs to take part in the fit (0: all do).
    piece_min_pixels : int
        Pixels a piece (bands next to each other holding any of the line's pixels) needs in its kept
        bands to take part, unless it reaches the view's far edge (0: all do).
    short_bend_share : float
        Share of a short marking's direction read as the road bending (``FitConfig.short_bend_share``).
    short_bend_max_slope : float
        ... only for a marking within this slope (bird's-eye pixels across per pixel along).

    Examples
    --------
    >>> from lanefinder.config import FitConfig
    >>> fit_params(FitConfig(), 3.7 / 150, 0.0985).min_pixels
    31
    """

    min_pixels: int
    huber_px: float
    support_pixels: float
    residual_scale_px: float
    robust_iterations: int
    min_span_fraction: float
    parallel: float
    full_span_fraction: float
    max_points: int
    band_rows: int = 10
    band_min_pixels: int = 0
    piece_min_pixels: int = 0
    short_bend_share: float = 0.0
    short_bend_max_slope: float = 0.0


def fit_params(cfg: FitConfig, xm_per_px: float, ym_per_px: float, marking_width_m: float = 0.15) -> FitParams:
    """Turn the metre settings of a fit config into pixels for a bird's-eye scale.

    Parameters
    ----------
    cfg : FitConfig
        The settings, metres.
    xm_per_px, ym_per_px : float
        Metres per bird's-eye pixel across and along the road.
    marking_width_m : float
        Width of a marking, metres: turns marking lengths into pixel counts.

    Returns
    -------
    FitParams
        The settings in pixels.

    Examples
    --------
    >>> from lanefinder.config import FitConfig
    >>> round(fit_params(FitConfig(), 3.7 / 150, 0.0985).huber_px, 2)
    2.43
    """
    per_m = marking_width_m / (xm_per_px * ym_per_px)  # marking pixels per metre of line
    return FitParams(
        min_pixels=max(6, round(cfg.min_marking_m * per_m)),
        huber_px=cfg.huber_m / xm_per_px,
        support_pixels=cfg.full_support_m * per_m,
        residual_scale_px=cfg.residual_scale_m / xm_per_px,
        robust_iterations=cfg.robust_iterations,
        min_span_fraction=cfg.min_span_fraction,
        parallel=cfg.parallel,
        full_span_fraction=cfg.full_span_fraction,
        max_points=cfg.max_points,
        band_rows=max(1, round(cfg.band_m / ym_per_px)),
        band_min_pixels=round(cfg.band_min_marking_m * per_m),
        piece_min_pixels=round(cfg.piece_min_marking_m * per_m),
        short_bend_share=cfg.short_bend_share,
        short_bend_max_slope=math.tan(math.radians(cfg.short_bend_max_deg)) * ym_per_px / xm_per_px,
    )


def _powers(y: np.ndarray, degree: int) -> tuple[np.ndarray, float, float]:
    """Give the powers t^0..t^(2*degree) of the centred and scaled rows t = (y - y0)/ys, one row each.

    The first ``degree + 1`` rows are the fit's basis (1, t[, t^2]); all of them give the
    normal equations' moments in one product with the weights.
    """
    y0, ys = float(y.mean()), float(y.max() - y.min()) or 1.0
    powers = np.empty((2 * degree + 1, y.size))
    powers[0] = 1.0
    np.subtract(y, y0, out=powers[1])
    powers[1] /= ys
    for k in range(2, 2 * degree + 1):
        np.multiply(powers[k - 1], powers[1], out=powers[k])
    return powers, y0, ys


def _solve(powers: np.ndarray, x: np.ndarray, w: np.ndarray | None) -> np.ndarray:
    """Weighted least squares x ~ coef @ basis (basis = the first rows of ``powers``); w None is all ones.

    The normal equations come from the weighted moments of t (a Hankel matrix), solved in
    closed form (the matrices are 2x2 or 3x3); lstsq takes over when they are singular.
    """
    m = powers.shape[0] // 2 + 1
    basis = powers[:m]
    mo = (powers.sum(axis=1) if w is None else powers @ w).tolist()
    b = (basis @ (x if w is None else w * x)).tolist()
    if m == 2:
        det = mo[0] * mo[2] - mo[1] * mo[1]
        if det > 1e-12 * mo[0] * mo[2]:
            return np.array([(b[0] * mo[2] - b[1] * mo[1]) / det, (mo[0] * b[1] - mo[1] * b[0]) / det])
    else:  # Cramer's rule on the symmetric [[m0 m1 m2] [m1 m2 m3] [m2 m3 m4]]
        m0, m1, m2, m3, m4 = mo
        c00, c01, c02 = m2 * m4 - m3 * m3, m2 * m3 - m1 * m4, m1 * m3 - m2 * m2
        det = m0 * c00 + m1 * c01 + m2 * c02
        if det > 1e-12 * m0 * m2 * m4:
            c11, c12, c22 = m0 * m4 - m2 * m2, m1 * m2 - m0 * m3, m0 * m2 - m1 * m1
            return np.array([(c00 * b[0] + c01 * b[1] + c02 * b[2]) / det,
                             (c01 * b[0] + c11 * b[1] + c12 * b[2]) / det,
                             (c02 * b[0] + c12 * b[1] + c22 * b[2]) / det])
    sw = np.ones_like(x) if w is None else np.sqrt(w)
    return np.linalg.lstsq(basis.T * sw[:, None], x * sw, rcond=None)[0]


def _in_y(coef: np.ndarray, y0: float, ys: float) -> np.ndarray:
    """Give (a, b, c) of x = a*y^2 + b*y + c from the coefficients (1, t[, t^2]) in t = (y - y0)/ys."""
    r, q, p = coef if coef.size == 3 else np.r_[coef, 0.0]
    return np.array([p / ys**2, q / ys - 2 * p * y0 / ys**2, p * y0**2 / ys**2 - q * y0 / ys + r])


def _marking(x: np.ndarray, y: np.ndarray, cfg: FitParams) -> tuple[np.ndarray, np.ndarray]:
    """Keep a line's pixels in bands and pieces that hold enough paint (specks are not a marking).

    A band (``band_rows`` rows) needs ``band_min_pixels``.  A piece is a run of bands next to
    each other that hold any of the line's pixels (a dash, a stretch of solid or worn line);
    it needs ``piece_min_pixels`` in its kept bands, unless the view's far edge cuts it (its
    marking may go on beyond the view).  A lone speck ten metres from the rest would otherwise
    stretch the line's span (its confidence) and bend its fit.
    """
    if (cfg.band_min_pixels <= 0 and cfg.piece_min_pixels <= 0) or not x.size:
        return x, y
    band = np.asarray(y).astype(np.intp) // cfg.band_rows  # rows: whole pixels, >= 0
    counts = np.bincount(band)
    kept = counts >= max(1, cfg.band_min_pixels)
    if cfg.piece_min_pixels > 0:
        seen = counts > 0
        piece = np.cumsum(np.diff(seen.astype(np.int8), prepend=0) == 1) * seen  # 1, 2, ...; 0: no pixels
        paint = np.bincount(piece, weights=counts * kept)
        ok = paint >= cfg.piece_min_pixels
        if piece[0]:  # a piece the view's far edge cuts: its marking goes on beyond the view
            ok[piece[0]] = True
        kept &= ok[piece]
    keep = kept[band]
    return x[keep], y[keep]


def fit_line(x: np.ndarray, y: np.ndarray, height_px: int, cfg: FitParams) -> LineFit | None:
    """Fit a line's pixels robustly (Huber IRLS, second order).

    Pixels in bands along the road that hold too little paint (``band_min_pixels`` in
    ``band_rows``), and in pieces of the line that hold too little (``piece_min_pixels``), are
    left out first.  Pixels covering less than ``min_span_fraction`` of the height get a
    straight fit.

    Parameters
    ----------
    x, y : ndarray
        The line's pixels, bird's-eye: columns, and rows (whole pixels, >= 0).
    height_px : int
        Height of the view, pixels.
    cfg : FitParams
        Settings in pixels.

    Returns
    -------
    LineFit or None
        The fit with its confidence; None with fewer than ``min_pixels`` pixels.

    Raises
    ------
    ValueError
        When a coordinate is not finite.

    Examples
    --------
    >>> from lanefinder.config import FitConfig
    >>> y = np.repeat(np.arange(300.0), 6)  # a marking 6 px wide
    >>> x = 0.001 * (y - 300) ** 2 + 125 + np.tile(np.arange(6) - 2.5, 300)
    >>> fit = fit_line(x, y, 300, fit_params(FitConfig(), 3.7 / 150, 0.0985))
    >>> fit.coeffs_px.round(3).tolist(), round(fit.confidence, 2)
    ([0.001, -0.6, 215.0], 0.82)
    """
    if not (np.isfinite(x).all() and np.isfinite(y).all()):
        raise ValueError("fit_line needs finite pixel coordinates")
    return _fit_marking(*_marking(x, y, cfg), height_px, cfg)


def _fit_marking(x: np.ndarray, y: np.ndarray, height_px: int, cfg: FitParams) -> LineFit | None:
    """Fit the pixels :func:`_marking` kept (see :func:`fit_line`)."""
    n = int(x.size)
    if n < cfg.min_pixels:
        return None
    top_px, bottom_px = float(np.min(y)), float(np.max(y))
    if n > cfg.max_points:  # every step-th row keeps the fit and bounds the cost
        step = n // cfg.max_points + 1  # (whole rows: every step-th pixel would take some columns of each row)
        keep = np.asarray(y).astype(np.intp) % step == 0
        if keep.sum() >= cfg.min_pixels:  # (sparse rows may miss every step-th one)
            x, y = x[keep], y[keep]
        else:
            x, y = x[::step], y[::step]
    x = x.astype(np.float64)
    y = y.astype(np.float64)
    span = float(np.ptp(y)) / height_px
    degree = 2 if span >= cfg.min_span_fraction else 1
    coeffs, residual = _robust_fit(x, y, degree, cfg)
    if degree == 1 and cfg.short_bend_share > 0 and abs(coeffs[1]) <= cfg.short_bend_max_slope:
        coeffs = (1 - cfg.short_bend_share) * coeffs + cfg.short_bend_share * _bend_fit(x, y, height_px, cfg)
    support = min(1.0, n / cfg.support_pixels)
    quality = 1.0 / (1.0 + (residual / cfg.residual_scale_px) ** 2)
    confidence = min(1.0, max(0.0, math.sqrt(min(1.0, span / cfg.full_span_fraction)) * support * quality))
    return LineFit(coeffs, n, residual, span, confidence, top_px, bottom_px)


def _robust_fit(x: np.ndarray, y: np.ndarray, degree: int, cfg: FitParams) -> tuple[np.ndarray, float]:
    """Fit x = poly(y) of a degree with Huber reweighting; give (a, b, c) and the weighted RMS residual, px."""
    powers, y0, ys = _powers(y, degree)  # built once for every reweighting
    basis = powers[: degree + 1]
    w = None
    coef = _solve(powers, x, w)
    for _ in range(cfg.robust_iterations):
        r = np.abs(x - coef @ basis)
        w = np.minimum(1.0, cfg.huber_px / np.maximum(r, 1e-9))
        coef = _solve(powers, x, w)
    r = x - coef @ basis
    residual = float(np.sqrt((r * r).mean() if w is None else (w * r * r).sum() / w.sum()))
    return _in_y(coef, y0, ys), residual


def _bend_fit(x: np.ndarray, y: np.ndarray, height_px: int, cfg: FitParams) -> np.ndarray:
    """Fit a short marking as a bend that leaves the car's heading: x = a*(y - H)^2 + c, H the bottom row.

    A short piece ahead gives only its place and its direction.  Read as a straight line, all
    of its direction is the lane's heading, and extrapolated to the car the line lands off by
    the bend's sagitta on a curve; read this way, all of it is the bend.  Gives (a, b, c) in y.
    """
    (_, a, c), _ = _robust_fit(x, (y - height_px) ** 2, 1, cfg)
    return np.array([a, -2.0 * a * height_px, a * height_px**2 + c])


def fit_lane(left: tuple[np.ndarray, np.ndarray], right: tuple[np.ndarray, np.ndarray], height_px: int,
             cfg: FitParams) -> tuple[LineFit | None, LineFit | None]:
    """Fit both lines; where both exist, pull their shapes towards each other.

    Lane lines are (nearly) parallel, so the shape (a, b) of each line moves towards the
    support-weighted shared shape, by up to ``cfg.parallel`` and by the other line's share of
    the squared support; its position c is refit as the median of the residual.  A
    short dashed line then borrows the shape of a long solid one instead of extrapolating
    its own, and the solid one keeps its own.

    Parameters
    ----------
    left, right : tuple of ndarray
        Each line's pixels (x, y), bird's-eye.
    height_px : int
        Height of the view, pixels.
    cfg : FitParams
        Settings in pixels.

    Returns
    -------
    tuple of (LineFit or None)
        The left and right fits.

    Examples
    --------
    >>> from lanefinder.config import FitConfig
    >>> y, dx = np.repeat(np.arange(300.0), 6), np.tile(np.arange(6) - 2.5, 300)  # markings 6 px wide
    >>> fl, fr = fit_lane((125.0 + dx, y), (275.0 + dx, y), 300, fit_params(FitConfig(), 3.7 / 150, 0.0985))
    >>> fl.coeffs_px.round(3).tolist(), fr.coeffs_px.round(3).tolist()
    ([0.0, 0.0, 125.0], [0.0, 0.0, 275.0])
    """
    left, right = _marking(*left, cfg), _marking(*right, cfg)  # once: the fit and the re-centring take them
    fl = _fit_marking(*left, height_px, cfg)
    fr = _fit_marking(*right, height_px, cfg)
    if fl is None or fr is None or cfg.parallel == 0:
        return fl, fr
    wl, wr = fl.n_pixels * fl.span**2 * fl.confidence, fr.n_pixels * fr.span**2 * fr.confidence
    if wl + wr <= 0:
        return fl, fr
    shared = (wl * fl.coeffs_px[:2] + wr * fr.coeffs_px[:2]) / (wl + wr)
    out = []
    pull_l, pull_r = wr**2 / (wl**2 + wr**2), wl**2 / (wl**2 + wr**2)
    for fit, (x, y), pull in ((fl, left, pull_l), (fr, right, pull_r)):
        # The weaker line moves more: up to ``parallel`` of the way, in proportion to the other's support.
        lam = cfg.parallel * pull
        ab = (1 - lam) * fit.coeffs_px[:2] + lam * shared
        c = float(np.median(x - poly_x((ab[0], ab[1], 0.0), y.astype(np.float64))))  # on the pixels the fit took
        out.append(LineFit(np.array([ab[0], ab[1], c]), fit.n_pixels, fit.residual_px, fit.span, fit.confidence,
                           fit.top_px, fit.bottom_px))
    return out[0], out[1]


def px_to_m(coeffs_px: np.ndarray, s: Scale) -> np.ndarray:
    """Convert a pixel fit (a, b, c) to a metre fit (A, B, C): x_m(d), d ahead of the bottom row.

    Parameters
    ----------
    coeffs_px : (3,) ndarray
        (a, b, c) of x = a*y^2 + b*y + c, bird's-eye pixels.
    s : Scale
        The bird's-eye scale.

    Returns
    -------
    (3,) ndarray
        (A, B, C) of x = A*d^2 + B*d + C, metres, x right of the car.

    Examples
    --------
    >>> s = Scale(xm_per_px=3.7 / 150, ym_per_px=0.1, height_px=300, car_x_px=200.0)
    >>> px_to_m(np.array([0.0, 0.0, 125.0]), s).round(3).tolist()
    [0.0, -0.0, -1.85]
    """
    a, b, c = coeffs_px
    h, xm, ym = s.height_px, s.xm_per_px, s.ym_per_px
    return np.array([xm * a / ym**2, -xm * (2 * a * h + b) / ym, xm * (a * h * h + b * h + c - s.car_x_px)])


def m_to_px(coeffs_m: np.ndarray, s: Scale) -> np.ndarray:
    """Convert a metre fit (A, B, C) back to a pixel fit (a, b, c); the inverse of :func:`px_to_m`.

    Parameters
    ----------
    coeffs_m : (3,) ndarray
        (A, B, C) of x = A*d^2 + B*d + C, metres.
    s : Scale
        The bird's-eye scale.

    Returns
    -------
    (3,) ndarray
        (a, b, c), bird's-eye pixels.

    Examples
    --------
    >>> s = Scale(xm_per_px=3.7 / 150, ym_per_px=0.1, height_px=300, car_x_px=200.0)
    >>> m_to_px(np.array([0.0, 0.0, -1.85]), s).round(3).tolist()
    [0.0, 0.0, 125.0]
    """
    big_a, big_b, big_c = coeffs_m
    h, xm, ym = s.height_px, s.xm_per_px, s.ym_per_px
    a = big_a * ym**2 / xm
    b = (-2 * big_a * ym**2 * h - big_b * ym) / xm
    c = (big_a * ym**2 * h * h + big_b * ym * h + big_c) / xm + s.car_x_px
    return np.array([a, b, c])


def curvature_per_m(coeffs_m: np.ndarray, d_m: float = 0.0) -> float:
    """Compute the signed curvature of a metre fit: positive bends right.

    Parameters
    ----------
    coeffs_m : (3,) ndarray
        (A, B, C), metres.
    d_m : float
        Distance ahead of the bird's-eye bottom row, metres.

    Returns
    -------
    float
        Curvature at ``d_m``, 1/m.

    Examples
    --------
    >>> curvature_per_m(np.array([5e-4, 0.0, 0.0]))
    0.001
    """
    big_a, big_b, _ = coeffs_m
    slope = 2 * big_a * d_m + big_b
    return float(2 * big_a / (1 + slope * slope) ** 1.5)


def radius_from_curvature(k: float, max_radius_m: float) -> float:
    """Turn a curvature into a radius, capped (a straight road gives the cap).

    Parameters
    ----------
    k : float
        Curvature, 1/m (any sign; NaN and inf give the cap).
    max_radius_m : float
        The cap, metres.

    Returns
    -------
    float
        1/|k|, metres; never negative, NaN or inf.

    Examples
    --------
    >>> radius_from_curvature(-0.002, 10000.0), radius_from_curvature(0.0, 10000.0)
    (500.0, 10000.0)
    """
    if not math.isfinite(k) or abs(k) < 1.0 / max_radius_m:
        return float(max_radius_m)
    return float(1.0 / abs(k))


def lane_width_m(left_m: np.ndarray, right_m: np.ndarray) -> float:
    """Measure the lane width at the car, across the lane: the x gap times the cosine of its heading.

    Parameters
    ----------
    left_m, right_m : (3,) ndarray
        Metre fits of the lines.

    Returns
    -------
    float
        Width, metres.

    Examples
    --------
    >>> lane_width_m(np.array([0.0, 0.0, -1.8]), np.array([0.0, 0.0, 1.9]))
    3.7
    """
    slope = (float(left_m[1]) + float(right_m[1])) / 2
    return float((right_m[2] - left_m[2]) / math.hypot(1.0, slope))


@dataclass(frozen=True)
class LaneGeometry:
    """Lane numbers at the car (the bird's-eye bottom row); see the module docstring.

    Attributes
    ----------
    curvature_per_m : float
        Signed curvature of the lane centre, 1/m.
    radius_m : float
        Radius, metres (capped).
    offset_m : float
        Camera centre line minus lane centre, metres.
    width_m : float
        Lane width, metres.
    straight : bool
        Radius above ``straight_radius_m``.

    Examples
    --------
    >>> from lanefinder.config import FitConfig
    >>> lane_geometry(np.array([0, 0, -1.8]), np.array([0, 0, 1.9]), FitConfig()).straight
    True
    """

    curvature_per_m: float
    radius_m: float
    offset_m: float
    width_m: float
    straight: bool


def lane_geometry(left_m: np.ndarray, right_m: np.ndarray, cfg: FitConfig) -> LaneGeometry:
    """Compute the curvature, radius, offset and width of the lane between two metre fits.

    Parameters
    ----------
    left_m, right_m : (3,) ndarray
        Metre fits of the lines.
    cfg : FitConfig
        ``max_radius_m`` and ``straight_radius_m``.

    Returns
    -------
    LaneGeometry
        The lane numbers at the car.

    Examples
    --------
    >>> from lanefinder.config import FitConfig
    >>> g = lane_geometry(np.array([0, 0, -1.8]), np.array([0, 0, 1.9]), FitConfig())
    >>> round(g.offset_m, 2), round(g.width_m, 2), g.radius_m
    (-0.05, 3.7, 10000.0)
    """
    centre = (np.asarray(left_m) + np.asarray(right_m)) / 2
    k = curvature_per_m(centre)
    radius = radius_from_curvature(k, cfg.max_radius_m)
    return LaneGeometry(
        curvature_per_m=k,
        radius_m=radius,
        offset_m=float(-centre[2]),
        width_m=lane_width_m(left_m, right_m),
        straight=radius >= cfg.straight_radius_m,
    )
