"""The one validated configuration: every tunable of the pipeline lives here.

Save it with ``lanefinder config --default > my.toml``, edit it, pass it back with
``-c my.toml``.  TOML, YAML and JSON are read; unknown keys and bad values are
errors that name the key.
"""

from __future__ import annotations

import functools
import json
import math
import re
import types
from pathlib import Path
from typing import Annotated, Any, Literal, Union, get_args, get_origin

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from .errors import LaneFinderError

__all__ = [
    "LANE_SPAN_PX",
    "LANE_WIDTH_M",
    "MAX_FOV_DEG",
    "MIN_FOV_DEG",
    "MIN_SEGMENT_S",
    "SETUP_SECTIONS",
    "VIEW_SIZE_PX",
    "BatchConfig",
    "BirdseyeConfig",
    "CameraConfig",
    "ColorConfig",
    "Config",
    "EventsConfig",
    "FarConfig",
    "FitConfig",
    "LimitsConfig",
    "RenderConfig",
    "RidgeConfig",
    "SearchConfig",
    "SelfCalConfig",
    "SobelHlsConfig",
    "StreaksConfig",
    "ThresholdConfig",
    "TrackingConfig",
    "VideoConfig",
    "YcrcbConfig",
    "config_arg",
    "config_from_dict",
    "default_dst",
    "dump_config",
    "field_of_view_deg",
    "load_config",
]

#: A point, pixels (of a frame or a view; well outside one is allowed, not without bound).
Coordinate = Annotated[float, Field(ge=-1e5, le=1e5)]
Point = tuple[Coordinate, Coordinate]
Fraction = Annotated[float, Field(ge=0, le=1)]
Byte = Annotated[int, Field(ge=0, le=255)]


def _low_high(band: tuple) -> tuple:
    """Refuse a band whose low end lies above its high end (it would select nothing)."""
    if band[0] > band[1]:
        raise ValueError(f"a band is (low, high): {band[0]} is above {band[1]}")
    return band


#: A band of channel values, (low, high), 0-255.
ByteBand = Annotated[tuple[Byte, Byte], AfterValidator(_low_high)]
#: A frame's width or height, pixels (16K video at most).
FrameSide = Annotated[int, Field(ge=16, le=16384)]
#: A bird's-eye view's width or height, pixels.
ViewSide = Annotated[int, Field(ge=16, le=8192)]
#: The finest step of ``search.heading_step_deg`` (other than 0, off), degrees.
MIN_HEADING_STEP_DEG = 0.5
#: The most curvatures the bend probe tries either way of straight (``search.bend_max_per_m``
#: over ``search.bend_step_per_m``): bounds its cost.
MAX_BEND_STEPS = 100

#: Lane width the default set-up is scaled by: 3.7 m between line centres (12 ft lanes).
LANE_WIDTH_M = 3.7
#: Size of the default bird's-eye view, (width, height) pixels.
VIEW_SIZE_PX = (400, 300)
#: Pixels the lane spans across the default bird's-eye view, centred in it.
LANE_SPAN_PX = 150.0
#: The sections that make a camera's set-up: what ``lanefinder setup`` writes (``lanefinder synth`` adds ``events``).
SETUP_SECTIONS = ("camera", "birdseye")
#: The horizontal fields of view a lens may have, degrees (``camera.focal_px``, camera files):
#: narrower or wider is a mistyped focal length, not a road camera.
MIN_FOV_DEG, MAX_FOV_DEG = 2.0, 175.0


def field_of_view_deg(focal_px: float, width_px: float) -> float:
    """Give a pinhole lens's horizontal field of view.

    Parameters
    ----------
    focal_px : float
        Focal length, pixels.
    width_px : float
        Width of the frames it is given for, pixels.

    Returns
    -------
    float
        The field of view, degrees (compare with ``MIN_FOV_DEG`` and ``MAX_FOV_DEG``).

    Examples
    --------
    >>> round(field_of_view_deg(640.0, 1280), 1)
    90.0
    """
    return math.degrees(2 * math.atan(width_px / 2 / focal_px))


def default_dst(size: tuple[int, int] = VIEW_SIZE_PX,
                lane_px: float = LANE_SPAN_PX) -> tuple[Point, Point, Point, Point]:
    """Return the bird's-eye rectangle of a lane ``lane_px`` wide, centred in a view of ``size``.

    Parameters
    ----------
    size : tuple of int
        The view's (width, height), pixels.
    lane_px : float
        Lane width across the view, pixels.

    Returns
    -------
    tuple of (float, float)
        Top-left, top-right, bottom-right and bottom-left corners, view pixels.

    Examples
    --------
    >>> default_dst()
    ((125.0, 0.0), (275.0, 0.0), (275.0, 300.0), (125.0, 300.0))
    """
    x0 = (size[0] - lane_px) / 2
    w, h = x0 + lane_px, float(size[1])
    return ((x0, 0.0), (w, 0.0), (w, h), (x0, h))


def _text_in(value: object) -> str | None:
    """Give the first piece of text in a value (itself, or in a list of lists), or None."""
    if isinstance(value, str):
        return value
    if isinstance(value, (list, tuple)):
        for item in value:
            text = _text_in(item)
            if text is not None:
                return text
    return None


@functools.cache
def _field_kind(cls: type, name: str) -> str:
    """Give what a section's field takes: ``section``, ``bool``, ``text`` (words) or ``number``."""
    annotation = cls.model_fields[name].annotation  # type: ignore[attr-defined]
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return "section"
    if annotation is bool or bool in get_args(annotation):
        return "bool"
    return "text" if _takes_text(annotation) else "number"


def _takes_text(annotation: object) -> bool:
    """Tell whether a field's type takes text: ``str``, a ``Literal`` of words, a union holding one."""
    if annotation is str:
        return True
    origin, args = get_origin(annotation), get_args(annotation)
    if origin is Annotated:
        return _takes_text(args[0])
    if origin is Literal:
        return any(isinstance(a, str) for a in args)
    if origin in (Union, types.UnionType):
        return any(_takes_text(a) for a in args)
    return False


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    @field_validator("*", mode="before")
    @classmethod
    def _numbers_not_words(cls, v: object, info: ValidationInfo) -> object:
        """Refuse true/false for a number and text for a number or a switch.

        pydantic would read ``n_windows = true`` as 1, ``n_windows = "9"`` as 9 and
        ``enabled = "off"`` as false: a file that quotes a number, or spells a switch, says
        something else than it seems to, so it is refused with the key named.
        """
        if info.field_name is None or not isinstance(v, (bool, str, list, tuple)):
            return v  # (a number or a table: the common case, at once)
        kind = _field_kind(cls, info.field_name)
        if kind == "section":
            return v  # pydantic says it must be a table
        if isinstance(v, bool) and kind not in ("bool", "text"):
            raise ValueError("expected a number, not true/false")
        text = _text_in(v)
        if text is not None and kind != "text":
            if kind == "bool":
                raise ValueError(f"expected true or false, not the text {text!r}")
            raise ValueError(f"expected a number, not the text {text!r} (leave out the quotes)")
        return v


class CameraConfig(_Section):
    """Which lens model to undo.

    Attributes
    ----------
    model : str
        ``udacity`` (the built-in calibration), ``none`` (an ideal pinhole), or the path of a
        camera file (JSON from ``lanefinder calibrate``, or OpenCV's YAML/XML), relative to the
        config file that names it.
    focal_px : float or None
        With ``none``: the pinhole's focal length, pixels at ``birdseye.reference_size``
        (``lanefinder setup`` measures and writes it; it places the car).  None: a 60 degree
        field of view.

    Examples
    --------
    >>> CameraConfig().model
    'udacity'
    """

    model: Annotated[str, Field(min_length=1)] = "udacity"
    focal_px: Annotated[float, Field(gt=1, le=1e6)] | None = None

    @model_validator(mode="after")
    def _check_focal(self) -> CameraConfig:
        if self.focal_px is not None and self.model != "none":
            raise ValueError("focal_px is for model 'none' only (the Udacity lens and a camera file have "
                             "their own focal length)")
        return self


class BirdseyeConfig(_Section):
    """The bird's-eye set-up: a road trapezoid in the frame and the rectangle it maps to.

    Defaults: tuned on straight_lines1/2 (see the README's "The bird's-eye view and its scale"
    and scripts/tune_birdseye.py).

    Attributes
    ----------
    reference_size : tuple of int
        (width, height) of the frames ``src`` is given for, pixels; frames of the same aspect
        ratio at another size scale it.
    src : 4 tuples of float
        The trapezoid in undistorted frame pixels: top-left, top-right, bottom-right, bottom-left.
    size : tuple of int
        (width, height) of the bird's-eye view, pixels.
    dst : 4 tuples of float
        Where ``src`` goes in the view, pixels, in the same order.
    xm_per_px : float
        Metres per view pixel across the road (0.002-0.5: finer makes the threshold's filters
        thousands of pixels wide).
    ym_per_px : float
        Metres per view pixel along the road (0.005-2).

    Examples
    --------
    >>> b = BirdseyeConfig()
    >>> b.size, round(b.xm_per_px, 5)
    ((400, 300), 0.02467)
    """

    reference_size: tuple[FrameSide, FrameSide] = (1280, 720)
    src: tuple[Point, Point, Point, Point] = ((581.3, 460.0), (702.9, 460.0), (1034.0, 675.0), (280.5, 675.0))
    size: tuple[ViewSide, ViewSide] = VIEW_SIZE_PX
    dst: tuple[Point, Point, Point, Point] = default_dst()
    xm_per_px: Annotated[float, Field(ge=0.002, le=0.5)] = LANE_WIDTH_M / LANE_SPAN_PX
    ym_per_px: Annotated[float, Field(ge=0.005, le=2.0)] = 0.09853

    @model_validator(mode="after")
    def _check_shapes(self) -> BirdseyeConfig:
        (x0, y0), (x1, y1), (x2, y2), (x3, y3) = self.src
        if not (x0 < x1 and x3 < x2 and y0 < y3 and y1 < y2):
            raise ValueError("src must be top-left, top-right, bottom-right, bottom-left")
        (a0, b0), (a1, b1), (a2, b2), (a3, b3) = self.dst
        if not (a0 < a1 and a3 < a2 and b0 < b3 and b1 < b2):
            raise ValueError("dst must be top-left, top-right, bottom-right, bottom-left")
        return self


class SobelHlsConfig(_Section):
    """``sobel-hls``: Sobel on the S channel of HLS plus an S colour threshold.

    Attributes
    ----------
    kernel : int
        Sobel kernel size (odd, 3-15).
    x_thresh, y_thresh, mag_thresh : tuple of int
        Bands (0-255) of the scaled x, y and magnitude gradients.
    dir_thresh : tuple of float
        Band of the gradient direction, radians.
    s_thresh : tuple of int
        Band of S itself.

    Examples
    --------
    >>> SobelHlsConfig().s_thresh
    (150, 255)
    """

    kernel: Literal[3, 5, 7, 9, 11, 13, 15] = 3
    x_thresh: ByteBand = (20, 255)
    y_thresh: ByteBand = (25, 255)
    mag_thresh: ByteBand = (30, 255)
    dir_thresh: Annotated[tuple[Annotated[float, Field(ge=0, le=math.pi / 2)],
                                Annotated[float, Field(ge=0, le=math.pi / 2)]], AfterValidator(_low_high)] = (0.0, 0.9)
    s_thresh: ByteBand = (150, 255)


class ColorConfig(_Section):
    """``color``: L of HLS and L of LUV for white, b of Lab for yellow.

    Attributes
    ----------
    hls_l, luv_l, lab_b : tuple of int
        Bands (0-255) of each channel.

    Examples
    --------
    >>> ColorConfig().lab_b
    (150, 255)
    """

    hls_l: ByteBand = (210, 255)
    luv_l: ByteBand = (215, 255)
    lab_b: ByteBand = (150, 255)


class YcrcbConfig(_Section):
    """``ycrcb``: Sobel x on Y of YCrCb, Y of YUV and R of RGB, OR-combined.

    Attributes
    ----------
    kernel : int
        Sobel kernel size (odd, 3-15).
    ycrcb_y_grad, yuv_y, rgb_r : tuple of int
        Bands (0-255) of the scaled gradient and of the two channels.

    Examples
    --------
    >>> YcrcbConfig().rgb_r
    (215, 255)
    """

    kernel: Literal[3, 5, 7, 9, 11, 13, 15] = 3
    ycrcb_y_grad: ByteBand = (30, 255)
    yuv_y: ByteBand = (205, 255)
    rgb_r: ByteBand = (215, 255)


class RidgeConfig(_Section):
    """``ridge`` (default): a line is brighter (or yellower) than the road on *both* sides.

    Horizontal top-hat of lightness (green) and of yellowness (red - blue) in the bird's-eye image over a window
    ``width_m`` wide; a pixel is a marking when its top-hat is above ``min_contrast`` and above
    ``rel_contrast`` times the local road level, so shadows (which scale brightness) and
    pavement seams (one-sided steps) do not pass.

    Attributes
    ----------
    width_m : float
        Width of the top-hat window across the road, metres.
    min_contrast : int
        Least lightness above the road on both sides (0-255).
    rel_contrast : float
        Least lightness above the road as a fraction of the road's own lightness.
    rel_contrast_max : int
        ... but never more than this many grey levels (0-255; 255: no cap).
    faint_contrast_max : int
        A second look for faint paint: where no line is found (none at least
        ``tracking.min_confidence`` sure), the view is thresholded again
        with ``rel_contrast_max`` at this (worn paint on light concrete is only 15-25 grey
        levels lighter than the road, less than ``rel_contrast`` of it), and the lines it finds
        are taken when each is at least ``faint_confidence`` sure; 255 turns it off.  Beside a
        held lane it also runs where one line is missing: see ``faint_pair_confidence``.
    faint_confidence : float
        The least confidence (0-1) of a line the second look finds.
    faint_pair_confidence : float
        The second look also runs where a lane is held and only one line is at least
        ``tracking.min_confidence`` sure; it is taken when it finds both lines, each at least
        this sure (and at least ``tracking.min_confidence``), and then measures both lines
        (at most 2; above 1 turns that off).
    yellow_min_contrast : int
        Least yellowness (red - blue) above the road on both sides.
    yellow_min : int
        Least yellowness of a yellow marking pixel.
    noise_factor : float
        Least lightness above the road as a multiple of the texture around the pixel (the mean
        top-hat of a patch ``noise_patch_m`` wide and a tenth of the view tall: rough asphalt and
        grass raise it, smooth pavement lowers it); 0 turns it off.
    noise_patch_m : float
        Width of that patch across the road, metres.

    Examples
    --------
    >>> RidgeConfig().width_m
    0.4
    """

    width_m: Annotated[float, Field(gt=0, le=2)] = 0.4
    min_contrast: Byte = 12
    rel_contrast: Annotated[float, Field(ge=0, le=5)] = 0.18
    rel_contrast_max: Byte = 255
    faint_contrast_max: Byte = 16
    faint_confidence: Fraction = 0.4
    faint_pair_confidence: Annotated[float, Field(ge=0, le=2)] = 0.6
    yellow_min_contrast: Byte = 18
    yellow_min: Byte = 30
    noise_factor: Annotated[float, Field(ge=0, le=20)] = 5.0
    noise_patch_m: Annotated[float, Field(gt=0, le=10)] = 1.5


class StreaksConfig(_Section):
    """Streaks that point at the camera, taken out of the bird's-eye binary before the search.

    Anything upright in the frame lies, in the bird's-eye view, on a ray from the road point
    right below the camera: the reflections of street lamps, tail lights and headlights on a
    wet road at night, a vehicle's sides, poles.  A lane line does so only where it passes
    under the car.  Set pixels that lie in one narrow fan of directions from that point over a
    long stretch are taken out (see :func:`lanefinder.threshold.streaks`).

    Attributes
    ----------
    enabled : bool
        Take the streaks out.
    bin_deg : float
        Width of a fan of directions, degrees.
    min_run_m : float
        A fan whose set pixels cover at least this much of the road ahead (rows, metres) holds
        a streak (a lane line that curves away from a ray stays in one fan only for a few metres;
        a lamp's reflection on a wet road runs most of the view).
    min_side_m : float
        Only fans that pass at least this far to the side of the car at the view's bottom row
        (m): a line passing under the car points at the camera too.

    Examples
    --------
    >>> StreaksConfig().min_run_m
    18.0
    """

    enabled: bool = True
    bin_deg: Annotated[float, Field(gt=0.01, le=10)] = 0.3
    min_run_m: Annotated[float, Field(gt=0, le=1000)] = 18.0
    min_side_m: Annotated[float, Field(ge=0, le=100)] = 0.1


class ThresholdConfig(_Section):
    """Which thresholding strategy finds marking pixels, and each strategy's levels.

    Attributes
    ----------
    strategy : str
        ``ridge`` (default), ``sobel-hls``, ``color`` or ``ycrcb``.
    ridge, sobel_hls, color, ycrcb : section
        Each strategy's settings.
    streaks : section
        Streaks pointing at the camera, taken out of the binary (:class:`StreaksConfig`).

    Examples
    --------
    >>> ThresholdConfig().strategy
    'ridge'
    """

    strategy: Literal["ridge", "sobel-hls", "color", "ycrcb"] = "ridge"
    ridge: RidgeConfig = RidgeConfig()
    sobel_hls: SobelHlsConfig = SobelHlsConfig()
    color: ColorConfig = ColorConfig()
    ycrcb: YcrcbConfig = YcrcbConfig()
    streaks: StreaksConfig = StreaksConfig()


class SearchConfig(_Section):
    """Finding line pixels in the bird's-eye binary.

    Sizes are in metres on the road and turn into pixels through the bird's-eye scale, so they
    hold for any set-up.  The comments beside the fields in the source say how they combine.

    Attributes
    ----------
    method : str
        The blind search: ``windows`` (sliding windows) or ``segments`` (a histogram per segment).
    n_windows : int
        Windows (or segments) up the view.
    margin_m : float
        Half-width of a window, metres.
    min_window_marking_m : float
        Length of marking a window needs to count as found, metres (through ``marking_width_m``).
    histogram_fraction : float
        Lower fraction of the view whose columns are summed for the line bases.
    around_margin_m : float
        Half-width of the band searched around the tracked lines, metres.
    lane_width_m : float
        Expected lane width, metres (pairs line bases; the width assumed before one is tracked).
    width_tolerance : float
        Relative tolerance on ``lane_width_m`` when pairing line bases.
    marking_width_m : float
        Width of a lane marking, metres: turns marking lengths into pixel counts.
    max_heading_deg, heading_step_deg : float
        The angled search: headings off the car's axis tried, and their step, degrees (step 0:
        off).
    heading_band_m : float
        Half-width of the band the angled search keeps around each window's ridge, metres.
    upper_histogram_weight : float
        Weight of the rows above ``histogram_fraction`` in the base histogram.
    peak_smoothing_m : float
        Width of the box filter on the base histogram, metres.
    max_peaks : int
        Highest histogram peaks paired into line bases.
    base_min_fraction : float
        Least peak height, as a fraction of a window's pixels.
    centre_preference : float
        Score a pair of bases loses per lane width its centre is off the car.
    inner_preference : float
        A pair of bases inside the best-scoring pair (each base at or inside it), nearer the
        expected lane width, that scores at least this fraction of it is taken instead (of
        several, the best-scoring): a lane is bounded by the first marking out
        from the car, and a kerb, rail or the next line beyond may be stronger.  0 (the
        default) takes the best pair.
    inner_retry_preference : float
        A blind search whose lane straddles a solid marking (a bright verge or kerb taken for
        a line, the true line inside: ``line-inside-lane`` in its middle half, or one within
        ``inner_retry_span``) is made again with ``inner_preference`` at this value (unless
        ``inner_preference`` is already on and at most this), and that lane is taken when it
        has both lines and passes the checks; 0: no second search.
    inner_retry_span : float
        How far from a blind lane's centre such a marking is looked for, as a fraction of the
        lane's width (0.4: all but its outer tenth on each side).
    pair_max_offset_m : float
        Farthest a pair of bases' centre may be off the car, metres (0: half a lane width
        either way, as before): a pair the car is not near the middle of (a line and the
        kerb beside the next lane) is not this lane's.
    momentum : float
        Share of the last window move kept for the next (the rest follows the latest drift).
    empty_window_decay : float
        Factor on the window move past an empty window.
    segment_reach, segment_max_shift, segment_band : float
        Segment search: histogram reach, largest peak shift, and band kept, in window margins.
    segment_min_fraction : float
        Segment search: pixels a segment needs, as a fraction of a window's.
    bend_max_per_m : float
        The bend probe (:func:`lanefinder.search.bend_search`): when every line a frame's search
        finds is too short for a curve (under ``fit.min_span_fraction`` of the view: one dash
        each near the car, the next ones beyond the search's band on a tight curve), each line's
        tangent is bent by curvatures up to this, 1/m either way (0: no probe) ...
    bend_step_per_m : float
        ... in steps of this, 1/m; the bend whose bands catch the most paint beyond the pieces
        (the fewer of the two lines') is searched again ...
    bend_band_m : float
        ... within this of the bent line, metres (narrower than ``around_margin_m``: a marking
        crossing at a slant then catches little) ...
    bend_min_gain : float
        ... when it catches this many times the paint the lines' straight continuation does ...
    bend_max_turn : float
        ... and each line's paint caught beyond heads within this of the bend, metres across
        per metre along (a slanted edge or specks at the view's edge are not the next dash).
        The measurer takes the new lines when neither is less confident and (with both) the pair passes the
        lane checks.  Chosen on tuning seeds 0-10 (exact set-ups, mean of 154 sequences): without
        the turn check 0.9332 -> 0.9319 (curve-entry 2 -0.255: a curvature of -1/42 m through
        specks); with it (0.05) 0.9336: three sequences changed, sharp-curve 4 0.635 -> 0.723,
        curve-entry 2 -0.017, glare 7 +0.0003.

    Examples
    --------
    >>> SearchConfig().margin_m
    0.6
    """

    method: Literal["windows", "segments"] = "windows"
    n_windows: Annotated[int, Field(ge=2, le=100)] = 12
    margin_m: Annotated[float, Field(gt=0, le=5)] = 0.6
    min_window_marking_m: Annotated[float, Field(gt=0, le=10)] = 0.2
    histogram_fraction: Annotated[float, Field(gt=0, le=1)] = 0.5
    around_margin_m: Annotated[float, Field(gt=0, le=5)] = 0.45
    lane_width_m: Annotated[float, Field(ge=1, le=10)] = LANE_WIDTH_M
    width_tolerance: Annotated[float, Field(gt=0, lt=1)] = 0.22
    marking_width_m: Annotated[float, Field(gt=0, le=1)] = 0.15
    # When the straight-ahead search finds weak lines, lines heading up to this many degrees off
    # the car's axis are tried too, every ``heading_step_deg`` (0 turns that search off; a
    # finer step than MIN_HEADING_STEP_DEG would only multiply the work).
    max_heading_deg: Annotated[float, Field(ge=0, lt=80)] = 25.0
    heading_step_deg: Annotated[float, Field(ge=0, le=45)] = 5.0
    # Each window of that angled search keeps only the pixels within this distance of its
    # strongest ridge, so clutter beside a slanted line stays out of its fit (0 keeps them all).
    heading_band_m: Annotated[float, Field(ge=0, le=5)] = 0.3
    # Line bases: the base histogram counts rows above the lower ``histogram_fraction`` with this
    # weight (a line with a gap at the bottom still gets a base), is smoothed over
    # ``peak_smoothing_m``, and its ``max_peaks`` highest peaks of at least ``base_min_fraction``
    # of a window's pixels are paired; a pair off-centre by a lane width loses
    # ``centre_preference`` of its score.
    upper_histogram_weight: Fraction = 0.5
    peak_smoothing_m: Annotated[float, Field(gt=0, le=5)] = 0.22
    max_peaks: Annotated[int, Field(ge=1, le=64)] = 8
    base_min_fraction: Fraction = 0.25
    centre_preference: Fraction = 0.3
    inner_preference: Fraction = 0.0
    # Tuning seeds 0-10: `hills` 0.763 -> 0.894 (0.821 on refused lanes alone), every other
    # scenario and the three videos unchanged.
    inner_retry_preference: Fraction = 0.5
    inner_retry_span: Annotated[float, Field(gt=0, lt=0.5)] = 0.4
    # A new lane must hold the car within ``tracking.max_offset_m`` of its centre, and a base
    # lies up to about half a metre off its line's x at the car in a bend: a pair centred
    # farther off than this cannot start a lane.
    pair_max_offset_m: Annotated[float, Field(ge=0, le=10)] = 1.5
    # Windows follow a bend: the next window moves by ``momentum`` of the last move plus the rest
    # of the latest drift; past an empty window the move shrinks by ``empty_window_decay``.
    momentum: Fraction = 0.5
    empty_window_decay: Fraction = 0.5
    # Segment search: a segment's histogram spans ``segment_reach`` margins either side, its
    # peak may lie ``segment_max_shift`` margins from where the line is heading, and keeps the
    # pixels within ``segment_band`` of a margin of it; a segment needs ``segment_min_fraction``
    # of a window's pixels.
    segment_reach: Annotated[float, Field(gt=0, le=20)] = 2.0
    segment_max_shift: Annotated[float, Field(gt=0, le=20)] = 1.5
    segment_band: Fraction = 0.5
    segment_min_fraction: Fraction = 0.5
    # The bend probe for lines too short for a curve (see the docstring).
    bend_max_per_m: Annotated[float, Field(ge=0, le=0.2)] = 0.025
    bend_step_per_m: Annotated[float, Field(gt=0, le=0.2)] = 0.0008
    bend_band_m: Annotated[float, Field(gt=0, le=5)] = 0.15
    bend_min_gain: Annotated[float, Field(ge=1, le=100)] = 2.0
    bend_max_turn: Annotated[float, Field(gt=0, le=10)] = 0.05

    @model_validator(mode="after")
    def _check_steps(self) -> SearchConfig:
        if 0 < self.heading_step_deg < MIN_HEADING_STEP_DEG:
            raise ValueError(f"heading_step_deg must be 0 (off) or at least {MIN_HEADING_STEP_DEG} degrees")
        if 0 < self.bend_max_per_m < self.bend_step_per_m:
            raise ValueError("bend_max_per_m must be 0 (off) or at least bend_step_per_m")
        if self.bend_max_per_m / self.bend_step_per_m > MAX_BEND_STEPS + 1e-9:
            raise ValueError(f"bend_max_per_m / bend_step_per_m must be at most {MAX_BEND_STEPS} "
                             "(curvatures the bend probe tries either way)")
        return self


class FitConfig(_Section):
    """Robust second-order fit x = a*y^2 + b*y + c (bird's-eye pixels); sizes in metres.

    Attributes
    ----------
    robust_iterations : int
        Huber reweighting rounds.
    huber_m : float
        Huber threshold on the residual, metres.
    min_marking_m : float
        Length of marking a line needs to be fitted at all, metres.
    full_support_m : float
        Length of marking for full support (confidence), metres.
    residual_scale_m : float
        Residual at which the fit quality (confidence) halves, metres.
    min_span_fraction : float
        Pixels spanning less of the view's height get a straight (first-order) fit.
    parallel : float
        How far the weaker line's shape moves towards the shared lane shape (0 off, 1 all).
    full_span_fraction : float
        Span of the view a line must cover for full confidence.
    max_points : int
        A line with more pixels is fitted on an even subsample of this many.
    band_m : float
        A line's pixels are counted in bands this long along the road, metres ...
    band_min_marking_m : float
        ... and a band holding less paint than this length of full-width marking is left out
        of the fit: specks and crack slivers in the search window, not a marking (a real dash
        fills its bands), metres (0: every pixel counts).
    piece_min_marking_m : float
        A piece of a line (bands next to each other that hold any of its pixels: a dash, a
        stretch of solid or worn line) holding less paint than this length of full-width
        marking, in bands kept as above, is left out of the fit (unless the view's far edge
        cuts it): a speck ten metres from the rest stretches the line's span and bends its fit,
        metres (0: every piece counts; 0.5, as ``min_marking_m``: the paint a line needs).
        Frames of a video only: a single still is fitted with every piece.
    short_bend_share : float
        A line too short for a curve (under ``min_span_fraction`` of the view: a dash or two far
        ahead) gives its place and direction.  This share of its direction is read as the road
        bending away from the car's heading (a parabola level with the car's axis at the view's
        bottom), the rest as the lane's heading (a straight line); 0 reads all of it as heading.
        Chosen on tuning seeds 0-10 / 0-2 (mean of 13 scenarios; without the angle limit below):
        0 0.9172, 0.3 0.9214, 0.5 0.9225, 0.7 0.9232, 1 0.9192; from 0.5 up straight roads lose at
        40-70 m (0.998 -> 0.982 at 0.5, a test's dashed seed 2 at 720p 1.00 -> 0.93) and worn
        roads more (0.584 -> 0.456).  0.3 with a 3 degree limit: 0.9210, every scenario equal or
        better but worn (0.8804 -> 0.8794); curve 0.929 -> 0.955, curve-entry lateral error 6 m
        ahead p90 0.096 -> 0.091 m.
    short_bend_max_deg : float
        ... only for a line heading within this angle of the car's axis (degrees): in a hairpin a
        short piece's steep direction is the lane's heading.  The harder challenge video's lane
        count moves with it (its hairpin's first second is lost or held on a knife edge): 1136
        frames with share 0.3 at 2 and 3 degrees, 1110 at 4; 1136 at 0.4 and 3, 1110 at 0.4 and 4.
    max_radius_m : float
        Cap on the reported radius, metres (a straight road reports it).
    straight_radius_m : float
        Radius above which the road is reported straight, metres.

    Examples
    --------
    >>> FitConfig().max_radius_m
    10000.0
    """

    robust_iterations: Annotated[int, Field(ge=0, le=10)] = 2
    huber_m: Annotated[float, Field(gt=0, le=2)] = 0.06
    min_marking_m: Annotated[float, Field(gt=0, le=100)] = 0.5
    full_support_m: Annotated[float, Field(gt=0, le=100)] = 1.9
    residual_scale_m: Annotated[float, Field(gt=0, le=5)] = 0.09
    min_span_fraction: Fraction = 0.25
    parallel: Fraction = 1.0
    # Span of the view (fraction of its height) a line must cover for full confidence.
    full_span_fraction: Annotated[float, Field(gt=0, le=1)] = 0.6
    # A line with more pixels is fitted on an even subsample of this many (bounds the cost).
    max_points: Annotated[int, Field(ge=10, le=100000)] = 1200
    band_m: Annotated[float, Field(ge=0.05, le=100)] = 1.0
    band_min_marking_m: Annotated[float, Field(ge=0, le=10)] = 0.13
    piece_min_marking_m: Annotated[float, Field(ge=0, le=10)] = 0.5
    short_bend_share: Fraction = 0.3
    short_bend_max_deg: Annotated[float, Field(ge=0, le=45)] = 3.0
    max_radius_m: Annotated[float, Field(gt=0, le=1e7)] = 10000.0
    straight_radius_m: Annotated[float, Field(gt=0, le=1e7)] = 3000.0

    @model_validator(mode="after")
    def _check_band(self) -> FitConfig:
        if self.band_min_marking_m >= self.band_m:
            raise ValueError("band_min_marking_m must be below band_m (a full-width marking fills its band)")
        return self


class TrackingConfig(_Section):
    """Across frames: the lane checks, smoothing, re-detection (see :mod:`lanefinder.checks`).

    Attributes
    ----------
    min_width_m, max_width_m : float
        Plausible lane width, metres.
    max_width_change_m : float
        Largest change from the tracked width, metres.
    width_renew_frames : int
        A pair refused for the change of width alone this many times in a row (frames with no
        pair between them do not count, nor break the row; a pair refused for anything else
        breaks it), each width within ``width_renew_spread_m`` of the mean of those before it,
        and more times than pairs made the tracked width, is taken, and its width becomes the
        tracked width: the track's width was the wrong one (a lane started from one line, its
        width then read once off a wrong partner, refused the true partner ever after) (0:
        never).
    width_renew_spread_m : float
        How far, in metres, each width in that row may lie from the mean of those before it.
    max_parallel_diff_m : float
        Largest change of the width along the view, metres, on a set-up that is not the
        config's own (the default one, a still's, or one self-calibration estimated).
    max_parallel_diff_own_setup_m : float
        The same with a set-up of the config's own (``birdseye`` not the default, as
        ``lanefinder setup`` writes it), metres: see the note at the field.
    max_curvature_diff : float
        Largest difference of the two lines' curvatures, 1/m.
    max_offset_jump_m : float
        Largest move of a line from its track at the car, metres.
    far_jump_factor : float
        The jump limit at the far end, as a multiple of ``max_offset_jump_m``.
    max_offset_m : float
        Farthest the car may be from the lane centre, metres.
    max_misses : int
        Misses after which the next frame is searched blind.
    lost_after : int
        Misses after which the lane is lost ...
    reference_fps : float
        The frame rate the counts (``max_misses``, ``lost_after``, ``hold_gentle_frames``,
        ``max_one_line_frames``, ``start_frames``, ``weak_start_frames``) and per-frame gains (``smoothing``,
        ``smoothing_fast_gain``, ``smoothing_min_gain``, ``width_smoothing``) are set for; a video
        at another rate gets them scaled to the same times (:func:`lanefinder.tracking.at_fps`).
    hold_gentle_frames, hold_gentle_radius_m : int, float
        ... or after ``hold_gentle_frames`` (at least ``lost_after``) when the lane curves no
        tighter than radius ``hold_gentle_radius_m`` (metres; 0: never): see
        :func:`lanefinder.tracking.hold_frames`.
    max_one_line_frames : int
        Frames one line alone may hold the lane.
    min_start_confidence : float
        Confidence a line needs to start (or re-place) a lane alone; both lines of a pair need
        it to start a lane at once after a lost one, or to replace a held lane elsewhere when
        re-detecting (``weak-pair``).
    sure_first_width : bool
        A lane's first pair sets its width only when both its lines are at least
        ``min_start_confidence`` sure, or when it restarts a lane after a lost one (a weak start
        is then confirmed: seen twice in one place).  After a weaker first pair, shown as found,
        the default width (``search.lane_width_m``) stands in: later pairs move it by
        ``width_smoothing`` a frame and are held to it (``max_width_change_m``).  A line inferred
        from the other keeps the width the lane was first given for as long as only one line is
        seen (synthetic ``worn`` seed 1: the first pair's right line, 0.32 sure, read a lane 3.5 m
        wide as 4.5 m, and the right line inferred from the left one stayed 1 m out for 20
        frames).  Where the true lane is narrower or wider than the default by more than
        ``max_width_change_m`` and its first pair is weak, its pairs are refused (one line kept,
        the other inferred at the default width) until the width is renewed
        (``width_renew_frames``).  Not used by a self-calibrating run
        (:class:`~lanefinder.pipeline.LaneFinder` turns it off): its set-up, estimated or the
        default, reads the road's metres only as well as the estimate, and the width measured
        is then no worse a guess than the default.
    min_start_radius_m : float
        A lane (one line or a pair) may not start bending tighter than this radius, m (reason
        ``start-bend``; 0: no limit).  A hairpin bends at 20-30 m; a tighter start comes from a
        fit bent by a metre or two of paint (glare: synthetic ``glare`` seed 8, a lone line read
        at 18 m, 0.6694 -> 0.7178).  Checked only without a usable track (no lane, or
        ``max_misses`` reached), and not against lines that re-place a held lane which bends
        as tight itself.
    still_start_confidence : float
        ... in a single still (``lanefinder image``), where no later frame can confirm or
        correct a start: the other line is then drawn as inferred at the default lane width.
    start_frames : int
        Sightings a lone line needs to start a lane after one was lost.
    weak_start_confidence, weak_start_frames : float, int
        Without a lane, a lone line less sure than ``min_start_confidence`` but at least this
        sure (and at least ``min_confidence``, or it is not used at all) starts the lane when
        seen in the same place, as far as it reaches, on this many frames (never fewer than
        ``start_frames``; a gap of up to ``start_frames`` allowed), the other line inferred at
        the default lane width: a marking seen only near the car in glare or on worn paint
        (0 frames: never).  It displaces no surer candidate: a pair or a confident line
        waiting elsewhere keeps its place.
    max_interior_fill, interior_strip_m, interior_excess, interior_min_pixels, interior_min_rows
        The no-marking-down-the-middle check (see the comment in the source).
    smoothing, smoothing_conf_floor, smoothing_fast_gain, smoothing_min_gain : float
        The smoothing gain of the metre fits (see the comment in the source).
    width_smoothing : float
        Gain of the tracked lane width per frame.
    rejected_pair_confidence : float
        Factor on both confidences of a pair that fails the lane checks (without a usable
        track, only on the weaker when it is below ``min_start_confidence``: the surer line,
        the one kept, keeps its own).
    inferred_weight : float
        An inferred line is smoothed with this times the confidence of the line it comes from.
    start_gap_m : float
        A measured line whose nearest paint lies further ahead than this (m: a dash gap beside
        the car, paint hidden near it) is extrapolated at the car: it may move the tracked line
        there by at most ``start_free_m`` a frame, and the rest of that move is held back (its
        heading and bend are taken as measured; 0: off).  A lane found afresh, and a line seen
        again after it was inferred, are taken as measured.
    start_free_m : float
        How far such a measurement may move the line at the car in one frame, m (at
        ``reference_fps``).
    start_both_frames : int
        The hold applies only while both lines were measured within this many frames: a lane
        seen by one line at a time for longer (a hairpin, where the near paint leaves the view)
        goes by the line it sees.
    min_confidence : float
        Confidence a measured line needs to be used.
    yellow_line_side : str
        Where a yellow marking may bound the lane: ``left``, ``right`` or ``either``.
    yellow_fraction : float
        Share of yellow pixels that makes a line yellow.
    yellow_saturation : float
        Least (red - blue) / red of a yellow pixel.

    Examples
    --------
    >>> TrackingConfig().max_misses
    5
    """

    min_width_m: Annotated[float, Field(gt=0, le=10)] = 2.5
    # 3.7 m lanes measure up to 4.7 m for a frame when the car pitches on a bump (the flat-road
    # bird's-eye view then stretches them), as at 22.4 s of the project video.
    max_width_m: Annotated[float, Field(gt=0, le=20)] = 4.8
    max_width_change_m: Annotated[float, Field(gt=0, le=10)] = 0.7
    width_renew_frames: Annotated[int, Field(ge=0, le=10_000)] = 5
    width_renew_spread_m: Annotated[float, Field(gt=0, le=10)] = 0.2
    max_parallel_diff_m: Annotated[float, Field(gt=0, le=20)] = 0.9
    # On a crest or in a sag the flat-road view parts or narrows a lane's lines ahead: with the
    # camera's own set-up, a pair whose width changes by more than 0.9 m is most often that, not
    # a wrong line (synthetic `hills`, tuning seeds 0-10: 0.7419 -> 0.9566 on seed 1, 0.6781 ->
    # 0.9597 on seed 6; 0.9288 -> 0.9332 over the 154 sequences, 1.3 to 2.0 alike, 1.1 less).
    # On a set-up not known (the default, a still's, a self-calibrated one) the set-up's own
    # error parts the lines too, and the looser limit let wrong pairs in and pitched the
    # self-calibrated set-up from hill-bent pairs (unknown mounts, tuning seeds: 0.8920 -> 0.8872;
    # harder_challenge_video: lane shown 94.7 -> 93.0%): there it stays 0.9.
    max_parallel_diff_own_setup_m: Annotated[float, Field(gt=0, le=20)] = 1.3
    max_curvature_diff: Annotated[float, Field(gt=0, le=1)] = 0.004
    max_offset_jump_m: Annotated[float, Field(gt=0, le=10)] = 0.4
    # The jump limit at the far end of the view, as a multiple of ``max_offset_jump_m``.
    far_jump_factor: Annotated[float, Field(gt=0, le=100)] = 3.0
    max_offset_m: Annotated[float, Field(gt=0, le=10)] = 0.9
    max_misses: Annotated[int, Field(gt=0, le=100_000)] = 5
    lost_after: Annotated[int, Field(gt=0, le=100_000)] = 12
    hold_gentle_frames: Annotated[int, Field(gt=0, le=100_000)] = 25
    reference_fps: Annotated[float, Field(ge=1, le=1000)] = 25.0
    hold_gentle_radius_m: Annotated[float, Field(ge=0, le=1e7)] = 150.0
    max_one_line_frames: Annotated[int, Field(gt=0, le=100_000)] = 50
    min_start_confidence: Fraction = 0.45
    sure_first_width: bool = True
    min_start_radius_m: Annotated[float, Field(ge=0, le=1e7)] = 20.0
    still_start_confidence: Fraction = 0.3
    start_frames: Annotated[int, Field(gt=0, le=100_000)] = 3
    weak_start_confidence: Fraction = 0.3
    weak_start_frames: Annotated[int, Field(ge=0, le=10_000)] = 5
    # No marking down the middle: set pixels in the middle half of a candidate lane, binned in
    # strips ``interior_strip_m`` wide (a strip counts on a row with ``interior_min_pixels``);
    # a strip filled on more than ``max_interior_fill`` of at least ``interior_min_rows`` rows,
    # and on ``interior_excess`` more of them than the median strip, is a marking.
    max_interior_fill: Fraction = 0.6
    interior_strip_m: Annotated[float, Field(ge=0.02, le=5)] = 0.2
    interior_excess: Fraction = 0.4
    interior_min_pixels: Annotated[int, Field(gt=0, le=1_000_000)] = 2
    interior_min_rows: Annotated[int, Field(gt=0, le=100_000)] = 10
    # Smoothing of the metre fits: the gain is (1 - smoothing) * (f + (1 - f) * confidence), with
    # f = ``smoothing_conf_floor``, plus ``smoothing_fast_gain`` times the change at the far end
    # relative to the jump limit (so bends are followed without lag), at least
    # ``smoothing_min_gain``.  The tracked lane width moves by ``width_smoothing`` per frame.
    smoothing: Fraction = 0.5
    smoothing_conf_floor: Fraction = 0.4
    smoothing_fast_gain: Fraction = 0.3
    smoothing_min_gain: Fraction = 0.05
    width_smoothing: Fraction = 0.1
    # A pair that fails the lane checks keeps one line, and both confidences are scaled by
    # ``rejected_pair_confidence`` (without a track, the kept line's not when the other is too
    # weak to start a lane); an inferred line is smoothed with ``inferred_weight`` times
    # the confidence of the line it is drawn from.
    rejected_pair_confidence: Fraction = 0.5
    inferred_weight: Fraction = 0.5
    # A line seen only from some way ahead (its nearest paint beyond ``start_gap_m``) says little
    # about where it is at the car: there it moves the track by ``start_free_m`` a frame at most.
    start_gap_m: Annotated[float, Field(ge=0, le=100)] = 6.0
    start_free_m: Annotated[float, Field(gt=0, le=10)] = 0.1
    start_both_frames: Annotated[int, Field(ge=0, le=100_000)] = 10
    min_confidence: Fraction = 0.3
    # Where a yellow marking may bound the car's lane: "left" for right-hand traffic as in North
    # America (yellow separates opposing traffic, so it is never the lane's right line), "right"
    # for the mirror case, "either" to ignore colour.
    yellow_line_side: Literal["left", "right", "either"] = "left"
    yellow_fraction: Fraction = 0.5
    yellow_saturation: Fraction = 0.45

    @model_validator(mode="after")
    def _check_widths(self) -> TrackingConfig:
        if self.min_width_m >= self.max_width_m:
            raise ValueError("min_width_m must be below max_width_m")
        return self


class FarConfig(_Section):
    """Following each line beyond the bird's-eye view (see :mod:`lanefinder.farfield`).

    Attributes
    ----------
    enabled : bool
        Follow the lines beyond the view.
    max_range_m : float
        How far ahead of the bird's-eye bottom row to look, m.
    window_m : float
        Half-width of the search window at the view's top edge, m.
    window_growth : float
        How much the half-width grows per metre beyond it, m/m.
    max_gap_m : float
        Longest stretch without marking that is crossed, m: several dash periods, since a
        dash far ahead spans one or two frame rows and is often missed.
    min_rows : int
        Far rows that must hold the marking for the far part to count.
    confidence_decay_m : float
        Beyond the view, a line's confidence falls by e every this many metres.
    width_factor : float
        The far view's width as a multiple of the bird's-eye view's, centred on it.
    strip_m : float
        Half-width of the strip around each line's extension that is looked at, m: how far
        the marking may stray from the near fit's extension.
    noise_factor : float
        The ridge threshold's texture test in the far strips (``threshold.ridge.noise_factor``
        there): far markings are a pixel or two wide and the strips hold little road besides.
    faint_contrast_max : int
        A second look for faint far paint: a line the far strips give no far part is followed
        again in its strip thresholded with ``threshold.ridge.rel_contrast_max`` at this (0-255;
        at or above that setting, or with another threshold strategy, no second look).  Far
        ahead a marking is a pixel or two wide and blurred: on light concrete it is less than
        ``rel_contrast`` of the road lighter than it (tuning seed 4: white dashes 0.10 m wide on
        concrete, none found beyond 40 m).  Chosen on tuning seeds 0-10 (exact set-ups, mean of
        14 scenarios, before 0.9399), with ``faint_short_m`` 0: 16 0.9422 (every scenario equal or better; the seed-4
        sequences +0.025 to +0.050), 12 0.9428 (the harder challenge video's labels 0.7198 ->
        0.7158, against 0.7169 at 16); the cap on every far strip instead of as a second look,
        0.9431 at 16, but it lost far parts on four seed-1 scenes (-0.010 to -0.013: stray
        pixels of a darker road with vehicles ahead scattered them).  255 turns it off ...
    faint_short_m : float
        ... and a line whose far part ends within this many metres of the far view's nearest
        row (a frame row beyond the view's top edge: 0.9 m at 720p, 1.8 m at 640x360 with the
        default set-up) gets the second look too, its far part taken when it reaches farther
        (on reach alone: no check that the two agree where the first ends), m (0: only a line
        with no far part).  The first look often finds a far dash or two just beyond the view
        and none farther.  Tuning seeds 0-10 (second look at 16): 0 0.9422, 15 0.9426, 30
        0.9431 (every scenario equal or better; `straight` 4 0.970 -> 0.991, no sequence down by
        more than 0.001).
    anchor_m : float
        The correction to the near fit is fitted as if the marking had also been found on the
        fit's extension this far beyond the view's top edge, m (0: not): a stray pixel in the
        first far rows, where a small offset means a steep slope, cannot then send the search
        off the line.
    max_scatter_m : float
        A far part whose rows lie further from its fitted curve than this (median), m, is no
        marking but texture (leaves, gravel, a verge) and is dropped (0: kept), unless at
        least 8 of them lie as close to a cubic, which takes at least half the scatter away
        (a bend that tightens or opens along the road strays from the fitted parabola far
        ahead, smoothly; texture scatters about any smooth curve: see
        :data:`lanefinder.farfield.SMOOTH_MIN_ROWS`).  Measured: on the project video half
        the far parts scatter under 0.03 m and nine in ten under 0.08 m; on the harder
        challenge video's verges and bushes half scatter over 0.1 m.  The cubic keeps 9 of
        the 42 far parts over the limit on the project video, 35 of 252 on the challenge
        video and 42 of 476 on the harder challenge video.
    min_px_per_m : float
        The far view ends where a metre across the road spans fewer frame pixels than this
        (0: at ``max_range_m`` only): beyond, a marking is narrower than about a pixel and
        what is found is mostly noise.  8 keeps the whole view at 1280x720 with the Udacity
        lens (about 12 px a metre at 96 m) and ends it about 62 m ahead at 640x360.
    hold : bool
        A held lane whose two lines' markings are both followed beyond the view on a frame
        ages slower towards lost (:func:`lanefinder.tracking.seen_far`, within its bounds; not
        on a frame whose measured lines were refused for lying elsewhere): worn paint whose near
        dashes are gone shows farther ones.  Tuning seeds 0-10 (own stretches): worn 0.8907 ->
        0.9026, no lane on 3.3% -> 1.5% of its frames; one line's far part was not enough
        (curve-entry 0.9581 -> 0.9355).

    Examples
    --------
    >>> FarConfig().max_range_m
    100.0
    """

    enabled: bool = True
    max_range_m: Annotated[float, Field(gt=0, le=300)] = 100.0
    window_m: Annotated[float, Field(gt=0, le=2)] = 0.35
    window_growth: Annotated[float, Field(ge=0, le=0.1)] = 0.01
    max_gap_m: Annotated[float, Field(gt=0, le=100)] = 40.0
    min_rows: Annotated[int, Field(ge=2, le=100)] = 4
    confidence_decay_m: Annotated[float, Field(gt=0, le=1000)] = 40.0
    width_factor: Annotated[float, Field(ge=1, le=8)] = 6.0
    strip_m: Annotated[float, Field(gt=0.5, le=20)] = 3.0
    noise_factor: Annotated[float, Field(ge=0, le=20)] = 0.0
    faint_contrast_max: Byte = 16
    faint_short_m: Annotated[float, Field(ge=0, le=300)] = 30.0
    anchor_m: Annotated[float, Field(ge=0, le=100)] = 20.0
    max_scatter_m: Annotated[float, Field(ge=0, le=10)] = 0.12
    min_px_per_m: Annotated[float, Field(ge=0, le=1000)] = 8.0
    hold: bool = True


class RenderConfig(_Section):
    """How the lane is drawn on the frame.

    Attributes
    ----------
    lane_color, left_color, right_color : tuple of int
        BGR colours of the lane fill and the two lines.
    alpha : float
        Opacity of the lane fill.
    line_thickness : int
        Line thickness, pixels.
    hud : bool
        Draw the radius/offset/width box.

    Examples
    --------
    >>> RenderConfig().line_thickness
    6
    """

    lane_color: tuple[Byte, Byte, Byte] = (0, 200, 0)
    left_color: tuple[Byte, Byte, Byte] = (0, 0, 255)
    right_color: tuple[Byte, Byte, Byte] = (255, 80, 0)
    alpha: Fraction = 0.3
    line_thickness: Annotated[int, Field(ge=1, le=50)] = 6
    hud: bool = True


class VideoConfig(_Section):
    """How the annotated video is encoded and decoded.

    Attributes
    ----------
    preset : str
        x264 preset.
    crf : int
        x264 quality, 0-51 (lower is better).
    threads : int
        FFmpeg threads (0: FFmpeg's choice).

    Examples
    --------
    >>> VideoConfig().preset
    'superfast'
    """

    preset: Literal["ultrafast", "superfast", "veryfast", "faster", "fast", "medium", "slow"] = "superfast"
    crf: Annotated[int, Field(ge=0, le=51)] = 23
    threads: Annotated[int, Field(ge=0, le=64)] = 0


class LimitsConfig(_Section):
    """What a run may use.

    Attributes
    ----------
    memory_mb : int
        Memory a run may need for its frames and views, MB; a frame or view size that would
        need more is refused before anything is allocated.

    Examples
    --------
    >>> LimitsConfig().memory_mb
    2048
    """

    memory_mb: Annotated[int, Field(ge=64, le=1_048_576)] = 2048


class SelfCalConfig(_Section):
    """Self-calibration: the set-up estimated from the video itself while it runs.

    It runs on ``lanefinder video`` (and batch, review) when the config gives no set-up of
    its own (``birdseye`` is the default).  Frames are looked at as for ``lanefinder setup``
    (vanishing point, ego lines, camera height from the lane width, curved frames refused);
    the focal length is the camera's (``camera.model``), or measured from the dashes when
    that is ``none`` without ``focal_px``.  The estimate replaces the set-up in use when it
    would read the road differently by more than the ``change_*`` limits.

    Attributes
    ----------
    enabled : bool
        Estimate the set-up from the video when the config gives none.
    every_frames : int
        Until a sure estimate, look at one frame in this many (for the first ``fast_frames``
        frames at most); an estimate not sure enough does not end these fast looks.
    fast_frames : int
        After this many frames, or once there is a sure estimate, the slow rate applies (a road
        that gives no sure estimate, curved all along, is not looked at closely for ever).
    refine_every_frames : int
        Afterwards, one in this many (slow refinement); with ``window_frames`` this sets how
        far back the estimate reaches (40 frames looked at, one in 50: 80 s at 25 fps).
    min_frames : int
        Accepted frames before the first estimate.
    window_frames : int
        The most recent accepted frames the estimate rests on.
    work_width_px : int
        Frames are looked at no wider than this, px (960: a look costs about half the line-segment
        detection of 1280, and estimates as good on synthetic unknown mounts).
    change_xm_pct, change_ym_pct : float
        A new estimate is taken when it reads distances across / along differently by more
        than this, percent ...
    change_car_m : float
        ... or places the car differently by more than this, m ...
    change_sigmas : float
        ... and by more than this many of the estimate's expected errors.
    dash_period_m : float
        Dash plus gap, m, for the focal length without one (12.2: US federal; 14.6: California).
    skip_radius_m : float
        A frame whose lane the pipeline has just read as curving tighter than this is not looked
        at (the set-up's straightness test would refuse it; a homography keeps straight lines
        straight, so a wrong set-up does not make a straight road look curved), m (0: look at
        every frame whose turn it is).
    stills : bool
        ``lanefinder image`` estimates each still's own set-up from the still alone (one
        straight frame is enough when the focal length is known) ...
    still_height_m : tuple of float
        ... and takes it when the camera height it implies (from the lane width) is in this
        range, a car's or an SUV's dashcam, m (one frame cannot tell a hill from a camera
        pitched otherwise; a curving road read as straight gives too high a camera) ...
    still_max_car_m : float
        ... and it places the car at most this far from where the set-up in use does, m (one
        frame cannot tell a car off its lane's centre from a camera turned).
    still_min_radius_m : float
        A still whose lane the config's set-up reads as curving tighter than this is not looked
        at (one frame of a curving road can mislead the estimate), m (0: every still is).
    still_work_width_px : int
        A still is looked at no wider than this, px (one frame has no others to outvote a noisy
        reading: at 960, test1.jpg, a curve, read a horizon 23 px off and was taken).
    still_horizon : bool
        A still that gives no set-up of its own (a curving road, or a camera height outside
        ``still_height_m``: the ego lines misread) but whose road lines meet on a vanishing
        point is found again with the config's set-up pitched to that point's row
        (:func:`lanefinder.selfcal.horizon_setup`; the height and the yaw kept), and so is a
        self-calibrating video's first frame (``first_frame``) ...
    still_horizon_margin : float
        ... and that result is kept when it has a lane and its lines' mean confidence is at
        least this much higher (or the config's set-up shows no lane) ...
    still_horizon_agree : float
        ... or, with any confidence, when that row and the one the near parts of the lines
        found with the config's set-up meet on (:func:`lanefinder.selfcal.lines_setup`) lie
        within this fraction of the frame's height of each other: two reads of the pitch from
        different pixels agree (0.007: 5 px at 720p; 0 turns this off).  A set-up that pitches
        the road wrong splays the lane in the view and a weak dashed line takes its strong
        partner's splayed shape, while a wrong pitch can leave that line surer.  Chosen on
        stills of the three videos at 0, 0.25 and 0.75 s of each second (the reported set is
        the middle frame; project, challenge, harder, of 152, 49 and 136): 0 146, 34, 65 agree;
        0.007 146, 38, 65; 0.0097 (7 px) 146, 39, 62; 0.014 (10 px) 146, 39, 62.
    still_lines : bool
        A still that gives no set-up of its own (a curving road, say), and whose horizon's
        set-up was not kept, is found again with the
        set-up the near parts of its lines give (:func:`lanefinder.selfcal.lines_setup`), and
        that result is kept when it has a lane and its lines are no less sure.
    estimate_check : bool
        A sure estimate that would replace the set-up in use is first tried on the frame it
        came with: that frame is found blind with each set-up, and the estimate is refused (the
        set-up in use stays, as if confirmed) when the set-up in use shows a lane whose lines'
        mean confidence is at least ``estimate_check_margin`` higher, or shows a lane where the
        estimate shows none (on synthetic unknown mounts, three frames' right ego line taken on
        a shadow's edge read the lane 42% narrow and the camera 2.88 m high) ...
    estimate_check_margin : float
        ... that margin (0-1).
    first_frame : bool
        A video's first frame is looked at alone, as a still is (its own set-up, the still
        gates, else its horizon's set-up as ``still_horizon`` says), and the set-up it gives
        is used until self-calibration has a sure estimate (telemetry ``setup`` = ``first-frame``;
        so is the set-up two early frames agree on, below).  Off, no frame is looked at alone.
    first_look_frames : int
        When the first frame gives no set-up, frames 1 to this - 1 whose index is a multiple of
        ``every_frames`` are each looked at alone too, while the set-up in use is still the
        default; a frame's own set-up (no horizon's set-up: on a curve the row where the lines
        meet drifts) is taken, as the first frame's is, when it agrees with the one the frame
        looked at before it gave (two looks in a row that give one; at most 2 * ``every_frames``:
        never; 0: none looked at) ...
    first_look_agree_px : float
        ... their horizons within this many pixels per 720 rows and their camera heights
        within 10% (one look alone took, at frame 12 of the harder challenge video, a horizon
        9.6 px above the one its estimates confirm: lane shown 94.7 -> 88.9%).
    unsure_parallel : float
        While a self-calibrating video runs on the default (or its first frame's) set-up, before its first sure estimate
        and within its first ``fast_frames`` frames, ``fit.parallel`` is this: a camera mounted
        otherwise than the default's makes a straight lane's lines converge or part in the
        bird's-eye view, and pulling them parallel bends them ...
    unsure_parallel_diff_m : float
        ... ``tracking.max_parallel_diff_m`` is this, m ...
    unsure_curvature_diff : float
        ... and ``tracking.max_curvature_diff`` is this, 1/m ...
    unsure_radius_m : float
        ... unless the last frame's lane curved tighter than this, m (a sharp curve's lines keep
        their shared shape: they lose more without it than a wrong set-up costs; 0: relaxed on
        every such frame).
    lines_horizon : bool
        The horizon is also read off the lane lines measured: on a flat road the near parts of
        the two lines meet on it (:meth:`lanefinder.selfcal.SelfCalibrator.offer_lines`).  Each
        frame with both lines measured on a road read as no tighter than ``skip_radius_m`` gives
        that row; their median pitches the set-up in use (camera height and yaw kept), and every
        later estimate, once ...
    lines_min_frames : int
        ... this many frames have given one (four seconds at 25 fps) ...
    lines_window_frames : int
        ... of the last this many ...
    lines_max_spread_px : float
        ... while they spread (a standard deviation, robust) no more than this, px per 720 rows (a
        winding or hilly road moves where its lines meet: the harder challenge video's spread
        about 12 px, the project and challenge videos' 3.5-5) ...
    lines_min_shift_px : float
        ... when it differs from the set-up's horizon by more than this, px per 720 rows ...
    lines_sigmas : float
        ... and by more than this many of the median's expected error (one frame in five counted
        as a new look at the road).

    Examples
    --------
    >>> SelfCalConfig().enabled, SelfCalConfig().min_frames
    (True, 4)
    """

    enabled: bool = True
    every_frames: Annotated[int, Field(ge=1, le=1000)] = 2
    fast_frames: Annotated[int, Field(ge=0, le=1_000_000)] = 250
    refine_every_frames: Annotated[int, Field(ge=1, le=100_000)] = 50
    min_frames: Annotated[int, Field(ge=1, le=1000)] = 4
    window_frames: Annotated[int, Field(ge=1, le=1000)] = 40
    work_width_px: Annotated[int, Field(ge=160, le=4096)] = 960
    change_xm_pct: Annotated[float, Field(gt=0, le=100)] = 3.0
    change_ym_pct: Annotated[float, Field(gt=0, le=100)] = 6.0
    change_car_m: Annotated[float, Field(gt=0, le=5)] = 0.08
    change_sigmas: Annotated[float, Field(ge=0, le=100)] = 3.0
    dash_period_m: Annotated[float, Field(ge=1, le=50)] = 12.2
    skip_radius_m: Annotated[float, Field(ge=0, le=100_000)] = 300.0
    stills: bool = True
    still_height_m: tuple[Annotated[float, Field(gt=0, le=20)], Annotated[float, Field(gt=0, le=20)]] = (1.0, 1.8)
    still_max_car_m: Annotated[float, Field(ge=0, le=5)] = 0.5
    still_min_radius_m: Annotated[float, Field(ge=0, le=1_000_000)] = 0.0
    still_work_width_px: Annotated[int, Field(ge=160, le=4096)] = 1280
    still_horizon: bool = True
    still_horizon_margin: Fraction = 0.05
    still_horizon_agree: Annotated[float, Field(ge=0, le=0.1)] = 0.007
    still_lines: bool = True
    estimate_check: bool = True
    estimate_check_margin: Fraction = 0.2
    first_frame: bool = True
    first_look_frames: Annotated[int, Field(ge=0, le=100_000)] = 25
    first_look_agree_px: Annotated[float, Field(ge=0, le=100)] = 3.0
    unsure_parallel: Fraction = 0.0
    unsure_parallel_diff_m: Annotated[float, Field(gt=0, le=20)] = 5.0
    unsure_curvature_diff: Annotated[float, Field(gt=0, le=1)] = 0.008
    unsure_radius_m: Annotated[float, Field(ge=0, le=100_000)] = 300.0
    lines_horizon: bool = True
    lines_min_frames: Annotated[int, Field(ge=1, le=100_000)] = 100
    lines_window_frames: Annotated[int, Field(ge=1, le=100_000)] = 1500
    lines_max_spread_px: Annotated[float, Field(gt=0, le=100)] = 8.0
    lines_min_shift_px: Annotated[float, Field(ge=0, le=100)] = 1.5
    lines_sigmas: Annotated[float, Field(ge=0, le=100)] = 2.0

    @model_validator(mode="after")
    def _check_heights(self) -> SelfCalConfig:
        if self.still_height_m[0] > self.still_height_m[1]:
            raise ValueError("still_height_m must be (lowest, highest)")
        if self.lines_min_frames > self.lines_window_frames:
            raise ValueError(f"lines_min_frames ({self.lines_min_frames}) must not exceed lines_window_frames "
                             f"({self.lines_window_frames}): only that many rows are kept")
        return self


#: The shortest segment ``lanefinder batch`` cuts a video into, s (a task costs about a second).
MIN_SEGMENT_S = 1.0


class BatchConfig(_Section):
    """How ``lanefinder batch`` cuts long videos into segments for the cluster.

    Attributes
    ----------
    segment_s : float
        Length of a segment, s: a video longer than this is processed as several segments in
        parallel (0: never split; else at least ``MIN_SEGMENT_S``: each segment costs a task).
    warmup_s : float
        Each segment after the first starts this much earlier, to warm the tracker up; the
        overlap is dropped when the segments are stitched, s.

    Examples
    --------
    >>> BatchConfig().segment_s, BatchConfig().warmup_s
    (120.0, 4.0)
    """

    segment_s: Annotated[float, Field(ge=0, le=86_400)] = 120.0
    warmup_s: Annotated[float, Field(ge=0, le=600)] = 4.0

    @model_validator(mode="after")
    def _check_segment(self) -> BatchConfig:
        if 0 < self.segment_s < MIN_SEGMENT_S:
            raise ValueError(f"segment_s must be 0 (never split) or at least {MIN_SEGMENT_S:g} s: each segment is "
                             f"a task that opens the video and warms the tracker up (got {self.segment_s:g})")
        return self


class EventsConfig(_Section):
    """Lane events found in the telemetry: departure warnings, lane changes, lost stretches.

    See :mod:`lanefinder.events` for the rules.  Distances are from a wheel's outer edge to a
    line's centre, at the bird's-eye bottom row, where the offset is measured.

    Attributes
    ----------
    car_width_m : float
        Width of the car over its wheels, m (the camera on its centre line).
    warning_margin_m : float
        A departure warning starts when a wheel is this close to the line or closer, m (0: at
        the line; negative: only once that far over it).
    release_m : float
        The warning ends once the wheel is ``warning_margin_m + release_m`` inside again, m.
    min_warning_s : float
        Shorter warnings are dropped, s.
    speed_window_s : float
        The lateral speed is the least-squares slope of the lateral position over this window,
        centred on each frame, s.
    min_speed_mps : float
        Below this speed towards the line a departure has no time to line crossing, m/s.
    max_gap_s : float
        Longest stretch without a measured lane (lost, held or missing rows) within one warning
        or lost stretch, s.
    lane_change_min_jump : float
        Least change of the offset at a switch of lane, as a fraction of the lane width.
    lane_change_min_offset_m : float
        Least offset on each side of a switch (from +|x| to -|x| or back), m.
    lane_change_max_gap_s : float
        Longest stretch without a measured lane that a switch may span, s.
    lane_change_speed_mps : float
        A lane change lasts while the car moves towards the new lane faster than this, m/s.
    lane_change_max_s : float
        Farthest a lane change's start or end is looked for from its switch, s.
    lane_change_flip_s : float
        A switch undone within this time is the tracker wavering, not a change, s.
    min_lost_frames : int
        Frames a lost stretch must cover.

    Examples
    --------
    >>> e = EventsConfig()
    >>> e.car_width_m, e.warning_margin_m, e.min_lost_frames
    (1.8, 0.0, 1)
    """

    car_width_m: Annotated[float, Field(ge=0.5, le=4.0)] = 1.8
    warning_margin_m: Annotated[float, Field(ge=-1.0, le=2.0)] = 0.0
    release_m: Annotated[float, Field(ge=0, le=1.0)] = 0.05
    min_warning_s: Annotated[float, Field(ge=0, le=60)] = 0.0
    speed_window_s: Annotated[float, Field(gt=0, le=5)] = 0.4
    min_speed_mps: Annotated[float, Field(ge=0, le=5)] = 0.05
    max_gap_s: Annotated[float, Field(ge=0, le=60)] = 0.5
    lane_change_min_jump: Annotated[float, Field(gt=0, le=1.5)] = 0.35
    lane_change_min_offset_m: Annotated[float, Field(ge=0, le=5)] = 0.3
    lane_change_max_gap_s: Annotated[float, Field(ge=0, le=60)] = 3.0
    lane_change_speed_mps: Annotated[float, Field(gt=0, le=5)] = 0.2
    lane_change_max_s: Annotated[float, Field(gt=0, le=60)] = 8.0
    lane_change_flip_s: Annotated[float, Field(ge=0, le=60)] = 1.0
    min_lost_frames: Annotated[int, Field(ge=1, le=1_000_000)] = 1


class Config(_Section):
    """All tunables of lanefinder, one validated section per stage.

    Unknown keys and bad values are errors that name the key (see :func:`load_config`).

    Attributes
    ----------
    camera : CameraConfig
    birdseye : BirdseyeConfig
    threshold : ThresholdConfig
    search : SearchConfig
    fit : FitConfig
    tracking : TrackingConfig
    far : FarConfig
    render : RenderConfig
    video : VideoConfig
    limits : LimitsConfig
    batch : BatchConfig
    events : EventsConfig
    selfcal : SelfCalConfig

    Examples
    --------
    >>> cfg = Config.model_validate({"search": {"n_windows": 9}})
    >>> cfg.search.n_windows, cfg.tracking.max_misses
    (9, 5)
    """

    camera: CameraConfig = CameraConfig()
    birdseye: BirdseyeConfig = BirdseyeConfig()
    threshold: ThresholdConfig = ThresholdConfig()
    search: SearchConfig = SearchConfig()
    fit: FitConfig = FitConfig()
    tracking: TrackingConfig = TrackingConfig()
    far: FarConfig = FarConfig()
    render: RenderConfig = RenderConfig()
    video: VideoConfig = VideoConfig()
    limits: LimitsConfig = LimitsConfig()
    batch: BatchConfig = BatchConfig()
    events: EventsConfig = EventsConfig()
    selfcal: SelfCalConfig = SelfCalConfig()

    def has_own_setup(self) -> bool:
        """Tell whether the config holds a bird's-eye set-up of its own (``birdseye`` not the default).

        Such a set-up is the camera's own (as ``lanefinder setup`` writes it): a run with it does
        not self-calibrate, and the lane checks trust it more (``tracking.max_parallel_diff_own_setup_m``).

        Returns
        -------
        bool
            True when ``birdseye`` differs from ``BirdseyeConfig()``.

        Examples
        --------
        >>> Config().has_own_setup()
        False
        >>> Config.model_validate({"birdseye": {"size": [400, 320]}}).has_own_setup()
        True
        """
        return self.birdseye != BirdseyeConfig()

    @model_validator(mode="after")
    def _check_field_of_view(self) -> Config:
        f, w = self.camera.focal_px, self.birdseye.reference_size[0]
        if f is not None:
            fov = field_of_view_deg(f, w)
            if not MIN_FOV_DEG <= fov <= MAX_FOV_DEG:
                raise ValueError(f"camera.focal_px {f:g} px over {w} px (birdseye.reference_size) is a {fov:.2f} "
                                 f"degree field of view: lanefinder takes {MIN_FOV_DEG:g} to {MAX_FOV_DEG:g}")
        return self


def _format_error(e: ValidationError, source: str) -> str:
    parts = []
    for err in e.errors():
        key = ".".join(str(p) for p in err["loc"])
        msg = err["msg"]
        if err["type"] == "extra_forbidden":
            msg = "unknown key"
        elif err["type"] == "value_error":
            msg = msg.removeprefix("Value error, ")
        parts.append(f"{key}: {msg}" if key else msg)  # (a check across sections names its keys)
    return f"invalid config {source}: " + "; ".join(parts)


def config_arg(config: object) -> Config:
    """Give a function's ``config`` argument as a Config: the defaults for None, or refuse what is not one.

    Parameters
    ----------
    config : Config or None
        What the caller passed.

    Returns
    -------
    Config
        ``config``, or the defaults.

    Raises
    ------
    LaneFinderError
        When ``config`` is something else (a dict, a path: :func:`load_config` reads a file).

    Examples
    --------
    >>> config_arg(None).search.lane_width_m
    3.7
    """
    if config is None:
        return Config()
    if not isinstance(config, Config):
        raise LaneFinderError(f"config must be a lanefinder Config (load_config(path) reads a file), "
                              f"not {type(config).__name__}")
    return config


def config_from_dict(data: dict, source: str = "") -> Config:
    """Validate a configuration given as nested dicts.

    Parameters
    ----------
    data : dict
        Sections and keys; what is left out keeps its default.
    source : str
        Where the data came from, for the error message.

    Returns
    -------
    Config
        The validated configuration.

    Raises
    ------
    LaneFinderError
        Naming each bad or unknown key.

    Examples
    --------
    >>> config_from_dict({"tracking": {"max_misses": 0}}, "my.toml")
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: invalid config my.toml: tracking.max_misses: Input should be greater than 0
    """
    try:
        return Config.model_validate(data)
    except ValidationError as e:
        raise LaneFinderError(_format_error(e, source or "(dict)")) from None


def _without_repeats(pairs: list[tuple[str, Any]]) -> dict:
    """Make a mapping of key-value pairs, refusing a key given twice (TOML refuses it; JSON and YAML kept the last)."""
    out: dict = {}
    for k, v in pairs:
        if k in out:
            raise ValueError(f"{k!r} is given twice")
        out[k] = v
    return out


#: A float with an exponent as YAML 1.2 writes it (``1e4``, ``5e-1``, ``6.02e23``, ``.5e3``).
_YAML_EXP_FLOAT = re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$")


def _yaml_without_repeats(text: str) -> Any:
    """Parse YAML safely, refusing a key given twice in a mapping."""
    import yaml

    class _Loader(yaml.SafeLoader):
        pass

    # YAML 1.1 (PyYAML) reads 1e4, 5e-1 and 6.02e23 as text: its floats need a dot and a signed
    # exponent.  They are numbers in YAML 1.2 and in TOML and JSON, and the config refuses text
    # for a number, so they are read as numbers here (on this loader's own copy of the table).
    _Loader.yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
    _Loader.add_implicit_resolver("tag:yaml.org,2002:float", _YAML_EXP_FLOAT, list("-+0123456789."))

    def mapping(loader: yaml.SafeLoader, node: yaml.MappingNode) -> dict:
        # The keys written in this mapping must differ; a merge (<<) may still be overridden by one.
        _without_repeats([(loader.construct_object(k, deep=True), None) for k, _ in node.value
                          if k.tag != "tag:yaml.org,2002:merge"])
        return loader.construct_mapping(node, deep=True)

    _Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, mapping)
    return yaml.load(text, Loader=_Loader)  # a SafeLoader with its mapping constructor changed


def load_config(path: str | Path | None) -> Config:
    """Read a TOML, YAML or JSON configuration file.

    A camera file it names is taken relative to the config file.

    Parameters
    ----------
    path : str or Path or None
        The file (``.toml``, ``.yaml``/``.yml`` or ``.json``); None gives the defaults.

    Returns
    -------
    Config
        The validated configuration.

    Raises
    ------
    LaneFinderError
        When the file is missing, unreadable, not valid in its format, or has bad values.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     _ = Path(d, "my.toml").write_text("search.n_windows = 9")
    ...     load_config(Path(d, "my.toml")).search.n_windows
    9
    """
    if path is None:
        return Config()
    p = Path(path)
    if p.is_dir():
        raise LaneFinderError(f"{p} is a folder, not a config file")
    if not p.is_file():
        raise LaneFinderError(f"config file not found: {p}")
    try:
        text = p.read_text().removeprefix("\ufeff")  # a byte-order mark (Windows Notepad) is not part of it
    except (UnicodeDecodeError, OSError) as e:
        raise LaneFinderError(f"config {p} cannot be read as text: {e}".splitlines()[0]) from None
    suffix = p.suffix.lower()
    try:
        if suffix == ".toml":
            try:
                import tomllib
            except ModuleNotFoundError:  # Python 3.10
                import tomli as tomllib

            data = tomllib.loads(text)
        elif suffix in (".yaml", ".yml"):
            data = _yaml_without_repeats(text) or {}
        elif suffix == ".json":
            data = json.loads(text, object_pairs_hook=_without_repeats)
        else:
            raise LaneFinderError(f"config {p}: use a .toml, .yaml or .json file")
    except LaneFinderError:
        raise
    except Exception as e:  # the parsers' own errors, reported in one line
        raise LaneFinderError(f"config {p} is not valid {suffix[1:].upper()}: {e}".splitlines()[0]) from None
    if not isinstance(data, dict):
        raise LaneFinderError(f"config {p}: the top level must be a table of sections")
    cfg = config_from_dict(data, str(p))
    if cfg.camera.model not in ("udacity", "none") and not Path(cfg.camera.model).is_absolute():
        # A camera file named in a config is relative to that config.
        cam_path = (p.parent / cfg.camera.model).resolve()  # absolute: a config saved elsewhere still finds it
        cfg = cfg.model_copy(update={"camera": CameraConfig(model=str(cam_path))})
    return cfg


def dump_config(cfg: Config, fmt: Literal["toml", "yaml", "json"] = "toml",
                sections: tuple[str, ...] | str | None = None) -> str:
    """Write a configuration out, in full or some sections of it, as :func:`load_config` reads it.

    A camera's set-up (``sections=SETUP_SECTIONS``, ``camera`` and ``birdseye``, as ``lanefinder
    setup`` writes it; ``lanefinder synth`` adds ``events``) leaves every other setting to the
    defaults of the lanefinder that reads it: a file written in full pins them all at the
    writer's defaults, and a later version that renamed one would refuse the file.

    Parameters
    ----------
    cfg : Config
        The configuration.
    fmt : {"toml", "yaml", "json"}
        The format.
    sections : tuple of str or str, optional
        Write only these sections (each in full); a string is one section; None: all of them.

    Returns
    -------
    str
        The text.

    Raises
    ------
    ValueError
        For a section the configuration does not have.

    Examples
    --------
    >>> print(dump_config(Config()).splitlines()[1])
    [camera]
    >>> [line for line in dump_config(Config(), sections=("camera",)).splitlines() if line.startswith("[")]
    ['[camera]']
    """
    data = cfg.model_dump(mode="json", exclude_none=True)  # None is "not set" (TOML has no null)
    if isinstance(sections, str):
        sections = (sections,)
    if sections is not None:
        if unknown := [name for name in sections if name not in data]:
            raise ValueError(f"no config section {', '.join(unknown)}; there are {', '.join(data)}")
        data = {name: data[name] for name in data if name in sections}
    if fmt == "toml":
        import tomli_w

        return "# lanefinder configuration: edit and pass back with -c\n" + tomli_w.dumps(data)
    if fmt == "yaml":
        import yaml

        return yaml.safe_dump(data, sort_keys=False)
    return json.dumps(data, indent=2) + "\n"
