"""A new camera in one step: the bird's-eye view and its scale from straight-road frames.

The road is modelled as a plane seen by a pinhole camera with no roll: the focal length f
(from the camera file, or measured), the vanishing point of the road (its pitch and yaw) and
the camera's height over the road.  Everything else follows from these: the trapezoid, both
scales and the car's place (the road point under the camera).

1. Each frame is looked at on its own (at most 1280 px wide, so every resolution gives the
   same answer), and accepted or refused with its reason:
   - vanishing point: line segments (LSD) below the middle of the frame that lean like lane
     lines, a robust (RANSAC, then least-squares) intersection;
   - the ego lines: marking pixels voted along rays from the vanishing point onto the bottom
     row; the strongest ray on each side of the camera;
   - the camera height: the lane width (``lane_width_m``) against the lines' spread.
2. Frames whose vanishing point or height disagree with the others' median by far more than
   the others' spread are refused: a refused frame never sinks the set.
3. Focal length: from the camera file, or measured from the dashes: the road is sampled along
   each dashed line in metres, and the dash period (``dash_period_m``) seen there fixes f
   (the lane width fixes the height, the dash period the distance along).
4. Straightness: each line's markings are followed on the road in metres, a parabola fitted
   and its curvature compared with ``max_curvature_per_m`` plus ``curvature_sigmas`` times the
   fit's own standard error: noisy frames are not refused for noise, curved ones are.
5. The view: the median vanishing point and height, the lane centred, from the bottom row to
   ``lookahead_m`` ahead; the expected error of the result comes from the frames' spread.

Nothing is clamped: an estimate that cannot be made is an error that says why.  Every
threshold is a documented field of :class:`SetupOptions`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import cv2
import numpy as np
from pydantic import ValidationError

from .birdseye import make_birdseye
from .camera import CameraModel
from .config import (
    LANE_SPAN_PX,
    LANE_WIDTH_M,
    VIEW_SIZE_PX,
    BirdseyeConfig,
    CameraConfig,
    Config,
    ThresholdConfig,
    default_dst,
)
from .errors import LaneFinderError
from .threshold import ridge

__all__ = [
    "MIN_LINE_STANDOUT",
    "FrameEvidence",
    "FrameLines",
    "RoadEstimate",
    "SetupOptions",
    "SetupQuality",
    "SetupResult",
    "auto_setup",
    "dash_period_m",
    "estimate_road",
    "frame_evidence",
    "frame_lines",
    "line_curvature",
    "line_segments",
    "nominal_setup",
    "prepare_frame",
    "preview",
    "road_from_lines",
    "road_homography",
    "road_points",
    "straight_fits",
    "straight_frames_from_video",
    "vanishing_point",
    "view_from_estimate",
]

#: Relative error of a dash period found on fewer than three line profiles (not measurable).
_FEW_PROFILES_ERROR = 0.1
#: The ridge settings the set-up finds markings with: the default ones without the texture test
#: (a patch in metres means nothing in the perspective frame, whose scale varies with the row).
_SETUP_RIDGE = ThresholdConfig().ridge.model_copy(update={"noise_factor": 0.0})

@dataclass(frozen=True)
class SetupOptions:
    """What the set-up assumes of the road, and the thresholds it judges frames by.

    Parameters
    ----------
    lane_width_m : float
        The ego lane's width between line centres, m: the across-road scale and the height.
    lookahead_m : float
        How far ahead the view reaches, m.
    bottom_fraction : float
        The view's bottom row as a fraction of the frame height (above the hood).
    dash_period_m : float
        Dash plus gap, m: fixes the focal length without a camera file.  12.2 m (40 ft) is
        the US federal (MUTCD) pattern; California, where the Udacity videos were filmed,
        paints 48 ft (14.6 m).
    min_frames : int
        Accepted frames needed.
    work_width_px : int
        Frames wider than this are shrunk to it first (the answer does not depend on the size).
    segment_top_fraction : float
        Line segments are looked for below this fraction of the frame height.
    min_segment_fraction : float
        Shortest segment, as a fraction of the frame height.
    segment_angle_deg : tuple of float
        Segments leaning between these angles from the horizontal, degrees, count.
    ransac_iterations : int
        Pairs of segments tried for the vanishing point.
    ransac_tol_px : float
        A segment passes through a candidate vanishing point within this distance, pixels at
        1280 px wide (twice it for the least-squares refinement).
    max_vp_fraction : float
        The vanishing point must lie above this fraction of the frame height.
    vote_start_fraction : float
        Marking pixels vote from this fraction of the way from the vanishing point down to
        the bottom row (the nearest rows of the horizon are too compressed to vote).
    min_marking_px : int
        Fewest marking pixels below the horizon.
    marking_width_m : float
        Marking width the ridge threshold looks for, m, over an assumed 50 px per metre at
        the bottom of a 1280-wide frame (at least 5 px wide).
    vote_sigma_fraction : float
        Blur of the ray votes, as a fraction of the frame width (a marking is a few px wide).
    lane_span_factor : float
        The ego lines are looked for within this many times the bottom row's depth below
        the horizon on each side of the vanishing point ...
    min_line_offset : float
        ... and no nearer to it than this many times that depth: a line at least this many
        camera heights to the side of the camera, which rides inside its lane (0.25: 0.3 m
        for a camera 1.2 m high, 0.45 m for 1.8 m), so that a seam or the edge of a lighter
        strip of pavement running under the car is not taken for a line.
    height_range_m : tuple of float
        Camera heights that the lane width may imply, m; outside, the frame is refused.
    outlier_sigmas : float
        A frame whose vanishing point or height is further than this many spreads (1.4826
        MAD) from the median is refused.
    vp_floor_fraction : float
        The spread of the vanishing point is taken as at least this fraction of the width.
    height_floor : float
        The relative spread of the height is taken as at least this.
    focal_guess_fraction : float
        First guess of the focal length as a fraction of the width, before the dashes are
        measured (three rounds correct it).
    marking_contrast : float
        A marking is this many grey levels brighter than the road beside it.
    dash_far_fraction : float
        Dashes are followed up to this fraction of the way from the horizon to the bottom row.
    dash_step_m : float
        Sampling step along the road, m (in the current guess of the scale).
    dash_fill_range : tuple of float
        A dashed line has marking on between these fractions of its length (else solid or
        absent).
    dash_period_range_m : tuple of float
        Periods looked for, m in the first guess of the scale (wide: the guess may be off
        by a factor of two).
    dash_length_m : tuple of float
        A dash is this long, m (the first guess allows 0.8 and 2 times these).
    min_dash_correlation : float
        The autocorrelation peak a dash period needs.
    bend_strip_m : float
        Half-width of the strip around each line in the straightness test, m.
    bend_step_m : float
        Rows of that strip, m apart along the road.
    min_bend_rows : int
        Rows with marking a line needs for its curvature to count.
    max_curvature_per_m : float
        A frame is straight when its lines' curvature is within this (1/m) ...
    curvature_sigmas : float
        ... plus this many standard errors of the fit.
    video_candidates : int
        Frames of a video looked at, evenly spread.

    Examples
    --------
    >>> opts = SetupOptions(lookahead_m=30.0)
    >>> opts.lane_width_m, opts.dash_period_m
    (3.7, 12.2)
    """

    lane_width_m: float = LANE_WIDTH_M
    lookahead_m: float = 35.0
    bottom_fraction: float = 0.9375
    dash_period_m: float = 12.2
    min_frames: int = 1
    work_width_px: int = 1280
    segment_top_fraction: float = 0.45
    min_segment_fraction: float = 0.03
    segment_angle_deg: tuple[float, float] = (20.0, 80.0)
    ransac_iterations: int = 500
    ransac_tol_px: float = 4.0
    max_vp_fraction: float = 0.8
    vote_start_fraction: float = 0.1
    min_marking_px: int = 50
    marking_width_m: float = 0.4
    vote_sigma_fraction: float = 1 / 400
    lane_span_factor: float = 3.0
    min_line_offset: float = 0.25
    height_range_m: tuple[float, float] = (0.4, 4.0)
    outlier_sigmas: float = 4.0
    vp_floor_fraction: float = 0.004
    height_floor: float = 0.02
    focal_guess_fraction: float = 1.0
    marking_contrast: float = 20.0
    dash_far_fraction: float = 0.15
    dash_step_m: float = 0.1
    dash_fill_range: tuple[float, float] = (0.08, 0.8)
    dash_period_range_m: tuple[float, float] = (4.0, 30.0)
    dash_length_m: tuple[float, float] = (1.0, 6.0)
    min_dash_correlation: float = 0.1
    bend_strip_m: float = 1.0
    bend_step_m: float = 0.5
    min_bend_rows: int = 8
    max_curvature_per_m: float = 1 / 1200
    curvature_sigmas: float = 2.0
    video_candidates: int = 60


@dataclass(frozen=True)
class FrameLines:
    """What one straight-road frame gives: the vanishing point and both lines at the bottom row.

    Attributes
    ----------
    vp : tuple of float
        The vanishing point (x, y), undistorted pixels.
    left_bottom_x, right_bottom_x : float
        Where the ego lane's lines cross the bottom row, pixels.
    bottom_y : float
        The bottom row, pixels.
    inlier_fraction : float
        Share of the segments' length that passes through the vanishing point.
    standout : float
        How many times the marking votes of the weaker of the two lines exceed the median vote
        across the frame's width (infinite when that median is 0): real lane lines stand out
        tens of times, the edges of trees in footage upside down two or three times.

    Examples
    --------
    >>> fl = FrameLines(vp=(640.0, 420.0), left_bottom_x=280.0, right_bottom_x=1030.0,
    ...                 bottom_y=674.0, inlier_fraction=0.6)
    >>> fl.right_bottom_x - fl.left_bottom_x
    750.0
    """

    vp: tuple[float, float]
    left_bottom_x: float
    right_bottom_x: float
    bottom_y: float
    inlier_fraction: float
    standout: float = math.inf


@dataclass(frozen=True)
class FrameEvidence:
    """One frame's evidence for the set-up, and whether it was accepted.

    Attributes
    ----------
    index : int
        The frame's place among those offered.
    lines : FrameLines or None
        Its vanishing point and lines (working pixels); None when none were found.
    reason : str
        Why it was refused; empty when accepted.
    curvature_per_m : float
        Its lines' curvature from the straightness test, 1/m (NaN when not measured).

    Examples
    --------
    >>> FrameEvidence(index=3, lines=None, reason="no lane markings found").accepted
    False
    """

    index: int
    lines: FrameLines | None
    reason: str = ""
    curvature_per_m: float = math.nan

    @property
    def accepted(self) -> bool:
        """True when the frame takes part in the set-up."""
        return self.lines is not None and not self.reason


@dataclass(frozen=True)
class RoadEstimate:
    """The road plane as the camera sees it, combined from the accepted frames (working pixels).

    Attributes
    ----------
    camera_matrix : (3, 3) ndarray
        K at the working size: known, or with the measured focal length.
    vp : tuple of float
        The vanishing point (x, y), pixels.
    height_m : float
        The camera's height over the road, m.
    centre_m : float
        The lane centre's lateral place, m right of the camera (median over the frames).
    focal_source : str
        Where the focal length came from.
    evidence : tuple of FrameEvidence
        Every frame offered, accepted or refused with its reason.
    vp_sigma_px : tuple of float
        Standard error of the vanishing point (x, y), pixels.
    height_sigma : float
        Relative standard error of the height.
    focal_sigma : float
        Relative standard error of the focal length (0 from a camera file).
    work_scale : float
        Working pixels per frame pixel.

    Examples
    --------
    >>> k = np.array([[1000.0, 0, 639.5], [0, 1000.0, 359.5], [0, 0, 1]])
    >>> est = RoadEstimate(camera_matrix=k, vp=(639.5, 359.5), height_m=1.3, centre_m=0.0,
    ...                    focal_source="camera file", evidence=())
    >>> est.frames_used
    0
    """

    camera_matrix: np.ndarray
    vp: tuple[float, float]
    height_m: float
    centre_m: float
    focal_source: str
    evidence: tuple[FrameEvidence, ...]
    vp_sigma_px: tuple[float, float] = (0.0, 0.0)
    height_sigma: float = 0.0
    focal_sigma: float = 0.0
    work_scale: float = 1.0

    @property
    def frames_used(self) -> int:
        """Accepted frames."""
        return sum(e.accepted for e in self.evidence)


@dataclass(frozen=True)
class SetupQuality:
    """How good a set-up is: how many frames, how well they agree, the expected errors.

    Attributes
    ----------
    frames_used, frames_offered : int
        Accepted frames, and all frames looked at.
    vp_spread_px : tuple of float
        Spread (1.4826 MAD) of the frames' vanishing points (x, y), frame pixels.
    height_spread : float
        Relative spread of the frames' camera heights.
    xm_error_pct, ym_error_pct : float
        Expected error (one standard error) of the scales across and along, percent; the
        across scale also rests on the lane width assumed.
    car_error_m : float
        Expected error of the car's place across the lane, m.
    refusals : tuple of str
        Each refused frame with its reason.

    Examples
    --------
    >>> q = SetupQuality(frames_used=5, frames_offered=6, vp_spread_px=(1.0, 2.0),
    ...                  height_spread=0.01, xm_error_pct=0.5, ym_error_pct=1.5, car_error_m=0.02)
    >>> q.lines()[0]
    'frames: 5 of 6 accepted'
    """

    frames_used: int
    frames_offered: int
    vp_spread_px: tuple[float, float]
    height_spread: float
    xm_error_pct: float
    ym_error_pct: float
    car_error_m: float
    refusals: tuple[str, ...] = ()

    def lines(self) -> list[str]:
        """Give the quality report as lines of text (printed, and a comment in the config).

        Returns
        -------
        list of str
            One fact per line.
        """
        out = [f"frames: {self.frames_used} of {self.frames_offered} accepted",
               f"agreement: vanishing point spread {self.vp_spread_px[0]:.1f} px across, "
               f"{self.vp_spread_px[1]:.1f} px up/down; camera height spread {100 * self.height_spread:.1f}%",
               f"expected error: xm {self.xm_error_pct:.1f}% (plus the lane width assumed), "
               f"ym {self.ym_error_pct:.1f}%, car position {self.car_error_m:.2f} m"]
        return out + [f"refused {r}" for r in self.refusals]


@dataclass(frozen=True)
class SetupResult:
    """A bird's-eye set-up found for a camera, with what it was based on.

    Attributes
    ----------
    birdseye : BirdseyeConfig
        The set-up, ready for a config file.
    camera_model : str
        The camera file it assumes (``none`` for no distortion model).
    vp : tuple of float
        The vanishing point (x, y), undistorted frame pixels.
    horizon_row : float
        The horizon's row, pixels.
    frames_used : int
        Frames that took part.
    frame_size : tuple of int
        (width, height), pixels.
    ym_source : str
        Where the along-road scale (the focal length) came from.
    focal_px : float
        The focal length, frame pixels.
    height_m : float
        The camera's height over the road, m.
    quality : SetupQuality or None
        How good it is.
    notes : tuple of str
        Warnings for the user.
    straightness_px : float
        The most a line bends over the view (sagitta of the largest accepted curvature),
        bird's-eye pixels.

    Examples
    --------
    >>> import cv2
    >>> from lanefinder.camera import udacity_camera
    >>> frames = [cv2.imread(f"data/test_images/straight_lines{i}.jpg") for i in (1, 2)]
    >>> result = auto_setup(frames, udacity_camera())
    >>> round(result.birdseye.xm_per_px, 6), result.config().camera.model
    (0.024667, 'none')
    """

    birdseye: BirdseyeConfig
    camera_model: str
    vp: tuple[float, float]
    horizon_row: float
    frames_used: int
    frame_size: tuple[int, int]
    ym_source: str
    focal_px: float = math.nan
    height_m: float = math.nan
    quality: SetupQuality | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
    straightness_px: float = 0.0

    def config(self) -> Config:
        """Give the whole configuration: the defaults with this camera and set-up.

        Without a camera file the measured focal length goes with ``camera.model = "none"``,
        so the car's place is computed with it.

        Returns
        -------
        Config
            Ready for :func:`lanefinder.config.dump_config`.
        """
        focal = round(self.focal_px, 3) if self.camera_model == "none" and math.isfinite(self.focal_px) else None
        return Config(camera=CameraConfig(model=self.camera_model, focal_px=focal), birdseye=self.birdseye)


def line_segments(gray: np.ndarray, opts: SetupOptions) -> np.ndarray:
    """Find line segments in the lower part of a frame that lean like lane lines (LSD).

    Parameters
    ----------
    gray : (H, W) uint8 ndarray
        The undistorted frame, grey.
    opts : SetupOptions
        Gives where to look, the shortest segment and the angles that count.

    Returns
    -------
    (N, 5) float64 ndarray
        x1, y1, x2, y2 (pixels) and length (pixels) of each segment.

    Examples
    --------
    >>> line_segments(np.zeros((720, 1280), np.uint8), SetupOptions()).shape
    (0, 5)
    """
    h = gray.shape[0]
    top = int(h * opts.segment_top_fraction)
    lsd = cv2.createLineSegmentDetector()
    found = lsd.detect(gray[top:])[0]
    if found is None:
        return np.empty((0, 5))
    seg = found.reshape(-1, 4).astype(np.float64)
    seg[:, [1, 3]] += top
    dx, dy = seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1]
    length = np.hypot(dx, dy)
    angle = np.degrees(np.arctan2(np.abs(dy), np.abs(dx)))
    lo, hi = opts.segment_angle_deg
    keep = (length > h * opts.min_segment_fraction) & (angle > lo) & (angle < hi)
    return np.column_stack([seg[keep], length[keep]])


def _weighted_pairs(w: np.ndarray, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Draw up to ``n`` pairs of distinct indices, each in proportion to ``w``, all at once.

    The first of a pair is drawn in proportion to the weights, the second in proportion to
    the weights of the rest (the first's share of the unit interval is stepped over): what
    ``Generator.choice(..., 2, replace=False, p=...)`` does, pair by pair.  A pair that
    rounding still leaves equal is left out; fewer than two positive weights give no pairs.
    """
    w = np.asarray(w, np.float64)
    if np.count_nonzero(w > 0) < 2:
        return np.empty(0, np.intp), np.empty(0, np.intp)
    p = w / w.sum()
    cdf = np.cumsum(p)
    start = cdf - p  # where each index's share of [0, 1) begins
    last = len(w) - 1
    rng = np.random.default_rng(seed)
    first = np.minimum(np.searchsorted(cdf, rng.random(n), side="right"), last)
    r = rng.random(n) * (1 - p[first])
    r += p[first] * (r >= start[first])
    second = np.minimum(np.searchsorted(cdf, r, side="right"), last)
    keep = first != second
    return first[keep], second[keep]


def vanishing_point(segments: np.ndarray, iterations: int = 500, tol_px: float = 4.0,
                    seed: int = 0) -> tuple[np.ndarray, float]:
    """Intersect segments robustly: RANSAC over pairs, then weighted least squares on the inliers.

    A candidate scores the geometric mean of the length of segments through it that lean
    left and of those that lean right.

    Parameters
    ----------
    segments : (N, 5) ndarray
        From :func:`line_segments`; weighted by length.
    iterations : int, optional
        Pairs tried.
    tol_px : float, optional
        Inlier distance, pixels (twice it for the refinement).
    seed : int, optional
        Seed of the pair sampling.

    Returns
    -------
    vp : (2,) ndarray
        The vanishing point (x, y), pixels.
    inlier_fraction : float
        Share of the segments' length passing within ``2 * tol_px``.

    Raises
    ------
    LaneFinderError
        With fewer than 4 segments, or when no two of them meet.

    Examples
    --------
    >>> segs = np.array([[0, 700, 300, 400, 424], [1280, 700, 980, 400, 424],
    ...                  [200, 700, 337.5, 500, 243], [1080, 700, 942.5, 500, 243]])
    >>> vp, share = vanishing_point(segs)
    >>> np.round(vp).tolist(), share
    ([640.0, 60.0], 1.0)
    """
    if len(segments) < 4:
        raise LaneFinderError("too few line segments: not a road frame with visible lane lines")
    p1, p2, w = segments[:, :2], segments[:, 2:4], segments[:, 4]
    lines = np.cross(np.column_stack([p1, np.ones(len(p1))]), np.column_stack([p2, np.ones(len(p2))]))
    lines /= np.hypot(lines[:, 0], lines[:, 1])[:, None]
    left = (p2[:, 0] - p1[:, 0]) * (p2[:, 1] - p1[:, 1]) < 0
    first, second = _weighted_pairs(w, iterations, seed)
    if first.size == 0:
        raise LaneFinderError("too few line segments of any length: not a road frame with visible lane lines")
    cands = np.cross(lines[first], lines[second])
    meet = np.abs(cands[:, 2]) >= 1e-9
    if not meet.any():
        raise LaneFinderError("the line segments do not meet: not a straight-road frame")
    cands = cands[meet] / cands[meet, 2:3]
    near = np.abs(lines @ cands.T) < tol_px  # (segments, candidates)
    # Lane lines lean both ways into the vanishing point: a point that only one side's
    # segments pass through (one line and a kerb, a car, a shadow) scores low.
    score = np.sqrt((w * left) @ near * ((w * ~left) @ near))
    best = cands[int(np.argmax(score))]
    inl = np.abs(lines @ best) < tol_px * 2
    a = lines[inl, :2] * w[inl, None]
    b = -lines[inl, 2] * w[inl]
    vp, *_ = np.linalg.lstsq(a, b, rcond=None)
    return vp, float(w[inl].sum() / w.sum())


def _ray_votes(undistorted: np.ndarray, vp: np.ndarray, y_b: float,
               opts: SetupOptions) -> tuple[np.ndarray, np.ndarray]:
    """Vote the marking pixels onto the bottom row along rays from the vanishing point."""
    w = undistorted.shape[1]
    mask = ridge(undistorted, _SETUP_RIDGE, xm_per_px=opts.marking_width_m / max(5, w / 50))
    y0 = int(vp[1] + opts.vote_start_fraction * (y_b - vp[1]))
    ys, xs = np.nonzero(mask[y0:int(y_b)])
    ys = ys + y0
    if xs.size < opts.min_marking_px:
        raise LaneFinderError("no lane markings found below the horizon")
    xb = vp[0] + (xs - vp[0]) * (y_b - vp[1]) / (ys - vp[1])
    hist, edges = np.histogram(xb, bins=int(w * 1.5), range=(-w * 0.25, w * 1.25))
    # Each pixel's vote spreads over the rays it could be on (a marking is a few pixels wide).
    sigma = max(1.0, w * opts.vote_sigma_fraction)
    hist = cv2.GaussianBlur(hist.astype(np.float32).reshape(1, -1), (0, 0), sigmaX=sigma).ravel()
    return hist, (edges[:-1] + edges[1:]) / 2


def _strongest_ray(hist: np.ndarray, centres: np.ndarray, sel: np.ndarray) -> float:
    """Give the bottom-row x of the strongest ray among ``sel``, to a fraction of a bin."""
    if not sel.any() or hist[sel].max() <= 0:
        raise LaneFinderError("could not find both lane lines: is the car in a marked lane?")
    idx = np.flatnonzero(sel)
    i = idx[int(np.argmax(hist[sel]))]
    lo, hi = max(0, i - 3), min(hist.size, i + 4)  # sub-bin peak over the bins around it
    return float(np.average(centres[lo:hi], weights=hist[lo:hi] + 1e-9))


def frame_lines(undistorted: np.ndarray, opts: SetupOptions) -> FrameLines:
    """Find the vanishing point and the ego lane's lines in one undistorted straight-road frame.

    Parameters
    ----------
    undistorted : (H, W, 3) uint8 ndarray
        The frame, undistorted, BGR.
    opts : SetupOptions
        The set-up's assumptions and thresholds.

    Returns
    -------
    FrameLines
        The vanishing point and both lines at the bottom row.

    Raises
    ------
    LaneFinderError
        When the frame is not a straight road ahead with both lines visible.

    Examples
    --------
    >>> import cv2
    >>> from lanefinder.camera import udacity_camera
    >>> frame = udacity_camera().undistort(cv2.imread("data/test_images/straight_lines1.jpg"))
    >>> fl = frame_lines(frame, SetupOptions())
    >>> round(fl.vp[0]), round(fl.left_bottom_x), round(fl.right_bottom_x)
    (640, 270, 1030)
    """
    h, w = undistorted.shape[:2]
    gray = cv2.cvtColor(undistorted, cv2.COLOR_BGR2GRAY)
    tol = max(1.5, opts.ransac_tol_px * w / 1280)
    vp, inliers = vanishing_point(line_segments(gray, opts), opts.ransac_iterations, tol)
    if not (0 <= vp[0] < w and 0 < vp[1] < h * opts.max_vp_fraction):
        raise LaneFinderError(f"the lane lines meet at ({vp[0]:.0f}, {vp[1]:.1f}), not within the frame's width "
                              f"above row {h * opts.max_vp_fraction:.1f}: not a straight road ahead")
    y_b = opts.bottom_fraction * (h - 1)
    hist, centres = _ray_votes(undistorted, vp, y_b, opts)
    # The ego lines: the strongest rays within a plausible lane of the middle on each side.
    mid, span, gap = vp[0], (y_b - vp[1]) * opts.lane_span_factor, (y_b - vp[1]) * opts.min_line_offset
    left = _strongest_ray(hist, centres, (centres < mid - gap) & (centres > mid - span))
    right = _strongest_ray(hist, centres, (centres > mid + gap) & (centres < mid + span))
    weaker = min(float(hist[np.argmin(np.abs(centres - x))]) for x in (left, right))
    background = float(np.median(hist[(centres >= 0) & (centres < w)]))
    standout = weaker / background if background > 0 else math.inf
    return FrameLines((float(vp[0]), float(vp[1])), left, right, float(y_b), inliers, standout)


# -- the road plane ----------------------------------------------------------------------
def road_homography(camera_matrix: np.ndarray, vp: Sequence[float], height_m: float) -> np.ndarray:
    """Give the homography from road coordinates (X right, Z ahead, metres) to image pixels.

    The camera has no roll; the road runs towards the vanishing point ``vp`` and lies
    ``height_m`` below the camera.  X and Z are measured from the road point under the camera.

    Parameters
    ----------
    camera_matrix : (3, 3) ndarray
        The camera's K (undistorted pixels).
    vp : (2,) sequence of float
        The road's vanishing point (x, y), pixels.
    height_m : float
        Camera height over the road, m.

    Returns
    -------
    (3, 3) float64 ndarray
        G with pixel ~ G @ (X, Z, 1).

    Examples
    --------
    >>> k = np.array([[1000.0, 0, 640], [0, 1000.0, 360], [0, 0, 1]])
    >>> g = road_homography(k, (640.0, 360.0), 1.5)
    >>> p = g @ [0.0, 10.0, 1.0]
    >>> (p[:2] / p[2]).round(1).tolist()
    [640.0, 510.0]
    """
    k = np.asarray(camera_matrix, np.float64)
    d = np.linalg.solve(k, [vp[0], vp[1], 1.0])
    d /= np.linalg.norm(d)
    n = np.cross(d, [1.0, 0.0, 0.0])  # the road's normal, downwards: no roll
    n /= np.linalg.norm(n)
    lateral = np.cross(n, d)
    return k @ np.column_stack([lateral, d, height_m * n])


def road_points(g: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """Map image pixels to road coordinates (X right, Z ahead), metres.

    Parameters
    ----------
    g : (3, 3) ndarray
        From :func:`road_homography`.
    pixels : (N, 2) array_like
        Undistorted (x, y) pixels below the horizon.

    Returns
    -------
    (N, 2) float64 ndarray
        (X, Z), m.

    Examples
    --------
    >>> k = np.array([[1000.0, 0, 640], [0, 1000.0, 360], [0, 0, 1]])
    >>> road_points(road_homography(k, (640.0, 360.0), 1.5), [[640.0, 510.0]]).round(3).tolist()
    [[0.0, 10.0]]
    """
    p = np.column_stack([np.asarray(pixels, np.float64).reshape(-1, 2), np.ones(len(np.atleast_2d(pixels)))])
    q = p @ np.linalg.inv(g).T
    return q[:, :2] / q[:, 2:]


def straight_fits(left_px: np.ndarray, right_px: np.ndarray, bottom_y_px: float) -> tuple[np.ndarray, float]:
    """Fit a straight line ``x = a + b y`` to each of two lines' pixels and give the row where they meet.

    Parameters
    ----------
    left_px, right_px : (N, 2) array_like
        (x, y) pixels of the left and the right line, undistorted (at least 10 each, over at
        least 20 rows).
    bottom_y_px : float
        The bottom row of the view, pixels: the lines must meet above it (and above their pixels).

    Returns
    -------
    fits : (2, 2) ndarray
        (a, b) of the left and the right line (least squares).
    row : float
        The row where they meet, pixels.

    Raises
    ------
    LaneFinderError
        As :func:`road_from_lines` for the pixels.

    Examples
    --------
    >>> y = np.arange(500.0, 700.0)
    >>> fits, row = straight_fits(np.column_stack([640 - (y - 420), y]), np.column_stack([640 + (y - 420), y]), 684)
    >>> round(row, 6), fits.round(3).tolist()
    (420.0, [[1060.0, -1.0], [220.0, 1.0]])
    """
    fits, top = np.empty((2, 2)), math.inf
    for i, pts in enumerate((left_px, right_px)):
        p = np.asarray(pts, np.float64)
        if p.ndim != 2 or p.shape[1] != 2 or not np.isfinite(p).all():
            raise LaneFinderError("each line's pixels must be a finite (N, 2) array of (x, y)")
        if len(p) < 10 or np.ptp(p[:, 1]) < 20:
            raise LaneFinderError("a line has too few pixels near the car to read the road from")
        x, y = p[:, 0], p[:, 1]
        ym = y.mean()
        b = float(np.dot(y - ym, x) / np.dot(y - ym, y - ym))  # least squares, in closed form
        fits[i] = x.mean() - b * ym, b
        top = min(top, float(y.min()))
    (a1, b1), (a2, b2) = fits
    if abs(b1 - b2) < 1e-6:
        raise LaneFinderError("the two lines do not meet: no vanishing point")
    y_v = float((a2 - a1) / (b1 - b2))
    if not y_v < min(top, bottom_y_px - 20):
        raise LaneFinderError(f"the two lines meet at row {y_v:.0f}, not above their pixels and the bottom row")
    return fits, y_v


def road_from_lines(left_px: np.ndarray, right_px: np.ndarray, camera_matrix: np.ndarray, bottom_y_px: float,
                    lane_width_m: float = LANE_WIDTH_M, vp_x: float | None = None) -> RoadEstimate:
    """Estimate the road plane from the near parts of the two lines of one lane, on a curve too.

    A straight line is fitted to each line's pixels (``x = a + b y``, least squares); where
    the two meet is taken as the vanishing point.  On a straight road that is the road's; on a
    curve the two lines' near parts are concentric arcs whose chords over the same stretch of
    road are parallel, so they still meet on the horizon (the column then mixes the camera's
    yaw with the curve's heading, which a single frame cannot tell apart: ``vp_x`` keeps a
    known column instead).  The camera height follows from the lane's width (``lane_width_m``)
    between the two fits at ``bottom_y_px``.

    Parameters
    ----------
    left_px, right_px : (N, 2) array_like
        (x, y) pixels of the left and the right line, undistorted, near the car (at least 10
        each, over at least 20 rows).
    camera_matrix : (3, 3) ndarray
        The camera's K.
    bottom_y_px : float
        The row the lane width is measured at, pixels.
    lane_width_m : float
        The lane's width, m.
    vp_x : float, optional
        The vanishing point's column to keep, pixels (None: where the two fits meet).

    Returns
    -------
    RoadEstimate
        The vanishing point, the camera height and the lane centre's lateral place (no
        evidence frames: ``frames_used`` is 0).

    Raises
    ------
    LaneFinderError
        When the pixels are not finite (N, 2) arrays, a line has too few of them, the lines
        do not meet above all their pixels and ``bottom_y_px``, the right line is not right of
        the left one at that row, or ``lane_width_m`` is not positive.

    Examples
    --------
    >>> k = np.array([[1000.0, 0, 640], [0, 1000.0, 360], [0, 0, 1]])
    >>> g = road_homography(k, (640.0, 380.0), 1.5)
    >>> z = np.linspace(6, 20, 30)
    >>> left, right = (_image_points(g, np.column_stack([np.full(30, x), z])) for x in (-1.55, 2.15))
    >>> est = road_from_lines(left, right, k, 700.0, 3.7)
    >>> [round(v, 2) for v in (*est.vp, est.height_m, est.centre_m)]
    [640.0, 380.0, 1.5, 0.3]
    """
    if not lane_width_m > 0:
        raise LaneFinderError(f"the lane width must be positive, not {lane_width_m}")
    ((a1, b1), (a2, b2)), y_v = straight_fits(left_px, right_px, bottom_y_px)
    vp = (float(a1 + b1 * y_v) if vp_x is None else float(vp_x), float(y_v))
    x_at = [[a1 + b1 * bottom_y_px, bottom_y_px], [a2 + b2 * bottom_y_px, bottom_y_px]]
    across = road_points(road_homography(camera_matrix, vp, 1.0), x_at)[:, 0]  # on a road 1 m down
    if not across[1] > across[0]:
        raise LaneFinderError("the right line is not right of the left one")
    height = lane_width_m / float(across[1] - across[0])
    return RoadEstimate(camera_matrix=np.asarray(camera_matrix, np.float64), vp=vp, height_m=height,
                        centre_m=float(across.mean()) * height, focal_source="camera file", evidence=())


def _image_points(g: np.ndarray, road: np.ndarray) -> np.ndarray:
    p = np.column_stack([np.asarray(road, np.float64).reshape(-1, 2), np.ones(len(road))]) @ g.T
    return p[:, :2] / p[:, 2:]


def _sample_road(gray: np.ndarray, g: np.ndarray, xs_m: np.ndarray, zs_m: np.ndarray) -> np.ndarray:
    """Sample a grey image on the road grid (rows: ``zs_m``, columns: ``xs_m``); 0 outside it."""
    xx, zz = np.meshgrid(xs_m, zs_m)
    p = np.stack([xx, zz, np.ones_like(xx)], axis=-1) @ g.T
    with np.errstate(divide="ignore", invalid="ignore"):
        mx = (p[..., 0] / p[..., 2]).astype(np.float32)
        my = (p[..., 1] / p[..., 2]).astype(np.float32)
    bad = ~np.isfinite(mx) | ~np.isfinite(my)
    mx[bad], my[bad] = -10, -10
    return cv2.remap(gray, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0).astype(np.float32)


# -- one frame ---------------------------------------------------------------------------
def prepare_frame(frame: np.ndarray, camera: CameraModel | None, work_width_px: int) -> tuple[np.ndarray, float]:
    """Shrink a frame to the working width (never enlarge it) and undo the lens.

    Parameters
    ----------
    frame : (H, W, 3) uint8 ndarray
        A raw frame, BGR.
    camera : CameraModel or None
        Its lens (None: no distortion model).
    work_width_px : int
        The widest frame worked on.

    Returns
    -------
    image : (h, w, 3) uint8 ndarray
        The undistorted frame at the working size.
    scale : float
        Working pixels per frame pixel (at most 1).

    Examples
    --------
    >>> img, s = prepare_frame(np.zeros((1080, 1920, 3), np.uint8), None, 1280)
    >>> img.shape, round(s, 4)
    ((720, 1280, 3), 0.6667)
    """
    h, w = frame.shape[:2]
    s = min(1.0, work_width_px / w)
    img = frame
    if s < 1.0:
        img = cv2.resize(frame, (round(w * s), round(h * s)), interpolation=cv2.INTER_AREA)
        s = img.shape[1] / w
    if camera is not None:
        cam = camera.scaled_to((img.shape[1], img.shape[0]))
        if cam.has_distortion:
            img = cam.undistort(img)
    return img, s


def frame_evidence(undistorted: np.ndarray, opts: SetupOptions, index: int = 0) -> FrameEvidence:
    """Look at one frame: its vanishing point and ego lines, or the reason it cannot serve.

    Parameters
    ----------
    undistorted : (H, W, 3) uint8 ndarray
        The frame (from :func:`prepare_frame`), BGR.
    opts : SetupOptions
        Thresholds.
    index : int, optional
        The frame's place among those offered.

    Returns
    -------
    FrameEvidence
        Accepted with its lines, or refused with a reason.

    Examples
    --------
    >>> frame_evidence(np.zeros((360, 640, 3), np.uint8), SetupOptions()).reason
    'too few line segments: not a road frame with visible lane lines'
    """
    try:
        return FrameEvidence(index=index, lines=frame_lines(undistorted, opts))
    except LaneFinderError as e:
        return FrameEvidence(index=index, lines=None, reason=str(e))


def _frame_plane(k: np.ndarray, fl: FrameLines, lane_width_m: float) -> tuple[np.ndarray, float, float, float]:
    """Give one frame's road homography, camera height and its lines' lateral places (m)."""
    g1 = road_homography(k, fl.vp, 1.0)
    (xl, _), (xr, _) = road_points(g1, [[fl.left_bottom_x, fl.bottom_y], [fl.right_bottom_x, fl.bottom_y]])
    height = lane_width_m / (xr - xl) if xr > xl else math.nan
    return road_homography(k, fl.vp, height), height, xl * height, xr * height


def _z_range(g: np.ndarray, fl: FrameLines, far_fraction: float) -> tuple[float, float]:
    """Give the distances ahead of the bottom row and of the row ``far_fraction`` down from the horizon."""
    vx, vy = fl.vp
    y_far = vy + far_fraction * (fl.bottom_y - vy)
    (_, z_lo), (_, z_hi) = road_points(g, [[vx, fl.bottom_y], [vx, y_far]])
    return float(z_lo), float(z_hi)


def _marking_strip(gray: np.ndarray, g: np.ndarray, x_m: float, zs: np.ndarray, half_m: float,
                   step_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Give a strip of the road around ``x_m`` with the road's level (row median) taken off, and its columns (m)."""
    xs = x_m + np.arange(-half_m, half_m + step_m / 2, step_m)
    strip = _sample_road(gray, g, xs, zs)
    return strip - np.median(strip, axis=1, keepdims=True), xs


def _dash_profile(gray: np.ndarray, g: np.ndarray, x_m: float, z_lo: float, z_hi: float,
                  opts: SetupOptions) -> np.ndarray | None:
    """Give the 0/1 marking profile along a line (``dash_step_m`` apart), or None when not dashed."""
    zs = np.arange(z_lo, z_hi, opts.dash_step_m)
    if zs.size < 20:
        return None
    strip, xs = _marking_strip(gray, g, x_m, zs, 1.0, 0.05)
    near = np.abs(xs - x_m) <= 0.2
    on = (strip[:, near].max(axis=1) > opts.marking_contrast).astype(np.float64)
    lo, hi = opts.dash_fill_range
    return on if lo <= on.mean() <= hi else None


def _clean_dashes(p: np.ndarray, run_lo: float, run_hi: float, step_m: float) -> np.ndarray | None:
    """Keep only the dash-long runs of a 0/1 profile (drop raised markers and speckle); None if solid."""
    edges = np.diff(np.concatenate([[0], (p > 0).astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    length = (ends - starts) * step_m
    cut = (starts == 0) | (ends == p.size)
    if np.any(length > run_hi):
        return None
    # Raised markers in the gaps look like short dashes far away (blur lengthens them): a dash
    # is also at least half as long as the longest whole run.
    whole = length[~cut]
    lo = max(run_lo, 0.5 * float(whole.max())) if whole.size else run_lo
    keep = (length >= lo) | cut
    out = np.zeros(p.size)
    for s0, e0 in zip(starts[keep], ends[keep], strict=True):
        out[s0:e0] = 1
    return out if 0 < out.sum() < out.size else None


def _autocorrelation(p: np.ndarray, size: int) -> np.ndarray:
    """Unbiased, normalised autocorrelation of a profile, ``size`` lags."""
    c = p - p.mean()
    n = c.size
    ac = np.correlate(c, c, "full")[n - 1:n - 1 + size]
    return ac / ac[0] * n / (n - np.arange(ac.size))


def _first_peak(ac: np.ndarray, first: int, last: int, min_corr: float) -> float | None:
    """Give the first clear local maximum of an autocorrelation in [first, last], to a fraction of a lag."""
    peaks = [i for i in range(max(first, 1), min(last, ac.size - 2) + 1)
             if ac[i] >= ac[i - 1] and ac[i] > ac[i + 1] and ac[i] >= min_corr]
    if not peaks:
        return None
    best = max(ac[i] for i in peaks)
    i = next(i for i in peaks if ac[i] >= 0.7 * best)
    a, b, c = ac[i - 1], ac[i], ac[i + 1]
    return i + (0.5 * (a - c) / (a - 2 * b + c) if a - 2 * b + c < 0 else 0.0)


def dash_period_m(profiles: Sequence[np.ndarray], step_m: float, opts: SetupOptions,
                  expected_m: float | None = None) -> tuple[float, float, int] | None:
    """Find the period of dashed lines by the autocorrelation of their dashes.

    Runs of marking shorter than a dash (``dash_length_m``: raised pavement markers,
    speckle) are dropped first, and a profile with a run longer than a dash (solid line) is
    left out.  The period is the first clear peak of the profiles' mean autocorrelation,
    within ``dash_period_range_m`` (or, given ``expected_m``, within 0.7-1.4 times it).

    Parameters
    ----------
    profiles : sequence of 1-D ndarray
        0/1 marking along lines, ``step_m`` apart.
    step_m : float
        Their step, m.
    opts : SetupOptions
        Dash lengths, periods and the correlation needed.
    expected_m : float, optional
        The period found so far, m.

    Returns
    -------
    (period_m, relative_error, count) or None
        The period, its relative standard error (from the profiles' own peaks when three or
        more have one, else 10%) and how many profiles it rests on; None without one.

    Examples
    --------
    >>> z = np.arange(0, 40, 0.1)
    >>> p = ((z % 12) < 3).astype(float)
    >>> period, err, n = dash_period_m([p], 0.1, SetupOptions())
    >>> round(period, 1), n
    (12.0, 1)
    """
    if expected_m is None:
        run_lo, run_hi = opts.dash_length_m[0] * 0.8, opts.dash_length_m[1] * 2
        lo_m, hi_m = opts.dash_period_range_m
    else:
        run_lo, run_hi = opts.dash_length_m
        lo_m, hi_m = 0.7 * expected_m, 1.4 * expected_m
    clean = [c for c in (_clean_dashes(p, run_lo, run_hi, step_m) for p in profiles) if c is not None]
    # A lag needs 1.25 periods of profile behind it.
    clean = [c for c in clean if c.size * step_m >= 1.25 * lo_m]
    if not clean:
        return None
    size = int(hi_m / step_m) + 2
    first = math.ceil(lo_m / step_m)
    acs = [_autocorrelation(c, min(size, c.size)) for c in clean]
    total = np.zeros(size)
    count = np.zeros(size)
    for ac in acs:
        last = min(ac.size, int(ac.size * 0.8) + 1)  # lags beyond 80% of a profile rest on too little
        total[:last] += ac[:last]
        count[:last] += 1
    reach = int(np.flatnonzero(count > 0)[-1]) + 1
    mean = total[:reach] / count[:reach]
    lag = _first_peak(mean, first, reach - 2, opts.min_dash_correlation)
    if lag is None:
        return None
    period = lag * step_m
    own = [x for x in (_first_peak(ac, int(0.7 * lag), int(1.4 * lag) + 1, opts.min_dash_correlation)
                       for ac in acs) if x is not None]
    # With fewer than three profiles the spread cannot be measured: a misread dash pattern is
    # then as likely as not, and the error stated is a tenth of the period.
    err = (1.2533 * _spread(np.array(own) * step_m) / period / math.sqrt(len(own)) if len(own) >= 3
           else _FEW_PROFILES_ERROR)
    return float(period), float(max(err, step_m / period / 2)), len(clean)


def line_curvature(gray: np.ndarray, g: np.ndarray, x_m: float, z_lo: float, z_hi: float,
                   opts: SetupOptions) -> tuple[float, float, float] | None:
    """Measure a line's curvature on the road: a parabola through its markings, in metres.

    Parameters
    ----------
    gray : (H, W) uint8 ndarray
        The undistorted frame, grey.
    g : (3, 3) ndarray
        The frame's road homography.
    x_m : float
        The line's lateral place at the car, m.
    z_lo, z_hi : float
        The stretch ahead followed, m.
    opts : SetupOptions
        Strip width, row step, rows needed and the contrast of a marking.

    Returns
    -------
    (curvature_per_m, standard_error, slope) or None
        2a of x = a z^2 + b z + c, 1/m, its standard error from the fit's residuals, and b
        (the line's direction at the car against the frame's road direction, radians); None
        with too few rows of marking.

    Examples
    --------
    >>> k = np.array([[1000.0, 0, 640], [0, 1000.0, 360], [0, 0, 1]])
    >>> g = road_homography(k, (640.0, 360.0), 1.5)
    >>> img = np.full((720, 1280), 80, np.uint8)
    >>> _ = cv2.line(img, (440, 719), (640, 360), 230, 5)
    >>> kappa, se, slope = line_curvature(img, g, -1.5, 6.0, 40.0, SetupOptions())
    >>> abs(kappa) < 1e-4
    True
    """
    zs = np.arange(z_lo, z_hi, opts.bend_step_m)
    strip, xs = _marking_strip(gray, g, x_m, zs, opts.bend_strip_m, 0.03)
    best = strip.argmax(axis=1)
    ok = strip[np.arange(zs.size), best] > opts.marking_contrast
    if ok.sum() < opts.min_bend_rows or np.ptp(zs[ok]) < 0.4 * (z_hi - z_lo):
        return None
    z, x = zs[ok], xs[best[ok]]
    # One robust pass: drop rows far off a first fit (a car, a seam, the next line).
    coef = np.polyfit(z, x, 2)
    res = x - np.polyval(coef, z)
    keep = np.abs(res) < max(0.1, 3 * 1.4826 * np.median(np.abs(res)))
    if keep.sum() < opts.min_bend_rows:
        return None
    coef, cov = np.polyfit(z[keep], x[keep], 2, cov="unscaled")
    res = x[keep] - np.polyval(coef, z[keep])
    dof = max(1, int(keep.sum()) - 3)
    sigma2 = max(float(res @ res) / dof, 0.03 ** 2)  # a column is 3 cm wide
    return float(2 * coef[0]), float(2 * math.sqrt(cov[0, 0] * sigma2)), float(coef[1])


# -- many frames -------------------------------------------------------------------------
def _spread(values: np.ndarray) -> float:
    return float(1.4826 * np.median(np.abs(values - np.median(values)))) if values.size else 0.0


def _refuse(evidence: list[FrameEvidence], bad: dict[int, str]) -> list[FrameEvidence]:
    return [replace(e, reason=bad[e.index]) if e.index in bad else e for e in evidence]


def _outliers(evidence: list[FrameEvidence], k: np.ndarray, width_px: int, opts: SetupOptions) -> dict[int, str]:
    """Refuse frames whose height is implausible, or whose vanishing point or height stray from the rest."""
    acc = [e for e in evidence if e.accepted]
    bad = {}
    heights = {}
    for e in acc:
        _, hgt, _, _ = _frame_plane(k, e.lines, opts.lane_width_m)
        lo, hi = opts.height_range_m
        if not lo <= hgt <= hi:
            bad[e.index] = (f"the lines are not one lane's width apart (they imply a camera {hgt:.2f} m over the "
                            f"road; {lo}-{hi} m is allowed)" if math.isfinite(hgt) else "the lines cross")
        else:
            heights[e.index] = hgt
    good = [e for e in acc if e.index in heights]
    if len(good) >= 3:
        vps = np.array([e.lines.vp for e in good])
        hs = np.array([heights[e.index] for e in good])
        med, hmed = np.median(vps, axis=0), float(np.median(hs))
        floor = opts.vp_floor_fraction * width_px
        sx, sy = max(_spread(vps[:, 0]), floor), max(_spread(vps[:, 1]), floor)
        sh = max(_spread(hs) / hmed, opts.height_floor)
        t = opts.outlier_sigmas
        for e, (x, y), hgt in zip(good, vps, hs, strict=True):
            if abs(x - med[0]) > t * sx or abs(y - med[1]) > t * sy:
                bad[e.index] = (f"its vanishing point ({x:.0f}, {y:.0f}) is far from the others' "
                                f"({med[0]:.0f}, {med[1]:.0f}): a bump, a hill or a turn")
            elif abs(hgt / hmed - 1) > t * sh:
                bad[e.index] = (f"its lane reads {100 * (hgt / hmed - 1):+.0f}% off the others' width: "
                                "another lane, or the lines misread")
    return bad


def _dash_focal(evidence: list[FrameEvidence], grays: dict[int, np.ndarray], k: np.ndarray,
                opts: SetupOptions, corrected: bool = False) -> tuple[np.ndarray, float, int]:
    """Correct K's focal length until the dashes repeat every ``dash_period_m``; with its relative error.

    With ``corrected`` (K already corrected once, on a larger set of frames) the period is only
    looked for near ``dash_period_m``, so that a multiple of it is not taken for it.
    """
    k = k.copy()
    expected, found = (opts.dash_period_m if corrected else None), None
    for _ in range(4):
        profiles = []
        for e in evidence:
            if not e.accepted:
                continue
            g, _, xl, xr = _frame_plane(k, e.lines, opts.lane_width_m)
            z_lo, z_hi = _z_range(g, e.lines, opts.dash_far_fraction)
            profiles += [p for p in (_dash_profile(grays[e.index], g, x, z_lo, z_hi, opts) for x in (xl, xr))
                         if p is not None]
        found = dash_period_m(profiles, opts.dash_step_m, opts, expected)
        if found is None:
            n = sum(e.accepted for e in evidence)
            raise LaneFinderError(
                f"cannot measure the along-road scale without a camera file: no dashed lane line repeats in the "
                f"{n} usable frame(s); give the camera file (--camera) or frames with a dashed line")
        factor = opts.dash_period_m / found[0]
        k[0, 0] *= factor
        k[1, 1] *= factor
        expected = opts.dash_period_m
        if abs(factor - 1) < 0.002:
            break
    return k, found[1], found[2]


def _curved(evidence: list[FrameEvidence], grays: dict[int, np.ndarray], k: np.ndarray,
            opts: SetupOptions) -> tuple[list[FrameEvidence], dict[int, str]]:
    """Measure each accepted frame's curvature; refuse those that are significantly curved.

    The segments of a gently curved road meet at the direction of the road some way ahead,
    not at the car: each frame's vanishing point is turned to its lines' direction at the car.
    """
    out, bad = [], {}
    for e in evidence:
        if not e.accepted:
            out.append(e)
            continue
        g, _, xl, xr = _frame_plane(k, e.lines, opts.lane_width_m)
        z_lo, z_hi = _z_range(g, e.lines, opts.dash_far_fraction)
        z_hi = min(z_hi, max(opts.lookahead_m, 2 * z_lo))
        fits = [f for f in (line_curvature(grays[e.index], g, x, z_lo, z_hi, opts) for x in (xl, xr)) if f]
        if not fits:
            out.append(e)
            continue
        w = np.array([1 / se ** 2 for _, se, _ in fits])
        kappa = float(np.sum([c for c, _, _ in fits] * w) / w.sum())
        slope = float(np.sum([b for _, _, b in fits] * w) / w.sum())
        se = float(1 / math.sqrt(w.sum()))
        vx, vy = e.lines.vp
        # Turn the vanishing point only where the curve is measurable (on a straight road b is noise).
        turn = k[0, 0] * slope if abs(kappa) > opts.curvature_sigmas * se else 0.0
        out.append(replace(e, curvature_per_m=kappa, lines=replace(e.lines, vp=(vx + turn, vy))))
        if abs(kappa) > opts.max_curvature_per_m + opts.curvature_sigmas * se:
            bad[e.index] = (f"the road curves (radius about {1 / abs(kappa):.0f} m, "
                            f"{'left' if kappa < 0 else 'right'}): not a straight road")
    return out, bad


def estimate_road(evidence: Sequence[FrameEvidence], grays: dict[int, np.ndarray], work_size: tuple[int, int],
                  camera_matrix: np.ndarray | None, opts: SetupOptions, work_scale: float = 1.0) -> RoadEstimate:
    """Combine frames into one road plane: refuse outliers and curves, measure f where unknown.

    Parameters
    ----------
    evidence : sequence of FrameEvidence
        From :func:`frame_evidence`, one per frame offered.
    grays : dict of int to (h, w) uint8 ndarray
        The accepted frames' undistorted grey images, by ``FrameEvidence.index``.
    work_size : tuple of int
        (width, height) of those images, pixels.
    camera_matrix : (3, 3) ndarray or None
        K at the working size, or None to measure the focal length from the dashes (the
        principal point then sits at the image centre).
    opts : SetupOptions
        Assumptions and thresholds.
    work_scale : float, optional
        Working pixels per frame pixel (kept in the result).

    Returns
    -------
    RoadEstimate
        The medians of the accepted frames, with their standard errors and every frame's
        verdict.

    Raises
    ------
    LaneFinderError
        When fewer than ``opts.min_frames`` frames are accepted (with the reasons), or the
        focal length cannot be measured.

    Examples
    --------
    >>> import cv2
    >>> img = cv2.imread("data/test_images/straight_lines1.jpg")
    >>> ev = frame_evidence(img, SetupOptions())
    >>> k = np.array([[1156.9, 0, 665.9], [0, 1152.8, 388.8], [0, 0, 1]])
    >>> est = estimate_road([ev], {0: cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)}, (1280, 720), k, SetupOptions())
    >>> round(est.height_m, 1), est.frames_used
    (1.2, 1)
    """
    w, h = work_size
    ev = list(evidence)
    known = camera_matrix is not None
    if known:
        k = np.asarray(camera_matrix, np.float64)
    else:
        f = opts.focal_guess_fraction * w
        k = np.array([[f, 0, (w - 1) / 2], [0, f, (h - 1) / 2], [0, 0, 1.0]])

    def check(evs: list[FrameEvidence]) -> None:
        if sum(e.accepted for e in evs) < opts.min_frames:
            reasons = sorted({e.reason for e in evs if e.reason})
            raise LaneFinderError(f"no usable straight-road frame among {len(evs)}: " + "; ".join(reasons[:3]))

    check(ev)
    focal_sigma, source = 0.0, "camera file"
    for attempt in range(2):
        ev = _refuse(ev, _outliers(ev, k, w, opts))
        check(ev)
        if not known:
            k, focal_sigma, n = _dash_focal(ev, grays, k, opts, corrected=attempt > 0)
            source = f"dash period ({n} dashed-line profile(s), {opts.dash_period_m} m)"
        ev, bad = _curved(ev, grays, k, opts)
        ev = _refuse(ev, bad)
        check(ev)
        if not bad:
            break
    acc = [e for e in ev if e.accepted]
    planes = [_frame_plane(k, e.lines, opts.lane_width_m) for e in acc]
    vps = np.array([e.lines.vp for e in acc])
    hs = np.array([p[1] for p in planes])
    centres = np.array([(p[2] + p[3]) / 2 for p in planes])
    n = len(acc)
    se = 1.2533 / math.sqrt(n)
    floor = opts.vp_floor_fraction * w
    height = float(np.median(hs))
    return RoadEstimate(camera_matrix=k, vp=(float(np.median(vps[:, 0])), float(np.median(vps[:, 1]))),
                        height_m=height, centre_m=float(np.median(centres)), focal_source=source,
                        evidence=tuple(ev),
                        vp_sigma_px=(se * max(_spread(vps[:, 0]), floor), se * max(_spread(vps[:, 1]), floor)),
                        height_sigma=se * max(_spread(hs) / height, opts.height_floor),
                        focal_sigma=focal_sigma, work_scale=work_scale)


def nominal_setup(camera: CameraModel, frame_size: tuple[int, int], pitch_deg: float, yaw_deg: float,
                  height_m: float, opts: SetupOptions | None = None) -> BirdseyeConfig:
    """Give the set-up of a lens mounted as given: the camera pitched, turned, at a height.

    For a lens without a set-up of its own: the starting set-up until self-calibration has an
    estimate (the default set-up's trapezoid is the Udacity lens's, and with another focal
    length it is no rectangle on the road).

    Parameters
    ----------
    camera : CameraModel
        The lens (scaled to ``frame_size`` here).
    frame_size : tuple of int
        (width, height) of the frames, pixels.
    pitch_deg : float
        How far the camera looks down, degrees (the horizon that far above the principal point's
        row; negative: looking up).
    yaw_deg : float
        How far it is turned left, degrees (the road's vanishing point that far right of the
        principal point's column).
    height_m : float
        The camera's height over the road, m.
    opts : SetupOptions, optional
        The view's reach and the lane width.

    Returns
    -------
    BirdseyeConfig
        The set-up for frames of ``frame_size``, the car in the lane's centre.

    Raises
    ------
    LaneFinderError
        When the horizon lies below the view's bottom row (``opts.bottom_fraction`` of the
        frame's height), or that row lies beyond the view's reach (:func:`view_from_estimate`).

    Examples
    --------
    >>> cam = CameraModel.ideal((1920, 1080), hfov_deg=90.0)
    >>> b = nominal_setup(cam, (1920, 1080), -1.5, 0.0, 1.3)
    >>> b.reference_size, b.size, [round(v) for v in b.src[0]]
    ((1920, 1080), (400, 300), [909, 600])
    """
    k = camera.scaled_to(frame_size).camera_matrix
    vp = (float(k[0, 2] + k[0, 0] * math.tan(math.radians(yaw_deg))),
          float(k[1, 2] - k[1, 1] * math.tan(math.radians(pitch_deg))))
    opts = opts or SetupOptions()
    if not vp[1] < opts.bottom_fraction * (frame_size[1] - 1):
        raise LaneFinderError(f"with this lens a camera pitched {pitch_deg:+.2f} degrees has its horizon below the "
                              "view's bottom row: no road ahead to see")
    est = RoadEstimate(camera_matrix=k, vp=vp, height_m=height_m, centre_m=0.0, focal_source="camera file",
                       evidence=())
    return view_from_estimate(est, frame_size, opts)[0]


def view_from_estimate(est: RoadEstimate, frame_size: tuple[int, int],
                       opts: SetupOptions) -> tuple[BirdseyeConfig, np.ndarray, SetupQuality]:
    """Give the bird's-eye set-up of a road estimate, K at the frame size, and the set-up's quality.

    The view runs from the bottom row (``bottom_fraction``) to ``lookahead_m`` ahead, the
    lane (``lane_width_m``, 150 px) centred in the default 400x300 view.

    Parameters
    ----------
    est : RoadEstimate
        The combined road plane.
    frame_size : tuple of int
        (width, height) of the frames, pixels.
    opts : SetupOptions
        The view's reach and the lane width.

    Returns
    -------
    birdseye : BirdseyeConfig
        The set-up for frames of ``frame_size``.
    camera_matrix : (3, 3) ndarray
        K at the frame size.
    quality : SetupQuality
        Frames, agreement and the expected errors.

    Raises
    ------
    LaneFinderError
        When the bottom row already lies beyond ``lookahead_m``.

    Examples
    --------
    >>> k = np.array([[1000.0, 0, 639.5], [0, 1000.0, 359.5], [0, 0, 1]])
    >>> est = RoadEstimate(camera_matrix=k, vp=(639.5, 340.0), height_m=1.3, centre_m=0.0,
    ...                    focal_source="camera file", evidence=())
    >>> b, _, q = view_from_estimate(est, (1280, 720), SetupOptions())
    >>> b.size, round(b.xm_per_px, 5), round(b.ym_per_px, 4)
    ((400, 300), 0.02467, 0.1038)
    """
    s = est.work_scale
    k = est.camera_matrix
    g = road_homography(k, est.vp, est.height_m)
    h_work = round(frame_size[1] * s)
    y_b = opts.bottom_fraction * (h_work - 1)
    z_near = float(road_points(g, [[est.vp[0], y_b]])[0, 1])
    z_far = opts.lookahead_m
    if not z_far > z_near + 5:
        raise LaneFinderError(f"the bottom row is already {z_near:.1f} m ahead, so a view to {z_far:g} m is too "
                              "short: give a longer --lookahead or a lower --bottom")
    half, c = opts.lane_width_m / 2, est.centre_m
    corners = _image_points(g, np.array([[c - half, z_far], [c + half, z_far], [c + half, z_near],
                                         [c - half, z_near]]))
    src = (corners + 0.5) / s - 0.5
    k_full = k.copy()
    k_full[0, 0] /= s
    k_full[1, 1] /= s
    k_full[:2, 2] = (k[:2, 2] + 0.5) / s - 0.5
    try:
        b = BirdseyeConfig(reference_size=(int(frame_size[0]), int(frame_size[1])),
                           src=tuple((round(float(x), 2), round(float(y), 2)) for x, y in src),
                           size=VIEW_SIZE_PX, dst=default_dst(VIEW_SIZE_PX, LANE_SPAN_PX),
                           xm_per_px=opts.lane_width_m / LANE_SPAN_PX, ym_per_px=(z_far - z_near) / VIEW_SIZE_PX[1])
    except ValidationError as e:  # a lens so wide (or a road so placed) that the view's corners fold
        first = e.errors()[0] if e.errors() else {}
        raise LaneFinderError(f"no bird's-eye view can be made of this road in this frame: "
                              f"{first.get('msg', 'invalid trapezoid')}") from None
    acc = [e for e in est.evidence if e.accepted]
    vps = np.array([e.lines.vp for e in acc]) / s if acc else np.zeros((0, 2))
    hs = np.array([_frame_plane(k, e.lines, opts.lane_width_m)[1] for e in acc])
    f = float(k[0, 0])
    z_mid = (z_near + z_far) / 2
    pitch_rel = est.vp_sigma_px[1] * z_mid / (f * est.height_m)
    q = SetupQuality(
        frames_used=len(acc), frames_offered=len(est.evidence),
        vp_spread_px=(_spread(vps[:, 0]), _spread(vps[:, 1])) if acc else (0.0, 0.0),
        height_spread=_spread(hs) / est.height_m if acc else 0.0,
        xm_error_pct=100 * est.height_sigma,
        ym_error_pct=100 * math.sqrt(est.focal_sigma ** 2 + est.height_sigma ** 2 + pitch_rel ** 2),
        car_error_m=est.height_m * est.vp_sigma_px[0] / (y_b - est.vp[1]),
        refusals=tuple(f"frame {e.index + 1}: {e.reason}" for e in est.evidence if not e.accepted))
    return b, k_full, q


#: The median ``FrameLines.standout`` of the frames a set-up is made from must reach this: the
#: Udacity videos' straight frames give 38-240 (and infinite), stills of them upside down 2-4.
MIN_LINE_STANDOUT = 5.0


def auto_setup(frames: Iterable[np.ndarray], camera: CameraModel | None, opts: SetupOptions | None = None,
               camera_ref: str = "none") -> SetupResult:
    """Find the bird's-eye set-up and its scale from straight-road frames.

    Each frame is accepted or refused on its own (the reasons are in ``result.quality``);
    the accepted ones are combined robustly.

    Parameters
    ----------
    frames : iterable of (H, W, 3) uint8 ndarray
        Road frames, BGR, all the same size; curved or odd ones are refused, not fatal.
    camera : CameraModel or None
        The calibrated camera; None for no distortion model, the principal point at the image
        centre and the focal length measured from the dashes.
    opts : SetupOptions, optional
        The assumptions and thresholds; default :class:`SetupOptions`.
    camera_ref : str, optional
        The camera file's name, written into the config.

    Returns
    -------
    SetupResult
        The set-up, what it is based on and how good it is.

    Raises
    ------
    LaneFinderError
        When there are no frames, sizes differ, no frame shows straight road, or (without a
        camera file) no dashed line fixes the focal length.

    Examples
    --------
    >>> import cv2
    >>> frames = [cv2.imread(f"data/test_images/straight_lines{i}.jpg") for i in (1, 2)]
    >>> result = auto_setup(frames, None)
    >>> result.birdseye.size, result.ym_source
    ((400, 300), 'dash period (2 dashed-line profile(s), 12.2 m)')
    """
    opts = opts or SetupOptions()
    evidence: list[FrameEvidence] = []
    grays: dict[int, np.ndarray] = {}
    size = work = None
    scale = 1.0
    for i, frame in enumerate(frames):
        if size is None:
            size = (frame.shape[1], frame.shape[0])
        elif (frame.shape[1], frame.shape[0]) != size:
            raise LaneFinderError("all frames must have the same size")
        und, scale = prepare_frame(frame, camera, opts.work_width_px)
        work = (und.shape[1], und.shape[0])
        ev = frame_evidence(und, opts, i)
        evidence.append(ev)
        if ev.accepted:
            grays[i] = cv2.cvtColor(und, cv2.COLOR_BGR2GRAY)
    if size is None or work is None:
        raise LaneFinderError("no frames given")
    standouts = [e.lines.standout for e in evidence if e.accepted and e.lines is not None]
    if standouts and float(np.median(standouts)) < MIN_LINE_STANDOUT:
        raise LaneFinderError(f"the lines found stand out only {float(np.median(standouts)):.1f} times from the "
                              f"texture beside them (lane lines: {MIN_LINE_STANDOUT:g} times or more, in "
                              f"{len(standouts)} frame(s)): is the footage upside down or sideways, or not of a road?")
    k = camera.scaled_to(work).camera_matrix if camera is not None else None
    est = estimate_road(evidence, grays, work, k, opts, scale)
    birdseye, k_full, quality = view_from_estimate(est, size, opts)
    notes = []
    if camera is None:
        notes.append("no camera file: no distortion model, the principal point at the image centre, and the focal "
                     f"length measured from the dashes ({k_full[0, 0]:.0f} px)")
    kappas = [abs(e.curvature_per_m) for e in est.evidence if e.accepted and math.isfinite(e.curvature_per_m)]
    length_m = birdseye.ym_per_px * birdseye.size[1]
    sagitta_px = max(kappas, default=0.0) * length_m ** 2 / 8 / birdseye.xm_per_px
    vp = tuple(float((v + 0.5) / scale - 0.5) for v in est.vp)
    return SetupResult(birdseye=birdseye, camera_model=camera_ref, vp=vp, horizon_row=vp[1],
                       frames_used=quality.frames_used, frame_size=size, ym_source=est.focal_source,
                       focal_px=float(k_full[0, 0]), height_m=est.height_m, quality=quality, notes=tuple(notes),
                       straightness_px=float(sagitta_px))


def preview(frame: np.ndarray, result: SetupResult, camera: CameraModel | None) -> np.ndarray:
    """Draw the set-up: the frame with trapezoid and vanishing point, beside the bird's-eye view.

    Parameters
    ----------
    frame : (H, W, 3) uint8 ndarray
        A frame of the camera, BGR.
    result : SetupResult
        The set-up.
    camera : CameraModel or None
        The camera it was found with.

    Returns
    -------
    (H, W + w, 3) uint8 ndarray
        The undistorted frame and the bird's-eye view (its lines marked) scaled to height H.

    Examples
    --------
    >>> import cv2
    >>> frame = cv2.imread("data/test_images/straight_lines1.jpg")
    >>> preview(frame, auto_setup([frame], None), None).shape
    (720, 2240, 3)
    """
    h, w = frame.shape[:2]
    cam = camera.scaled_to((w, h)) if camera else CameraModel.ideal((w, h))
    b = result.birdseye
    be = make_birdseye(cam, np.array(b.src), np.array(b.dst), b.size, b.xm_per_px, b.ym_per_px)
    left = cam.undistort(frame) if cam.has_distortion else frame.copy()
    cv2.polylines(left, [np.round(np.array(b.src)).astype(np.int32)], True, (0, 0, 255), 2, cv2.LINE_AA)
    vx, vy = result.vp
    cv2.circle(left, (round(vx), round(vy)), 6, (0, 255, 255), 2)
    cv2.line(left, (0, round(vy)), (w - 1, round(vy)), (0, 255, 255), 1)
    view = be.warp(frame)
    for x, _ in b.dst[:2]:
        cv2.line(view, (round(x), 0), (round(x), b.size[1] - 1), (0, 0, 255), 1)
    scale = h / view.shape[0]
    view = cv2.resize(view, (round(view.shape[1] * scale), h))
    return np.hstack([left, view])


def straight_frames_from_video(path: str | Path, opts: SetupOptions) -> list[np.ndarray]:
    """Take frames evenly spread over a video for the set-up (it refuses the unsuitable ones).

    Parameters
    ----------
    path : str or Path
        The video.
    opts : SetupOptions
        ``video_candidates`` frames are taken, shrunk to ``work_width_px``.

    Returns
    -------
    list of (H, W, 3) uint8 ndarray
        The raw frames (the set-up undoes the lens), BGR, in order.

    Raises
    ------
    LaneFinderError
        When the video cannot be read.

    Examples
    --------
    >>> opts = SetupOptions(video_candidates=5)
    >>> len(straight_frames_from_video("data/clips/project_37-47s.mp4", opts))
    5
    """
    from .video import VideoInfo, frames

    info = VideoInfo.from_path(path)
    step = max(1, info.total_frames // opts.video_candidates)
    out = []
    for i, f in enumerate(frames(path)):
        if len(out) >= opts.video_candidates:
            break  # nothing more to take: stop decoding
        if i % step == 0:
            out.append(prepare_frame(f.image, None, opts.work_width_px)[0])
    return out
