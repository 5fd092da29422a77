"""The one validated configuration: every tunable of the pipeline lives here.

Save it with ``lanefinder config --default > my.toml``, edit it, pass it back with
``-c my.toml``.  TOML, YAML and JSON are read; unknown keys and bad values are
errors that name the key.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from .errors import LaneFinderError

Point = tuple[float, float]
PositiveInt = Annotated[int, Field(gt=0)]
PositiveFloat = Annotated[float, Field(gt=0)]
Fraction = Annotated[float, Field(ge=0, le=1)]
Byte = Annotated[int, Field(ge=0, le=255)]

#: Lane width the default set-up is scaled by: 3.7 m between line centres (12 ft lanes).
LANE_WIDTH_M = 3.7
#: Size of the default bird's-eye view, (width, height) pixels.
VIEW_SIZE_PX = (400, 300)
#: Pixels the lane spans across the default bird's-eye view, centred in it.
LANE_SPAN_PX = 150.0


def default_dst(size: tuple[int, int] = VIEW_SIZE_PX, lane_px: float = LANE_SPAN_PX) -> tuple[Point, Point, Point, Point]:
    """The bird's-eye rectangle of a lane ``lane_px`` wide, centred in a view of ``size``.

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


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class CameraConfig(_Section):
    """Which lens model to undo: "udacity" (built in), "none", or a camera file path."""

    model: str = "udacity"


class BirdseyeConfig(_Section):
    """Source trapezoid (undistorted pixels of a ``reference_size`` frame) and its bird's-eye rectangle.

    Defaults: tuned on straight_lines1/2 (see docs/birdseye.md and scripts/tune_birdseye.py).
    """

    reference_size: tuple[PositiveInt, PositiveInt] = (1280, 720)
    src: tuple[Point, Point, Point, Point] = ((581.3, 460.0), (702.9, 460.0), (1034.0, 675.0), (280.5, 675.0))
    size: tuple[PositiveInt, PositiveInt] = VIEW_SIZE_PX
    dst: tuple[Point, Point, Point, Point] = default_dst()
    xm_per_px: PositiveFloat = LANE_WIDTH_M / LANE_SPAN_PX
    ym_per_px: PositiveFloat = 0.09853

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
    """``sobel-hls``: Sobel on the S channel of HLS plus an S colour threshold."""

    kernel: Literal[3, 5, 7, 9, 11, 13, 15] = 3
    x_thresh: tuple[Byte, Byte] = (20, 255)
    y_thresh: tuple[Byte, Byte] = (25, 255)
    mag_thresh: tuple[Byte, Byte] = (30, 255)
    dir_thresh: tuple[float, float] = (0.0, 0.9)
    s_thresh: tuple[Byte, Byte] = (150, 255)


class ColorConfig(_Section):
    """``color``: L of HLS and L of LUV for white, b of Lab for yellow."""

    hls_l: tuple[Byte, Byte] = (210, 255)
    luv_l: tuple[Byte, Byte] = (215, 255)
    lab_b: tuple[Byte, Byte] = (150, 255)


class YcrcbConfig(_Section):
    """``ycrcb``: Sobel x on Y of YCrCb, Y of YUV and R of RGB, OR-combined."""

    kernel: Literal[3, 5, 7, 9, 11, 13, 15] = 3
    ycrcb_y_grad: tuple[Byte, Byte] = (30, 255)
    yuv_y: tuple[Byte, Byte] = (205, 255)
    rgb_r: tuple[Byte, Byte] = (215, 255)


class RidgeConfig(_Section):
    """``ridge`` (default): a line is brighter (or yellower) than the road on *both* sides.

    Horizontal top-hat of lightness (green) and of yellowness (red - blue) in the bird's-eye image over a window
    ``width_m`` wide; a pixel is a marking when its top-hat is above ``min_contrast`` and above
    ``rel_contrast`` times the local road level, so shadows (which scale brightness) and
    pavement seams (one-sided steps) do not pass.
    """

    width_m: PositiveFloat = 0.4
    min_contrast: Byte = 12
    rel_contrast: Annotated[float, Field(ge=0)] = 0.18
    yellow_min_contrast: Byte = 18
    yellow_min: Byte = 30


class ThresholdConfig(_Section):
    strategy: Literal["ridge", "sobel-hls", "color", "ycrcb"] = "ridge"
    ridge: RidgeConfig = RidgeConfig()
    sobel_hls: SobelHlsConfig = SobelHlsConfig()
    color: ColorConfig = ColorConfig()
    ycrcb: YcrcbConfig = YcrcbConfig()


class SearchConfig(_Section):
    """Finding line pixels in the bird's-eye binary.  Sizes are in metres on the road and turn
    into pixels through the bird's-eye scale, so they hold for any set-up.
    """

    method: Literal["windows", "segments"] = "windows"
    n_windows: Annotated[int, Field(ge=2, le=100)] = 12
    margin_m: PositiveFloat = 0.6
    min_window_marking_m: PositiveFloat = 0.2
    histogram_fraction: Annotated[float, Field(gt=0, le=1)] = 0.5
    around_margin_m: PositiveFloat = 0.45
    lane_width_m: PositiveFloat = LANE_WIDTH_M
    width_tolerance: Annotated[float, Field(gt=0, lt=1)] = 0.22
    marking_width_m: PositiveFloat = 0.15
    # When the straight-ahead search finds weak lines, lines heading up to this many degrees off
    # the car's axis are tried too, every ``heading_step_deg`` (0 turns that search off).
    max_heading_deg: Annotated[float, Field(ge=0, lt=80)] = 25.0
    heading_step_deg: Annotated[float, Field(ge=0, le=45)] = 5.0
    # Each window of that angled search keeps only the pixels within this distance of its
    # strongest ridge, so clutter beside a slanted line stays out of its fit (0 keeps them all).
    heading_band_m: Annotated[float, Field(ge=0)] = 0.3
    # Line bases: the base histogram counts rows above the lower ``histogram_fraction`` with this
    # weight (a line with a gap at the bottom still gets a base), is smoothed over
    # ``peak_smoothing_m``, and its ``max_peaks`` highest peaks of at least ``base_min_fraction``
    # of a window's pixels are paired; a pair off-centre by a lane width loses
    # ``centre_preference`` of its score.
    upper_histogram_weight: Fraction = 0.5
    peak_smoothing_m: PositiveFloat = 0.22
    max_peaks: Annotated[int, Field(ge=1, le=64)] = 8
    base_min_fraction: Fraction = 0.25
    centre_preference: Fraction = 0.3
    # Windows follow a bend: the next window moves by ``momentum`` of the last move plus the rest
    # of the latest drift; past an empty window the move shrinks by ``empty_window_decay``.
    momentum: Fraction = 0.5
    empty_window_decay: Fraction = 0.5
    # Segment search: a segment's histogram spans ``segment_reach`` margins either side, its
    # peak may lie ``segment_max_shift`` margins from where the line is heading, and keeps the
    # pixels within ``segment_band`` of a margin of it; a segment needs ``segment_min_fraction``
    # of a window's pixels.
    segment_reach: PositiveFloat = 2.0
    segment_max_shift: PositiveFloat = 1.5
    segment_band: Fraction = 0.5
    segment_min_fraction: Fraction = 0.5


class FitConfig(_Section):
    """Robust second-order fit x = a*y^2 + b*y + c (bird's-eye pixels); sizes in metres."""

    robust_iterations: Annotated[int, Field(ge=0, le=10)] = 2
    huber_m: PositiveFloat = 0.06
    min_marking_m: PositiveFloat = 0.5
    full_support_m: PositiveFloat = 1.9
    residual_scale_m: PositiveFloat = 0.09
    min_span_fraction: Fraction = 0.25
    parallel: Fraction = 1.0
    # Span of the view (fraction of its height) a line must cover for full confidence.
    full_span_fraction: Annotated[float, Field(gt=0, le=1)] = 0.6
    # A line with more pixels is fitted on an even subsample of this many (bounds the cost).
    max_points: Annotated[int, Field(ge=10, le=100000)] = 1200
    max_radius_m: PositiveFloat = 10000.0
    straight_radius_m: PositiveFloat = 3000.0


class TrackingConfig(_Section):
    """Across frames: sanity checks, smoothing, re-detection."""

    min_width_m: PositiveFloat = 2.5
    # 3.7 m lanes measure up to 4.7 m for a frame when the car pitches on a bump (the flat-road
    # bird's-eye view then stretches them), as at 22.4 s of the project video.
    max_width_m: PositiveFloat = 4.8
    max_width_change_m: PositiveFloat = 0.7
    max_parallel_diff_m: PositiveFloat = 0.9
    max_curvature_diff: PositiveFloat = 0.004
    max_offset_jump_m: PositiveFloat = 0.4
    # The jump limit at the far end of the view, as a multiple of ``max_offset_jump_m``.
    far_jump_factor: PositiveFloat = 3.0
    max_offset_m: PositiveFloat = 0.9
    max_misses: PositiveInt = 5
    lost_after: PositiveInt = 12
    max_one_line_frames: PositiveInt = 50
    min_start_confidence: Fraction = 0.45
    start_frames: PositiveInt = 3
    # No marking down the middle: set pixels in the middle half of a candidate lane, binned in
    # strips ``interior_strip_m`` wide (a strip counts on a row with ``interior_min_pixels``);
    # a strip filled on more than ``max_interior_fill`` of at least ``interior_min_rows`` rows,
    # and on ``interior_excess`` more of them than the median strip, is a marking.
    max_interior_fill: Fraction = 0.6
    interior_strip_m: PositiveFloat = 0.2
    interior_excess: Fraction = 0.4
    interior_min_pixels: PositiveInt = 2
    interior_min_rows: PositiveInt = 10
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
    # ``rejected_pair_confidence``; an inferred line is smoothed with ``inferred_weight`` times
    # the confidence of the line it is drawn from.
    rejected_pair_confidence: Fraction = 0.5
    inferred_weight: Fraction = 0.5
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


class RenderConfig(_Section):
    lane_color: tuple[Byte, Byte, Byte] = (0, 200, 0)
    left_color: tuple[Byte, Byte, Byte] = (0, 0, 255)
    right_color: tuple[Byte, Byte, Byte] = (255, 80, 0)
    alpha: Fraction = 0.3
    line_thickness: PositiveInt = 6
    hud: bool = True


class VideoConfig(_Section):
    preset: Literal["ultrafast", "superfast", "veryfast", "faster", "fast", "medium", "slow"] = "superfast"
    crf: Annotated[int, Field(ge=0, le=51)] = 23
    threads: Annotated[int, Field(ge=0, le=64)] = 0


class Config(_Section):
    """All tunables of lanefinder."""

    camera: CameraConfig = CameraConfig()
    birdseye: BirdseyeConfig = BirdseyeConfig()
    threshold: ThresholdConfig = ThresholdConfig()
    search: SearchConfig = SearchConfig()
    fit: FitConfig = FitConfig()
    tracking: TrackingConfig = TrackingConfig()
    render: RenderConfig = RenderConfig()
    video: VideoConfig = VideoConfig()


def _format_error(e: ValidationError, source: str) -> str:
    parts = []
    for err in e.errors():
        key = ".".join(str(p) for p in err["loc"]) or "(top level)"
        msg = err["msg"]
        if err["type"] == "extra_forbidden":
            msg = "unknown key"
        parts.append(f"{key}: {msg}")
    return f"invalid config {source}: " + "; ".join(parts)


def config_from_dict(data: dict, source: str = "") -> Config:
    try:
        return Config.model_validate(data)
    except ValidationError as e:
        raise LaneFinderError(_format_error(e, source or "(dict)")) from None


def load_config(path: str | Path | None) -> Config:
    """Read a TOML, YAML or JSON config; None gives the defaults."""
    if path is None:
        return Config()
    p = Path(path)
    if not p.is_file():
        raise LaneFinderError(f"config file not found: {p}")
    text = p.read_text()
    suffix = p.suffix.lower()
    try:
        if suffix == ".toml":
            try:
                import tomllib
            except ModuleNotFoundError:  # Python 3.10
                import tomli as tomllib

            data = tomllib.loads(text)
        elif suffix in (".yaml", ".yml"):
            import yaml

            data = yaml.safe_load(text) or {}
        elif suffix == ".json":
            data = json.loads(text)
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
        cam_path = (p.parent / cfg.camera.model)
        cfg = cfg.model_copy(update={"camera": CameraConfig(model=str(cam_path))})
    return cfg


def dump_config(cfg: Config, fmt: Literal["toml", "yaml", "json"] = "toml") -> str:
    data = cfg.model_dump(mode="json")
    if fmt == "toml":
        import tomli_w

        return "# lanefinder configuration: edit and pass back with -c\n" + tomli_w.dumps(data)
    if fmt == "yaml":
        import yaml

        return yaml.safe_dump(data, sort_keys=False)
    return json.dumps(data, indent=2) + "\n"
