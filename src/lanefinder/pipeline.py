"""The pipeline: composes camera, bird's-eye view, threshold, measuring and tracking.

:class:`LaneFinder` knows the order of the stages and nothing of their insides: the
bird's-eye remap (:mod:`lanefinder.birdseye`), the threshold (:mod:`lanefinder.threshold`),
the measuring step with its search-retry policy (:mod:`lanefinder.measure`) and the pure
tracker transition (:mod:`lanefinder.tracking`), whose verdict becomes a
:class:`~lanefinder.lane.LaneResult`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

import numpy as np

from .autosetup import nominal_setup
from .birdseye import BirdsEye, make_birdseye, setup_of, src_vanishing_point
from .camera import CameraModel, load_camera, udacity_camera
from .config import BirdseyeConfig, Config, ThresholdConfig, load_config
from .errors import LaneFinderError
from .farfield import FarView, follow_line, make_farview
from .geometry import Scale, lane_geometry, poly_x
from .lane import SIDES, LaneResult
from .limits import check_memory
from .measure import Measured, Measurer, measure
from .search import Pixels
from .selfcal import SelfCalibrator, lines_setup, look_at_still
from .selfcal import wanted as selfcal_wanted
from .threshold import rowwise, streak_points, threshold
from .tracking import Track, Verdict, seen_far, step

__all__ = [
    "MIN_FRAME_PX",
    "LaneFinder",
    "LaneResult",
    "birdseye_config_used",
    "birdseye_from_config",
    "camera_from_config",
    "load_checked_config",
]


def camera_from_config(cfg: Config, frame_size: tuple[int, int] | None = None) -> CameraModel:
    """Return the camera a configuration names: built-in Udacity, none (ideal pinhole), or a camera file.

    Parameters
    ----------
    cfg : Config
        The configuration (``camera.model``).
    frame_size : tuple of int, optional
        (width, height) of the frames, pixels; sizes the ideal pinhole of ``none``.

    Returns
    -------
    CameraModel
        The lens model.

    Raises
    ------
    LaneFinderError
        When a camera file cannot be read.

    Examples
    --------
    >>> camera_from_config(Config()).image_size
    (1280, 720)
    """
    name = cfg.camera.model
    if name == "udacity":
        return udacity_camera()
    if name == "none":
        ref = cfg.birdseye.reference_size
        size = frame_size or ref
        focal = cfg.camera.focal_px
        return CameraModel.ideal(size, focal_px=None if focal is None else focal * size[0] / ref[0])
    return load_camera(name)


def load_checked_config(path: str | Path | None) -> Config:
    """Load a config file whose camera file (if it names one) must exist and describe a lens.

    Every command that takes ``-c`` checks this before any work, so that a config whose camera
    file is missing is one error at the start, not a failure of every frame or video.

    Parameters
    ----------
    path : str or Path or None
        The config file (``.toml``, ``.yaml`` or ``.json``); None gives the defaults.

    Returns
    -------
    Config
        The configuration.

    Raises
    ------
    LaneFinderError
        When the config or its camera file cannot be read.

    Examples
    --------
    >>> load_checked_config(None).camera.model
    'udacity'
    """
    cfg = load_config(path)
    if path is not None:
        camera_from_config(cfg)
    return cfg


def birdseye_from_config(cfg: Config, camera: CameraModel, frame_size: tuple[int, int]) -> BirdsEye:
    """Build the bird's-eye set-up a configuration gives, for frames of one size.

    The source trapezoid is given for ``birdseye.reference_size`` and scales with the frame.
    The default set-up's trapezoid is the Udacity lens's: for another lens given by a camera file
    with no set-up of its own, the set-up is that lens mounted as the default set-up's camera is
    (:func:`birdseye_config_used`), for frames of the lens's aspect ratio.

    Parameters
    ----------
    cfg : Config
        The configuration (``birdseye``).
    camera : CameraModel
        The lens model (scaled to the frame size here).
    frame_size : tuple of int
        (width, height) of the frames, pixels.

    Returns
    -------
    BirdsEye
        The set-up, with its combined undistort-and-warp remap.

    Raises
    ------
    LaneFinderError
        When the frame has another aspect ratio than the set-up.

    Examples
    --------
    >>> be = birdseye_from_config(Config(), camera_from_config(Config()), (640, 360))
    >>> be.size, round(be.xm_per_px, 4)
    ((400, 300), 0.0247)
    """
    w, h = frame_size
    check_memory(cfg, (w, h))
    b = birdseye_config_used(cfg, camera, (w, h))
    rw, rh = b.reference_size
    if abs((w / h) / (rw / rh) - 1) > 0.01:
        raise LaneFinderError(
            f"frame size {w}x{h} has another aspect ratio than the configured set-up ({rw}x{rh}); "
            "run 'lanefinder setup' for this camera"
        )
    cam = camera.scaled_to(frame_size)
    src = np.asarray(b.src, np.float64) * [w / rw, h / rh]
    return make_birdseye(cam, src, np.asarray(b.dst), b.size, b.xm_per_px, b.ym_per_px)


def birdseye_config_used(cfg: Config, camera: CameraModel | None, frame_size: tuple[int, int]) -> BirdseyeConfig:
    """Give the set-up a configuration puts in use for a lens and frames of one size.

    That is ``cfg.birdseye``, except for a config without a set-up of its own and a lens of its
    own (a camera file) other than the Udacity camera's (the default set-up's trapezoid was drawn
    for that lens; with another focal length it is no rectangle on the road): then the lens
    mounted as the default set-up's camera is (:func:`lanefinder.autosetup.nominal_setup`:
    looking 1.45 degrees up, turned 1.36 degrees right, 1.26 m over the road), for frames of
    ``frame_size``.  When that mount gives no view (a long focal length: the frame's bottom rows
    lie beyond the view's 40 m reach, or the horizon below them; at 1280x720 a lens narrower
    than about 16 degrees), the default trapezoid.

    ``camera.model = "none"`` keeps the default trapezoid: its lens's principal point is a guess
    (the frame's centre), and a pitch from a guessed axis placed the horizon worse on footage
    of the Udacity lens (whose principal point lies 30 px below the centre) than the trapezoid does.

    Parameters
    ----------
    cfg : Config
        The configuration (``birdseye``).
    camera : CameraModel or None
        The lens model; None: the config's (``camera.model``), and when that cannot be read,
        ``cfg.birdseye`` (to report the set-up of a run, or draw it).
    frame_size : tuple of int
        (width, height) of the frames, pixels.

    Returns
    -------
    BirdseyeConfig
        The set-up (its ``reference_size`` is the frame size for a nominal one).

    Examples
    --------
    >>> birdseye_config_used(Config(), udacity_camera(), (1920, 1080)) == Config().birdseye
    True
    >>> wide = CameraModel.ideal((1920, 1080), hfov_deg=90.0)
    >>> birdseye_config_used(Config(), wide, (1920, 1080)).reference_size
    (1920, 1080)
    """
    b = cfg.birdseye
    if cfg.has_own_setup() or cfg.camera.model == "none":
        return b
    if camera is None:
        try:
            camera = camera_from_config(cfg, frame_size)
        except LaneFinderError:
            return b
    if _udacity_lens(camera):
        return b
    # (For a 90-degree 1080p lens the default trapezoid put the horizon 79 px off.)
    try:
        return nominal_setup(camera, frame_size, *_default_mount())
    except (LaneFinderError, ValueError):
        return b


def _udacity_lens(camera: CameraModel) -> bool:
    """Tell whether a lens is the Udacity camera's (the default set-up's), at any frame size of its aspect."""
    ref = udacity_camera()
    w, h = camera.image_size
    if abs((w / h) / (ref.image_size[0] / ref.image_size[1]) - 1) > 0.01:
        return False
    same = camera.scaled_to(ref.image_size)
    d, dr = same.dist_coeffs.ravel(), ref.dist_coeffs.ravel()
    n = max(d.size, dr.size)
    return bool(np.allclose(same.camera_matrix, ref.camera_matrix, rtol=1e-4, atol=1e-3)
                and np.allclose(np.pad(d, (0, n - d.size)), np.pad(dr, (0, n - dr.size)), rtol=1e-4, atol=1e-6))


@functools.cache
def _default_mount() -> tuple[float, float, float]:
    """Give the default set-up's camera pitch (degrees down), yaw (degrees left) and height (m): Udacity lens."""
    be = birdseye_from_config(Config(), udacity_camera(), (1280, 720))
    vp_x, vp_y = src_vanishing_point(be.src_px)
    k = be.camera.camera_matrix
    return (math.degrees(math.atan((k[1, 2] - vp_y) / k[1, 1])), math.degrees(math.atan((vp_x - k[0, 2]) / k[0, 0])),
            setup_of(be)[1])


#: Reasons that refuse a measured line for lying elsewhere than the held lane (see ``_seen_far``).
_AGAINST_HELD = frozenset({"offset", "one-line-too-long", "weak-pair"})


def _confidences(measured: Measured) -> list[float]:
    """Each measured line's confidence, 0 for a line not measured."""
    return [0.0 if line is None else line.confidence for line in measured.lines]


def _sureness(result: LaneResult) -> float:
    """Give the mean of a result's two line confidences (to choose between two set-ups of one still)."""
    return (result.left.confidence + result.right.confidence) / 2


def _surer(other: LaneResult, first: LaneResult, margin: float) -> bool:
    """Tell whether ``other`` shows a lane and, where ``first`` shows one too, lines surer by ``margin``."""
    return other.lane_found and (not first.lane_found or _sureness(other) >= _sureness(first) + margin)


#: The smallest frame the lane is looked for in, (width, height) pixels: below, a 15 cm marking 10 m
#: ahead is under two pixels wide with the Udacity lens (a 16x9 still once gave a "lane").
MIN_FRAME_PX = (128, 64)


def _strips_binary(strips: np.ndarray, rows: int, cfg: ThresholdConfig, xm_per_px: float) -> np.ndarray:
    """Threshold far strips stacked one below the other, each ``rows`` tall, as one image where the threshold allows."""
    if rowwise(cfg):  # one call for the strips
        return threshold(strips, cfg, xm_per_px)
    # a filter across rows would mix the strips at their seam
    return np.vstack([threshold(strips[i:i + rows], cfg, xm_per_px) for i in range(0, len(strips), rows)])


def _check_frame(frame: np.ndarray) -> None:
    """Raise a LaneFinderError unless ``frame`` is a BGR uint8 image of at least ``MIN_FRAME_PX``."""
    if (not isinstance(frame, np.ndarray) or frame.ndim != 3 or frame.shape[2] != 3
            or frame.dtype != np.uint8 or 0 in frame.shape):
        raise LaneFinderError("a frame must be a BGR uint8 image of shape (height, width, 3)")
    if frame.shape[1] < MIN_FRAME_PX[0] or frame.shape[0] < MIN_FRAME_PX[1]:
        raise LaneFinderError(f"a frame of {frame.shape[1]}x{frame.shape[0]} pixels is too small to find lane "
                              f"markings in: at least {MIN_FRAME_PX[0]}x{MIN_FRAME_PX[1]}")


class LaneFinder:
    """Finds the lane in frames, keeping a track across calls to :meth:`process`.

    Call :meth:`reset` between unrelated frames or clips.

    Parameters
    ----------
    config : Config, optional
        The configuration (defaults when omitted).
    camera : CameraModel, optional
        The lens model; by default the one ``config.camera.model`` names.
    keep_debug : bool
        Keep each frame's bird's-eye binary and search in the result (for debug views).
    self_calibrate : bool
        Estimate the set-up from the frames while they come (:mod:`lanefinder.selfcal`; for
        the frames of one video); :func:`lanefinder.selfcal.wanted` tells when a config asks
        for it.  Until the first sure estimate, frames are measured as ``selfcal.unsure_*`` say;
        ``tracking.sure_first_width`` is off in such a run.

    Attributes
    ----------
    config : Config
        The configuration.
    track : Track
        What the tracker remembers from the frames so far.
    selfcal : SelfCalibrator or None
        The self-calibration, once the first frame is in (with ``self_calibrate``).
    last_birdseye : BirdsEye or None
        The set-up the last frame given to :meth:`process` was seen with: its result's lines
        are in it (self-calibration may put another in use for the next frame).
    last_still : bool
        The last frame was measured with a still's rules (by :meth:`process_still` or
        :meth:`find_as_still`, on a finder that does not self-calibrate).

    Examples
    --------
    >>> import cv2
    >>> finder = LaneFinder(Config())
    >>> r = finder.process(cv2.imread("data/test_images/test3.jpg"))
    >>> r.left.found, r.right.found, round(r.width_m, 1)
    (True, True, 3.7)
    """

    def __init__(self, config: Config | None = None, camera: CameraModel | None = None, keep_debug: bool = False,
                 self_calibrate: bool = False):
        self.config = config or Config()
        self.camera = camera
        self.keep_debug = keep_debug
        self._last_search = None  # the last frame's measured line pixels (self-calibration reads the horizon off them)
        self.self_calibrate = self_calibrate
        self.selfcal: SelfCalibrator | None = None
        self.track = Track()
        self._birdseye: BirdsEye | None = None
        self._measurer: Measurer | None = None
        self._farview: tuple[BirdsEye, FarView | None] | None = None
        self._ridge_variants: dict[tuple, ThresholdConfig] = {}  # the threshold with ridge settings changed
        self._config_birdseye: BirdsEye | None = None
        self._measurer_variants: dict[str, Measurer] = {}  # this set-up's, with settings changed
        self.last_birdseye: BirdsEye | None = None
        self.last_still = False
        self._still_source: str | None = None  # a still's own set-up left in use: its label
        self._in_still = False  # inside process_still or find_as_still: measured with a still's rules
        self._curvature_per_m = math.nan  # the last frame's lane, as read (NaN: no lane)

    def birdseye(self, frame_size: tuple[int, int]) -> BirdsEye:
        """Return the (cached) bird's-eye set-up for a frame size.

        Parameters
        ----------
        frame_size : tuple of int
            (width, height) of the frames, pixels.

        Returns
        -------
        BirdsEye
            The set-up, built on first use for that size.

        Raises
        ------
        LaneFinderError
            When the camera cannot serve frames of that size (another aspect ratio).
        """
        be = self._birdseye
        if be is None or be.frame_size != tuple(frame_size):
            if self.camera is None:
                self.camera = camera_from_config(self.config, frame_size)
            be = birdseye_from_config(self.config, self.camera, tuple(frame_size))
            self._birdseye = be
            self._build_measurer(be)
            self._still_source = None  # a still's own set-up is no longer the one in use
        return be

    def _unsure(self) -> bool:
        """Tell whether a self-calibrating run is on the default (or first frame's) set-up, still searching."""
        if not (self.self_calibrate and selfcal_wanted(self.config)):
            return False
        return self.config.selfcal.fast_frames > 0 if self.selfcal is None else self.selfcal.searching

    def _measuring_config(self) -> Config:
        """Give the config frames are measured with: a self-calibrating run's keeps a weak first width.

        The default lane width is a width on the road; a set-up estimated from the video (or the
        default one) reads the road's metres only as well as the estimate, so the width a weak
        pair measures is kept (``tracking.sure_first_width`` off).
        """
        cfg = self.config
        if not (self.self_calibrate and selfcal_wanted(cfg) and cfg.tracking.sure_first_width):
            return cfg
        return cfg.model_copy(update={"tracking": cfg.tracking.model_copy(update={"sure_first_width": False})})

    def _build_measurer(self, be: BirdsEye) -> None:
        """Build the measuring settings for a set-up (their variants when a frame first needs them)."""
        scale = Scale(be.xm_per_px, be.ym_per_px, be.size[1], be.car_x_px)
        self._measurer = Measurer.build(self._measuring_config(), scale)
        self._measurer_variants = {}

    def _measurer_variant(self, name: str, fit: dict | None = None, tracking: dict | None = None) -> Measurer:
        """Give the set-up's measuring settings with some ``fit`` and ``tracking`` settings changed, made once."""
        if name not in self._measurer_variants:
            cfg = self._measuring_config()
            changed = cfg.model_copy(update={"fit": cfg.fit.model_copy(update=fit or {}),
                                             "tracking": cfg.tracking.model_copy(update=tracking or {})})
            self._measurer_variants[name] = Measurer.build(changed, self.measurer.scale)
        return self._measurer_variants[name]

    def _frame_measurer(self) -> Measurer:
        """Give the settings to measure this frame with: relaxed while unsure of the set-up on a road read as straight.

        A camera mounted otherwise than the default set-up's makes a straight lane's lines
        converge or part in the bird's-eye view; the lane checks that assume parallel lines
        then refuse the true lines, and the fit's pull towards a shared shape bends them.  On a
        curving road the shared shape is worth more than the set-up's error (synthetic sharp
        curves of unknown mounts, and the harder challenge video, lose without it).  Relaxed
        means as ``selfcal.unsure_*`` say.
        """
        sc = self.config.selfcal
        if not self._unsure() or abs(self._curvature_per_m) * sc.unsure_radius_m > 1:  # NaN (no lane): relaxed
            return self.measurer
        return self._measurer_variant("relaxed", fit={"parallel": sc.unsure_parallel},
                                      tracking={"max_parallel_diff_m": sc.unsure_parallel_diff_m,
                                                "max_curvature_diff": sc.unsure_curvature_diff})

    @property
    def measurer(self) -> Measurer:
        """The measuring settings in pixels for the current set-up (after the first frame), as configured.

        A self-calibrating run's have ``tracking.sure_first_width`` off; while it is unsure of
        its set-up, :meth:`process` measures frames of a road read as straight with these
        relaxed as ``selfcal.unsure_*`` say.
        """
        if self._measurer is None:
            raise LaneFinderError("no frame size yet: call birdseye() or process() first")
        return self._measurer

    def reset(self) -> None:
        """Forget the track (start of a new clip, or independent images)."""
        self.track = Track()
        self._curvature_per_m = math.nan

    def use_birdseye(self, be: BirdsEye) -> None:
        """Put another set-up in use for frames of its size.

        The track is kept: for a set-up that differs a little, the search around the lines
        found so far allows for it; call :meth:`reset` to start afresh (:meth:`process` does,
        when self-calibration changes the set-up).

        Parameters
        ----------
        be : BirdsEye
            The new set-up (from :mod:`lanefinder.selfcal`, say).
        """
        self._birdseye = be
        self._build_measurer(be)
        self._farview = None
        self._still_source = None

    def process(self, frame: np.ndarray) -> LaneResult:
        """Find the lane in one frame.

        Parameters
        ----------
        frame : (H, W, 3) uint8 ndarray
            A BGR frame from the camera (raw, with lens distortion).

        Returns
        -------
        LaneResult
            The lines, the lane numbers (m, 1/m) and the tracker's state.  Its lines are in the
            set-up :attr:`last_birdseye` holds after the call (on a first frame, the one it gave
            alone; self-calibration may put another in use for the next frame).

        Raises
        ------
        LaneFinderError
            When ``frame`` is not a BGR uint8 image, or its size does not suit the camera.
        """
        _check_frame(frame)
        be = self.birdseye((frame.shape[1], frame.shape[0]))
        self.last_still = self._in_still and not self.self_calibrate  # measured with a still's rules
        if self.self_calibrate:
            new = None
            looks = self.config.selfcal.first_frame and selfcal_wanted(self.config)
            if self.selfcal is None or self.selfcal.current.frame_size != be.frame_size:
                self.selfcal = SelfCalibrator(self.config, be.camera, be)
                self._curvature_per_m = math.nan
                # The first frame alone, as a still: a set-up of its own, used until a sure estimate (on
                # synthetic unknown mounts the frames before the first estimate scored 0.43-0.59).
                if looks:
                    new = self.selfcal.first_look(frame, lambda other: self._seen_better(frame, be, other))
            elif looks:
                # While still on the default set-up, early frames looked at alone as the first was (two
                # that agree): on synthetic unknown mounts the default's frames scored 0.17 below exact.
                new = self.selfcal.look_again(frame)
            if new is not None:
                self.use_birdseye(new)
                self.reset()
                be = new
        self.last_birdseye = be
        view = be.warp(frame)
        binary = threshold(view, self.config.threshold, be.xm_per_px)
        if not self.self_calibrate:
            measurer = self._still_measurer() if self._in_still else None
            result = self.extend_far(frame, self.process_binary(binary, be, view, measurer), be)
            self._seen_far(result)
            return result if self._still_source is None else replace(result, setup=self._still_source)
        result = self.extend_far(frame, self.process_binary(binary, be, view, self._frame_measurer()), be)
        self._seen_far(result)
        self._curvature_per_m = result.curvature_per_m if result.lane_found else math.nan
        used = self.selfcal.state.source  # the set-up this frame was seen with (an estimate applies from the next)
        # A sure estimate is refused when this frame, found blind, shows a surer lane with the set-up in
        # use (synthetic unknown mounts, 50 frames: tuning seeds 0-10 0.8762 -> 0.8905).
        judge = (lambda cur, est: self._seen_better(frame, est, cur, self.config.selfcal.estimate_check_margin)
                 ) if self.config.selfcal.estimate_check else None
        new = self.selfcal.offer(frame, self._curvature_per_m, judge)
        if new is not None:
            # From the next frame on, and searched for afresh: lines tracked in the old view would be
            # looked for in the wrong place of the new one (a track kept across a large change held
            # a wrong lane width on synthetic footage of unknown mounts).
            self.use_birdseye(new)
            self.reset()
            return replace(result, setup=used)
        search = self._last_search
        if result.left.found and result.right.found and search is not None:
            pitched = self.selfcal.offer_lines(search.left, search.right, self._curvature_per_m)
            if pitched is not None:
                # The track is kept: a pitch changed by a few pixels moves the lines a little in the
                # view, which the search around them allows for (synthetic unknown mounts, 200 frames:
                # tuning seeds 0-3 0.9502 with the track reset, 0.9508 kept; held out 0.8727, 0.8731).
                self.use_birdseye(pitched)
        return replace(result, setup=used)

    def process_still(self, frame: np.ndarray) -> LaneResult:
        """Find the lane in a single still, blind: no track, and the still's own set-up when it gives one.

        With a config that has no set-up of its own (:func:`lanefinder.selfcal.wanted`) and
        ``selfcal.stills``, a still whose lane does not read as curving tighter than
        ``selfcal.still_min_radius_m`` (or shows no lane) with the config's set-up is looked at as a one-frame video
        (:func:`lanefinder.selfcal.look_at_still`), and found again with its own set-up when that
        gives one.  When it gives none, two other set-ups are tried in turn, and the first whose
        result has a lane whose lines are surer than with the config's set-up (or that has a lane
        where that one has none) is kept:

        - with ``selfcal.still_horizon``, the config's set-up with the horizon moved to the row
          the still's road lines meet on (:func:`lanefinder.selfcal.horizon_setup`), kept when
          its lines are surer by ``selfcal.still_horizon_margin``, or whatever their
          confidence when that row and the one the set-up below gives agree within
          ``selfcal.still_horizon_agree`` of the frame's height;
        - with ``selfcal.still_lines``, the set-up the lines found in it give
          (:func:`lanefinder.selfcal.lines_setup`), kept when they are no less sure.

        A still has no later frame to confirm a start, so one line may start its lane when
        ``tracking.still_start_confidence`` (0.3) sure, the other drawn as inferred at the
        default lane width (a video's start needs ``min_start_confidence``).

        That set-up stays in use (:meth:`birdseye` gives it, to draw the result, and
        :meth:`process` labels its frames with it) until the next still; call :meth:`reset`
        and :meth:`use_birdseye` before using the finder for a video.

        Parameters
        ----------
        frame : (H, W, 3) uint8 ndarray
            The still, BGR (raw, with lens distortion).

        Returns
        -------
        LaneResult
            As :meth:`process`; ``setup`` is ``estimated`` when the still's own set-up was used,
            ``horizon`` when its horizon's was, ``lines`` when the set-up its lines give was,
            ``default`` when none was, ``config`` when the config has a set-up or
            ``selfcal.stills`` is off.

        Raises
        ------
        LaneFinderError
            As :meth:`process`.

        Examples
        --------
        >>> import cv2
        >>> r = LaneFinder().process_still(cv2.imread("data/test_images/straight_lines1.jpg"))
        >>> r.lane_found, r.setup
        (True, 'default')
        """
        with self._as_still():
            return self._find_still(frame)

    def find_as_still(self, frame: np.ndarray) -> LaneResult:
        """Find the lane in a frame blind, with a still's measuring rules, in the set-up in use.

        As :meth:`process_still` measures a still once it has chosen its set-up (a lone line
        may start the lane, every piece of a line counts), but no set-up of its own is looked
        for: to see again how a still was found (:func:`lanefinder.stages.inspect_frame`).
        The track then holds the still's lane: call :meth:`reset` before using the finder for
        a video.

        Parameters
        ----------
        frame : (H, W, 3) uint8 ndarray
            The still, BGR (raw, with lens distortion).

        Returns
        -------
        LaneResult
            As :meth:`process`.

        Raises
        ------
        LaneFinderError
            As :meth:`process`, and for a finder that self-calibrates (its frames are a
            video's).

        Examples
        --------
        >>> import cv2
        >>> r = LaneFinder().find_as_still(cv2.imread("data/test_images/test3.jpg"))
        >>> r.lane_found, r.state
        (True, 're-detect')
        """
        if self.self_calibrate:
            raise LaneFinderError("find_as_still needs a finder that does not self-calibrate")
        self.reset()
        with self._as_still():
            return self.process(frame)

    @contextmanager
    def _as_still(self) -> Iterator[None]:
        """Measure the frames processed within with a still's rules (:meth:`_still_measurer`)."""
        self._in_still = True
        try:
            yield
        finally:
            self._in_still = False

    def _find_still(self, frame: np.ndarray) -> LaneResult:
        """:meth:`process_still`'s work (a lone line may start the lane: ``tracking.still_start_confidence``)."""
        self.reset()
        self._still_source = None
        sc = self.config.selfcal
        if not (selfcal_wanted(self.config) and sc.stills):
            return self.process(frame)
        _check_frame(frame)
        size = (frame.shape[1], frame.shape[0])
        if self._config_birdseye is None or self._config_birdseye.frame_size != size:
            self._birdseye = None
            self._config_birdseye = self.birdseye(size)
        elif self._birdseye is not self._config_birdseye:
            self.use_birdseye(self._config_birdseye)
        keep = self.keep_debug
        # the lines' pixels, for lines_setup
        self.keep_debug = keep or sc.still_lines or (sc.still_horizon and sc.still_horizon_agree > 0)
        try:
            first = replace(self.process(frame), setup="default")
        finally:
            self.keep_debug = keep
        search = first.search
        if not keep:
            first = replace(first, binary=None, search=None)
        if first.lane_found and abs(first.curvature_per_m) * sc.still_min_radius_m > 1:
            return first  # a curving road: one frame's vanishing point and lines are not to be trusted
        look = look_at_still(frame, self.config, self._config_birdseye)
        if look.own is not None:
            self.use_birdseye(look.own)
            return self._still_with("estimated", frame)
        horizon = look.horizon if sc.still_horizon else None
        agree_px = sc.still_horizon_agree * size[1]
        read = None  # the set-up the lines found with the config's set-up give
        if search is not None and (sc.still_lines or (horizon is not None and agree_px > 0)):
            read = lines_setup(self._config_birdseye, search.left, search.right, self.config)
        tries = []  # (label, the set-up, how much surer its lines must be)
        if horizon is not None:
            agree = agree_px > 0 and read is not None and abs(setup_of(read)[0] - setup_of(horizon)[0]) <= agree_px
            tries.append(("horizon", horizon, -math.inf if agree else sc.still_horizon_margin))
        if sc.still_lines and read is not None:
            tries.append(("lines", read, 0.0))
        tried = False
        for label, be, margin in tries:
            tried = True
            self.use_birdseye(be)
            other = self._still_with(label, frame)
            if _surer(other, first, margin):
                return other
        if tried:
            self.use_birdseye(self._config_birdseye)
            self.last_birdseye = self._config_birdseye  # the set-up ``first`` was found with
            self.reset()
        return first

    def _seen_better(self, frame: np.ndarray, be: BirdsEye, other: BirdsEye, margin: float | None = None) -> bool:
        """Tell whether a frame found blind shows a surer lane with ``other`` than with ``be``, by ``margin``.

        Found as a video's frame without history (not with a still's rules); ``margin`` is the mean
        line confidence ``other`` must gain (default ``selfcal.still_horizon_margin``).
        """
        probe = LaneFinder(self.config, self.camera)
        probe.use_birdseye(be)
        with_be = probe.process(frame)
        probe.reset()
        probe.use_birdseye(other)
        m = self.config.selfcal.still_horizon_margin if margin is None else margin
        return _surer(probe.process(frame), with_be, m)

    def _still_measurer(self) -> Measurer:
        """Give the measuring settings for a single still (made once per set-up).

        One line may start its lane there when ``tracking.still_start_confidence`` sure, and
        every piece of a line counts (``fit.piece_min_marking_m`` is for frames of a video:
        measured on stills it lost, synthetic stills 0.786 -> 0.781, the project video's 50 -> 48).
        """
        start = self.config.tracking.still_start_confidence
        return self._measurer_variant("still", fit={"piece_min_marking_m": 0.0},
                                      tracking={"min_start_confidence": start})

    def _still_with(self, label: str, frame: np.ndarray) -> LaneResult:
        """Find a still afresh with the set-up just put in use, labelled (as later frames are) with its source."""
        self.reset()
        self._still_source = label
        return replace(self.process(frame), setup=label)

    def _faint_threshold(self) -> ThresholdConfig | None:
        """Give the threshold settings of the second look for faint paint (None: no second look), made once."""
        return self._capped_variant(self.config.threshold.ridge.faint_contrast_max)

    def _far_threshold(self) -> ThresholdConfig:
        """Give the threshold settings for the far strips (the texture test at ``far.noise_factor``), made once."""
        return self._ridge_variant(noise_factor=self.config.far.noise_factor)

    def _far_faint_threshold(self) -> ThresholdConfig | None:
        """Give the far strips' settings for a second look, capped at ``far.faint_contrast_max`` (None: none)."""
        far = self.config.far
        return self._capped_variant(far.faint_contrast_max, noise_factor=far.noise_factor)

    def _capped_variant(self, cap: int, **ridge) -> ThresholdConfig | None:
        """Give a second look's settings: ``rel_contrast_max`` at ``cap`` (and ``ridge`` changed), made once.

        None (no second look) unless the strategy is ``ridge`` and ``cap`` is below its ``rel_contrast_max``.
        """
        t = self.config.threshold
        if t.strategy != "ridge" or cap >= t.ridge.rel_contrast_max:
            return None
        return self._ridge_variant(**ridge, rel_contrast_max=cap)

    def _ridge_variant(self, **ridge) -> ThresholdConfig:
        """Give the config's threshold settings with some ``threshold.ridge`` settings changed, made once."""
        key = tuple(sorted(ridge.items()))
        if key not in self._ridge_variants:
            t = self.config.threshold
            same = all(getattr(t.ridge, k) == v for k, v in ridge.items())
            self._ridge_variants[key] = t if same else t.model_copy(update={"ridge": t.ridge.model_copy(update=ridge)})
        return self._ridge_variants[key]

    def _seen_far(self, result: LaneResult) -> None:
        """Keep a held lane from ageing on a frame where both its lines are followed beyond the view (``far.hold``).

        Not on a frame whose measured lines were refused for lying elsewhere than the held lane
        (a jump, the offset, one line for too long, a weak pair): those speak against it.
        """
        if not self.config.far.hold or any(c.endswith("-jump") or c in _AGAINST_HELD for c in result.checks):
            return
        if all(line.far_fit_px is not None for line in result.lines):
            self.track = seen_far(self.track, self.measurer.rules.cfg)

    def extend_far(self, frame: np.ndarray, result: LaneResult, be: BirdsEye) -> LaneResult:
        """Follow the result's shown lines beyond the bird's-eye view (see :mod:`lanefinder.farfield`).

        A line that gets no far part (no marking found, or what was found dropped as texture), or
        one that ends within ``far.faint_short_m`` of the far view's nearest row (a frame row
        beyond the view's top edge), is followed again in its strip thresholded for faint paint,
        the contrast asked capped at ``far.faint_contrast_max``; that far part is taken when
        there was none, or when it reaches farther.

        Parameters
        ----------
        frame : (H, W, 3) uint8 ndarray
            The raw frame, BGR.
        result : LaneResult
            The frame's result from the near view.
        be : BirdsEye
            Its set-up.

        Returns
        -------
        LaneResult
            The same result with each line's far part (``far_fit_px``, ``far_end_px``) and,
            for a line found this frame, its ``range_m`` extended; the lane numbers at the car
            are unchanged.
        """
        if not (result.left.shown or result.right.shown):
            return result
        if self._farview is None or self._farview[0] is not be:
            self._farview = (be, make_farview(be, self.config.far))
        fv = self._farview[1]
        if fv is None:
            return result
        cfg = self.config.far
        half = math.ceil(cfg.strip_m / be.xm_per_px)
        sides = [side for side in SIDES if getattr(result, side).shown]
        # Only strips around the lines' extensions are mapped and thresholded: one image for both.
        centres = [poly_x(getattr(result, side).fit_px, fv.v_px) - fv.u0_px for side in sides]
        strips, col0 = fv.strip(frame, np.array(centres), half)
        k = len(fv.v_px)
        far_binary = _strips_binary(strips, k, self._far_threshold(), be.xm_per_px)
        faint_cfg = self._far_faint_threshold()
        lines = {}
        for i, side in enumerate(sides):
            line = getattr(result, side)
            far = follow_line(far_binary[i * k:(i + 1) * k], fv, line.fit_px, be.xm_per_px, cfg, col0[i])
            if faint_cfg is not None and (far is None or far.range_m < fv.d_m[-1] + cfg.faint_short_m):
                # A second look for faint far paint (none found, what was found dropped as texture,
                # or a far part that ends soon): a marking a pixel or two wide, blurred, on light
                # concrete is less than rel_contrast of the road lighter than it.
                faint = _strips_binary(strips[i * k:(i + 1) * k], k, faint_cfg, be.xm_per_px)
                again = follow_line(faint, fv, line.fit_px, be.xm_per_px, cfg, col0[i])
                if again is not None and (far is None or again.range_m > far.range_m):
                    far = again
            if far is not None:
                lines[side] = replace(line, far_fit_px=far.fit_px, far_end_px=far.end_px,
                                      range_m=far.range_m if line.found else line.range_m)
        return replace(result, **lines) if lines else result

    def process_binary(self, binary: np.ndarray, be: BirdsEye, view: np.ndarray | None = None,
                       measurer: Measurer | None = None) -> LaneResult:
        """Measure and track on a bird's-eye binary.

        With ``view``, a frame whose binary gives no line at least ``tracking.min_confidence``
        sure is thresholded again for faint paint (``threshold.ridge.faint_contrast_max``), and
        that binary replaces ``binary`` when its lines are taken, each at least
        ``threshold.ridge.faint_confidence`` sure (the result's debug binary is the one used).
        So is a frame with one line that sure while a lane is held, when the second look finds
        both lines, each at least ``threshold.ridge.faint_pair_confidence`` sure (worn paint on
        one side: the held lane's width would otherwise stand in for the line).  The far field
        is thresholded on its own, with its own second look (``far.faint_contrast_max``, see
        :meth:`extend_far`).

        Parameters
        ----------
        binary : (H, W) uint8 ndarray
            The bird's-eye binary, 0/1, of the set-up ``be``.
        be : BirdsEye
            The set-up (from :meth:`birdseye`).
        view : (H, W, 3) uint8 ndarray, optional
            The bird's-eye colour image (BGR); with it, a yellow line is only taken as the side
            of the lane that ``tracking.yellow_line_side`` allows.
        measurer : Measurer, optional
            The settings to measure with; by default :attr:`measurer`.

        Returns
        -------
        LaneResult
            The frame's result.
        """
        self.birdseye(be.frame_size)
        m = measurer or self.measurer
        binary, px = self._without_streaks(binary, be)
        measured = measure(binary, view, self.track, m, px)
        ridge = self.config.threshold.ridge
        sure = sum(c >= self.config.tracking.min_confidence for c in _confidences(measured))
        # The least confidence of each line a second look must find: with no line to take, any
        # line it finds; with a held lane and one line sure, the other line too.
        # (beside a held lane never below min_confidence: the tracker would refuse its lines)
        bar = ridge.faint_confidence if sure == 0 else max(ridge.faint_pair_confidence,
                                                           self.config.tracking.min_confidence)
        if (view is not None and (sure == 0 or (sure == 1 and self.track.has_lane and bar <= 1))
                and (faint := self._faint_threshold()) is not None):
            # A second look for faint paint (worn paint on light concrete), taken when it finds
            # more lines than the first look was sure of, each at least ``bar`` sure.
            binary2, px2 = self._without_streaks(threshold(view, faint, be.xm_per_px), be)
            again = measure(binary2, view, self.track, m, px2)
            found = [c for c in _confidences(again) if c > 0]
            if len(found) > sure and min(found) >= bar:
                measured, binary = again, binary2
        self.track, verdict = step(self.track, measured.lines, measured.blind, m.rules)
        self._last_search = measured.search
        debug = {"binary": binary, "search": measured.search} if self.keep_debug else {}
        return self._result(verdict, (*measured.reasons, *verdict.reasons), debug)

    def _without_streaks(self, binary: np.ndarray, be: BirdsEye) -> tuple[np.ndarray, Pixels]:
        """Take the streaks pointing at the camera out of a bird's-eye binary and its pixels (``threshold.streaks``)."""
        px = Pixels.of(binary)
        cfg = self.config.threshold.streaks
        if not cfg.enabled:
            return binary, px
        on = streak_points(px.x, px.y, px.shape, (be.car_x_px, be.car_y_px), be.xm_per_px, be.ym_per_px, cfg)
        if not on.any():
            return binary, px
        out = binary.copy()
        out[px.y[on], px.x[on]] = 0
        off = ~on
        return out, Pixels(px.x[off], px.y[off], px.shape)

    def _result(self, v: Verdict, checks: tuple[str, ...], debug: dict) -> LaneResult:
        if not v.has_lane:
            nan = math.nan
            return LaneResult(left=v.left, right=v.right, radius_m=nan, curvature_per_m=nan, offset_m=nan,
                              width_m=nan, straight=False, state=v.state, misses=v.misses, checks=checks, **debug)
        g = lane_geometry(v.left.fit_m, v.right.fit_m, self.config.fit)
        return LaneResult(left=v.left, right=v.right, radius_m=g.radius_m, curvature_per_m=g.curvature_per_m,
                          offset_m=g.offset_m, width_m=g.width_m, straight=g.straight, state=v.state,
                          misses=v.misses, checks=checks, **debug)
