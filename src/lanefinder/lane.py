"""The records a frame's answer is made of: one :class:`Line` per side, and the :class:`LaneResult`.

Each line's attributes live in one record, so a new per-line attribute is added in one place
and reaches the result, the telemetry and the drawing through it.  Fits follow
docs/conventions.md: ``fit_px`` is (a, b, c) of x = a*y^2 + b*y + c in bird's-eye pixels,
``fit_m`` is (A, B, C) of x = A*d^2 + B*d + C in metres, d ahead of the bird's-eye bottom row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .search import SearchResult

__all__ = ["LOST", "NO_LINE", "REDETECT", "SIDES", "TRACKING", "LaneResult", "Line"]

#: The tracker's states: following the last lane, searched blind this frame, or no lane.
TRACKING, REDETECT, LOST = "tracking", "re-detect", "lost"
#: The two sides, in the order every left/right pair is kept.
SIDES = ("left", "right")


@dataclass(frozen=True, eq=False)
class Line:
    """One lane line in one frame: what was measured, and what is shown.

    Attributes
    ----------
    fit_px : (3,) ndarray or None
        The shown line, (a, b, c) in bird's-eye pixels; None when no lane is shown.
    fit_m : (3,) ndarray or None
        The shown line, (A, B, C) in metres; None when no lane is shown.
    confidence : float
        Confidence of this frame's measurement, 0..1 (0 when nothing was measured).
    found : bool
        The line was measured and accepted this frame.
    inferred : bool
        The line is drawn from the other line and the tracked lane width (it was not seen).
    n_pixels : int
        Marking pixels the measurement was fitted on (0 when nothing was measured).
    range_m : float
        How far ahead the measured marking reaches, metres along the road from the bird's-eye
        bottom row (the d of ``fit_m``): beyond the view when the far field followed it; NaN
        when the line was not found this frame.
    start_m : float
        How far ahead its nearest measured marking lies, metres from the bird's-eye bottom row
        (more than a few metres: a dash gap, or paint hidden near the car, so the line at the car
        is extrapolated); NaN when the line was not found this frame.
    far_fit_px : (3,) ndarray or None
        The line beyond the bird's-eye view's top edge, (a, b, c) in bird's-eye pixels, valid
        for y from ``far_end_px`` to 0 (see :mod:`lanefinder.farfield`); None when the marking
        was not followed beyond the view.
    far_end_px : float
        Bird's-eye y (negative) of the farthest marking followed; NaN without a far part.

    Examples
    --------
    >>> line = Line(fit_px=None, fit_m=None, confidence=0.0, found=False, inferred=False)
    >>> line.shown, line.range_m
    (False, nan)
    """

    fit_px: np.ndarray | None
    fit_m: np.ndarray | None
    confidence: float
    found: bool
    inferred: bool
    n_pixels: int = 0
    range_m: float = math.nan
    start_m: float = math.nan
    far_fit_px: np.ndarray | None = None
    far_end_px: float = math.nan

    @property
    def shown(self) -> bool:
        """Whether the line is drawn this frame (found, inferred or held)."""
        return self.fit_px is not None


#: A side with no line at all.
NO_LINE = Line(fit_px=None, fit_m=None, confidence=0.0, found=False, inferred=False)


@dataclass(frozen=True, eq=False)
class LaneResult:
    """Everything found in one frame.

    The lane numbers are measured at the car (the bird's-eye bottom row; see
    docs/conventions.md) and are NaN only when ``lane_found`` is False.

    Attributes
    ----------
    left, right : Line
        The lane's two lines.
    radius_m : float
        Radius of the lane centre, metres, capped at ``fit.max_radius_m``.
    curvature_per_m : float
        Signed curvature of the lane centre, 1/m; positive when the lane bends right.
    offset_m : float
        Camera centre line minus lane centre, metres; positive when the car is right of centre.
    width_m : float
        Lane width between the line centres, metres.
    straight : bool
        The radius is above ``fit.straight_radius_m``.
    state : str
        ``tracking``, ``re-detect`` (searched blind this frame) or ``lost``.
    misses : int
        Consecutive frames without an accepted measurement.
    checks : tuple of str
        The reasons (named checks) that rejected something this frame.
    setup : str
        Where the bird's-eye set-up came from: ``config``, ``default`` (self-calibration
        has no sure estimate yet), ``first-frame`` (a video's first frame gave it alone, or two
        early frames agreed on it, until a sure estimate), ``lines`` (in a video: the default or
        first frame's set-up pitched to where the lane lines measured meet,
        :meth:`lanefinder.selfcal.SelfCalibrator.offer_lines`),
        ``estimated`` (self-calibration's estimate, or the set-up in use once a sure estimate
        confirmed it or was refused in its favour: :class:`lanefinder.selfcal.SetupState`) or,
        for a still,
        ``horizon`` (the default pitched to where its road lines meet:
        :func:`lanefinder.selfcal.horizon_setup`) or ``lines`` (read from the lines found in
        it: :func:`lanefinder.selfcal.lines_setup`).
    binary : ndarray or None
        The bird's-eye binary (uint8 0/1), kept for debugging views only.
    search : SearchResult or None
        The search's pixels and windows, kept for debugging views only.

    Examples
    --------
    >>> import numpy as np
    >>> from lanefinder import Config, LaneFinder
    >>> r = LaneFinder(Config()).process(np.zeros((720, 1280, 3), np.uint8))
    >>> r.lane_found, r.state, r.left.found
    (False, 'lost', False)
    """

    left: Line
    right: Line
    radius_m: float
    curvature_per_m: float
    offset_m: float
    width_m: float
    straight: bool
    state: str
    misses: int = 0
    checks: tuple[str, ...] = ()
    setup: str = "config"
    binary: np.ndarray | None = None
    search: SearchResult | None = None

    @property
    def lane_found(self) -> bool:
        """Whether a lane is shown: both lines have a fit."""
        return self.left.shown and self.right.shown

    @property
    def lines(self) -> tuple[Line, Line]:
        """The (left, right) lines, for code that treats both sides alike."""
        return self.left, self.right

    def line(self, side: str) -> Line:
        """Return the line of one side.

        Parameters
        ----------
        side : {"left", "right"}
            Which line.

        Returns
        -------
        Line
            That side's line.
        """
        return self.left if side == "left" else self.right
