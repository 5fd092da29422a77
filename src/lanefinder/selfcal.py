"""Self-calibration: the bird's-eye set-up estimated from the video itself while it runs.

A :class:`SelfCalibrator` looks at one frame in ``selfcal.every_frames`` (after a sure estimate,
or after ``fast_frames`` frames, one in ``refine_every_frames``), shrunk to ``work_width_px`` and
undistorted, exactly as ``lanefinder setup`` looks at a frame
(:func:`lanefinder.autosetup.frame_evidence`): the vanishing point, the ego lines, the camera
height from the lane width.  The most recent
``window_frames`` accepted frames are combined robustly (outliers such as bumps, hills and
lane changes refused, curved frames refused, see :func:`lanefinder.autosetup.estimate_road`)
once ``min_frames`` are in, and again as more come.  An estimate replaces the set-up in use
only when it reads the road differently by more than the ``change_*`` limits
(:func:`lanefinder.evaluate.setup_error`), so a set-up that is right stays exactly as it is,
and, with ``selfcal.estimate_check``, when the frame it came with does not show the lane surer
with the set-up in use (:meth:`SelfCalibrator.offer`'s ``judge``).

The lane lines the pipeline measures tell the pitch too: where their near parts meet is the
horizon on a flat road.  :meth:`SelfCalibrator.offer_lines` keeps that row for each frame with
both lines measured, and once enough frames agree (``selfcal.lines_*``) the set-up in use, and
every later estimate, is pitched to their median.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from contextlib import suppress
from dataclasses import dataclass, replace

import cv2
import numpy as np

from .autosetup import (
    FrameEvidence,
    RoadEstimate,
    SetupOptions,
    SetupQuality,
    estimate_road,
    frame_evidence,
    road_from_lines,
    straight_fits,
    view_from_estimate,
)
from .birdseye import BirdsEye, make_birdseye, setup_of, src_vanishing_point
from .camera import CameraModel
from .config import LANE_WIDTH_M, Config, SelfCalConfig
from .errors import LaneFinderError
from .evaluate import setup_error
from .search import LinePixels

__all__ = ["SelfCalibrator", "SetupState", "StillLook", "horizon_setup", "lines_setup", "look_at_still", "setup_of",
           "still_setup", "wanted"]


@dataclass(frozen=True)
class SetupState:
    """Where the set-up in use comes from, and how sure it is.

    Attributes
    ----------
    source : str
        ``config`` (given by the config), ``default`` (self-calibration has no sure estimate
        yet), ``first-frame`` (the set-up the video's first frame gave alone, as a still's, or two
        early frames agreed on: :meth:`SelfCalibrator.look_again`; in use until a sure estimate),
        ``lines`` (no sure estimate yet; the set-up in use pitched to where the lane lines
        measured meet: :meth:`SelfCalibrator.offer_lines`) or ``estimated``
        (self-calibration's estimate is in use, or a sure estimate confirmed the set-up in use
        or was refused in its favour by the frame check, ``selfcal.estimate_check``).
    frames : int
        Accepted frames the last estimate rests on.
    updates : int
        Times the set-up was replaced.
    horizon_px : float
        The horizon's row (the vanishing point's y) of the set-up in use, frame pixels.
    height_m : float
        The camera's height over the road it implies, m.
    focal_px : float
        Its focal length, frame pixels.
    quality : SetupQuality or None
        The last estimate's quality.
    refused : int
        Sure estimates refused by the frame check (:meth:`SelfCalibrator.offer`'s ``judge``).

    Examples
    --------
    >>> SetupState(source="config").updates
    0
    """

    source: str
    frames: int = 0
    updates: int = 0
    horizon_px: float = math.nan
    height_m: float = math.nan
    focal_px: float = math.nan
    quality: SetupQuality | None = None
    refused: int = 0

    @classmethod
    def of(cls, source: str, be: BirdsEye, **more) -> SetupState:
        """Give the state of a set-up in use: its horizon, camera height and focal length read from it.

        Parameters
        ----------
        source : str
            Where it comes from (see the class).
        be : BirdsEye
            The set-up.
        **more
            The other fields (``frames``, ``updates``, ``quality``, ``refused``).

        Returns
        -------
        SetupState
            The state.

        Examples
        --------
        >>> from lanefinder import LaneFinder
        >>> state = SetupState.of("default", LaneFinder().birdseye((1280, 720)))
        >>> state.source, 400 < state.horizon_px < 480
        ('default', True)
        """
        horizon, height, focal = setup_of(be)
        return cls(source=source, horizon_px=horizon, height_m=height, focal_px=focal, **more)


def wanted(config: Config) -> bool:
    """Tell whether a run with this config self-calibrates: enabled, and no set-up of its own.

    Parameters
    ----------
    config : Config
        The run's configuration.

    Returns
    -------
    bool
        True when ``selfcal.enabled`` and ``birdseye`` is the default.

    Examples
    --------
    >>> wanted(Config()), wanted(Config.model_validate({"selfcal": {"enabled": False}}))
    (True, False)
    """
    return config.selfcal.enabled and not config.has_own_setup()


class SelfCalibrator:
    """Estimate the set-up from the frames of one video, and say when to replace the one in use.

    Parameters
    ----------
    config : Config
        The run's configuration (``selfcal``, ``camera``).
    camera : CameraModel
        The lens (its K gives the focal length unless ``camera.model`` is ``none`` without
        ``focal_px``).
    current : BirdsEye
        The set-up in use at the start.

    Attributes
    ----------
    state : SetupState
        Where the set-up in use comes from.
    last_evidence : FrameEvidence or None
        What the last frame looked at showed (its vanishing point and ego lines, or why it was
        refused); None before the first.
    last_estimate : SetupState or None
        The last estimate made, as a set-up (its horizon, camera height and quality), whether
        or not it was taken; None before the first.
    last_verdict : str
        What became of it: ``taken`` (it replaced the set-up in use), ``confirms`` (sure, and
        reading the road as the set-up in use does), ``refused`` (sure and reading it otherwise,
        but the frame it came with looked worse with it: see :meth:`offer`) or ``unsure`` (none
        of these); empty before the first.

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> be = LaneFinder().birdseye((1280, 720))
    >>> cal = SelfCalibrator(Config(), be.camera, be)
    >>> cal.offer(np.zeros((720, 1280, 3), np.uint8)) is None, cal.state.source
    (True, 'default')
    """

    def __init__(self, config: Config, camera: CameraModel, current: BirdsEye):
        self.config = config
        self.cfg = config.selfcal
        self.current = current
        w, h = current.frame_size
        s = min(1.0, self.cfg.work_width_px / w)
        self.work = (round(w * s), round(h * s))
        self.scale = self.work[0] / w
        self.camera = camera.scaled_to((w, h))
        small = camera.scaled_to(self.work)
        self._maps = (cv2.initUndistortRectifyMap(small.camera_matrix, small.dist_coeffs, None, small.camera_matrix,
                                                  self.work, cv2.CV_16SC2) if small.has_distortion else None)
        self._k = (None if config.camera.model == "none" and config.camera.focal_px is None
                   else small.camera_matrix)
        self.opts = SetupOptions(lane_width_m=LANE_WIDTH_M, work_width_px=self.cfg.work_width_px,
                                 dash_period_m=self.cfg.dash_period_m)
        self._frames: deque = deque(maxlen=self.cfg.window_frames)
        self.last_evidence: FrameEvidence | None = None
        self.last_estimate: SetupState | None = None
        self.last_verdict = ""
        self._seen = 0
        self._new = 0
        self._horizons: deque = deque(maxlen=self.cfg.lines_window_frames)
        self._lines_taken = 0
        self._look_candidate: BirdsEye | None = None
        self.state = SetupState.of("default", current)

    @property
    def searching(self) -> bool:
        """True while there is no sure estimate and the next frame is among the first ``fast_frames``."""
        return self.state.source in ("default", "first-frame", "lines") and self._seen < self.cfg.fast_frames

    def first_look(self, frame: np.ndarray, prefer: Callable[[BirdsEye], bool] | None = None) -> BirdsEye | None:
        """Look at a video's first frame alone, as a still is, for a set-up to use until the estimate.

        The frame gets its own set-up when :func:`still_setup` gives one (one straight frame,
        the still gates).  When it gives none, the set-up in use pitched to the frame's horizon
        (:func:`look_at_still`) is taken when ``selfcal.still_horizon`` and ``prefer`` says the
        frame is seen better with it.  Either replaces the set-up in use, and ``state.source``
        becomes ``first-frame``.  Call it before :meth:`offer` is given any frame.

        Parameters
        ----------
        frame : (H, W, 3) uint8 ndarray
            The video's first frame, BGR (raw).
        prefer : callable, optional
            Given the horizon's set-up, tells whether to take it (None: never).

        Returns
        -------
        BirdsEye or None
            The frame's own set-up, or None to keep the current one.

        Examples
        --------
        >>> from lanefinder import LaneFinder
        >>> be = LaneFinder().birdseye((1280, 720))
        >>> cal = SelfCalibrator(Config(), be.camera, be)
        >>> cal.first_look(np.zeros((720, 1280, 3), np.uint8)) is None, cal.state.source
        (True, 'default')
        """
        look = look_at_still(frame, self.config, self.current)
        new = look.own
        if (new is None and look.horizon is not None and self.cfg.still_horizon and prefer is not None
                and prefer(look.horizon)):
            new = look.horizon
        return None if new is None else self._take_early(new)

    def look_again(self, frame: np.ndarray) -> BirdsEye | None:
        """Look at an early frame alone, as :meth:`first_look` looks at the first, while the default is in use.

        Only while the set-up in use is still the default (no first frame's set-up, no sure
        estimate), on frames 1 to ``selfcal.first_look_frames`` - 1 whose index is a multiple of
        ``every_frames`` (those :meth:`offer` looks at while it looks fast); call it before
        :meth:`offer` is given the frame.  The frame's own set-up (:func:`look_at_still`; its
        horizon's set-up is not used: on a curve the row where its lines meet drifts with the
        bend) becomes the candidate, and is taken when it agrees with the candidate before it
        (the last frame that gave one): horizons within ``selfcal.first_look_agree_px`` (per
        720 rows) and camera heights within ``FIRST_LOOK_AGREE_HEIGHT``.  The later of the two
        is taken, and ``state.source`` becomes ``first-frame``, as for the first frame's (what
        an unsure estimate left in the state is kept).

        Parameters
        ----------
        frame : (H, W, 3) uint8 ndarray
            The next raw frame, BGR.

        Returns
        -------
        BirdsEye or None
            The set-up to use from this frame on, or None to keep the current one.

        Examples
        --------
        >>> from lanefinder import LaneFinder
        >>> be = LaneFinder().birdseye((1280, 720))
        >>> cal = SelfCalibrator(Config(), be.camera, be)
        >>> cal.offer(np.zeros((720, 1280, 3), np.uint8)) is None  # frame 0
        True
        >>> cal.offer(np.zeros((720, 1280, 3), np.uint8)) is None  # frame 1
        True
        >>> cal.look_again(np.zeros((720, 1280, 3), np.uint8)) is None, cal.state.source  # frame 2: no lines
        (True, 'default')
        """
        if not (self.state.source == "default" and 0 < self._seen < self.cfg.first_look_frames
                and self._seen % self.cfg.every_frames == 0):
            return None
        new = look_at_still(frame, self.config, self.current).own
        if new is None:
            return None
        before, self._look_candidate = self._look_candidate, new
        if before is None:
            return None
        (h0, m0, _), (h1, m1, _) = setup_of(before), setup_of(new)
        limit = self.cfg.first_look_agree_px * self.current.frame_size[1] / 720
        if not (abs(h1 - h0) <= limit and abs(m1 / m0 - 1) <= FIRST_LOOK_AGREE_HEIGHT):
            return None
        return self._take_early(new)

    def _take_early(self, new: BirdsEye) -> BirdsEye:
        """Put an early frame's own set-up in use until a sure estimate (``state.source`` ``first-frame``).

        What an unsure estimate left in the state (its frames and quality) is kept; before the
        first frame is offered there is none.
        """
        self.current = new
        self.state = SetupState.of("first-frame", new, frames=self.state.frames, updates=self.state.updates,
                                   refused=self.state.refused, quality=self.state.quality)
        return new

    def _prepare(self, frame: np.ndarray) -> np.ndarray:
        """As :func:`lanefinder.autosetup.prepare_frame`, with the undistortion tables built once per run."""
        img = frame
        if self.work != (frame.shape[1], frame.shape[0]):
            img = cv2.resize(frame, self.work, interpolation=cv2.INTER_AREA)
        if self._maps is not None:
            img = cv2.remap(img, self._maps[0], self._maps[1], cv2.INTER_LINEAR)
        return img

    def offer(self, frame: np.ndarray, curvature_per_m: float = math.nan,
              judge: Callable[[BirdsEye, BirdsEye], bool] | None = None) -> BirdsEye | None:
        """Look at a frame (when it is its turn); give a new set-up when one should replace the current.

        Parameters
        ----------
        frame : (H, W, 3) uint8 ndarray
            The next raw frame, BGR.
        curvature_per_m : float, optional
            The lane's curvature as the pipeline read it in this frame, 1/m (NaN: unknown); a
            frame curving tighter than ``selfcal.skip_radius_m`` is not looked at.
        judge : callable, optional
            ``judge(current, estimate) -> bool``, called at most once per estimate and only for
            a sure estimate that would replace the set-up in use: True when ``frame`` is seen
            better with the set-up in use.  The estimate is then refused and the set-up in use
            stays, as if the estimate had confirmed it (``last_verdict`` = ``refused``,
            ``state.refused`` counts them; the fast looks end, as after any sure estimate).  A
            judge that raises :class:`LaneFinderError` refuses nothing.  The pipeline judges as
            ``selfcal.estimate_check`` says.

        Returns
        -------
        BirdsEye or None
            The set-up to use from now on, or None to keep the current one.
        """
        # One frame in every_frames until a sure estimate: an unsure one does not end the fast looks
        # (synthetic unknown mounts, 50 frames: tuning seeds 0-10 0.8905 -> 0.8977).
        fast = self.searching
        self._seen += 1
        every = self.cfg.every_frames if fast else self.cfg.refine_every_frames
        if (self._seen - 1) % every:
            return None
        if self.cfg.skip_radius_m > 0 and abs(curvature_per_m) * self.cfg.skip_radius_m > 1:  # NaN: looked at
            return None
        und = self._prepare(frame)
        ev = self.last_evidence = frame_evidence(und, self.opts, index=self._seen)
        if not ev.accepted:
            return None
        self._frames.append((ev, cv2.cvtColor(und, cv2.COLOR_BGR2GRAY)))
        self._new += 1
        need = self.cfg.min_frames if self.state.quality is None else max(1, self.cfg.min_frames // 2)
        if len(self._frames) < self.cfg.min_frames or self._new < need:
            return None
        self._new = 0
        return self._estimate(judge)

    def lines_horizon(self) -> float:
        """Give the horizon where the lane lines measured so far meet, or NaN when they do not tell it.

        The median of the rows where the near parts of the two lines measured on each frame
        meet (:meth:`offer_lines`), once ``selfcal.lines_min_frames`` frames have given one and
        while those rows spread no more than ``selfcal.lines_max_spread_px`` (per 720 rows; a
        winding or hilly road moves where its lines meet).

        Returns
        -------
        float
            The row, undistorted frame pixels, or NaN.

        Examples
        --------
        >>> from lanefinder import LaneFinder
        >>> be = LaneFinder().birdseye((1280, 720))
        >>> SelfCalibrator(Config(), be.camera, be).lines_horizon()
        nan
        """
        stats = self._lines_stats()
        return math.nan if stats is None else stats[0]

    def _lines_stats(self) -> tuple[float, float] | None:
        """Give the median of the lines' horizons and its expected error (px), or None (see :meth:`lines_horizon`)."""
        if len(self._horizons) < max(1, self.cfg.lines_min_frames):
            return None
        q25, median, q75 = np.percentile(np.asarray(self._horizons), [25, 50, 75])
        spread = float(q75 - q25) / 1.349  # a standard deviation robust to outliers (and not fooled by two modes)
        if spread > self.cfg.lines_max_spread_px * self.current.frame_size[1] / 720:
            return None
        # Frames in a row see much the same stretch of road: one in LINES_CORRELATED_FRAMES counts as a new look.
        return float(median), 1.2533 * spread / math.sqrt(max(1.0, len(self._horizons) / LINES_CORRELATED_FRAMES))

    def offer_lines(self, left: LinePixels, right: LinePixels, curvature_per_m: float) -> BirdsEye | None:
        """Take the lane lines measured on a frame; give a new set-up when where they meet says so.

        On a flat road the near parts of a lane's two lines meet on the horizon, straight or
        gently curving (:func:`lanefinder.autosetup.road_from_lines`); a set-up pitched wrong shows
        them closing or parting in the view, and the fit's pull towards a shared shape then bends
        the weaker line off its paint.  Each frame with both lines measured on a road read as no
        tighter than ``selfcal.skip_radius_m`` gives that row (the last
        ``selfcal.lines_window_frames`` are kept), and :meth:`lines_horizon` their median, weighed
        once every ``LINES_CORRELATED_FRAMES`` rows.  The set-up in use is pitched towards it when
        they differ by more than ``selfcal.lines_min_shift_px`` (per 720 rows) and by more than
        ``selfcal.lines_sigmas`` of the median's expected error, and by no more than
        ``LINES_MAX_SHIFT`` of the frame's height; by at most ``LINES_STEP`` of it at a time, so
        the caller may keep its track (the pipeline does).  Its camera height and yaw are kept,
        the view rebuilt around the camera as self-calibration builds one.  Each step counts as
        an update of the set-up; ``state.source`` becomes ``lines`` unless the set-up in use is
        an estimate.  An estimate made later (:meth:`offer`) takes the lines' horizon too, while
        :meth:`lines_horizon` gives one within ``LINES_MAX_SHIFT`` of the frames' own.

        Parameters
        ----------
        left, right : LinePixels
            The two lines' pixels measured on the frame, in the view of the set-up in use.
        curvature_per_m : float
            The lane's curvature read on the frame, 1/m (NaN: the frame is not taken).

        Returns
        -------
        BirdsEye or None
            The set-up to use from now on, or None to keep the current one.

        Examples
        --------
        >>> from lanefinder import LaneFinder
        >>> from lanefinder.search import LinePixels
        >>> be = LaneFinder().birdseye((1280, 720))
        >>> cal = SelfCalibrator(Config(), be.camera, be)
        >>> y = np.arange(100.0, 300.0)
        >>> cal.offer_lines(LinePixels(x=np.full(200, 125.0), y=y), LinePixels(x=np.full(200, 275.0), y=y), 0.0)
        >>> len(cal._horizons), cal.state.source  # one frame, parallel lines: nothing to change
        (1, 'default')
        """
        if not (self.cfg.lines_horizon and abs(curvature_per_m) * self.cfg.skip_radius_m <= 1):
            return None
        pts = _near_points(self.current, left, right)
        if pts is None:
            return None
        try:
            _, row = straight_fits(pts[0], pts[1], self.opts.bottom_fraction * (self.current.frame_size[1] - 1))
        except LaneFinderError:
            return None
        self._horizons.append(row)
        self._lines_taken += 1
        if self._lines_taken % LINES_CORRELATED_FRAMES:  # weighed again once per new look at the road
            return None
        stats = self._lines_stats()
        if stats is None:
            return None
        median, sigma = stats
        now = self.state.horizon_px  # the set-up in use's: the state is always made from it
        shift = median - now
        h = self.current.frame_size[1]
        least = max(self.cfg.lines_min_shift_px * h / 720, self.cfg.lines_sigmas * sigma)
        if not least < abs(shift) <= LINES_MAX_SHIFT * h:
            return None
        # At most LINES_STEP of the frame's height at a time: the pipeline keeps its track across it.
        to = now + float(np.clip(shift, -LINES_STEP * h, LINES_STEP * h))
        new = _pitched(self.current, to)
        if new is None:
            return None
        self.current = new
        source = "estimated" if self.state.source == "estimated" else "lines"
        self.state = SetupState.of(source, new, frames=self.state.frames, updates=self.state.updates + 1,
                                   refused=self.state.refused,
                                   quality=self.state.quality)
        return new

    def _estimate(self, judge: Callable[[BirdsEye, BirdsEye], bool] | None = None) -> BirdsEye | None:
        try:
            est = estimate_road([e for e, _ in self._frames], {e.index: g for e, g in self._frames}, self.work,
                                self._k, self.opts, self.scale)
            b, k_full, quality = view_from_estimate(est, self.current.frame_size, self.opts)
        except LaneFinderError:
            return None
        lines = (self.lines_horizon() + 0.5) * self.scale - 0.5  # working pixels
        if abs(lines - est.vp[1]) <= LINES_MAX_SHIFT * self.work[1]:  # NaN: none
            # The lane lines measured tell the pitch better than the frames' vanishing points.
            pitched = replace(est, vp=(est.vp[0], lines))
            with suppress(LaneFinderError):  # else the frames' own reading stays
                b, k_full, _ = view_from_estimate(pitched, self.current.frame_size, self.opts)
        cam = self.camera if self._k is not None else CameraModel.ideal(self.current.frame_size,
                                                                        focal_px=float(k_full[0, 0]))
        be = make_birdseye(cam, np.array(b.src), np.array(b.dst), b.size, b.xm_per_px, b.ym_per_px)
        err = setup_error(self.current, be)  # how the set-up in use misreads the road as now estimated
        # A change must exceed the limits and three times the estimate's own expected error.
        sure = self.cfg.change_sigmas
        differs = (abs(err["xm_pct"]) > max(self.cfg.change_xm_pct, sure * quality.xm_error_pct)
                   or abs(err["ym_pct"]) > max(self.cfg.change_ym_pct, sure * quality.ym_error_pct)
                   or abs(err["car_m"]) > max(self.cfg.change_car_m, sure * quality.car_error_m))
        # ... and the estimate must itself be surer than the limits (twisty roads give wide spreads).
        sure_enough = quality.xm_error_pct <= self.cfg.change_xm_pct and quality.car_error_m <= self.cfg.change_car_m
        differs = differs and sure_enough
        refused = False
        if differs and judge is not None:
            with suppress(LaneFinderError):
                refused = bool(judge(self.current, be))
        differs = differs and not refused
        updates = self.state.updates + differs
        use = be if differs else self.current
        # An estimate not sure enough neither replaces nor confirms the set-up: the source stays.
        source = "estimated" if sure_enough else self.state.source
        self.state = SetupState.of(source, use, frames=quality.frames_used, updates=updates, quality=quality,
                                   refused=self.state.refused + refused)
        self.last_estimate = SetupState.of("estimated", be, frames=quality.frames_used, quality=quality)
        self.last_verdict = ("taken" if differs else "refused" if refused else "confirms" if sure_enough
                             else "unsure")
        if differs:
            self.current = be
            return be
        return None


@dataclass(frozen=True)
class StillLook:
    """What one still, looked at alone, says about the set-up to see it with.

    Attributes
    ----------
    own : BirdsEye or None
        Its own set-up (:func:`still_setup`), or None.
    horizon : BirdsEye or None
        When it has no set-up of its own: the set-up in use with the horizon moved to the row
        its road lines meet on (:func:`horizon_setup`), or None.

    Examples
    --------
    >>> StillLook(own=None, horizon=None).own is None
    True
    """

    own: BirdsEye | None
    horizon: BirdsEye | None


def look_at_still(frame: np.ndarray, config: Config, current: BirdsEye) -> StillLook:
    """Look at a single still alone, as a one-frame video: its own set-up, else its horizon.

    The still's own set-up is :func:`still_setup`'s.  When it gives none (a curving road, a
    camera height from the lane width outside ``selfcal.still_height_m``: the ego lines misread)
    but the still's road lines still meet on a vanishing point, that point's row is the
    horizon on a flat road, curving or not; :func:`horizon_setup` moves the set-up in use to
    it.  The still is looked at once for both.

    Parameters
    ----------
    frame : (H, W, 3) uint8 ndarray
        The still, BGR, raw (with lens distortion).
    config : Config
        The configuration (``selfcal``; the focal length as for self-calibration).
    current : BirdsEye
        The set-up the still would otherwise be seen with, for its size.

    Returns
    -------
    StillLook
        Its own set-up and the horizon's, each None where the still gives none.

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> be = LaneFinder().birdseye((1280, 720))
    >>> look_at_still(np.zeros((720, 1280, 3), np.uint8), Config(), be)
    StillLook(own=None, horizon=None)
    """
    one = config.selfcal.model_copy(update={"min_frames": 1, "every_frames": 1, "fast_frames": 1,
                                            "work_width_px": config.selfcal.still_work_width_px})
    cal = SelfCalibrator(config.model_copy(update={"selfcal": one}), current.camera, current)
    new = cal.offer(frame)
    if new is not None and _plausible_for_a_still(current, new, cal.state.height_m, config.selfcal):
        return StillLook(own=new, horizon=None)
    ev = cal.last_evidence
    if ev is None or not ev.accepted or ev.lines is None or cal._k is None:  # no lines, or no focal length
        return StillLook(own=None, horizon=None)
    return StillLook(own=None, horizon=horizon_setup(current, ev.lines.vp[1] / cal.scale, config))


def still_setup(frame: np.ndarray, config: Config, current: BirdsEye) -> BirdsEye | None:
    """Estimate a single still's own set-up from the still alone, as a one-frame video.

    The still must be accepted as ``lanefinder setup`` accepts a frame (a vanishing point, two
    ego lines, a straight road) and the estimate must be sure by the ``selfcal`` limits.  It is
    taken only when it differs from ``current`` by more than those limits, puts the camera at a
    height within ``selfcal.still_height_m`` and moves the car by no more than
    ``selfcal.still_max_car_m`` (one frame cannot tell a hill from a camera pitched otherwise,
    or a car off the lane's centre from a camera turned).

    Parameters
    ----------
    frame : (H, W, 3) uint8 ndarray
        The still, BGR, raw (with lens distortion).
    config : Config
        The configuration (``selfcal``; the focal length as for self-calibration).
    current : BirdsEye
        The set-up the still would otherwise be seen with, for its size.

    Returns
    -------
    BirdsEye or None
        The still's own set-up, or None to keep ``current``.

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> be = LaneFinder().birdseye((1280, 720))
    >>> still_setup(np.zeros((720, 1280, 3), np.uint8), Config(), be) is None
    True
    """
    return look_at_still(frame, config, current).own


def horizon_setup(current: BirdsEye, horizon_px: float, config: Config | None = None) -> BirdsEye | None:
    """Give the set-up in use with its horizon moved to another row, its height and yaw kept.

    On a flat road every direction along it vanishes on the horizon, so the row where a
    still's road lines meet is the horizon whether the road is straight or curving, and is read
    well from one frame (on synthetic stills of random mounts it lay within 2 px of the truth
    where the camera height read from the same lines was 25-50% off).  The camera height and
    the vanishing point's column (the yaw) stay those of ``current``; the pitch follows the
    row.  The set-up must pass the gates of a still's own set-up (``selfcal.still_max_car_m``).

    Parameters
    ----------
    current : BirdsEye
        The set-up in use.
    horizon_px : float
        The horizon's row, undistorted frame pixels.
    config : Config, optional
        The gates (``selfcal``); the defaults without one.

    Returns
    -------
    BirdsEye or None
        The set-up, or None when the row is within ``LINES_MIN_SHIFT`` of the frame's height
        of the one in use (nothing to change) or more than ``LINES_MAX_SHIFT`` from it, or the
        car would move by more than ``still_max_car_m``.

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> be = LaneFinder().birdseye((1280, 720))
    >>> horizon_setup(be, setup_of(be)[0] + 3) is None  # 3 px: the set-up in use stays
    True
    >>> round(setup_of(horizon_setup(be, setup_of(be)[0] - 20))[0] - setup_of(be)[0])
    -20
    """
    cfg = (config or Config()).selfcal
    if not math.isfinite(horizon_px):
        return None
    if not _still_shift(current, horizon_px):
        return None
    new = _pitched(current, horizon_px)
    return new if new is not None and _plausible_for_a_still(current, new, setup_of(current)[1], cfg) else None


def _still_shift(current: BirdsEye, horizon_px: float) -> bool:
    """Tell whether a still's horizon is far enough from ``current``'s to change it, and near enough to trust.

    More than ``LINES_MIN_SHIFT`` and at most ``LINES_MAX_SHIFT`` of the frame's height away.
    """
    h = current.frame_size[1]
    return LINES_MIN_SHIFT * h < abs(horizon_px - setup_of(current)[0]) <= LINES_MAX_SHIFT * h


def _still_setup_from(current: BirdsEye, est: RoadEstimate, cfg: SelfCalConfig) -> BirdsEye | None:
    """Give the set-up of a still's road estimate, or None (see :func:`horizon_setup`).

    None when its horizon is within ``LINES_MIN_SHIFT`` of the frame's height of ``current``'s or
    more than ``LINES_MAX_SHIFT`` from it, or when it fails a still's gates.
    """
    if not _still_shift(current, est.vp[1]):
        return None
    new = _setup_from(current, est)
    return new if new is not None and _plausible_for_a_still(current, new, est.height_m, cfg) else None


def _setup_from(current: BirdsEye, est: RoadEstimate) -> BirdsEye | None:
    """Give the set-up a road estimate makes for ``current``'s camera, or None when it cannot be built.

    Built as self-calibration builds one (:func:`lanefinder.autosetup.view_from_estimate`).
    """
    try:
        b, _, _ = view_from_estimate(est, current.frame_size, SetupOptions())
    except LaneFinderError:
        return None
    return make_birdseye(current.camera, np.array(b.src), np.array(b.dst), b.size, b.xm_per_px, b.ym_per_px)


def _plausible_for_a_still(current: BirdsEye, new: BirdsEye, height_m: float, cfg: SelfCalConfig) -> bool:
    """Tell whether a still's set-up passes the still gates: the camera's height, the car's move."""
    low, high = cfg.still_height_m
    return low <= height_m <= high and not abs(setup_error(current, new)["car_m"]) > cfg.still_max_car_m


#: Two early frames' own set-ups agree (:meth:`SelfCalibrator.look_again`) when their camera heights
#: differ by at most this fraction (and their horizons by ``selfcal.first_look_agree_px``).
FIRST_LOOK_AGREE_HEIGHT = 0.1
#: Frames in a row that :meth:`SelfCalibrator.offer_lines` counts as one look at the road.
LINES_CORRELATED_FRAMES = 5
#: The most :meth:`SelfCalibrator.offer_lines` pitches a video's set-up at a time, a fraction of the
#: frame's height (10 px at 720p: the track is kept across it).
LINES_STEP = 1 / 72
#: The near part of the view whose line pixels :func:`lines_setup` reads the road from (a
#: fraction of the view's height, from its bottom: about 18 m of a 30 m view).
LINES_NEAR_FRACTION = 0.6
#: The horizon :func:`lines_setup` finds may lie this fraction of the frame's height above or
#: below the one in use (120 px at 720p: about 6 degrees of pitch with the Udacity lens).
LINES_MAX_SHIFT = 1 / 6
#: ... and must differ from it by more than this fraction of the frame's height (10 px at 720p),
#: or the set-up in use is kept: on 49 stills of the project video, whose default set-up is
#: right, the estimate's horizon lay within 5.5 px of it on 45 and 10.5 px at most.
LINES_MIN_SHIFT = 1 / 72


def lines_setup(current: BirdsEye, left: LinePixels, right: LinePixels,
                config: Config | None = None) -> BirdsEye | None:
    """Give a still's set-up from the near parts of the lines found in it with another set-up.

    For a still that gives no set-up of its own (:func:`still_setup`: a curving road, say),
    the two lines' pixels in the nearest ``LINES_NEAR_FRACTION`` of the view are mapped back
    to the frame, and the horizon read from where their straight fits meet and the camera
    height from how far apart they are (:func:`lanefinder.autosetup.road_from_lines`).  With a
    set-up that pitches the road wrong, the lines splay or close in the view; the set-up
    returned makes them parallel.  The vanishing point's column (the camera's yaw) stays that
    of ``current``: on a curve the lines' own column takes the curve's heading, which would put
    the car 0.4-0.7 m off on a curve of R 250 m.  The set-up must pass the gates of a still's
    own set-up (``selfcal.still_height_m``, ``selfcal.still_max_car_m``).

    Parameters
    ----------
    current : BirdsEye
        The set-up the lines were found with.
    left, right : LinePixels
        Their pixels in its view.
    config : Config, optional
        The gates (``selfcal``); the defaults without one.

    Returns
    -------
    BirdsEye or None
        The set-up the lines give, or None when they give none (too few pixels near the car,
        lines that do not meet above them, a horizon more than ``LINES_MAX_SHIFT`` of the
        frame's height from the one in use, a camera height outside ``still_height_m``, or the
        car moved by more than ``still_max_car_m``), or when it is too close to ``current`` to
        tell from it (the horizon within ``LINES_MIN_SHIFT`` of the frame's height).

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> from lanefinder.search import LinePixels
    >>> be = LaneFinder().birdseye((1280, 720))
    >>> y = np.arange(100.0, 300.0)
    >>> lines_setup(be, LinePixels(x=np.full(200, 125.0), y=y), LinePixels(x=np.full(200, 275.0), y=y)) is None
    True
    >>> new = lines_setup(be, LinePixels(x=130 - (y - 100) / 16, y=y), LinePixels(x=270 + (y - 100) / 16, y=y))
    >>> round(setup_of(new)[0] - setup_of(be)[0]), round(setup_of(new)[1] / setup_of(be)[1], 2)
    (11, 0.87)
    """
    cfg = (config or Config()).selfcal
    est = _near_lines_estimate(current, left, right)
    return None if est is None else _still_setup_from(current, est, cfg)


def _near_points(current: BirdsEye, left: LinePixels, right: LinePixels) -> list[np.ndarray] | None:
    """Give the pixels of two lines within ``LINES_NEAR_FRACTION`` of a view's bottom, undistorted; None when few."""
    h_view = current.size[1]
    pts = []
    for line in (left, right):
        near = line.y >= h_view * (1 - LINES_NEAR_FRACTION)
        if np.count_nonzero(near) < 10:
            return None
        pts.append(current.to_undistorted(np.column_stack([line.x[near], line.y[near]])))
    return pts


def _near_lines_estimate(current: BirdsEye, left: LinePixels, right: LinePixels) -> RoadEstimate | None:
    """Read the road from the near parts of two lines' pixels in a set-up's view (see :func:`lines_setup`)."""
    pts = _near_points(current, left, right)
    if pts is None:
        return None
    opts = SetupOptions()
    bottom_px = opts.bottom_fraction * (current.frame_size[1] - 1)
    try:
        return road_from_lines(pts[0], pts[1], current.camera.camera_matrix, bottom_px, opts.lane_width_m,
                               vp_x=src_vanishing_point(current.src_px)[0])
    except LaneFinderError:
        return None


def _pitched(current: BirdsEye, horizon_px: float) -> BirdsEye | None:
    """Give the set-up in use pitched to another horizon row, its camera height and yaw kept (no gates).

    The view is built as self-calibration builds one (:func:`lanefinder.autosetup.view_from_estimate`),
    centred on the camera.
    """
    est = RoadEstimate(camera_matrix=current.camera.camera_matrix, vp=(src_vanishing_point(current.src_px)[0],
                       float(horizon_px)), height_m=setup_of(current)[1], centre_m=0.0, focal_source="camera file",
                       evidence=())
    return _setup_from(current, est)
