"""Every rule that judges a lane, as a named check that returns its reason.

A check returns the reason it fails (the name that shows up in ``LaneResult.checks``, the
telemetry and the ``--debug`` overlay) or None when it passes.  Each one reads its limits from
:class:`~lanefinder.config.TrackingConfig`.  The tracker (:mod:`lanefinder.tracking`) and the
measuring step (:mod:`lanefinder.measure`) apply them; this module holds no state.

Lines are metre fits x = A*d^2 + B*d + C (see docs/conventions.md).
"""

from __future__ import annotations

import math
import statistics

import numpy as np

from .config import TrackingConfig
from .geometry import Scale, curvature_per_m, lane_width_m, m_to_px, poly_x
from .search import LinePixels, Pixels

__all__ = [
    "check_confidence",
    "check_curvature",
    "check_jump",
    "check_line_inside",
    "check_offset",
    "check_one_line",
    "check_parallel",
    "check_start_bend",
    "check_width",
    "check_width_change",
    "is_yellow",
    "lines_close",
    "pair_problems",
    "yellow_side",
]


def check_confidence(side: str, confidence: float | None, cfg: TrackingConfig) -> str | None:
    """Fail a measured line whose fit confidence is below ``min_confidence``.

    Parameters
    ----------
    side : {"left", "right"}
        The line's side, for the reason.
    confidence : float or None
        The measurement's confidence, 0..1; None when nothing was measured (which passes: there
        is nothing to reject).
    cfg : TrackingConfig
        Holds ``min_confidence``.

    Returns
    -------
    str or None
        ``"<side>-confidence"``, or None.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> check_confidence("left", 0.1, TrackingConfig())
    'left-confidence'
    >>> check_confidence("left", 0.9, TrackingConfig()) is None
    True
    """
    if confidence is not None and confidence < cfg.min_confidence:
        return f"{side}-confidence"
    return None


def lines_close(a: np.ndarray, b: np.ndarray, lookahead_m: float, cfg: TrackingConfig) -> bool:
    """Tell whether two fits of one line lie within the jump limit.

    Within ``max_offset_jump_m`` at the car, and ``far_jump_factor`` times that at ``lookahead_m``.

    Parameters
    ----------
    a, b : (3,) ndarray
        Metre fits.
    lookahead_m : float
        The far end of the view, metres ahead of its bottom row.
    cfg : TrackingConfig
        Holds the limits.

    Returns
    -------
    bool
        True when the two are the same line, as far as the jump limit can tell.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> a = np.array([0.0, 0.0, -1.8])
    >>> lines_close(a, a + [0, 0, 0.3], 30.0, TrackingConfig()), lines_close(a, a + [0, 0, 0.5], 30.0, TrackingConfig())
    (True, False)
    """
    lim = cfg.max_offset_jump_m
    far = abs(poly_x(a, lookahead_m) - poly_x(b, lookahead_m))
    return bool(abs(a[2] - b[2]) <= lim and far <= cfg.far_jump_factor * lim)


def check_jump(side: str, near: bool, guessed_frames: int, other_near: bool) -> str | None:
    """Fail a measured line that jumped away from the track.

    A line that has only been inferred lately may come back away from the guess, but only
    beside a line that is where the track expects it: a lone line far from the track is not
    trusted.

    Parameters
    ----------
    side : {"left", "right"}
        The line's side, for the reason.
    near : bool
        The measurement is close to the tracked line (see :func:`lines_close`), or no jump
        limit holds (no track, or re-detecting).
    guessed_frames : int
        Frames in a row this line has been inferred rather than measured.
    other_near : bool
        The other line was measured close to its track.

    Returns
    -------
    str or None
        ``"<side>-jump"``, or None.

    Examples
    --------
    >>> check_jump("right", near=False, guessed_frames=0, other_near=True)
    'right-jump'
    >>> check_jump("right", near=False, guessed_frames=2, other_near=True) is None
    True
    """
    if near or (guessed_frames and other_near):
        return None
    return f"{side}-jump"


def check_width(left_m: np.ndarray, right_m: np.ndarray, cfg: TrackingConfig) -> str | None:
    """Fail a pair whose lane width is outside ``min_width_m``..``max_width_m``.

    Parameters
    ----------
    left_m, right_m : (3,) ndarray
        Metre fits of the pair.
    cfg : TrackingConfig
        Holds the limits.

    Returns
    -------
    str or None
        ``"width"``, or None.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> check_width(np.array([0, 0, -0.8]), np.array([0, 0, 0.7]), TrackingConfig())
    'width'
    """
    return None if cfg.min_width_m <= lane_width_m(left_m, right_m) <= cfg.max_width_m else "width"


def check_offset(left_m: np.ndarray, right_m: np.ndarray, cfg: TrackingConfig, holding: bool = False) -> str | None:
    """Fail a lane that does not hold the car: x = 0 inside it, within ``max_offset_m`` of its centre.

    A lane that is being held (tracked, not re-detected) only needs the car inside it, so a
    car that drifts to a line, or over it before a lane change, keeps its lane; a new lane
    must also have the car within ``max_offset_m`` of its centre.

    Parameters
    ----------
    left_m, right_m : (3,) ndarray
        Metre fits of the lane's lines.
    cfg : TrackingConfig
        Holds ``max_offset_m``.
    holding : bool
        The lane continues a tracked one.

    Returns
    -------
    str or None
        ``"offset"``, or None.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> check_offset(np.array([0, 0, 0.5]), np.array([0, 0, 4.2]), TrackingConfig())
    'offset'
    >>> check_offset(np.array([0, 0, -1.8]), np.array([0, 0, 1.9]), TrackingConfig()) is None
    True
    >>> check_offset(np.array([0, 0, -0.3]), np.array([0, 0, 3.4]), TrackingConfig(), holding=True) is None
    True
    """
    ok = left_m[2] < 0 < right_m[2] and (holding or abs(left_m[2] + right_m[2]) / 2 <= cfg.max_offset_m)
    return None if ok else "offset"


def _across_m(left_m: np.ndarray, right_m: np.ndarray, d_m: float) -> float:
    """Give the lane's width d_m ahead measured across the lines (not along a row), metres.

    Lines heading off at slope s are ``1 / sqrt(1 + s^2)`` as far apart across them as along
    the row: in a tight curve two parallel lines grow apart along the rows ahead.  (The width
    check, :func:`check_width`, still takes the width along the row at the car.)
    """
    slope = (2 * left_m[0] * d_m + left_m[1] + 2 * right_m[0] * d_m + right_m[1]) / 2
    return float((poly_x(right_m, d_m) - poly_x(left_m, d_m)) / math.sqrt(1 + slope * slope))


def check_parallel(left_m: np.ndarray, right_m: np.ndarray, lookahead_m: float,
                   cfg: TrackingConfig) -> str | None:
    """Fail a pair whose width at mid-view or at the far end differs from the near width.

    The widths are measured across the lines (a tight curve's lines, parallel, are further
    apart along a row ahead than across).

    Parameters
    ----------
    left_m, right_m : (3,) ndarray
        Metre fits of the pair.
    lookahead_m : float
        The far end of the view, metres ahead of its bottom row.
    cfg : TrackingConfig
        Holds ``max_parallel_diff_m``.

    Returns
    -------
    str or None
        ``"parallel"``, or None.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> check_parallel(np.array([0, 0, -1.8]), np.array([0.003, 0, 1.9]), 30.0, TrackingConfig())
    'parallel'
    >>> # A tight left bend's lines as fitted (harder_challenge_video at 2.5 s): 4.8 m apart along
    >>> # the row 30 m ahead, 4.3 m across, 3.6 m at the car.
    >>> check_parallel(np.array([-0.0094, 0.0094, -1.81]), np.array([-0.008, 0.0082, 1.80]), 30.0,
    ...                TrackingConfig()) is None
    True
    """
    w_near = _across_m(left_m, right_m, 0.0)
    w_far = _across_m(left_m, right_m, lookahead_m)
    w_mid = _across_m(left_m, right_m, lookahead_m / 2)
    return "parallel" if max(abs(w_far - w_near), abs(w_mid - w_near)) > cfg.max_parallel_diff_m else None


def check_curvature(left_m: np.ndarray, right_m: np.ndarray, cfg: TrackingConfig) -> str | None:
    """Fail a pair whose curvatures differ by more than ``max_curvature_diff`` (1/m).

    Parameters
    ----------
    left_m, right_m : (3,) ndarray
        Metre fits of the pair.
    cfg : TrackingConfig
        Holds ``max_curvature_diff``.

    Returns
    -------
    str or None
        ``"curvature"``, or None.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> check_curvature(np.array([0, 0, -1.8]), np.array([0.003, 0, 1.9]), TrackingConfig())
    'curvature'
    """
    diff = abs(curvature_per_m(left_m) - curvature_per_m(right_m))
    return "curvature" if diff > cfg.max_curvature_diff else None


def check_width_change(left_m: np.ndarray, right_m: np.ndarray, tracked_width_m: float | None,
                       cfg: TrackingConfig) -> str | None:
    """Fail a pair whose width differs from the tracked width by more than ``max_width_change_m``.

    Parameters
    ----------
    left_m, right_m : (3,) ndarray
        Metre fits of the pair.
    tracked_width_m : float or None
        The tracked lane width, metres; None (the check passes) without a current track.
    cfg : TrackingConfig
        Holds ``max_width_change_m``.

    Returns
    -------
    str or None
        ``"width-change"``, or None.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> check_width_change(np.array([0, 0, -1.8]), np.array([0, 0, 1.9]), 2.8, TrackingConfig())
    'width-change'
    """
    if tracked_width_m is None:
        return None
    return "width-change" if abs(lane_width_m(left_m, right_m) - tracked_width_m) > cfg.max_width_change_m else None


def pair_problems(left_m: np.ndarray, right_m: np.ndarray, tracked_width_m: float | None, lookahead_m: float,
                  cfg: TrackingConfig, holding: bool = False) -> list[str]:
    """Apply the lane checks to a measured pair and list the reasons it fails.

    Width, the car inside the lane, parallel lines, matching curvatures and, while tracking,
    the change of width.

    Parameters
    ----------
    left_m, right_m : (3,) ndarray
        Metre fits of the pair.
    tracked_width_m : float or None
        The tracked lane width, metres; None without a current track.
    lookahead_m : float
        The far end of the view, metres ahead of its bottom row.
    cfg : TrackingConfig
        The limits.
    holding : bool
        The pair continues a tracked lane (see :func:`check_offset`).

    Returns
    -------
    list of str
        The reasons, in that order; empty when the pair passes.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> pair_problems(np.array([0, 0, -1.8]), np.array([0, 0, -0.3]), None, 30.0, TrackingConfig())
    ['width', 'offset']
    """
    found = (check_width(left_m, right_m, cfg), check_offset(left_m, right_m, cfg, holding),
             check_parallel(left_m, right_m, lookahead_m, cfg), check_curvature(left_m, right_m, cfg),
             check_width_change(left_m, right_m, tracked_width_m, cfg))
    return [reason for reason in found if reason]


def check_start_bend(fits_m: tuple[np.ndarray, np.ndarray], re_detecting: bool, cfg: TrackingConfig,
                     held_m: tuple[np.ndarray, np.ndarray] | None = None) -> str | None:
    """Fail a lane that would start bending tighter than ``min_start_radius_m``.

    Roads bend no tighter than a hairpin's 20-30 m.  A lane read as bending tighter when it
    starts afresh (no usable track: no lane, or ``max_misses`` reached) comes from a fit bent by
    a few rows of paint (glare leaving a metre or two of marking beside the car), and the lane
    that follows refuses the right lines as jumps from it.  Lines that re-place a held lane
    which itself bends that tight are not refused: the road does.  A lane tracked frame to
    frame is not checked.

    Parameters
    ----------
    fits_m : tuple of (3,) ndarray
        The left and right metre fits of the lane to start (a lone line's lane is implied:
        :func:`lanefinder.tracking.implied_lane`).
    re_detecting : bool
        There is no usable track.
    cfg : TrackingConfig
        Holds ``min_start_radius_m`` (0: no limit).
    held_m : tuple of (3,) ndarray, optional
        The metre fits of the lane still held, if any.

    Returns
    -------
    str or None
        ``"start-bend"``, or None.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> tight = (np.array([1 / 30, 0, -1.8]), np.array([1 / 30, 0, 1.9]))  # radius 15 m
    >>> check_start_bend(tight, True, TrackingConfig())
    'start-bend'
    >>> check_start_bend(tight, False, TrackingConfig()) is None  # a lane tracked frame to frame
    True
    >>> check_start_bend(tight, True, TrackingConfig(), held_m=tight) is None  # a held lane that tight
    True
    """
    if not re_detecting or cfg.min_start_radius_m <= 0:
        return None

    def tight(fits: tuple[np.ndarray, np.ndarray]) -> bool:
        return abs(curvature_per_m(fits[0]) + curvature_per_m(fits[1])) / 2 * cfg.min_start_radius_m > 1

    return "start-bend" if tight(fits_m) and not (held_m is not None and tight(held_m)) else None


def check_one_line(confidence: float, re_detecting: bool, frames_since_both: int, cfg: TrackingConfig) -> str | None:
    """Fail one line alone that may not place or hold the lane.

    Without a lane, or re-detecting after misses (when no jump limit holds), a line alone must
    be confident (``min_start_confidence``); and one line alone holds the lane for at most
    ``max_one_line_frames`` frames after both were last seen.

    Parameters
    ----------
    confidence : float
        The lone line's confidence, 0..1.
    re_detecting : bool
        There is no usable track (no lane, or ``max_misses`` reached).
    frames_since_both : int
        Frames since both lines were last accepted together.
    cfg : TrackingConfig
        The limits.

    Returns
    -------
    str or None
        ``"one-line-start"``, ``"one-line-too-long"``, or None.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> check_one_line(0.3, True, 0, TrackingConfig())
    'one-line-start'
    >>> check_one_line(0.9, False, 80, TrackingConfig())
    'one-line-too-long'
    """
    if re_detecting and confidence < cfg.min_start_confidence:
        return "one-line-start"
    if frames_since_both >= cfg.max_one_line_frames:
        return "one-line-too-long"
    return None


#: At most this many of a line's pixels (evenly spaced) are looked at by :func:`is_yellow`.
_YELLOW_SAMPLE = 400


def is_yellow(view: np.ndarray, line: LinePixels, cfg: TrackingConfig, yellow_min: int) -> bool:
    """Tell whether most of a line's pixels are saturated yellow (paint, not dry grass or sunlit asphalt).

    Parameters
    ----------
    view : (H, W, 3) uint8 ndarray
        The bird's-eye colour image, BGR.
    line : LinePixels
        The line's pixels in that image.
    cfg : TrackingConfig
        Holds ``yellow_saturation`` and ``yellow_fraction``.
    yellow_min : int
        Least red-minus-blue of a yellow pixel (``threshold.ridge.yellow_min``).

    Returns
    -------
    bool
        True when more than ``yellow_fraction`` of the pixels are yellow.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> from lanefinder.search import LinePixels
    >>> view = np.zeros((10, 10, 3), np.uint8); view[:, 5] = (20, 200, 230)
    >>> line = LinePixels(np.full(10, 5.0), np.arange(10.0))
    >>> is_yellow(view, line, TrackingConfig(), 30)
    True
    """
    if line.x.size == 0:
        return False
    step = line.x.size // _YELLOW_SAMPLE + 1  # an even sample measures the share as well
    px = view[line.y[::step].astype(np.intp), line.x[::step].astype(np.intp)].astype(np.float32)
    blue, red = px[:, 0], px[:, 2]
    yellow = (red - blue > yellow_min) & (blue < (1 - cfg.yellow_saturation) * red)
    return bool(yellow.mean() > cfg.yellow_fraction)


def yellow_side(x_at_car_m: tuple[float | None, float | None], yellow: tuple[bool, bool],
                cfg: TrackingConfig) -> tuple[tuple[int | None, int | None], str | None]:
    """Enforce ``yellow_line_side``: which measurement each side of the lane takes.

    A yellow line found on the side where yellow may not bound the lane (the right, for
    ``"left"``) is not that line: if it passes on the allowed side of the car, and the line on
    that side is not yellow too, it is the allowed side's line (what was found beyond it
    belongs to another lane); otherwise it is dropped.

    Parameters
    ----------
    x_at_car_m : tuple of (float or None)
        Each measured line's x at the car (its C), metres; None where nothing was measured.
    yellow : tuple of bool
        Each side's line is mostly yellow (:func:`is_yellow`).
    cfg : TrackingConfig
        Holds ``yellow_line_side``.

    Returns
    -------
    sides : tuple of (int or None)
        For the left and the right line, the index (0 left, 1 right) of the measurement it
        takes, or None for no line.
    reason : str or None
        ``"right-is-yellow"`` or ``"left-is-yellow"``, or None when nothing changed.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> yellow_side((-1.8, -0.2), (False, True), TrackingConfig())
    ((1, None), 'right-is-yellow')
    >>> yellow_side((-1.8, 1.9), (True, False), TrackingConfig())
    ((0, 1), None)
    """
    keep = (0, 1)
    if cfg.yellow_line_side == "either":
        return keep, None
    allowed = 0 if cfg.yellow_line_side == "left" else 1
    other = 1 - allowed
    if x_at_car_m[other] is None or not yellow[other]:
        return keep, None
    x = x_at_car_m[other]
    on_allowed_side = x < 0 if allowed == 0 else x > 0
    out: list[int | None] = [None, None]
    if on_allowed_side and not (x_at_car_m[allowed] is not None and yellow[allowed]):
        out[allowed] = other
    else:
        out[allowed] = allowed if x_at_car_m[allowed] is not None else None
    return (out[0], out[1]), f"{('left', 'right')[other]}-is-yellow"


def check_line_inside(pixels: Pixels, left_m: np.ndarray, right_m: np.ndarray, scale: Scale,
                      cfg: TrackingConfig, half_width: float = 0.25) -> str | None:
    """Fail a lane with a solid marking down its middle half (a centre line the lane straddles).

    Set pixels in the middle half of the lane (or within ``half_width`` of its width either
    side of its centre) are placed by their distance from the lane centre, in strips
    ``interior_strip_m`` wide; a marking parallel to the lane keeps to one
    strip (or two neighbours) on more than ``max_interior_fill`` of the rows, and on
    ``interior_excess`` more of them than the median strip, while shadows and cracks wander
    across strips.

    Parameters
    ----------
    pixels : Pixels
        All set pixels of the bird's-eye binary.
    left_m, right_m : (3,) ndarray
        Metre fits of the lane's lines.
    scale : Scale
        The bird's-eye scale.
    cfg : TrackingConfig
        The limits.
    half_width : float, optional
        How far either side of the lane's centre is looked at, as a fraction of its width
        (0.25: the middle half).

    Returns
    -------
    str or None
        ``"line-inside-lane"``, or None.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> from lanefinder.geometry import Scale
    >>> from lanefinder.search import Pixels
    >>> b = np.zeros((300, 400), np.uint8); b[:, 197:203] = 1
    >>> s = Scale(3.7 / 150, 0.1, 300, 200.0)
    >>> check_line_inside(Pixels.of(b), np.array([0, 0, -1.85]), np.array([0, 0, 1.85]), s, TrackingConfig())
    'line-inside-lane'
    """
    h, w = pixels.shape
    rows = np.arange(h, dtype=np.float64)
    xl, xr = poly_x(m_to_px(left_m, scale), rows), poly_x(m_to_px(right_m, scale), rows)
    centre, quarter = (xl + xr) / 2, (xr - xl) * half_width
    valid = (quarter > 0) & (centre - quarter >= 0) & (centre + quarter < w)
    if valid.sum() <= cfg.interior_min_rows:
        return None
    strip_px = cfg.interior_strip_m / scale.xm_per_px
    n_strips = int(np.ceil(2 * quarter[valid].max() / strip_px)) + 1
    ys = pixels.y
    s = pixels.x - centre[ys]
    inside = valid[ys] & (np.abs(s) < quarter[ys])
    strip = ((s[inside] + quarter[ys[inside]]) / strip_px).astype(np.intp)
    counts = np.bincount(ys[inside] * n_strips + strip, minlength=h * n_strips).reshape(h, n_strips)
    present = counts >= cfg.interior_min_pixels  # (rows that are not valid have no pixels counted)
    pair = present[:, :-1] | present[:, 1:] if n_strips > 1 else present
    fill = (pair.sum(axis=0) / int(valid.sum())).tolist()
    # A marking stands out from the rest of the lane; dense clutter fills every strip alike.
    best = max(fill)
    if best > cfg.max_interior_fill and best - statistics.median(fill) > cfg.interior_excess:
        return "line-inside-lane"
    return None
