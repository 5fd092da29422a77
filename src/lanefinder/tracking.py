"""Tracking the lane across frames, as one pure transition: ``step(track, measured, rules)``.

A :class:`Track` is what the tracker remembers between frames (frozen); :func:`step` takes it
and one frame's measured lines and returns the next track and a :class:`Verdict`: the two
:class:`~lanefinder.lane.Line` records to show, the state and the reasons (named checks from
:mod:`lanefinder.checks`) that rejected anything.  Works on metre fits
x = A*d^2 + B*d + C, d ahead (see docs/conventions.md).

The rules, in the order :func:`step` applies them:

1. A measured line needs ``min_confidence`` and must not jump from its track (``<side>-jump``;
   a line that was only inferred lately may come back elsewhere beside a line that is where
   the track expects it).
2. A measured pair must pass the lane checks (:func:`~lanefinder.checks.pair_problems`); a
   failing pair keeps the line nearer its track (or the more confident one without a track);
   a pair refused for the change of width alone ``width_renew_frames`` times in a row, each
   width near the mean of those before it, more times than pairs made the tracked width,
   renews it.
3. Without a usable track, a lane may not start bending tighter than ``min_start_radius_m``
   unless the lane still held bends as tight (``start-bend``).
4. One line alone must be confident to place the lane, and holds it only so long; without a lane,
   a less sure one places it once seen in the same place on ``weak_start_frames`` frames.
5. After the lane was lost, a weak start must be seen again in the same place (``confirming``);
   while a lane is held and searched blind, a weak pair elsewhere does not replace it
   (``weak-pair``).
6. A lane's first pair sets its width only when both its lines are sure enough to start a lane
   (or it restarts a lane after a lost one, confirmed); after a weaker one the default width
   stands in, which later pairs move and are held to (``sure_first_width``).  The lane implied
   by what is left must hold the car (``offset``).
7. Otherwise the fits are smoothed in (a line seen again after being inferred snaps to it);
   a rejected frame is a miss, and after ``max_misses`` the next frame is searched blind,
   after ``hold_gentle_frames`` the lane is lost (after ``lost_after`` in a tight bend: see
   :func:`hold_frames`; frames whose held lines are both seen far ahead count less: see
   :func:`seen_far`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .checks import (
    check_confidence,
    check_jump,
    check_offset,
    check_one_line,
    check_start_bend,
    lines_close,
    pair_problems,
)
from .config import TrackingConfig
from .geometry import Scale, curvature_per_m, lane_width_m, m_to_px, poly_x
from .lane import LOST, REDETECT, SIDES, TRACKING, Line

__all__ = ["Candidate", "Rules", "Track", "Verdict", "at_fps", "hold_frames", "implied_lane", "seen_far", "step"]

Fit = np.ndarray
Pair = tuple[Line | None, Line | None]


@dataclass(frozen=True)
class Rules:
    """What :func:`step` needs besides the track: the limits and the view's geometry.

    Attributes
    ----------
    cfg : TrackingConfig
        The limits of every check, and the smoothing.
    lookahead_m : float
        The farthest distance the fits are checked at (the bird's-eye top), metres.
    default_width_m : float
        Lane width assumed before one is tracked, metres (``search.lane_width_m``).
    scale : Scale
        The bird's-eye scale, to give the shown lines in pixels too.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> from lanefinder.geometry import Scale
    >>> rules = Rules(TrackingConfig(), 29.6, 3.7, Scale(3.7 / 150, 0.0985, 300, 200.0))
    >>> rules.lookahead_m
    29.6
    """

    cfg: TrackingConfig
    lookahead_m: float
    default_width_m: float
    scale: Scale


@dataclass(frozen=True, eq=False)
class Candidate:
    """While there is no lane: a candidate lane waiting to be confirmed.

    Attributes
    ----------
    fits_m : tuple of ndarray
        Its left and right metre fits.
    sightings : int
        How often it was seen in the same place.
    age : int
        Frames since it was last seen.
    ahead_m : tuple of float
        Per line, how far ahead it was seen (the next sighting is compared with it no farther),
        metres.
    weak : bool
        It is a lone line less sure than a start needs (``weak_start_confidence``), which
        another weak line may displace.

    Examples
    --------
    >>> Candidate((np.zeros(3), np.ones(3)), sightings=1, age=0).sightings
    1
    """

    fits_m: tuple[Fit, Fit]
    sightings: int
    age: int = 0
    ahead_m: tuple[float, float] = (math.inf, math.inf)
    weak: bool = False


@dataclass(frozen=True, eq=False)
class Track:
    """What the tracker remembers between frames.  The start of a clip is ``Track()``.

    Attributes
    ----------
    fits_m : tuple of (ndarray or None)
        The tracked left and right metre fits; (None, None) without a lane.
    width_m : float or None
        The tracked lane width, metres; None until the lane's first pair, and the default width
        (made from no pair) after a weak first pair (``tracking.sure_first_width``).
    misses : int
        Consecutive frames without an accepted measurement.
    guessed : tuple of int
        Per line, frames in a row it has been inferred rather than measured: an inferred line
        is a guess, so a measurement of it is not held to the jump limit.
    since_both : int
        Frames since both lines were last accepted together: one line alone holds the lane only
        so long.
    candidate : Candidate or None
        While there is no lane, the last candidate lane.
    was_lost : bool
        A lane was shown and then lost since the clip began: a weak start must then be
        confirmed (at the start of a clip, or for a single image, the first plausible lane is
        taken).
    width_pairs : int
        How many pairs the tracked width was made from, since the lane was started or its
        width last renewed (the renewing pair counts as one); 0 while the default width stands
        in for one.
    width_doubt : tuple of (int, float)
        The pairs refused in a row for the change of width alone, and their mean width (m):
        at ``tracking.width_renew_frames`` of them, and more than ``width_pairs``, the width is
        renewed (:func:`step`).

    Examples
    --------
    >>> Track().has_lane, Track().misses
    (False, 0)
    """

    fits_m: tuple[Fit | None, Fit | None] = (None, None)
    width_m: float | None = None
    misses: int = 0
    guessed: tuple[int, int] = (0, 0)
    since_both: int = 0
    candidate: Candidate | None = None
    was_lost: bool = False
    width_pairs: int = 0
    width_doubt: tuple[int, float] = (0, math.nan)

    @property
    def has_lane(self) -> bool:
        """Whether a lane is being tracked."""
        return self.fits_m[0] is not None and self.fits_m[1] is not None

    def needs_blind_search(self, cfg: TrackingConfig) -> bool:
        """Tell whether the next frame should be searched without a prior.

        Parameters
        ----------
        cfg : TrackingConfig
            Holds ``max_misses``.

        Returns
        -------
        bool
            True without a lane, or after ``max_misses`` misses in a row.
        """
        return not self.has_lane or self.misses >= cfg.max_misses

    def tracked_width(self, cfg: TrackingConfig) -> float | None:
        """Return the lane width a measurement is held to, or None when none holds.

        Parameters
        ----------
        cfg : TrackingConfig
            Holds ``max_misses``.

        Returns
        -------
        float or None
            The tracked width (m) while tracking; None without a track or when re-detecting.
        """
        return None if self.width_m is None or self.needs_blind_search(cfg) else self.width_m


@dataclass(frozen=True, eq=False)
class Verdict:
    """The tracker's answer for one frame.

    Attributes
    ----------
    left, right : Line
        The lines to show (``fit_m``/``fit_px`` None when lost), with this frame's ``found``,
        ``inferred`` and confidence.
    state : str
        ``tracking``, ``re-detect`` or ``lost``.
    misses : int
        Consecutive misses after this frame.
    reasons : tuple of str
        The named checks that rejected something this frame.

    Examples
    --------
    >>> from lanefinder.lane import NO_LINE
    >>> Verdict(NO_LINE, NO_LINE, "lost", 13, ()).has_lane
    False
    """

    left: Line
    right: Line
    state: str
    misses: int
    reasons: tuple[str, ...] = ()

    @property
    def has_lane(self) -> bool:
        """Whether a lane is shown."""
        return self.left.fit_m is not None and self.right.fit_m is not None


def implied_lane(left_m: Fit | None, right_m: Fit | None, width_m: float) -> tuple[Fit, Fit]:
    """Complete a lane from one or two metre fits: a missing line is the other one shifted by the width.

    Across the road, at the car, the other line is ``width_m`` away along the normal of the
    seen line: sqrt(1 + slope^2) times that in x when the car is not parallel to the lane.

    Parameters
    ----------
    left_m, right_m : (3,) ndarray or None
        Metre fits; at least one must be given.
    width_m : float
        The lane width, metres.

    Returns
    -------
    tuple of ndarray
        The left and right metre fits.

    Raises
    ------
    ValueError
        When neither line is given.

    Examples
    --------
    >>> left, right = implied_lane(np.array([0.0, 0.0, -1.8]), None, 3.7)
    >>> right
    array([0. , 0. , 1.9])
    """
    if left_m is None and right_m is None:
        raise ValueError("implied_lane needs at least one line")
    if left_m is None:
        left_m = right_m - np.array([0.0, 0.0, width_m * float(np.hypot(1.0, right_m[1]))])
    if right_m is None:
        right_m = left_m + np.array([0.0, 0.0, width_m * float(np.hypot(1.0, left_m[1]))])
    return left_m, right_m


def _smooth(old: Fit, new: Fit, conf: float, rules: Rules) -> Fit:
    """Exponential smoothing weighted by confidence, faster for large changes.

    The gain rises with the size of the change at the far end relative to the jump limit, so a
    sharp bend is followed without lag while small wobble is damped.
    """
    c = rules.cfg
    far_move = abs(poly_x(new, rules.lookahead_m) - poly_x(old, rules.lookahead_m))
    change = far_move / max(c.max_offset_jump_m, 1e-6)
    gain = (1 - c.smoothing) * (c.smoothing_conf_floor + (1 - c.smoothing_conf_floor) * conf)
    gain = float(np.clip(gain + c.smoothing_fast_gain * min(change, 1.0), c.smoothing_min_gain, 1.0))
    return old + gain * (new - old)


def _lines(fits: tuple[Fit | None, Fit | None], found: tuple[bool, bool], conf: tuple[float, float],
           measured: Pair, rules: Rules, shown: bool) -> tuple[Line, Line]:
    """Make the two :class:`Line` records of a verdict."""
    out = []
    for fit, ok, c, m in zip(fits, found, conf, measured, strict=True):
        out.append(Line(
            fit_px=None if fit is None else m_to_px(fit, rules.scale), fit_m=None if fit is None else fit.copy(),
            confidence=c, found=ok, inferred=shown and not ok, n_pixels=m.n_pixels if m is not None else 0,
            range_m=m.range_m if ok and m is not None else math.nan,
            start_m=m.start_m if ok and m is not None else math.nan))
    return out[0], out[1]


#: Frame rates outside this range are taken as misreported: tracking is not scaled to them.
_MIN_FPS, _MAX_FPS = 5.0, 240.0


def at_fps(cfg: TrackingConfig, fps: float) -> TrackingConfig:
    """Give the tracking settings for a video at ``fps``: the same times as at ``cfg.reference_fps``.

    Counts of frames (``max_misses``, ``lost_after``, ``hold_gentle_frames``,
    ``max_one_line_frames``, ``start_frames``, ``weak_start_frames``, ``start_both_frames``,
    ``width_renew_frames``) scale with the frame rate, and so does the per-frame move
    ``start_free_m`` (inversely); a per-frame smoothing gain g becomes
    ``1 - (1 - g) ** (reference_fps / fps)`` (the retention ``smoothing`` becomes
    ``smoothing ** (reference_fps / fps)``), so a lane is held, confirmed and smoothed over the
    same seconds; a lone line still needs at least two sightings to start a lane after a lost one
    when it needed two or more, and a width two refusals to be renewed.  Rates within 2% of the
    reference, and rates that are unknown or outside 5-240 fps (misreported), keep the settings
    as they are.

    Parameters
    ----------
    cfg : TrackingConfig
        The settings, for ``cfg.reference_fps``.
    fps : float
        The video's frame rate.

    Returns
    -------
    TrackingConfig
        The settings for ``fps``.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> cfg = at_fps(TrackingConfig(), 50.0)
    >>> cfg.hold_gentle_frames, cfg.lost_after, round(cfg.smoothing, 3)
    (50, 24, 0.707)
    """
    fps = float(fps)
    if not (math.isfinite(fps) and _MIN_FPS <= fps <= _MAX_FPS):
        return cfg
    ratio = fps / cfg.reference_fps
    if abs(ratio - 1) <= 0.02:
        return cfg

    def count(n: int) -> int:
        return max(1, round(n * ratio))

    def gain(g: float) -> float:
        return 1 - (1 - g) ** (1 / ratio)

    return cfg.model_copy(update={
        "max_misses": count(cfg.max_misses), "lost_after": count(cfg.lost_after),
        "hold_gentle_frames": count(cfg.hold_gentle_frames), "max_one_line_frames": count(cfg.max_one_line_frames),
        "start_frames": max(min(2, cfg.start_frames), count(cfg.start_frames)),
        "weak_start_frames": max(min(2, cfg.weak_start_frames), count(cfg.weak_start_frames))
        if cfg.weak_start_frames else 0,
        "smoothing": cfg.smoothing ** (1 / ratio),
        "smoothing_fast_gain": gain(cfg.smoothing_fast_gain), "smoothing_min_gain": gain(cfg.smoothing_min_gain),
        "width_smoothing": gain(cfg.width_smoothing), "start_free_m": cfg.start_free_m / ratio,
        "start_both_frames": count(cfg.start_both_frames) if cfg.start_both_frames else 0,
        "width_renew_frames": max(min(2, cfg.width_renew_frames), count(cfg.width_renew_frames))
        if cfg.width_renew_frames else 0,
        "reference_fps": fps})


def hold_frames(track: Track, cfg: TrackingConfig) -> int:
    """Give how many frames in a row without a measurement the track's lane is held before it is lost.

    A gentle lane (its curvature at the car no tighter than ``1 / hold_gentle_radius_m``) is
    held for ``hold_gentle_frames`` (at least ``lost_after``): across a long gap in worn or dashed
    paint the road ahead changes little.  A tighter one, whose bend can change within a second
    (a hairpin), for ``lost_after``.  (A lost track's ``misses`` stays ``lost_after + 1``.)

    Parameters
    ----------
    track : Track
        The track (with a lane).
    cfg : TrackingConfig
        ``lost_after``, ``hold_gentle_frames``, ``hold_gentle_radius_m``.

    Returns
    -------
    int
        Frames.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> straight = Track(fits_m=(np.array([0.0, 0.0, -1.8]), np.array([0.0, 0.0, 1.9])))
    >>> hairpin = Track(fits_m=(np.array([0.02, 0.0, -1.8]), np.array([0.02, 0.0, 1.9])))
    >>> cfg = TrackingConfig()
    >>> hold_frames(straight, cfg) == cfg.hold_gentle_frames, hold_frames(hairpin, cfg) == cfg.lost_after
    (True, True)
    """
    return max(cfg.lost_after, cfg.hold_gentle_frames) if _gentle(track, cfg) else cfg.lost_after


def _gentle(track: Track, cfg: TrackingConfig) -> bool:
    """Tell whether a track's lane curves no tighter than ``1 / hold_gentle_radius_m`` (0: never gentle)."""
    if not track.has_lane or cfg.hold_gentle_radius_m <= 0:
        return False
    k = max(abs(curvature_per_m(f)) for f in track.fits_m)  # type: ignore[arg-type]
    return bool(k * cfg.hold_gentle_radius_m <= 1)


def seen_far(track: Track, cfg: TrackingConfig) -> Track:
    """Take back a held lane's last miss: both its lines' markings were seen beyond the view.

    Worn paint whose near dashes are gone may still show farther ones where the held lane
    runs on; the far field (:mod:`lanefinder.farfield`) follows them.  Such a frame is not
    counted towards losing the lane, within bounds: only once the held lane is searched blind
    (after ``max_misses``; a pair found blind, sure enough, still replaces it), only while
    both lines were measured together no more than ``2 * hold_gentle_frames`` frames ago
    (so a held lane is lost after about three times the gentle hold at most), and only for a
    gentle lane (:func:`hold_frames`: a tighter bend can change within a second).

    Parameters
    ----------
    track : Track
        The track after a frame's :func:`step`.
    cfg : TrackingConfig
        ``max_misses``, ``hold_gentle_frames``, ``hold_gentle_radius_m``.

    Returns
    -------
    Track
        The same track with one miss fewer, or ``track`` where the bounds above say no.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> cfg = TrackingConfig()
    >>> held = Track(fits_m=(np.array([0.0, 0.0, -1.8]), np.array([0.0, 0.0, 1.9])), misses=cfg.max_misses + 3)
    >>> seen_far(held, cfg).misses - held.misses, seen_far(replace(held, misses=2), cfg).misses
    (-1, 2)
    """
    if not _gentle(track, cfg) or track.misses <= cfg.max_misses:
        return track
    if track.since_both > 2 * cfg.hold_gentle_frames:
        return track
    return replace(track, misses=track.misses - 1)


def _miss(track: Track, reasons: list[str], conf: tuple[float, float], measured: Pair, blind: bool,
          rules: Rules, keep_candidate: bool = False) -> tuple[Track, Verdict]:
    """Handle a frame whose measurements were not taken: hold the lane, or lose it."""
    c = rules.cfg
    misses, since_both, cand = track.misses + 1, track.since_both + 1, track.candidate
    if not keep_candidate and cand is not None:
        cand = replace(cand, age=cand.age + 1) if cand.age < c.start_frames else None
    if not track.has_lane or misses > hold_frames(track, c):
        had_lane = track.fits_m[0] is not None or track.was_lost
        lost = Track(misses=c.lost_after + 1, candidate=cand, was_lost=had_lane)
        left, right = _lines((None, None), (False, False), conf, measured, rules, shown=False)
        return lost, Verdict(left, right, LOST, lost.misses, tuple(reasons))
    held = replace(track, misses=misses, since_both=since_both, candidate=cand)
    left, right = _lines(track.fits_m, (False, False), conf, measured, rules, shown=True)
    return held, Verdict(left, right, REDETECT if blind else TRACKING, misses, tuple(reasons))


def _confirm(track: Track, fits: tuple[Fit, Fit], pair: bool, rules: Rules, ahead_m: tuple[float, float],
             need: int | None = None, weak: bool = False) -> tuple[Candidate, bool]:
    """Count sightings of the same candidate lane, each line compared as far as both sightings reach.

    ``ahead_m`` is how far this sighting's lines reach (:func:`_seen_ahead_m`). A gap of up to
    ``start_frames`` frames is allowed between sightings; a pair needs two, one line
    ``start_frames`` (or ``need``).
    """
    prev = track.candidate
    same = prev is not None and all(
        lines_close(f, p, min(a, b), rules.cfg)
        for f, p, a, b in zip(fits, prev.fits_m, ahead_m, prev.ahead_m, strict=True))
    count = prev.sightings + 1 if same and prev is not None else 1
    cand = Candidate((fits[0].copy(), fits[1].copy()), count, 0, ahead_m, weak)
    return cand, count >= (need if need is not None else 2 if pair else rules.cfg.start_frames)


def _seen_ahead_m(measured: Pair, ok: list[bool], rules: Rules) -> tuple[float, float]:
    """Per line, how far ahead a candidate's line is compared: as far as its marking reaches.

    A short marking's fit wanders beyond its reach (most in a tight bend), so a candidate is
    compared only where it was seen (at most to the view's end).  A line not measured (inferred)
    or of unknown reach is compared as far as the other, measured line reaches, else to the
    view's end.
    """
    reach = []
    for m, taken in zip(measured, ok, strict=True):
        r = m.range_m if taken and m is not None else math.nan
        reach.append(min(rules.lookahead_m, r) if math.isfinite(r) and r > 0 else math.nan)
    out = [r if math.isfinite(r) else (reach[1 - i] if ok[1 - i] and math.isfinite(reach[1 - i]) else rules.lookahead_m)
           for i, r in enumerate(reach)]
    return out[0], out[1]


def _weak_start(track: Track, fits: tuple[Fit, Fit], ok: list[bool], conf: list[float],
                rules: Rules, ahead_m: tuple[float, float]) -> tuple[Candidate, bool] | None:
    """Rule 3's exception: without a lane, a lone weak line seen in the same place long enough starts it.

    Gives the candidate counted and whether it is confirmed (None: the line is too weak, the
    rule is off, or a surer candidate waits elsewhere, which a weak line does not displace).  It
    is confirmed once seen on ``weak_start_frames`` frames, and never on fewer than a
    confident lone line needs (``start_frames``), the same as far as it is seen
    (:func:`_confirm`: a short marking's fit wanders beyond).  ``fits`` is the lane the line
    implies, ``ahead_m`` how far it reaches (:func:`_seen_ahead_m`).
    """
    c = rules.cfg
    i = 0 if ok[0] else 1
    if track.has_lane or not c.weak_start_frames or conf[i] < c.weak_start_confidence:
        return None
    need = max(c.weak_start_frames, c.start_frames)
    cand, confirmed = _confirm(track, fits, False, rules, ahead_m, need=need, weak=True)
    if cand.sightings == 1 and track.candidate is not None and not track.candidate.weak:
        return None  # not where a surer candidate waits: a plain miss, as before
    return cand, confirmed


def _near_track(track: Track, measured: Pair, ok: list[bool], rules: Rules) -> list[bool]:
    """Per line: taken so far and within the jump limit of its track (or no jump limit holds)."""
    blind = track.needs_blind_search(rules.cfg)
    near = []
    for m, tracked, taken in zip(measured, track.fits_m, ok, strict=True):
        free = tracked is None or blind
        near.append(taken and (free or lines_close(m.fit_m, tracked, rules.lookahead_m, rules.cfg)))  # type: ignore[union-attr,arg-type]
    return near


def _taken_lines(track: Track, measured: Pair, rules: Rules, reasons: list[str]) -> list[bool]:
    """Rule 1: the measured lines that are confident and did not jump from their track."""
    c = rules.cfg
    ok = []
    for side, m in zip(SIDES, measured, strict=True):
        reason = check_confidence(side, None if m is None else m.confidence, c)
        reasons.extend([reason] if reason else [])
        ok.append(m is not None and reason is None)
    near = _near_track(track, measured, ok, rules)
    for i, side in enumerate(SIDES):
        if ok[i] and (reason := check_jump(side, near[i], track.guessed[i], near[1 - i])):
            ok[i] = False
            reasons.append(reason)
    return ok


def _width_doubt(track: Track, problems: list[str], width_m: float, cfg: TrackingConfig) -> tuple[int, float]:
    """Count a pair refused for the change of width alone (see ``tracking.width_renew_frames``).

    Gives the new ``width_doubt``: one more with the mean updated when the width lies within
    ``width_renew_spread_m`` of the mean of the row so far, else a new row of one; (0, NaN) for
    a pair refused for anything else too, or taken.
    """
    if problems != ["width-change"] or cfg.width_renew_frames == 0:
        return 0, math.nan
    n, mean = track.width_doubt
    if n and abs(width_m - mean) <= cfg.width_renew_spread_m:
        return n + 1, mean + (width_m - mean) / (n + 1)
    return 1, width_m


def _renews(track: Track, doubt: tuple[int, float], cfg: TrackingConfig) -> bool:
    """Tell whether the pairs refused in a row for the change of width renew the tracked width.

    At ``width_renew_frames`` of them (0: never), and more of them than pairs made the tracked
    width: a width read off many pairs is not overturned by a few (the harder challenge video:
    a guard rail's foot refused five times in a row at one width, beside a width of hundreds).
    """
    return cfg.width_renew_frames > 0 and doubt[0] >= cfg.width_renew_frames and doubt[0] > track.width_pairs


def _settle_pair(track: Track, measured: Pair, ok: list[bool], conf: list[float], rules: Rules,
                 reasons: list[str]) -> tuple[list[float], tuple[int, float], bool]:
    """Rule 2: a pair that fails the lane checks keeps one line; the confidences drop.

    Both drop by ``rejected_pair_confidence``, except that without a usable track (a blind
    start, or re-detecting after ``max_misses``) the surer line is kept and keeps its
    confidence when the other is too weak to start a lane alone (below
    ``min_start_confidence``).  A pair refused for the change of width alone, the
    ``tracking.width_renew_frames``-th time in a row at much the same width and more times
    than pairs made the tracked width, is taken (the tracked width was wrong).  Also gives the
    track's new ``width_doubt`` and whether the pair renews the width.
    """
    c = rules.cfg
    lm, rm = measured[0].fit_m, measured[1].fit_m  # type: ignore[union-attr]
    holding = not track.needs_blind_search(c)
    problems = pair_problems(lm, rm, track.tracked_width(c), rules.lookahead_m, c, holding=holding)
    doubt = _width_doubt(track, problems, lane_width_m(lm, rm), c)
    if not problems:
        return conf, doubt, False
    if _renews(track, doubt, c):
        return conf, (0, math.nan), True
    reasons.extend(problems)
    # Keep the line that agrees better with the track, else the more confident one.
    if holding:
        drop = 0 if abs(lm[2] - track.fits_m[0][2]) > abs(rm[2] - track.fits_m[1][2]) else 1  # type: ignore[index]
    else:
        drop = 0 if conf[0] < conf[1] else 1
    ok[drop] = False
    if not holding and conf[drop] < c.min_start_confidence:
        # A line too weak to start a lane alone says little against a sure one: the sure one keeps its say.
        return [v if i != drop else v * c.rejected_pair_confidence for i, v in enumerate(conf)], doubt, False
    return [v * c.rejected_pair_confidence for v in conf], doubt, False


def _weak_elsewhere(track: Track, fits: tuple[Fit, Fit], ok: list[bool], conf: list[float], rules: Rules) -> bool:
    """Rule 4 while a lane is held: a weak blind pair away from it does not replace it.

    Searched blind (after ``max_misses``) while the lane is still held, a pair that is not
    sure enough to start a lane at once (a line below ``min_start_confidence``) and one of
    whose lines lies beyond the jump limit of the held one
    (:func:`~lanefinder.checks.lines_close`) is a miss: the held lane stays until it is lost,
    and after that such a pair must be seen twice (``confirming``; sightings while it was held
    count).  In glare and on worn paint the blind search pairs glare edges and shadows
    (synthetic glare, tuning seed 8: a lane 0.6 m off, then kept by the jump check; a weak
    pair seen twice was not enough either: glare showed the same wrong pair again).
    """
    c = rules.cfg
    if not (track.has_lane and ok[0] and ok[1] and track.needs_blind_search(c)):
        return False
    if min(conf) >= c.min_start_confidence:
        return False
    return not all(lines_close(f, t, rules.lookahead_m, c) for f, t in zip(fits, track.fits_m, strict=True))


def _unconfirmed(track: Track, fits: tuple[Fit, Fit], ok: list[bool], conf: list[float],
                 rules: Rules, ahead_m: tuple[float, float]) -> Candidate | None:
    """Rule 4: after a lost lane, the candidate a weak start still waits on (None: go ahead)."""
    if track.has_lane or not track.was_lost:
        return None
    both = ok[0] and ok[1]
    if both and min(conf) >= rules.cfg.min_start_confidence:
        return None
    cand, confirmed = _confirm(track, fits, both, rules, ahead_m)
    return None if confirmed else cand


def _held_at_car(old: Fit, new: Fit, start_m: float, cfg: TrackingConfig) -> Fit:
    """Hold back a measured line seen only from ``start_m`` ahead: at the car it may move ``cfg.start_free_m``.

    Its position at the car (``c``) moves from the tracked line ``old`` by at most
    ``start_free_m``; its heading and bend are taken as measured.  Nearer paint (within
    ``start_gap_m``), or ``start_gap_m`` 0, takes the measurement as it is.
    """
    if not (cfg.start_gap_m > 0 and start_m > cfg.start_gap_m):
        return new
    move = float(new[2] - old[2])
    excess = move - float(np.clip(move, -cfg.start_free_m, cfg.start_free_m))
    if excess == 0:
        return new
    return new - np.array([0.0, 0.0, excess])


def _commit(track: Track, fits: tuple[Fit, Fit], ok: list[bool], conf: list[float], rules: Rules,
            start_m: tuple[float, float] = (math.nan, math.nan)) -> Track:
    """Rule 6: smooth the fits into the track (a line seen again after being guessed snaps to it).

    A measured line whose nearest paint is more than ``tracking.start_gap_m`` ahead (``start_m``)
    moves the line at the car by ``tracking.start_free_m`` at most before smoothing (not on a
    fresh start, nor when a guessed line is seen again: those snap to the measurement).
    """
    c = rules.cfg
    fresh = track.needs_blind_search(c)
    # Both lines moving apart (or together) at the car is the lane's width, or the car pitching on
    # a bump (the flat-road view stretches the lane): not held.
    apart = ok[0] and ok[1] and not fresh and (fits[0][2] - track.fits_m[0][2]) * (  # type: ignore[index]
        fits[1][2] - track.fits_m[1][2]) < 0  # type: ignore[index]
    new_fits = []
    for i in (0, 1):
        if fresh or (ok[i] and track.guessed[i] > 0):
            new_fits.append(fits[i].copy())
        else:
            weight = conf[i] if ok[i] else c.inferred_weight * conf[1 - i]
            held = ok[i] and not apart and track.since_both <= c.start_both_frames  # (one line at a time: goes by it)
            target = _held_at_car(track.fits_m[i], fits[i], start_m[i], c) if held else fits[i]  # type: ignore[arg-type]
            new_fits.append(_smooth(track.fits_m[i], target, weight, rules))  # type: ignore[arg-type]
    guessed = (0 if ok[0] else track.guessed[0] + 1, 0 if ok[1] else track.guessed[1] + 1)
    return replace(track, fits_m=(new_fits[0], new_fits[1]), misses=0, guessed=guessed)


def _first_width(w_meas: float, conf: list[float], restarted: bool, rules: Rules) -> tuple[float, int]:
    """Give a lane without a width the one its first pair makes, and how many pairs made it.

    As measured when both lines are at least ``min_start_confidence`` sure, or the pair restarts
    a lane after a lost one (a weak start is then confirmed: seen twice in one place, where a
    sighting may be of one sure line, or of a weak pair counted while the lost lane was held);
    else the default width, made from no pair (``tracking.sure_first_width``): one weak line
    says little, and a line inferred from the other keeps the width for as long as it is inferred.
    """
    c = rules.cfg
    if not c.sure_first_width or restarted or min(conf) >= c.min_start_confidence:
        return w_meas, 1
    return rules.default_width_m, 0


def step(track: Track, measured: Pair, blind: bool, rules: Rules) -> tuple[Track, Verdict]:
    """Fold one frame's measured lines into the track.

    Parameters
    ----------
    track : Track
        The track before this frame (``Track()`` at the start of a clip).
    measured : tuple of (Line or None)
        This frame's measured left and right lines (``fit_m`` and ``confidence`` are used;
        ``n_pixels`` and ``range_m`` are passed on), None where nothing was measured.
    blind : bool
        The frame was searched without a prior (reported as the ``re-detect`` state).
    rules : Rules
        The limits and the view's geometry.

    Returns
    -------
    track : Track
        The track after this frame.
    verdict : Verdict
        The lines to show, the state and the reasons.

    Examples
    --------
    >>> from lanefinder.config import TrackingConfig
    >>> from lanefinder.geometry import Scale
    >>> from lanefinder.lane import Line
    >>> rules = Rules(TrackingConfig(), 29.6, 3.7, Scale(3.7 / 150, 0.0985, 300, 200.0))
    >>> seen = lambda c: Line(fit_px=None, fit_m=np.array([0.0, 0.0, c]), confidence=0.9, found=True, inferred=False)
    >>> track, verdict = step(Track(), (seen(-1.8), seen(1.9)), True, rules)
    >>> verdict.state, verdict.left.found, verdict.right.found, track.width_m
    ('re-detect', True, True, 3.7)
    >>> track, verdict = step(track, (seen(-1.8), None), False, rules)
    >>> verdict.right.inferred, round(float(verdict.right.fit_m[2]), 2)
    (True, 1.9)
    """
    c = rules.cfg
    reasons: list[str] = []
    ok = _taken_lines(track, measured, rules, reasons)
    conf = [m.confidence if m is not None else 0.0 for m in measured]
    renew = False
    if ok[0] and ok[1]:
        conf, doubt, renew = _settle_pair(track, measured, ok, conf, rules, reasons)
        track = replace(track, width_doubt=doubt)
    conf_t = (conf[0], conf[1])
    if not (ok[0] or ok[1]):
        return _miss(track, reasons, conf_t, measured, blind, rules)
    # The lane what is left implies, and how far its lines reach (for a candidate's sightings).
    width = track.width_m if track.width_m is not None else rules.default_width_m
    fits = implied_lane(measured[0].fit_m if ok[0] else None,  # type: ignore[union-attr]
                        measured[1].fit_m if ok[1] else None, width)  # type: ignore[union-attr]
    ahead = _seen_ahead_m(measured, ok, rules)
    held = track.fits_m if track.has_lane else None
    if reason := check_start_bend(fits, track.needs_blind_search(c), c, held):  # type: ignore[arg-type]
        # A lane may not start bending tighter than any road does (a fit bent by a few rows of
        # paint in glare): it waits for lines that read as a road.
        reasons.append(reason)
        return _miss(track, reasons, conf_t, measured, blind, rules)
    weak_started = False
    if ok[0] != ok[1]:
        lone = check_one_line(conf[0] if ok[0] else conf[1], track.needs_blind_search(c), track.since_both, c)
        reasons.extend([lone] if lone else [])
        if lone == "one-line-start" and (weak := _weak_start(track, fits, ok, conf, rules, ahead)) is not None:
            if not weak[1]:
                return _miss(replace(track, candidate=weak[0]), reasons, conf_t, measured, blind, rules,
                             keep_candidate=True)
            lone, weak_started = None, True  # seen long enough: it starts the lane, confirmed
            reasons.remove("one-line-start")
        if lone:
            return _miss(track, reasons, conf_t, measured, blind, rules)

    both = ok[0] and ok[1]
    if _weak_elsewhere(track, fits, ok, conf, rules):
        # Its sightings are counted, for when the held lane is lost (rule 5).
        reasons.append("weak-pair")
        cand, _ = _confirm(track, fits, True, rules, ahead)
        return _miss(replace(track, candidate=cand), reasons, conf_t, measured, blind, rules, keep_candidate=True)
    if not weak_started and (cand := _unconfirmed(track, fits, ok, conf, rules, ahead)) is not None:
        # A weak start must be seen again in the same place before it is shown.
        reasons.append("confirming")
        return _miss(replace(track, candidate=cand), reasons, conf_t, measured, blind, rules, keep_candidate=True)
    restarted = not track.has_lane and track.was_lost  # after a lost lane: sure, or confirmed just now
    width_m, pairs = track.width_m, track.width_pairs
    if both:
        w_meas = lane_width_m(*fits)
        if renew:
            width_m, pairs = w_meas, 1  # taken as measured: the tracked width was wrong
        elif width_m is not None:
            width_m, pairs = width_m + c.width_smoothing * (w_meas - width_m), pairs + 1
        else:
            width_m, pairs = _first_width(w_meas, conf, restarted, rules)
    track = replace(track, candidate=None, since_both=0 if both else track.since_both + 1, width_m=width_m,
                    width_pairs=pairs)
    if reason := check_offset(*fits, c, holding=not track.needs_blind_search(c)):
        # The lane these lines make would not hold the car: not this lane.
        reasons.append(reason)
        return _miss(track, reasons, conf_t, measured, blind, rules)
    starts = tuple(m.start_m if taken and m is not None else math.nan for m, taken in zip(measured, ok, strict=True))
    track = _commit(track, fits, ok, conf, rules, starts)  # type: ignore[arg-type]
    left, right = _lines(track.fits_m, (ok[0], ok[1]), conf_t, measured, rules, shown=True)
    return track, Verdict(left, right, REDETECT if blind else TRACKING, 0, tuple(reasons))
