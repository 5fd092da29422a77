"""A new camera in one step: the bird's-eye view and its scale from straight-road frames.

1. Undistort each frame (with the camera file, or none: no distortion model).
2. Vanishing point: line segments (LSD) below the middle of the frame that lean like lane
   lines, then a robust (RANSAC, then least-squares) intersection.
3. The ego lane's lines: marking pixels (the ridge threshold) voted along rays from the
   vanishing point onto the bottom row; the strongest ray on each side of the camera.
4. Trapezoid: those two lines between the bottom row and the row ``lookahead_m`` ahead;
   rectangle: the default 400x300 view with the lane 150 px wide in its middle.
5. Scale: across, the lane width (3.7 m) over 150 px; along, from the camera geometry (the
   road plane seen through K must be metric: |r1| = |r2|), or without a calibration from the
   dash period (3 m dashes + 9 m gaps).

Frames that are not straight road (segments that do not meet, lines that bend in the
bird's-eye view) are refused with a message.  Every threshold is a documented field of
:class:`SetupOptions`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from .birdseye import make_birdseye, plane_pose
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
    "FrameLines",
    "SetupOptions",
    "SetupResult",
    "auto_setup",
    "frame_lines",
    "line_segments",
    "preview",
    "straight_frames_from_video",
    "vanishing_point",
]


@dataclass(frozen=True)
class SetupOptions:
    """What the set-up assumes of the road, and the thresholds it judges frames by.

    Parameters
    ----------
    lane_width_m : float
        The ego lane's width between line centres, m: the across-road scale.
    lookahead_m : float
        How far ahead the view reaches, m (with a camera file).
    bottom_fraction : float
        The trapezoid's bottom row as a fraction of the frame height (above the hood).
    dash_period_m : float
        Dash plus gap, m: the along-road scale without a camera file.
    min_frames : int
        Straight-road frames needed.
    segment_top_fraction : float
        Line segments are looked for below this fraction of the frame height.
    min_segment_fraction : float
        Shortest segment, as a fraction of the frame height.
    segment_angle_deg : tuple of float
        Segments leaning between these angles from the horizontal, degrees, count.
    ransac_iterations : int
        Pairs of segments tried for the vanishing point.
    ransac_tol_px : float
        A segment passes through a candidate vanishing point within this distance, pixels
        (twice it for the least-squares refinement).
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
        the horizon on each side of the vanishing point (half a lane plus an offset, over
        the camera height, is below 3).
    default_top_fraction : float
        Without a camera file, the trapezoid's top lies this fraction of the way from the
        horizon to the bottom row (the Udacity proportion).
    top_fraction_range : tuple of float
        The trapezoid's top is kept within these fractions of the way down from the horizon.
    dash_strip_px : int
        Half-width of the bird's-eye column searched for dashes, pixels.
    dash_fill_range : tuple of float
        A dashed column has marking on between these fractions of its rows (else solid or
        absent).
    min_dash_period_px : int
        Shortest dash period looked for, bird's-eye pixels.
    min_dash_correlation : float
        The autocorrelation peak a dash period needs.
    bend_bands : int
        Horizontal bands a line's strip is cut into for the straightness check.
    bend_band_share : float
        A band counts when it holds this share of the busiest band's marking pixels (and 5).
    bend_strip_px : int
        Half-width of each line's strip in the straightness check, bird's-eye pixels.
    max_bend_px : float
        The most a line may bend (sagitta) in the new view, pixels.
    video_candidates : int
        Frames of a video looked at for straight road.
    video_keep : int
        Straight-road frames kept from a video.

    Examples
    --------
    >>> opts = SetupOptions(lookahead_m=30.0)
    >>> opts.lane_width_m, opts.max_bend_px
    (3.7, 3.0)
    """

    lane_width_m: float = LANE_WIDTH_M
    lookahead_m: float = 35.0
    bottom_fraction: float = 0.9375
    dash_period_m: float = 12.0
    min_frames: int = 1
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
    default_top_fraction: float = 0.137
    top_fraction_range: tuple[float, float] = (0.05, 0.5)
    dash_strip_px: int = 6
    dash_fill_range: tuple[float, float] = (0.05, 0.85)
    min_dash_period_px: int = 20
    min_dash_correlation: float = 0.3
    bend_bands: int = 10
    bend_band_share: float = 0.3
    bend_strip_px: int = 15
    max_bend_px: float = 3.0
    video_candidates: int = 60
    video_keep: int = 12


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
        The vanishing point (x, y), undistorted pixels.
    horizon_row : float
        The horizon's row, pixels.
    frames_used : int
        Straight-road frames that took part.
    frame_size : tuple of int
        (width, height), pixels.
    ym_source : str
        Where the along-road scale came from.
    notes : tuple of str
        Warnings for the user.
    straightness_px : float
        The most a line bends in the new view, pixels.

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
    notes: tuple[str, ...] = field(default_factory=tuple)
    straightness_px: float = 0.0

    def config(self) -> Config:
        """Give the whole configuration: the defaults with this camera and set-up.

        Returns
        -------
        Config
            Ready for :func:`lanefinder.config.dump_config`.
        """
        return Config(camera=CameraConfig(model=self.camera_model), birdseye=self.birdseye)


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


def vanishing_point(segments: np.ndarray, iterations: int = 500, tol_px: float = 4.0,
                    seed: int = 0) -> tuple[np.ndarray, float]:
    """Intersect segments robustly: RANSAC over pairs, then weighted least squares on the inliers.

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
    rng = np.random.default_rng(seed)
    best, best_score = None, -1.0
    for _ in range(iterations):
        i, j = rng.choice(len(lines), 2, replace=False, p=w / w.sum())
        v = np.cross(lines[i], lines[j])
        if abs(v[2]) < 1e-9:
            continue
        v = v / v[2]
        dist = np.abs(lines @ v)
        score = w[dist < tol_px].sum()
        if score > best_score:
            best, best_score = v, score
    if best is None:
        raise LaneFinderError("the line segments do not meet: not a straight-road frame")
    inl = np.abs(lines @ best) < tol_px * 2
    a = lines[inl, :2] * w[inl, None]
    b = -lines[inl, 2] * w[inl]
    vp, *_ = np.linalg.lstsq(a, b, rcond=None)
    return vp, float(w[inl].sum() / w.sum())


def _ray_votes(undistorted: np.ndarray, vp: np.ndarray, y_b: float,
               opts: SetupOptions) -> tuple[np.ndarray, np.ndarray]:
    """Vote the marking pixels onto the bottom row along rays from the vanishing point."""
    w = undistorted.shape[1]
    mask = ridge(undistorted, ThresholdConfig().ridge, xm_per_px=opts.marking_width_m / max(5, w / 50))
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
    vp, inliers = vanishing_point(line_segments(gray, opts), opts.ransac_iterations, opts.ransac_tol_px)
    if not (0 <= vp[0] < w and 0 < vp[1] < h * opts.max_vp_fraction):
        raise LaneFinderError(f"the lane lines meet at ({vp[0]:.0f}, {vp[1]:.0f}), outside the frame: "
                              "not a straight road ahead")
    y_b = opts.bottom_fraction * (h - 1)
    hist, centres = _ray_votes(undistorted, vp, y_b, opts)
    # The ego lines: the strongest rays within a plausible lane of the middle on each side.
    mid, span = vp[0], (y_b - vp[1]) * opts.lane_span_factor
    left = _strongest_ray(hist, centres, (centres < mid) & (centres > mid - span))
    right = _strongest_ray(hist, centres, (centres > mid) & (centres < mid + span))
    return FrameLines((float(vp[0]), float(vp[1])), left, right, float(y_b), inliers)


def _dash_period_px(binary: np.ndarray, x: float, opts: SetupOptions) -> float | None:
    """Period (px) of the dashes along the bird's-eye column ``x``, by autocorrelation; None if solid/absent."""
    half = opts.dash_strip_px
    col = binary[:, max(0, int(x) - half):int(x) + half + 1].max(axis=1).astype(np.float64)
    lo, hi = opts.dash_fill_range
    if col.mean() < lo or col.mean() > hi:
        return None
    col -= col.mean()
    ac = np.correlate(col, col, "full")[col.size - 1:]
    ac /= ac[0] if ac[0] > 0 else 1
    min_px = opts.min_dash_period_px
    if ac.size <= min_px * 2:
        return None
    lag = int(np.argmax(ac[min_px:])) + min_px
    return float(lag) if ac[lag] > opts.min_dash_correlation else None


def _bend_px(strip: np.ndarray, opts: SetupOptions) -> float:
    """How far a line's markings in a vertical strip bend away from a straight line (px).

    Medians of the marking pixels per horizontal band, a parabola through them, and its sagitta
    over the stretch covered; 0 when fewer than 4 bands hold markings (too little to judge).
    """
    h, bands = strip.shape[0], opts.bend_bands
    found = [np.nonzero(strip[i * h // bands:(i + 1) * h // bands]) for i in range(bands)]
    most = max((bx.size for _, bx in found), default=0)
    ys, xs = [], []
    for i, (by, bx) in enumerate(found):
        # A band counts when it holds marking, not just road speckle: a good share of the busiest band.
        if bx.size >= max(5, opts.bend_band_share * most):
            ys.append(i * h / bands + float(np.median(by)))
            xs.append(float(np.median(bx)))
    if len(ys) < 4:
        return 0.0
    a = np.polyfit(ys, xs, 2)[0]
    return float(abs(a) * np.ptp(ys) ** 2 / 4)  # the sagitta over the stretch covered


def _frames_lines(frames: list[np.ndarray], camera: CameraModel, opts: SetupOptions) -> list[FrameLines]:
    """Find the lines of every frame that shows a straight road; raise when too few do."""
    h, w = frames[0].shape[:2]
    lines, errors = [], []
    for f in frames:
        if f.shape[:2] != (h, w):
            raise LaneFinderError("all frames must have the same size")
        try:
            lines.append(frame_lines(camera.undistort(f) if camera.has_distortion else f, opts))
        except LaneFinderError as e:
            errors.append(str(e))
    if len(lines) < opts.min_frames:
        raise LaneFinderError("no straight-road frame: " + (errors[0] if errors else "nothing usable"))
    return lines


def _trapezoid(lines: list[FrameLines], camera: CameraModel, calibrated: bool,
               opts: SetupOptions) -> tuple[np.ndarray, tuple[tuple[float, float], ...]]:
    """Give the common vanishing point and the road trapezoid between the bottom and top rows."""
    vp = np.median([fl.vp for fl in lines], axis=0)
    y_b = lines[0].bottom_y
    # Each frame's lines as bottom-row x; the set-up's lines run from the common vanishing point.
    xl = float(np.median([fl.left_bottom_x for fl in lines]))
    xr = float(np.median([fl.right_bottom_x for fl in lines]))
    depth = y_b - vp[1]
    if calibrated:
        # Camera geometry: height from the lane width at the bottom row, then the row lookahead_m ahead.
        height_m = opts.lane_width_m * depth / (xr - xl)
        y_t = vp[1] + camera.camera_matrix[1, 1] * height_m / opts.lookahead_m
    else:
        y_t = vp[1] + opts.default_top_fraction * depth  # nothing is known of the lens
    lo, hi = opts.top_fraction_range
    y_t = float(min(max(y_t, vp[1] + lo * depth), vp[1] + hi * depth))

    def x_at(xb: float, y: float) -> float:
        return float(vp[0] + (xb - vp[0]) * (y - vp[1]) / depth)

    return vp, ((x_at(xl, y_t), y_t), (x_at(xr, y_t), y_t), (xr, y_b), (xl, y_b))


def _along_scale(frames: list[np.ndarray], camera: CameraModel, calibrated: bool, src: tuple, dst: tuple,
                 xm: float, opts: SetupOptions) -> tuple[float, str, list[str]]:
    """Give metres per bird's-eye pixel along the road, where that came from, and notes."""
    ym_guess = 0.1
    k = camera.camera_matrix
    m = cv2.getPerspectiveTransform(np.float32(src), np.float32(dst))
    if calibrated:
        return ym_guess / plane_pose(k, m, xm, ym_guess)[3], "camera geometry", []
    be = make_birdseye(camera, np.array(src), np.array(dst), VIEW_SIZE_PX, xm, ym_guess)
    periods = []
    for f in frames:
        binary = ridge(be.warp(f), ThresholdConfig().ridge, xm)
        for x in (dst[0][0], dst[1][0]):
            p = _dash_period_px(binary, x, opts)
            if p:
                periods.append(p)
    if periods:
        return (opts.dash_period_m / float(np.median(periods)),
                f"dash period ({len(periods)} measurement(s), {opts.dash_period_m} m)", [])
    return (ym_guess / plane_pose(k, m, xm, ym_guess)[3],
            "camera geometry with an assumed focal length (no dashes seen): treat with care",
            ["no dashed line seen: the along-road scale assumes a 60 degree field of view"])


def _straightness_px(frames: list[np.ndarray], be, dst: tuple, xm: float, opts: SetupOptions) -> float:
    """Measure the most the markings near either line bend in the new view, pixels."""
    worst, half = 0.0, opts.bend_strip_px
    for f in frames:
        binary = ridge(be.warp(f), ThresholdConfig().ridge, xm)
        for x in (dst[0][0], dst[1][0]):
            worst = max(worst, _bend_px(binary[:, int(x) - half:int(x) + half + 1], opts))
    return worst


def auto_setup(frames: list[np.ndarray], camera: CameraModel | None, opts: SetupOptions | None = None,
               camera_ref: str = "none") -> SetupResult:
    """Find the bird's-eye set-up and its scale from straight-road frames.

    Parameters
    ----------
    frames : list of (H, W, 3) uint8 ndarray
        Straight-road frames, BGR, all the same size.
    camera : CameraModel or None
        The calibrated camera; None for no distortion model, an assumed 60 degree field of
        view and the along-road scale from the dash period.
    opts : SetupOptions, optional
        The assumptions and thresholds; default :class:`SetupOptions`.
    camera_ref : str, optional
        The camera file's name, written into the config.

    Returns
    -------
    SetupResult
        The set-up and what it is based on.

    Raises
    ------
    LaneFinderError
        When there are no frames, sizes differ, or no frame shows straight road.

    Examples
    --------
    >>> import cv2
    >>> frames = [cv2.imread(f"data/test_images/straight_lines{i}.jpg") for i in (1, 2)]
    >>> result = auto_setup(frames, None)
    >>> result.birdseye.size, result.ym_source
    ((400, 300), 'dash period (2 measurement(s), 12.0 m)')
    """
    opts = opts or SetupOptions()
    if not frames:
        raise LaneFinderError("no frames given")
    h, w = frames[0].shape[:2]
    notes = []
    calibrated = camera is not None
    if camera is None:
        camera = CameraModel.ideal((w, h))
        notes.append("no camera file: working with no distortion model and an assumed 60 degree field of view; "
                     "the along-road scale comes from the dash period")
    else:
        camera = camera.scaled_to((w, h))
    lines = _frames_lines(frames, camera, opts)
    vp, src = _trapezoid(lines, camera, calibrated, opts)
    dst = default_dst(VIEW_SIZE_PX, LANE_SPAN_PX)
    xm = opts.lane_width_m / LANE_SPAN_PX
    ym, ym_source, more_notes = _along_scale(frames, camera, calibrated, src, dst, xm, opts)
    notes += more_notes
    cfg = BirdseyeConfig(reference_size=(w, h), src=tuple((round(x, 2), round(y, 2)) for x, y in src),
                         size=VIEW_SIZE_PX, dst=dst, xm_per_px=xm, ym_per_px=float(ym))
    # Straightness check in the new view: markings near each line must run straight down.
    be = make_birdseye(camera, np.array(cfg.src), np.array(dst), VIEW_SIZE_PX, xm, float(ym))
    worst = _straightness_px(frames, be, dst, xm, opts)
    if worst > opts.max_bend_px:
        raise LaneFinderError(f"the lane lines bend by {worst:.0f} px in the bird's-eye view: "
                              "these are not straight-road frames")
    return SetupResult(cfg, camera_ref, (float(vp[0]), float(vp[1])), float(vp[1]), len(lines), (w, h),
                       ym_source, tuple(notes), worst)


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


def straight_frames_from_video(path: str | Path, camera: CameraModel | None,
                               opts: SetupOptions) -> list[np.ndarray]:
    """Pick frames of a video that look like straight road (their lines meet and stay straight).

    Parameters
    ----------
    path : str or Path
        The video.
    camera : CameraModel or None
        The camera, if calibrated.
    opts : SetupOptions
        ``video_candidates`` frames are looked at, evenly spread; the best ``video_keep``
        (by the share of segments through the vanishing point) that pass the set-up are kept.

    Returns
    -------
    list of (H, W, 3) uint8 ndarray
        The frames, BGR, best first.

    Raises
    ------
    LaneFinderError
        When the video cannot be read or shows no straight road.

    Examples
    --------
    >>> opts = SetupOptions(video_candidates=5, video_keep=1)
    >>> len(straight_frames_from_video("data/clips/project_37-47s.mp4", None, opts))
    1
    """
    from .video import VideoInfo, frames

    info = VideoInfo.from_path(path)
    step = max(1, info.total_frames // opts.video_candidates)
    scored = []
    for i, f in enumerate(frames(path)):
        if i % step:
            continue
        img = f.image
        und = camera.scaled_to((img.shape[1], img.shape[0])).undistort(img) if camera else img
        try:
            fl = frame_lines(und, opts)
        except LaneFinderError:
            continue
        scored.append((fl.inlier_fraction, img))
    scored.sort(key=lambda s: -s[0])
    good = []
    for _, img in scored:
        try:
            auto_setup([img], camera, opts)
        except LaneFinderError:
            continue
        good.append(img)
        if len(good) >= opts.video_keep:
            break
    if not good:
        raise LaneFinderError(f"no straight-road frames found in {path}")
    return good
