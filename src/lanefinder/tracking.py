"""Tracking the lane across frames: sanity checks, confidence, smoothing, re-detection.

Works on metre fits (see :mod:`lanefinder.geometry`): x = A*d^2 + B*d + C, d ahead.
A :class:`LaneTracker` takes each frame's measured lines and returns the lane to show.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .config import TrackingConfig
from .geometry import curvature_per_m, lane_width_m

TRACKING, REDETECT, LOST = "tracking", "re-detect", "lost"


@dataclass(frozen=True, eq=False)
class Measurement:
    """One line as measured in a frame: metre fit and fit confidence (0..1)."""

    coeffs_m: np.ndarray
    confidence: float


@dataclass(frozen=True, eq=False)
class TrackedLane:
    """The tracker's answer for one frame.

    left_m/right_m: metre fits to show (None when lost).  *_found: measured and accepted this
    frame; *_inferred: drawn from the other line and the tracked width.  checks: names of the
    sanity checks that failed this frame.
    """

    left_m: np.ndarray | None
    right_m: np.ndarray | None
    left_found: bool
    right_found: bool
    left_inferred: bool
    right_inferred: bool
    left_conf: float
    right_conf: float
    state: str
    misses: int
    checks: tuple[str, ...] = ()

    @property
    def has_lane(self) -> bool:
        return self.left_m is not None and self.right_m is not None


def _x_at(c: np.ndarray, d: float) -> float:
    return float((c[0] * d + c[1]) * d + c[2])


@dataclass
class LaneTracker:
    """Stateful lane tracker; one per video.

    ``lookahead_m`` is the farthest distance the fits are checked at (the bird's-eye top).
    """

    cfg: TrackingConfig
    lookahead_m: float
    default_width_m: float = 3.7
    left: np.ndarray | None = None
    right: np.ndarray | None = None
    width_m: float | None = None
    misses: int = 0
    # Frames in a row each line has been inferred rather than measured: an inferred line is a
    # guess, so a measurement of it is not held to the jump limit.
    left_guessed: int = 0
    right_guessed: int = 0
    # Frames since both lines were last accepted together: one line alone holds the lane only
    # so long, and starts (or restarts after "lost") a lane only when it is confident.
    since_both: int = 0
    # While there is no lane: the last candidate lane (left, right, sightings, frames since).
    candidate: tuple[np.ndarray, np.ndarray, int, int] | None = None
    # A lane was shown and then lost since the clip began: a weak start must then be confirmed
    # (at the start of a clip, or for a single image, the first plausible lane is taken).
    was_lost: bool = False
    stats: dict = field(default_factory=lambda: {"frames": 0, "tracked": 0, "redetect": 0, "lost": 0, "rejected": 0})

    @property
    def needs_blind_search(self) -> bool:
        """True when the next frame should be searched without a prior."""
        return self.left is None or self.right is None or self.misses >= self.cfg.max_misses

    def reset(self) -> None:
        """Forget the track, as at the start of a clip."""
        self.was_lost = False
        self.left = self.right = None
        self.width_m = None
        self.misses = 0
        self.left_guessed = self.right_guessed = 0
        self.since_both = 0
        self.candidate = None

    # -- checks -------------------------------------------------------------------------
    def pair_problems(self, lm: np.ndarray, rm: np.ndarray) -> list[str]:
        """The lane checks a measured pair (metre fits) fails: width, the car inside the lane,
        parallel lines, matching curvatures and, while tracking, the change of width."""
        c = self.cfg
        problems = []
        w_near = rm[2] - lm[2]
        w_far = _x_at(rm, self.lookahead_m) - _x_at(lm, self.lookahead_m)
        w_mid = _x_at(rm, self.lookahead_m / 2) - _x_at(lm, self.lookahead_m / 2)
        width = lane_width_m(lm, rm)
        if not c.min_width_m <= width <= c.max_width_m:
            problems.append("width")
        if not self._offset_ok(lm, rm):
            problems.append("offset")
        if max(abs(w_far - w_near), abs(w_mid - w_near)) > c.max_parallel_diff_m:
            problems.append("parallel")
        if abs(curvature_per_m(lm) - curvature_per_m(rm)) > c.max_curvature_diff:
            problems.append("curvature")
        tracked_width = self.width_m is not None and not self.needs_blind_search
        if tracked_width and abs(width - self.width_m) > c.max_width_change_m:
            problems.append("width-change")
        return problems

    def _offset_ok(self, lm: np.ndarray, rm: np.ndarray) -> bool:
        """The car (x = 0) is inside the lane, at most ``max_offset_m`` from its centre."""
        return lm[2] < 0 < rm[2] and abs(lm[2] + rm[2]) / 2 <= self.cfg.max_offset_m

    def _close(self, a: np.ndarray, b: np.ndarray) -> bool:
        """Two fits of one line within the jump limit: at the car, and three times it at the far end."""
        lim = self.cfg.max_offset_jump_m
        far = abs(_x_at(a, self.lookahead_m) - _x_at(b, self.lookahead_m))
        return abs(a[2] - b[2]) <= lim and far <= 3 * lim

    def _jump_ok(self, meas: np.ndarray, tracked: np.ndarray | None) -> bool:
        return tracked is None or self.misses >= self.cfg.max_misses or self._close(meas, tracked)

    # -- update -------------------------------------------------------------------------
    def update(self, left: Measurement | None, right: Measurement | None, blind: bool) -> TrackedLane:
        """Fold one frame's measurements into the track and return what to show."""
        c = self.cfg
        self.stats["frames"] += 1
        checks: list[str] = []
        ok_l = left is not None and left.confidence >= c.min_confidence
        ok_r = right is not None and right.confidence >= c.min_confidence
        if left is not None and not ok_l:
            checks.append("left-confidence")
        if right is not None and not ok_r:
            checks.append("right-confidence")
        # A line that was only guessed may come back away from the guess, but only beside a line
        # that is where the track expects it: a lone line far from the track is not trusted.
        near_l = ok_l and self._jump_ok(left.coeffs_m, self.left)
        near_r = ok_r and self._jump_ok(right.coeffs_m, self.right)
        if ok_l and not near_l and not (self.left_guessed and near_r):
            ok_l = False
            checks.append("left-jump")
        if ok_r and not near_r and not (self.right_guessed and near_l):
            ok_r = False
            checks.append("right-jump")
        conf_l = left.confidence if left is not None else 0.0
        conf_r = right.confidence if right is not None else 0.0
        if ok_l and ok_r:
            problems = self.pair_problems(left.coeffs_m, right.coeffs_m)
            if problems:
                checks.extend(problems)
                # Keep the line that agrees better with the track, else the more confident one.
                if self.left is not None and self.right is not None and not self.needs_blind_search:
                    dl = abs(left.coeffs_m[2] - self.left[2])
                    dr = abs(right.coeffs_m[2] - self.right[2])
                    drop_left = dl > dr
                else:
                    drop_left = conf_l < conf_r
                if drop_left:
                    ok_l = False
                else:
                    ok_r = False
                conf_l *= 0.5
                conf_r *= 0.5

        if ok_l != ok_r:
            one_conf = conf_l if ok_l else conf_r
            # Without a lane, or re-detecting after misses (when the jump limit no longer holds),
            # a line alone must be confident to place the lane.
            if self.needs_blind_search and one_conf < c.min_start_confidence:
                checks.append("one-line-start")
                return self._miss(checks, conf_l, conf_r, blind)
            if self.since_both >= c.max_one_line_frames:
                checks.append("one-line-too-long")
                return self._miss(checks, conf_l, conf_r, blind)
        if not ok_l and not ok_r:
            return self._miss(checks, conf_l, conf_r, blind)

        meas_l, meas_r = self.implied_lane(left.coeffs_m if ok_l else None, right.coeffs_m if ok_r else None)
        if self.left is None or self.right is None:
            strong = ok_l and ok_r and min(conf_l, conf_r) >= c.min_start_confidence
            if self.was_lost and not strong and not self._confirmed(meas_l, meas_r, ok_l and ok_r):
                # A weak start must be seen again in the same place before it is shown.
                checks.append("confirming")
                return self._miss(checks, conf_l, conf_r, blind, keep_candidate=True)
        self.candidate = None
        self.since_both = 0 if ok_l and ok_r else self.since_both + 1
        if ok_l and ok_r:
            w_meas = lane_width_m(meas_l, meas_r)
            self.width_m = w_meas if self.width_m is None else self.width_m + 0.1 * (w_meas - self.width_m)
        if not self._offset_ok(meas_l, meas_r):
            # One line seen, and the lane it implies would not hold the car: not this lane.
            checks.append("offset")
            return self._miss(checks, conf_l, conf_r, blind)
        fresh = self.left is None or self.right is None or self.needs_blind_search
        # A line seen again after being guessed snaps to the measurement.
        snap_l = fresh or (ok_l and self.left_guessed > 0)
        snap_r = fresh or (ok_r and self.right_guessed > 0)
        self.left = meas_l.copy() if snap_l else self._smooth(self.left, meas_l, conf_l if ok_l else 0.5 * conf_r)
        self.right = meas_r.copy() if snap_r else self._smooth(self.right, meas_r, conf_r if ok_r else 0.5 * conf_l)
        self.misses = 0
        self.left_guessed = 0 if ok_l else self.left_guessed + 1
        self.right_guessed = 0 if ok_r else self.right_guessed + 1
        self.stats["tracked"] += 1
        if blind:
            self.stats["redetect"] += 1
        return TrackedLane(self.left.copy(), self.right.copy(), ok_l, ok_r, not ok_l, not ok_r,
                           conf_l, conf_r, REDETECT if blind else TRACKING, 0, tuple(checks))

    def implied_lane(self, left: np.ndarray | None, right: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Both lines from one or two metre fits: a missing line is the other one shifted by the
        tracked lane width (the default width before any is tracked)."""
        width = self.width_m if self.width_m is not None else self.default_width_m
        if left is None and right is None:
            raise ValueError("implied_lane needs at least one line")
        # Across the road, at the car, the other line is ``width`` away along the normal of the
        # seen line: sqrt(1 + slope^2) times that in x when the car is not parallel to the lane.
        if left is None:
            left = right - np.array([0.0, 0.0, width * float(np.hypot(1.0, right[1]))])
        if right is None:
            right = left + np.array([0.0, 0.0, width * float(np.hypot(1.0, left[1]))])
        return left, right

    def _smooth(self, old: np.ndarray, new: np.ndarray, conf: float) -> np.ndarray:
        # Exponential smoothing weighted by confidence.  The gain rises with the size of the
        # change relative to the jump limit, so a sharp bend is followed without lag while
        # small wobble is damped.
        base = self.cfg.smoothing
        far_move = abs(_x_at(new, self.lookahead_m) - _x_at(old, self.lookahead_m))
        change = far_move / max(self.cfg.max_offset_jump_m, 1e-6)
        gain = float(np.clip((1 - base) * (0.4 + 0.6 * conf) + 0.3 * min(change, 1.0), 0.05, 1.0))
        return old + gain * (new - old)

    def _confirmed(self, left_m: np.ndarray, right_m: np.ndarray, pair: bool) -> bool:
        """Count sightings of the same candidate lane (a gap of up to ``start_frames`` frames is
        allowed between them); a pair needs two sightings, one line ``start_frames``."""
        prev = self.candidate
        same = prev is not None and self._close(left_m, prev[0]) and self._close(right_m, prev[1])
        count = prev[2] + 1 if same else 1
        self.candidate = (left_m.copy(), right_m.copy(), count, 0)
        return count >= (2 if pair else self.cfg.start_frames)

    def _miss(self, checks: list[str], conf_l: float, conf_r: float, blind: bool,
              keep_candidate: bool = False) -> TrackedLane:
        self.misses += 1
        self.since_both += 1
        self.stats["rejected"] += 1
        if not keep_candidate and self.candidate is not None:
            lm, rm, count, age = self.candidate
            self.candidate = (lm, rm, count, age + 1) if age < self.cfg.start_frames else None
        if self.left is None or self.right is None or self.misses > self.cfg.lost_after:
            candidate, had_lane = self.candidate, self.left is not None or self.was_lost
            self.reset()
            self.candidate, self.was_lost = candidate, had_lane
            self.misses = self.cfg.lost_after + 1
            self.stats["lost"] += 1
            return TrackedLane(None, None, False, False, False, False, conf_l, conf_r, LOST, self.misses, tuple(checks))
        if blind:
            self.stats["redetect"] += 1
        return TrackedLane(self.left.copy(), self.right.copy(), False, False, True, True, conf_l, conf_r,
                           REDETECT if blind else TRACKING, self.misses, tuple(checks))
