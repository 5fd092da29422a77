"""The pipeline object: composes camera, bird's-eye view, threshold, search, fit and tracking.

>>> finder = LaneFinder(Config())          # doctest: +SKIP
>>> result = finder.process(frame_bgr)      # doctest: +SKIP
>>> result.radius_m, result.offset_m        # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .birdseye import BirdsEye, make_birdseye
from .camera import CameraModel, load_camera, udacity_camera
from .config import Config
from .errors import LaneFinderError
from .geometry import FitParams, LineFit, Scale, fit_lane, fit_params, lane_geometry, m_to_px, px_to_m
from .search import (
    LinePixels,
    Pixels,
    SearchParams,
    SearchResult,
    blind_search,
    heading_search,
    search_around,
    search_params,
)
from .threshold import threshold
from .tracking import LOST, LaneTracker, Measurement, TrackedLane


@dataclass(frozen=True, eq=False)
class LaneResult:
    """Everything found in one frame.

    Fits: ``*_fit_px`` are (a, b, c) of x = a*y^2 + b*y + c in bird's-eye pixels; ``*_fit_m`` are
    (A, B, C) of x = A*d^2 + B*d + C in metres (see :mod:`lanefinder.geometry`).
    Numbers are NaN only when ``lane_found`` is False.
    """

    left_found: bool
    right_found: bool
    left_inferred: bool
    right_inferred: bool
    left_fit_px: np.ndarray | None
    right_fit_px: np.ndarray | None
    left_fit_m: np.ndarray | None
    right_fit_m: np.ndarray | None
    left_pixels: int
    right_pixels: int
    left_conf: float
    right_conf: float
    radius_m: float
    curvature_per_m: float
    offset_m: float
    width_m: float
    straight: bool
    state: str
    misses: int = 0
    checks: tuple[str, ...] = ()
    binary: np.ndarray | None = None
    search: SearchResult | None = None

    @property
    def lane_found(self) -> bool:
        return self.left_fit_px is not None and self.right_fit_px is not None


def _conf(fit: LineFit | None) -> float:
    return -1.0 if fit is None else fit.confidence


def _weak(fit: LineFit | None, cfg: Config) -> bool:
    return fit is None or fit.confidence < cfg.tracking.min_confidence


def camera_from_config(cfg: Config, frame_size: tuple[int, int] | None = None) -> CameraModel:
    """The configured camera: built-in Udacity, none (ideal pinhole), or a camera file."""
    name = cfg.camera.model
    if name == "udacity":
        return udacity_camera()
    if name == "none":
        size = frame_size or cfg.birdseye.reference_size
        return CameraModel.ideal(size)
    return load_camera(name)


def birdseye_from_config(cfg: Config, camera: CameraModel, frame_size: tuple[int, int]) -> BirdsEye:
    """The bird's-eye set-up for frames of ``frame_size``: src points scale with the frame."""
    b = cfg.birdseye
    w, h = frame_size
    rw, rh = b.reference_size
    if abs((w / h) / (rw / rh) - 1) > 0.01:
        raise LaneFinderError(
            f"frame size {w}x{h} has another aspect ratio than the configured set-up ({rw}x{rh}); "
            "run 'lanefinder setup' for this camera"
        )
    cam = camera.scaled_to(frame_size)
    src = np.asarray(b.src, np.float64) * [w / rw, h / rh]
    return make_birdseye(cam, src, np.asarray(b.dst), b.size, b.xm_per_px, b.ym_per_px)


class LaneFinder:
    """Finds the lane in frames; keeps a track across calls to :meth:`process` (call :meth:`reset` between clips)."""

    def __init__(self, config: Config | None = None, camera: CameraModel | None = None, keep_debug: bool = False):
        self.config = config or Config()
        self._camera = camera
        self._birdseye: BirdsEye | None = None
        self.keep_debug = keep_debug
        self.tracker: LaneTracker | None = None
        self.search_px: SearchParams | None = None
        self.fit_px: FitParams | None = None

    def birdseye(self, frame_size: tuple[int, int]) -> BirdsEye:
        """The (cached) bird's-eye set-up for this frame size."""
        be = self._birdseye
        if be is None or be.frame_size != tuple(frame_size):
            if self._camera is None:
                self._camera = camera_from_config(self.config, frame_size)
            be = birdseye_from_config(self.config, self._camera, tuple(frame_size))
            self._birdseye = be
            self.search_px = search_params(self.config.search, be.xm_per_px, be.ym_per_px)
            self.fit_px = fit_params(self.config.fit, be.xm_per_px, be.ym_per_px, self.config.search.marking_width_m)
            lookahead = be.size[1] * be.ym_per_px
            self.tracker = LaneTracker(self.config.tracking, lookahead)
        return be

    def scale(self, be: BirdsEye) -> Scale:
        return Scale(be.xm_per_px, be.ym_per_px, be.size[1], be.car_x_px)

    def reset(self) -> None:
        """Forget the track (start of a new clip, or independent images)."""
        if self.tracker is not None:
            self.tracker.reset()

    def process(self, frame: np.ndarray) -> LaneResult:
        """Find the lane in one BGR uint8 frame."""
        if frame is None or frame.ndim != 3 or frame.shape[2] != 3 or frame.dtype != np.uint8:
            raise LaneFinderError("a frame must be a BGR uint8 image of shape (height, width, 3)")
        be = self.birdseye((frame.shape[1], frame.shape[0]))
        view = be.warp(frame)
        binary = threshold(view, self.config.threshold, be.xm_per_px)
        return self.process_binary(binary, be, view)

    def process_binary(self, binary: np.ndarray, be: BirdsEye, view: np.ndarray | None = None) -> LaneResult:
        """Search, fit and track on a bird's-eye binary (uint8 0/1).

        ``view`` is the bird's-eye colour image (BGR); with it, a yellow line is only taken as the
        side of the lane that ``tracking.yellow_line_side`` allows.
        """
        tracker, sp = self.tracker, self.search_px
        assert tracker is not None and sp is not None
        scale = self.scale(be)
        pixels = Pixels.of(binary)
        blind = tracker.needs_blind_search
        if blind:
            found = blind_search(binary, sp, be.car_x_px, pixels)
        else:
            found = search_around(binary, m_to_px(tracker.left, scale), m_to_px(tracker.right, scale),
                                  sp.around_margin_px, pixels)
        fit_l, fit_r = self._fit(found)
        if not blind and (_weak(fit_l, self.config) or _weak(fit_r, self.config)):
            # A line went weak around the track: search blind in the same frame and keep, per
            # line, whichever search gives the more confident fit.
            found, fit_l, fit_r = self._keep_better(found, fit_l, fit_r, blind_search(binary, sp, be.car_x_px, pixels))
        if sp.shears_px and (_weak(fit_l, self.config) or _weak(fit_r, self.config)):
            # Still weak: look for lines that cross the view at an angle (the car heading off the
            # lane).  Those come as a pair, taken only when neither line is weak and the pair is
            # the more confident in all; without a track to hold it to (start, re-detection), the
            # pair must also pass the lane checks.  While tracking, the tracker judges it.
            slant = heading_search(binary, sp, be.car_x_px, pixels)
            slant_l, slant_r = self._fit(slant)
            c_new = _conf(slant_l) + _conf(slant_r)
            c_old = max(_conf(fit_l), 0.0) + max(_conf(fit_r), 0.0)
            take = not (_weak(slant_l, self.config) or _weak(slant_r, self.config)) and c_new > c_old
            if take and blind:
                assert slant_l is not None and slant_r is not None
                take = not tracker.pair_problems(px_to_m(slant_l.coeffs_px, scale), px_to_m(slant_r.coeffs_px, scale))
            if take:
                found, fit_l, fit_r = slant, slant_l, slant_r
        meas_l, meas_r = self._measure(fit_l, scale), self._measure(fit_r, scale)
        frame_checks: tuple[str, ...] = ()  # checks made here, before the tracker's
        if view is not None and self.config.tracking.yellow_line_side != "either":
            meas_l, meas_r, frame_checks = self._yellow_side(view, found, meas_l, meas_r)
        if self._line_inside(pixels, meas_l, meas_r, scale, tracker):
            # A solid marking runs down the middle of the lane these lines would make: not our lane.
            meas_l = meas_r = None
            frame_checks = (*frame_checks, "line-inside-lane")
        track = tracker.update(meas_l, meas_r, blind)
        if frame_checks:
            track = replace(track, checks=(*frame_checks, *track.checks))
        return self._result(track, fit_l, fit_r, found, binary, scale)

    def _fit(self, found: SearchResult) -> tuple[LineFit | None, LineFit | None]:
        """Robust fits of a search's left and right line pixels."""
        assert self.fit_px is not None and self._birdseye is not None
        return fit_lane((found.left.x, found.left.y), (found.right.x, found.right.y), self._birdseye.size[1],
                        self.fit_px)

    def _keep_better(self, found: SearchResult, fit_l: LineFit | None, fit_r: LineFit | None,
                     again: SearchResult) -> tuple[SearchResult, LineFit | None, LineFit | None]:
        """Per line, the more confident of two searches' fits (and the search result to match)."""
        again_l, again_r = self._fit(again)
        use_l, use_r = _conf(again_l) > _conf(fit_l), _conf(again_r) > _conf(fit_r)
        if not (use_l or use_r):
            return found, fit_l, fit_r
        if use_l and use_r:
            return again, again_l, again_r
        merged = SearchResult(again.left if use_l else found.left, again.right if use_r else found.right,
                              f"{found.method}+{again.method}", again.histogram, again.bases_px, found.band_px,
                              {**found.extra, **again.extra})
        return (merged, *self._fit(merged))

    def _is_yellow(self, view: np.ndarray, line: LinePixels) -> bool:
        """Most of the line's pixels are saturated yellow (paint, not dry grass or sunlit asphalt)."""
        if line.x.size == 0:
            return False
        t = self.config.tracking
        px = view[line.y.astype(np.intp), line.x.astype(np.intp)].astype(np.float32)
        blue, red = px[:, 0], px[:, 2]
        yellow = (red - blue > self.config.threshold.ridge.yellow_min) & (blue < (1 - t.yellow_saturation) * red)
        return bool(yellow.mean() > t.yellow_fraction)

    def _yellow_side(self, view: np.ndarray, found: SearchResult, left: Measurement | None,
                     right: Measurement | None) -> tuple[Measurement | None, Measurement | None, tuple[str, ...]]:
        """Enforce ``yellow_line_side``.  A yellow line found as the right line (for "left") is not
        our right line: if it passes left of the car, and the left line is not yellow too, it is
        our left line and what was found beyond it belongs to another lane; otherwise it is dropped."""
        side = self.config.tracking.yellow_line_side
        if side == "left" and right is not None and self._is_yellow(view, found.right):
            if right.coeffs_m[2] < 0 and not (left is not None and self._is_yellow(view, found.left)):
                return right, None, ("right-is-yellow",)
            return left, None, ("right-is-yellow",)
        if side == "right" and left is not None and self._is_yellow(view, found.left):
            if left.coeffs_m[2] > 0 and not (right is not None and self._is_yellow(view, found.right)):
                return None, left, ("left-is-yellow",)
            return None, right, ("left-is-yellow",)
        return left, right, ()

    def _line_inside(self, pixels: Pixels, left: Measurement | None, right: Measurement | None, scale: Scale,
                     tracker: LaneTracker) -> bool:
        """True when a solid marking runs down the middle half of the lane the measurements imply.

        Set pixels in the middle half are placed by their distance from the lane centre, in
        0.2 m strips; a marking parallel to the lane keeps to one strip (or two neighbours) on more
        than ``max_interior_fill`` of the rows, and on 40% more rows than the median strip, while
        shadows and cracks wander across strips.
        """
        if left is None and right is None:
            return False
        lm, rm = tracker.implied_lane(left.coeffs_m if left else None, right.coeffs_m if right else None)
        h, w = pixels.shape
        rows = np.arange(h, dtype=np.float64)
        xl, xr = np.polyval(m_to_px(lm, scale), rows), np.polyval(m_to_px(rm, scale), rows)
        centre, quarter = (xl + xr) / 2, (xr - xl) / 4
        valid = (quarter > 0) & (centre - quarter >= 0) & (centre + quarter < w)
        if valid.sum() <= 10:
            return False
        strip_px = 0.2 / scale.xm_per_px
        n_strips = int(np.ceil(2 * quarter[valid].max() / strip_px)) + 1
        ys = pixels.y
        s = pixels.x - centre[ys]
        inside = valid[ys] & (np.abs(s) < quarter[ys])
        strip = ((s[inside] + quarter[ys[inside]]) / strip_px).astype(np.intp)
        counts = np.bincount(ys[inside] * n_strips + strip, minlength=h * n_strips).reshape(h, n_strips)
        present = counts[valid] >= 2
        pair = present[:, :-1] | present[:, 1:] if n_strips > 1 else present
        fill = pair.mean(axis=0)
        # A marking stands out from the rest of the lane; dense clutter fills every strip alike.
        best = float(fill.max())
        return best > self.config.tracking.max_interior_fill and best - float(np.median(fill)) > 0.4

    @staticmethod
    def _measure(fit: LineFit | None, scale: Scale) -> Measurement | None:
        return None if fit is None else Measurement(px_to_m(fit.coeffs_px, scale), fit.confidence)

    def _result(self, t: TrackedLane, fit_l: LineFit | None, fit_r: LineFit | None, found: SearchResult,
                binary: np.ndarray, scale: Scale) -> LaneResult:
        debug = {"binary": binary, "search": found} if self.keep_debug else {}
        nan = float("nan")
        if not t.has_lane:
            return LaneResult(False, False, False, False, None, None, None, None,
                              fit_l.n_pixels if fit_l else 0, fit_r.n_pixels if fit_r else 0,
                              t.left_conf, t.right_conf, nan, nan, nan, nan, False, LOST, t.misses, t.checks, **debug)
        g = lane_geometry(t.left_m, t.right_m, self.config.fit)
        return LaneResult(
            t.left_found, t.right_found, t.left_inferred, t.right_inferred,
            m_to_px(t.left_m, scale), m_to_px(t.right_m, scale), t.left_m, t.right_m,
            fit_l.n_pixels if fit_l else 0, fit_r.n_pixels if fit_r else 0,
            t.left_conf, t.right_conf, g.radius_m, g.curvature_per_m, g.offset_m, g.width_m, g.straight,
            t.state, t.misses, t.checks, **debug,
        )
