"""A new camera in one step: the bird's-eye view and its scale from straight-road frames.

1. Undistort each frame (with the camera file, or none: no distortion model).
2. Vanishing point: line segments (LSD) below the middle of the frame that lean like lane
   lines, then a robust (RANSAC, then least-squares) intersection.
3. The ego lane's lines: marking pixels (the ridge threshold) voted along rays from the
   vanishing point onto the bottom row; the strongest ray on each side of the camera.
4. Trapezoid: those two lines between the bottom row and the row ``lookahead_m`` ahead;
   rectangle: the default 400x300 view with the lines at x = 125 and 275.
5. Scale: across, the lane width (3.7 m) over 150 px; along, from the camera geometry (the
   road plane seen through K must be metric: |r1| = |r2|), or without a calibration from the
   dash period (3 m dashes + 9 m gaps).
Frames that are not straight road (segments that do not meet, lines that bend in the
bird's-eye view) are refused with a message.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from .birdseye import make_birdseye, plane_pose
from .camera import CameraModel
from .config import BirdseyeConfig, CameraConfig, Config, ThresholdConfig
from .errors import LaneFinderError
from .threshold import ridge

VIEW = (400, 300)
LANE_PX = 150.0


@dataclass(frozen=True)
class SetupOptions:
    lane_width_m: float = 3.7
    lookahead_m: float = 35.0
    bottom_fraction: float = 0.9375  # bottom row of the trapezoid, as a fraction of the height
    dash_period_m: float = 12.0
    min_frames: int = 1


@dataclass(frozen=True)
class FrameLines:
    """What one straight-road frame gives: the vanishing point and both lines at the bottom row."""

    vp: tuple[float, float]
    left_bottom_x: float
    right_bottom_x: float
    bottom_y: float
    inlier_fraction: float


@dataclass(frozen=True)
class SetupResult:
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
        return Config(camera=CameraConfig(model=self.camera_model), birdseye=self.birdseye)


def _segments(gray: np.ndarray) -> np.ndarray:
    """LSD segments (x1, y1, x2, y2, length) in the lower part of the frame that lean like lane lines."""
    h = gray.shape[0]
    top = int(h * 0.45)
    lsd = cv2.createLineSegmentDetector()
    found = lsd.detect(gray[top:])[0]
    if found is None:
        return np.empty((0, 5))
    seg = found.reshape(-1, 4).astype(np.float64)
    seg[:, [1, 3]] += top
    dx, dy = seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1]
    length = np.hypot(dx, dy)
    angle = np.degrees(np.arctan2(np.abs(dy), np.abs(dx)))
    keep = (length > h * 0.03) & (angle > 20) & (angle < 80)
    return np.column_stack([seg[keep], length[keep]])


def vanishing_point(segments: np.ndarray, iterations: int = 500, tol_px: float = 4.0,
                    seed: int = 0) -> tuple[np.ndarray, float]:
    """Robust intersection of segments: RANSAC over pairs, then weighted least squares on inliers.

    Returns (vp (x, y), fraction of segment length that passes within ``tol_px``).
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


def frame_lines(undistorted: np.ndarray, opts: SetupOptions) -> FrameLines:
    """The vanishing point and the ego lane's lines of one (undistorted) straight-road frame."""
    h, w = undistorted.shape[:2]
    gray = cv2.cvtColor(undistorted, cv2.COLOR_BGR2GRAY)
    vp, inliers = vanishing_point(_segments(gray))
    if not (0 <= vp[0] < w and 0 < vp[1] < h * 0.8):
        raise LaneFinderError(f"the lane lines meet at ({vp[0]:.0f}, {vp[1]:.0f}), outside the frame: "
                              "not a straight road ahead")
    y_b = opts.bottom_fraction * (h - 1)
    # Marking pixels, voted onto the bottom row along rays from the vanishing point.
    mask = ridge(undistorted, ThresholdConfig().ridge, xm_per_px=0.4 / max(5, w / 50))
    y0 = int(vp[1] + 0.1 * (y_b - vp[1]))
    ys, xs = np.nonzero(mask[y0:int(y_b)])
    ys = ys + y0
    if xs.size < 50:
        raise LaneFinderError("no lane markings found below the horizon")
    xb = vp[0] + (xs - vp[0]) * (y_b - vp[1]) / (ys - vp[1])
    hist, edges = np.histogram(xb, bins=int(w * 1.5), range=(-w * 0.25, w * 1.25))
    # Each pixel's vote spreads over the rays it could be on (a marking is a few pixels wide).
    hist = cv2.GaussianBlur(hist.astype(np.float32).reshape(1, -1), (0, 0), sigmaX=max(1.0, w / 400)).ravel()
    centres = (edges[:-1] + edges[1:]) / 2
    mid = vp[0]

    def strongest(sel: np.ndarray) -> float:
        if not sel.any() or hist[sel].max() <= 0:
            raise LaneFinderError("could not find both lane lines: is the car in a marked lane?")
        idx = np.flatnonzero(sel)
        i = idx[int(np.argmax(hist[sel]))]
        lo, hi = max(0, i - 3), min(hist.size, i + 4)  # sub-bin peak
        return float(np.average(centres[lo:hi], weights=hist[lo:hi] + 1e-9))

    # The ego lines: the strongest rays within a plausible lane of the middle on each side.
    span = (y_b - vp[1]) * 3.0  # half a lane plus an offset, over the camera height, is below 3
    left = strongest((centres < mid) & (centres > mid - span))
    right = strongest((centres > mid) & (centres < mid + span))
    return FrameLines((float(vp[0]), float(vp[1])), left, right, float(y_b), inliers)


def _dash_period_px(binary: np.ndarray, x: float, min_px: int = 20) -> float | None:
    """Period (px) of the dashes along the bird's-eye column ``x``, by autocorrelation; None if solid/absent."""
    col = binary[:, max(0, int(x) - 6):int(x) + 7].max(axis=1).astype(np.float64)
    if col.mean() < 0.05 or col.mean() > 0.85:
        return None
    col -= col.mean()
    ac = np.correlate(col, col, "full")[col.size - 1:]
    ac /= ac[0] if ac[0] > 0 else 1
    if ac.size <= min_px * 2:
        return None
    lag = int(np.argmax(ac[min_px:])) + min_px
    return float(lag) if ac[lag] > 0.3 else None


def _bend_px(strip: np.ndarray, bands: int = 10) -> float:
    """How far a line's markings in a vertical strip bend away from a straight line (px).

    Medians of the marking pixels per horizontal band, a parabola through them, and its sagitta
    over the stretch covered; 0 when fewer than 4 bands hold markings (too little to judge).
    """
    h = strip.shape[0]
    found = [np.nonzero(strip[i * h // bands:(i + 1) * h // bands]) for i in range(bands)]
    most = max((bx.size for _, bx in found), default=0)
    ys, xs = [], []
    for i, (by, bx) in enumerate(found):
        # A band counts when it holds marking, not just road speckle: a good share of the busiest band.
        if bx.size >= max(5, 0.3 * most):
            ys.append(i * h / bands + float(np.median(by)))
            xs.append(float(np.median(bx)))
    if len(ys) < 4:
        return 0.0
    a = np.polyfit(ys, xs, 2)[0]
    return float(abs(a) * np.ptp(ys) ** 2 / 4)  # the sagitta over the stretch covered


def auto_setup(frames: list[np.ndarray], camera: CameraModel | None, opts: SetupOptions | None = None,
               camera_ref: str = "none") -> SetupResult:
    """The bird's-eye set-up from straight-road frames (BGR, all the same size)."""
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
    vp = np.median([fl.vp for fl in lines], axis=0)
    y_b = lines[0].bottom_y
    # Each frame's lines as bottom-row x; the set-up's lines run from the common vanishing point.
    xl = float(np.median([fl.left_bottom_x for fl in lines]))
    xr = float(np.median([fl.right_bottom_x for fl in lines]))
    width_b = xr - xl
    k = camera.camera_matrix
    if calibrated:
        # Camera geometry: height from the lane width at the bottom row, then the row lookahead_m ahead.
        height_m = opts.lane_width_m * (y_b - vp[1]) / width_b
        y_t = vp[1] + k[1, 1] * height_m / opts.lookahead_m
    else:
        y_t = vp[1] + 0.137 * (y_b - vp[1])  # the Udacity proportion, when nothing is known of the lens
    y_t = float(min(max(y_t, vp[1] + 0.05 * (y_b - vp[1])), vp[1] + 0.5 * (y_b - vp[1])))

    def x_at(xb: float, y: float) -> float:
        return float(vp[0] + (xb - vp[0]) * (y - vp[1]) / (y_b - vp[1]))

    src = ((x_at(xl, y_t), y_t), (x_at(xr, y_t), y_t), (xr, y_b), (xl, y_b))
    x0 = (VIEW[0] - LANE_PX) / 2
    dst = ((x0, 0.0), (x0 + LANE_PX, 0.0), (x0 + LANE_PX, float(VIEW[1])), (x0, float(VIEW[1])))
    xm = opts.lane_width_m / LANE_PX
    ym_guess = 0.1
    m = cv2.getPerspectiveTransform(np.float32(src), np.float32(dst))
    ym_source = "camera geometry"
    if calibrated:
        _, _, _, ratio = plane_pose(k, m, xm, ym_guess)
        ym = ym_guess / ratio
    else:
        ym = None
        be = make_birdseye(camera, np.array(src), np.array(dst), VIEW, xm, ym_guess)
        periods = []
        for f in frames:
            binary = ridge(be.warp(f), ThresholdConfig().ridge, xm)
            for x in (dst[0][0], dst[1][0]):
                p = _dash_period_px(binary, x)
                if p:
                    periods.append(p)
        if periods:
            ym = opts.dash_period_m / float(np.median(periods))
            ym_source = f"dash period ({len(periods)} measurement(s), {opts.dash_period_m} m)"
        else:
            _, _, _, ratio = plane_pose(k, m, xm, ym_guess)
            ym = ym_guess / ratio
            ym_source = "camera geometry with an assumed focal length (no dashes seen): treat with care"
            notes.append("no dashed line seen: the along-road scale assumes a 60 degree field of view")
    cfg = BirdseyeConfig(reference_size=(w, h), src=tuple((round(x, 2), round(y, 2)) for x, y in src),
                         size=VIEW, dst=dst, xm_per_px=xm, ym_per_px=float(ym))
    # Straightness check in the new view: markings near each line must run straight down.
    be = make_birdseye(camera, np.array(cfg.src), np.array(dst), VIEW, xm, float(ym))
    worst = 0.0
    for f in frames:
        binary = ridge(be.warp(f), ThresholdConfig().ridge, xm)
        for x in (dst[0][0], dst[1][0]):
            worst = max(worst, _bend_px(binary[:, int(x) - 15:int(x) + 16]))
    if worst > 3:
        raise LaneFinderError(f"the lane lines bend by {worst:.0f} px in the bird's-eye view: "
                              "these are not straight-road frames")
    return SetupResult(cfg, camera_ref, (float(vp[0]), float(vp[1])), float(vp[1]), len(lines), (w, h),
                       ym_source, tuple(notes), worst)


def preview(frame: np.ndarray, result: SetupResult, camera: CameraModel | None) -> np.ndarray:
    """Side by side: the frame with the trapezoid and vanishing point, and the bird's-eye view with the lines."""
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


def straight_frames_from_video(path: str | Path, camera: CameraModel | None, opts: SetupOptions,
                               candidates: int = 60, keep: int = 12) -> list[np.ndarray]:
    """Pick frames of a video that look like straight road (their lines meet and stay straight)."""
    from .video import VideoInfo, frames

    info = VideoInfo.from_path(path)
    step = max(1, info.total_frames // candidates)
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
        if len(good) >= keep:
            break
    if not good:
        raise LaneFinderError(f"no straight-road frames found in {path}")
    return good
