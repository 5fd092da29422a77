"""Measuring a frame's lines: the search-retry policy, the fits and the checks made before tracking.

:func:`measure` is the one function the pipeline calls between the threshold and the tracker:

0. Where glare blows out rows of the view, a line's full span (its confidence) is that of the
   rows left (``MIN_FULL_SPAN_FRACTION``).
1. Search: around the tracked lane, or blind (histogram and windows) when the track needs it.
2. A line that comes out weak around the track is searched for blind in the same frame; per
   line, the more confident search wins.
3. Still weak: lines that cross the view at an angle (:func:`~lanefinder.search.heading_search`);
   that pair is taken only when both its lines are confident and together more confident, and,
   without a track to hold it to, when it passes the lane checks.
4. A blind pair whose lines' shapes disagree (a faint line lost by its windows in a tight bend):
   the weaker line is searched again along the stronger one's shape, and taken when the pair
   then passes the lane checks.
5. Every line found too short for a curve (under ``fit.min_span_fraction`` of the view: a dash
   near the car each, the next ones off their straight continuation on a tight curve): the
   pieces are bent on by the curvature that finds them the most paint
   (:func:`~lanefinder.search.bend_search`), and those lines are taken when neither is less
   confident and (with both) the pair passes the lane checks.
6. Frame checks (:mod:`lanefinder.checks`): a yellow line only on its allowed side
   (``tracking.yellow_line_side``), and no solid marking down the middle of the lane.
7. A blind search whose lane straddles a solid marking (in its middle half: refused by that
   last check; or nearer its lines, within ``search.inner_retry_span`` of its width from its
   centre): a bright verge or a kerb taken for a line, the true line inside the lane.  The
   search is made again preferring the markings nearest the car
   (``search.inner_retry_preference``), and that lane is taken when it has both lines and
   passes the checks (its search's method then ends in ``+inner``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .checks import check_line_inside, is_yellow, pair_problems, yellow_side
from .config import Config
from .geometry import FitParams, LineFit, Scale, fit_lane, fit_params, m_to_px, poly_x, px_to_m
from .lane import Line
from .search import (
    Pixels,
    SearchParams,
    SearchResult,
    bend_search,
    blind_search,
    heading_search,
    search_around,
    search_params,
)
from .threshold import blown_out_rows
from .tracking import Rules, Track, implied_lane

__all__ = ["Measured", "Measurer", "measure"]

Fits = tuple[LineFit | None, LineFit | None]


@dataclass(frozen=True)
class Measurer:
    """Everything :func:`measure` needs for one bird's-eye set-up, in pixels.

    Attributes
    ----------
    config : Config
        The configuration (``search`` and ``threshold.ridge.yellow_min`` are read here; the
        tracking settings from ``rules.cfg``, whose parallel limit depends on the set-up:
        :meth:`build`).
    search : SearchParams
        Search settings in bird's-eye pixels.
    fit : FitParams
        Fit settings in bird's-eye pixels.
    rules : Rules
        The tracker's rules (its lane checks gate the angled search's pair).

    Examples
    --------
    >>> from lanefinder.config import Config
    >>> from lanefinder.geometry import Scale
    >>> m = Measurer.build(Config(), Scale(3.7 / 150, 0.0985, 300, 200.0))
    >>> round(m.search.margin_px, 1), m.rules.lookahead_m
    (24.3, 29.55)
    """

    config: Config
    search: SearchParams
    fit: FitParams
    rules: Rules

    @property
    def scale(self) -> Scale:
        """The bird's-eye scale."""
        return self.rules.scale

    @classmethod
    def build(cls, config: Config, scale: Scale) -> Measurer:
        """Turn a configuration's metre settings into pixels for a bird's-eye scale.

        With a set-up of the config's own (``birdseye`` not the default) the lane checks allow
        ``tracking.max_parallel_diff_own_setup_m`` for the parallel check (``rules.cfg`` holds it
        as ``max_parallel_diff_m``, whatever ``tracking.max_parallel_diff_m`` says); otherwise
        ``tracking.max_parallel_diff_m``.

        Parameters
        ----------
        config : Config
            The configuration.
        scale : Scale
            The bird's-eye scale.

        Returns
        -------
        Measurer
            The settings for that scale.
        """
        sp = search_params(config.search, scale.xm_per_px, scale.ym_per_px)
        fp = fit_params(config.fit, scale.xm_per_px, scale.ym_per_px, config.search.marking_width_m)
        tracking = config.tracking
        if config.has_own_setup():  # the camera's own set-up: a lane parting ahead is the road's
            tracking = tracking.model_copy(update={"max_parallel_diff_m": tracking.max_parallel_diff_own_setup_m})
        rules = Rules(tracking, scale.height_px * scale.ym_per_px, config.search.lane_width_m, scale)
        return cls(config, sp, fp, rules)


@dataclass(frozen=True, eq=False)
class Measured:
    """One frame's measurements, ready for the tracker.

    Attributes
    ----------
    lines : tuple of (Line or None)
        The measured left and right lines (``found`` True, fit in pixels and metres, confidence,
        pixel count, range), None where no line was measured or a frame check dropped it.
    search : SearchResult
        The search whose pixels were fitted.
    blind : bool
        The frame was searched without a prior.
    reasons : tuple of str
        The frame checks that dropped or moved a line.

    Examples
    --------
    >>> from lanefinder.config import Config
    >>> from lanefinder.geometry import Scale
    >>> from lanefinder.tracking import Track
    >>> m = Measurer.build(Config(), Scale(3.7 / 150, 0.0985, 300, 200.0))
    >>> b = np.zeros((300, 400), np.uint8); b[:, 122:128] = 1; b[:, 272:278] = 1
    >>> out = measure(b, None, Track(), m)
    >>> out.blind, [round(float(line.fit_m[2]), 2) for line in out.lines]
    (True, [-1.86, 1.84])
    """

    lines: tuple[Line | None, Line | None]
    search: SearchResult
    blind: bool
    reasons: tuple[str, ...] = ()


def _conf(fit: LineFit | None) -> float:
    return -1.0 if fit is None else fit.confidence


def _weak(fits: Fits, m: Measurer) -> bool:
    return any(f is None or f.confidence < m.rules.cfg.min_confidence for f in fits)


def _fit(found: SearchResult, m: Measurer) -> Fits:
    """Robust fits of a search's left and right line pixels."""
    return fit_lane((found.left.x, found.left.y), (found.right.x, found.right.y), m.scale.height_px, m.fit)


def _keep_better(found: SearchResult, fits: Fits, again: SearchResult, m: Measurer) -> tuple[SearchResult, Fits]:
    """Per line, the more confident of two searches' fits (and the search result to match)."""
    again_fits = _fit(again, m)
    use_l, use_r = _conf(again_fits[0]) > _conf(fits[0]), _conf(again_fits[1]) > _conf(fits[1])
    if not (use_l or use_r):
        return found, fits
    if use_l and use_r:
        return again, again_fits
    merged = SearchResult(again.left if use_l else found.left, again.right if use_r else found.right,
                          f"{found.method}+{again.method}", again.histogram, again.bases_px, found.band_px,
                          {**found.extra, **again.extra})
    return merged, _fit(merged, m)


def find_lines(binary: np.ndarray, pixels: Pixels, track: Track, m: Measurer) -> tuple[SearchResult, Fits, bool]:
    """Search and fit with the retry policy (steps 1-5 of the module docstring)."""
    sp, scale, cfg = m.search, m.scale, m.rules.cfg
    blind = track.needs_blind_search(cfg)
    if blind:
        found = blind_search(binary, sp, scale.car_x_px, pixels)
    else:
        left, right = (m_to_px(f, scale) for f in track.fits_m)  # type: ignore[arg-type]
        found = search_around(binary, left, right, sp.around_margin_px, pixels)
    fits = _fit(found, m)
    if not blind and _weak(fits, m):
        found, fits = _keep_better(found, fits, blind_search(binary, sp, scale.car_x_px, pixels), m)
    if sp.shears_px and _weak(fits, m):
        slant = heading_search(binary, sp, scale.car_x_px, pixels)
        slant_fits = _fit(slant, m)
        c_new = _conf(slant_fits[0]) + _conf(slant_fits[1])
        c_old = max(_conf(fits[0]), 0.0) + max(_conf(fits[1]), 0.0)
        take = not _weak(slant_fits, m) and c_new > c_old
        if take and blind:
            take = not _pair_problems(slant_fits, track, m)
        if take:
            found, fits = slant, slant_fits
    if blind and fits[0] is not None and fits[1] is not None:
        found, fits = _along_partner(binary, pixels, found, fits, track, m)
    if m.search.bend_px:
        found, fits = _along_bend(binary, pixels, found, fits, track, m)
    return found, fits, blind


def _along_bend(binary: np.ndarray, pixels: Pixels, found: SearchResult, fits: Fits, track: Track,
                m: Measurer) -> tuple[SearchResult, Fits]:
    """Step 5: lines all too short for a curve, bent on by :func:`~lanefinder.search.bend_search`.

    Taken when every line found before is found again no less confident and, with both, the pair
    passes every lane check (a lone line is held to the tracker's checks alone).
    """
    given = [f for f in fits if f is not None]
    if not given or any(f.span >= m.fit.min_span_fraction for f in given):
        return found, fits
    pieces = tuple(None if f is None else (f.coeffs_px, f.top_px, f.bottom_px) for f in fits)
    again = bend_search(binary, pieces, m.search, m.fit.min_pixels, pixels)  # type: ignore[arg-type]
    if again is None:
        return found, fits
    new = _fit(again, m)
    if any(old is not None and _conf(fit) < old.confidence for old, fit in zip(fits, new, strict=True)):
        return found, fits
    if new[0] is not None and new[1] is not None and _pair_problems(new, track, m):
        return found, fits
    return replace(again, method=f"{found.method}+bend", histogram=found.histogram, bases_px=found.bases_px,
                   extra={**found.extra, **again.extra}), new


def _pair_problems(fits: Fits, track: Track, m: Measurer) -> list[str]:
    """Give the lane checks' reasons against a pair of pixel fits (both present)."""
    cfg = m.rules.cfg
    lm, rm = (px_to_m(f.coeffs_px, m.scale) for f in fits)  # type: ignore[union-attr]
    return pair_problems(lm, rm, track.tracked_width(cfg), m.rules.lookahead_m, cfg)


def _along_partner(binary: np.ndarray, pixels: Pixels, found: SearchResult, fits: Fits, track: Track,
                   m: Measurer) -> tuple[SearchResult, Fits]:
    """Step 4: a blind pair whose shapes disagree: the weaker line searched along the stronger one's shape.

    Windows that lose a faint line in a tight bend go on straight up and give it another
    shape than its partner's (the ``parallel`` or ``curvature`` check fails).  The weaker line
    is then looked for in a band (``search.around_margin_m``) around the stronger line's fit
    moved to the weaker line's x at the bottom row, and the stronger one around its own fit.
    That search is taken only when its pair passes every lane check, both its lines are
    confident (``tracking.min_confidence``) and the weaker one is no less so than before.
    """
    min_conf = m.rules.cfg.min_confidence
    strong = 0 if fits[0].confidence >= fits[1].confidence else 1  # type: ignore[union-attr]
    weak = 1 - strong
    if fits[strong].confidence < min_conf or not {"parallel", "curvature"} & set(  # type: ignore[union-attr]
            _pair_problems(fits, track, m)):
        return found, fits
    shape, own = fits[strong].coeffs_px, fits[weak].coeffs_px  # type: ignore[union-attr]
    bottom = float(m.scale.height_px)  # the view's bottom row, where the car is
    moved = shape + np.array([0.0, 0.0, poly_x(own, bottom) - poly_x(shape, bottom)])
    priors = (moved, shape) if weak == 0 else (shape, moved)
    again = search_around(binary, priors[0], priors[1], m.search.around_margin_px, pixels)
    new = _fit(again, m)
    if new[0] is None or new[1] is None or min(new[0].confidence, new[1].confidence) < min_conf:
        return found, fits
    if new[weak].confidence < fits[weak].confidence or _pair_problems(new, track, m):  # type: ignore[union-attr]
        return found, fits
    return replace(again, method=f"{found.method}+partner", histogram=found.histogram,
                   bases_px=found.bases_px), new


def _line(fit: LineFit | None, scale: Scale) -> Line | None:
    """Make a measured line's record; its range (start) is how far ahead its farthest (nearest) fitted pixel lies.

    (Pixels the fit left out, specks beyond a dash, do not stretch it.)
    """
    if fit is None:
        return None
    reach_m = (scale.height_px - fit.top_px) * scale.ym_per_px
    start_m = (scale.height_px - fit.bottom_px) * scale.ym_per_px
    return Line(fit_px=fit.coeffs_px, fit_m=px_to_m(fit.coeffs_px, scale), confidence=fit.confidence,
                found=True, inferred=False, n_pixels=fit.n_pixels, range_m=reach_m, start_m=start_m)


def measure(binary: np.ndarray, view: np.ndarray | None, track: Track, m: Measurer,
            pixels: Pixels | None = None) -> Measured:
    """Measure a frame's lines on its bird's-eye binary, ready for :func:`~lanefinder.tracking.step`.

    Parameters
    ----------
    binary : (H, W) uint8 ndarray
        The bird's-eye binary, 0/1.
    view : (H, W, 3) uint8 ndarray or None
        The bird's-eye colour image (BGR); without it, the yellow-side check is not made.
    track : Track
        The track before this frame (it decides where to search).
    m : Measurer
        The settings in pixels.
    pixels : Pixels, optional
        The set pixels of ``binary``, when already extracted.

    Returns
    -------
    Measured
        The measured lines, the search, whether it was blind, and the frame checks' reasons.

    Examples
    --------
    >>> from lanefinder.config import Config
    >>> from lanefinder.geometry import Scale
    >>> from lanefinder.tracking import Track
    >>> m = Measurer.build(Config(), Scale(3.7 / 150, 0.0985, 300, 200.0))
    >>> b = np.zeros((300, 400), np.uint8); b[:, 122:128] = 1; b[:, 197:203] = 1; b[:, 272:278] = 1
    >>> measure(b, None, Track(), m).reasons
    ('line-inside-lane',)
    """
    px = pixels if pixels is not None else Pixels.of(binary)
    m = _in_view_left(view, m)
    got = _measure_with(binary, view, track, m, px)
    sc = m.config.search
    # inner_preference: 0 is off, and a higher value asks more of the inner pair.
    looser = sc.inner_retry_preference > 0 and not 0 < m.search.inner_preference <= sc.inner_retry_preference
    if got.blind and looser and _straddles(got, px, m):
        # The lane straddles a marking: its lines were likely beyond the true ones (step 7).
        inner = replace(m, search=replace(m.search, inner_preference=sc.inner_retry_preference))
        again = _measure_with(binary, view, track, inner, px)
        if "line-inside-lane" not in again.reasons and all(line is not None for line in again.lines):
            return replace(again, search=replace(again.search, method=f"{again.search.method}+inner"))
    return got


#: A line spans its view fully (for its confidence) when it spans ``fit.full_span_fraction`` of the
#: rows glare leaves: rows at least half blown out (:func:`~lanefinder.threshold.blown_out_rows`)
#: are taken off, down to this fraction of the view.  (Tuning seeds 0-10: glare 0.770 -> 0.826,
#: no lane 9.5% -> 3.0%; every other scenario unchanged.)
MIN_FULL_SPAN_FRACTION = 0.1


def _in_view_left(view: np.ndarray | None, m: Measurer) -> Measurer:
    """Give the settings for a view glare blows out in part: a full span is that of the rows left."""
    if view is None:
        return m
    seen = 1.0 - float(blown_out_rows(view).mean())
    if seen >= 1.0:
        return m
    full = max(MIN_FULL_SPAN_FRACTION, m.fit.full_span_fraction * seen)
    return replace(m, fit=replace(m.fit, full_span_fraction=full))


def _straddles(got: Measured, px: Pixels, m: Measurer) -> bool:
    """Tell whether a measured lane has a solid marking inside it (``search.inner_retry_span``)."""
    if "line-inside-lane" in got.reasons:
        return True
    if got.lines[0] is None or got.lines[1] is None:
        return False
    lane = (got.lines[0].fit_m, got.lines[1].fit_m)
    return check_line_inside(px, *lane, m.scale, m.rules.cfg, m.config.search.inner_retry_span) is not None


def _measure_with(binary: np.ndarray, view: np.ndarray | None, track: Track, m: Measurer, px: Pixels) -> Measured:
    """Measure with one set of search settings: steps 1-6 of :func:`measure`."""
    found, fits, blind = find_lines(binary, px, track, m)
    lines = (_line(fits[0], m.scale), _line(fits[1], m.scale))
    reasons: list[str] = []
    cfg = m.rules.cfg
    if view is not None and cfg.yellow_line_side != "either":
        yellow = tuple(line is not None and is_yellow(view, pix, cfg, m.config.threshold.ridge.yellow_min)
                       for line, pix in zip(lines, (found.left, found.right), strict=True))
        x_at_car = tuple(None if line is None else float(line.fit_m[2]) for line in lines)  # type: ignore[index]
        sides, reason = yellow_side(x_at_car, yellow, cfg)  # type: ignore[arg-type]
        if reason:
            lines = tuple(None if i is None else lines[i] for i in sides)  # type: ignore[assignment]
            reasons.append(reason)
    if lines[0] is not None or lines[1] is not None:
        width = track.width_m if track.width_m is not None else m.rules.default_width_m
        lane = implied_lane(*(None if line is None else line.fit_m for line in lines), width)
        if reason := check_line_inside(px, *lane, m.scale, cfg):
            # A solid marking runs down the middle of the lane these lines would make: not our lane.
            lines = (None, None)
            reasons.append(reason)
    return Measured(lines, found, blind, tuple(reasons))
