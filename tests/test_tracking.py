"""Tracking logic on synthetic sequences of metre fits, through the pure transition ``step``."""

from __future__ import annotations

from dataclasses import replace
from fractions import Fraction

import numpy as np
import pytest

from lanefinder.checks import check_parallel
from lanefinder.config import BirdseyeConfig, Config, TrackingConfig
from lanefinder.geometry import Scale
from lanefinder.lane import LOST, REDETECT, TRACKING, Line
from lanefinder.measure import Measurer
from lanefinder.tracking import Rules, Track, Verdict, at_fps, implied_lane, step

LEFT = np.array([2e-4, 0.01, -1.8])
RIGHT = np.array([2e-4, 0.01, 1.9])
RULES = Rules(TrackingConfig(), lookahead_m=29.6, default_width_m=3.7, scale=Scale(3.7 / 150, 0.0987, 300, 200.0))


def meas(c, conf: float = 0.9, range_m: float = float("nan")) -> Line:
    return Line(fit_px=None, fit_m=np.asarray(c, float), confidence=conf, found=True, inferred=False,
                range_m=range_m)


class Tracker:
    """Threads the track through ``step`` frame by frame, as the pipeline does."""

    def __init__(self, rules: Rules = RULES) -> None:
        self.rules = rules
        self.cfg = rules.cfg
        self.track = Track()

    def update(self, left: Line | None, right: Line | None, blind: bool) -> Verdict:
        self.track, verdict = step(self.track, (left, right), blind, self.rules)
        return verdict

    @property
    def needs_blind_search(self) -> bool:
        return self.track.needs_blind_search(self.cfg)

    def reset(self) -> None:
        self.track = Track()

    def hold_until_blind(self) -> None:
        """Start afresh with the lane LEFT/RIGHT, then miss it until the next frame is searched blind."""
        self.reset()
        self.update(meas(LEFT), meas(RIGHT), blind=True)
        for _ in range(self.cfg.max_misses):
            self.update(None, None, blind=False)
        assert self.needs_blind_search


@pytest.fixture
def tracker() -> Tracker:
    return Tracker()


def test_steady_lane_is_tracked(tracker):
    first = tracker.update(meas(LEFT), meas(RIGHT), blind=True)
    assert first.state == REDETECT and first.left.found and first.right.found
    assert not tracker.needs_blind_search
    for _ in range(10):
        t = tracker.update(meas(LEFT), meas(RIGHT), blind=False)
    assert t.state == TRACKING and t.misses == 0
    np.testing.assert_allclose(t.left.fit_m, LEFT, atol=1e-9)


def test_an_outlier_frame_is_rejected_and_the_lane_held(tracker):
    tracker.update(meas(LEFT), meas(RIGHT), blind=True)
    bad_left = LEFT + np.array([0, 0, 1.2])  # a 1.2 m jump of the left line, lane width 2.5 m
    t = tracker.update(meas(bad_left), meas(RIGHT), blind=False)
    assert not t.left.found and t.right.found
    assert "left-jump" in t.reasons
    # The left line is inferred from the right one and the tracked width, not from the outlier.
    assert t.left.inferred
    assert t.left.fit_m[2] == pytest.approx(-1.8, abs=0.05)


def test_after_n_misses_the_lane_is_found_again_blind(tracker):
    cfg = tracker.cfg
    tracker.update(meas(LEFT), meas(RIGHT), blind=True)
    for i in range(cfg.max_misses):
        t = tracker.update(None, None, blind=False)
        assert t.misses == i + 1 and t.has_lane  # held
    assert tracker.needs_blind_search
    # A lane 0.7 m away (beyond the 0.4 m jump limit) is accepted blind: no jump check once the
    # track is stale.
    shifted_l, shifted_r = LEFT + np.array([0, 0, 0.7]), RIGHT + np.array([0, 0, 0.7])
    t = tracker.update(meas(shifted_l), meas(shifted_r), blind=True)
    assert t.state == REDETECT and t.left.found and t.right.found
    assert t.left.fit_m[2] == pytest.approx(-1.1)


def test_one_line_lost_is_inferred_from_the_other_and_the_width(tracker):
    for _ in range(5):
        tracker.update(meas(LEFT), meas(RIGHT), blind=False)
    t = tracker.update(meas(LEFT), None, blind=False)
    assert t.left.found and not t.right.found and t.right.inferred
    assert t.right.fit_m[2] - t.left.fit_m[2] == pytest.approx(3.7, abs=0.05)
    np.testing.assert_allclose(t.right.fit_m[:2], LEFT[:2], atol=1e-6)


def test_nothing_for_long_says_lost(tracker):
    tracker.update(meas(LEFT), meas(RIGHT), blind=True)
    states = [tracker.update(None, None, blind=tracker.needs_blind_search).state for _ in range(40)]
    assert states[-1] == LOST
    # A straight lane is held for hold_gentle_frames (1 s at 25 fps), then lost.
    hold = tracker.cfg.hold_gentle_frames
    assert LOST not in states[:hold] and states[hold] == LOST


def test_a_tight_bend_is_held_for_less_time(tracker):
    bend = np.array([1 / (2 * 60.0), 0.0, 0.0])  # radius 60 m: its bend may change within a second
    tracker.update(meas(LEFT + bend), meas(RIGHT + bend), blind=True)
    states = [tracker.update(None, None, blind=tracker.needs_blind_search).state for _ in range(40)]
    lost_after = tracker.cfg.lost_after
    assert lost_after < tracker.cfg.hold_gentle_frames
    assert LOST not in states[:lost_after] and states[lost_after] == LOST


def test_implausible_pairs_are_rejected(tracker):
    # Too narrow: 1.5 m.
    t = tracker.update(meas(LEFT), meas(LEFT + np.array([0, 0, 1.5])), blind=True)
    assert "width" in t.reasons and not (t.left.found and t.right.found)
    tracker.reset()
    # Not parallel: the right line swings 2 m out at 30 m.
    t = tracker.update(meas(LEFT), meas(RIGHT + np.array([0.0025, 0, 0])), blind=True)
    assert {"parallel", "curvature"} & set(t.reasons)


def test_low_confidence_lines_are_not_used(tracker):
    tracker.update(meas(LEFT), meas(RIGHT), blind=True)
    t = tracker.update(meas(LEFT, 0.1), meas(RIGHT, 0.9), blind=False)
    assert not t.left.found and t.right.found and "left-confidence" in t.reasons


def test_a_lane_is_started_from_one_line_only_when_it_is_confident(tracker):
    t = tracker.update(meas(LEFT, 0.4), None, blind=True)
    assert t.state == LOST and "one-line-start" in t.reasons
    t = tracker.update(meas(LEFT, 0.9), None, blind=True)
    assert t.state == REDETECT and t.left.found and t.right.inferred
    # The other line is 3.7 m away across the lane (normal to it), a little more in x.
    assert t.right.fit_m[2] - t.left.fit_m[2] == pytest.approx(3.7 * np.hypot(1.0, LEFT[1]))


def test_a_lane_does_not_start_bending_tighter_than_a_road(tracker):
    # Glare leaving a metre of paint beside the car bent a lone line's fit to a radius of 18 m
    # (synthetic `glare` seed 8); the lane it started refused the right lines as jumps.
    tight = np.array([1 / 30, 0.0, -1.8])  # radius 15 m
    t = tracker.update(meas(tight), None, blind=True)
    assert t.state == LOST and "start-bend" in t.reasons
    t = tracker.update(meas(tight), meas(tight + np.array([0.0, 0.0, 3.7])), blind=True)
    assert t.state == LOST and "start-bend" in t.reasons  # a pair as well
    t = tracker.update(meas(np.array([1 / 60, 0.0, -1.8])), None, blind=True)  # 30 m: a hairpin
    assert t.state == REDETECT and "start-bend" not in t.reasons


def test_a_lane_that_bends_tight_is_kept_and_re_placed():
    # A hairpin's lines, their shapes shared (as the fit's pull makes them), looked at 10 m ahead.
    tracker = Tracker(replace(RULES, lookahead_m=10.0))

    def lane(radius_m: float) -> tuple[Line, Line]:
        return meas(np.array([1 / (2 * radius_m), 0.0, -1.85])), meas(np.array([1 / (2 * radius_m), 0.0, 1.85]))

    # Tracked from 30 m down to 16 m frame by frame: the limit is for starts only.
    for i, radius_m in enumerate(np.linspace(30, 16, 57)):
        t = tracker.update(*lane(radius_m), blind=i == 0)
        assert t.left.found and t.right.found and "start-bend" not in t.reasons, (radius_m, t.reasons)
    # Searched blind after misses, lines as tight as the held lane re-place it.
    for _ in range(tracker.cfg.max_misses):
        tracker.update(None, None, blind=False)
    assert tracker.needs_blind_search
    t = tracker.update(*lane(16.0), blind=True)
    assert t.left.found and t.right.found and "start-bend" not in t.reasons, t.reasons
    # The same lines with no lane held do not start one.
    t = Tracker(tracker.rules).update(*lane(16.0), blind=True)
    assert t.state == LOST and "start-bend" in t.reasons


def test_the_start_bend_limit_can_be_turned_off():
    rules = replace(RULES, cfg=TrackingConfig(min_start_radius_m=0))
    t = Tracker(rules).update(meas(np.array([1 / 30, 0.0, -1.8])), None, blind=True)
    assert t.state == REDETECT


def test_one_line_alone_holds_the_lane_only_so_long(tracker):
    tracker.update(meas(LEFT), meas(RIGHT), blind=True)
    n = tracker.cfg.max_one_line_frames
    states = [tracker.update(meas(LEFT), None, blind=tracker.needs_blind_search) for _ in range(n + 40)]
    assert all(s.left.found and s.right.inferred for s in states[:n])
    assert "one-line-too-long" in states[n].reasons
    # Held for hold_gentle_frames more frames (a straight lane), then "lost" (until a confident start).
    assert states[n + tracker.cfg.hold_gentle_frames].state == LOST


def test_smoothing_damps_wobble_but_follows_a_bend(tracker):
    rng = np.random.default_rng(0)
    tracker.update(meas(LEFT), meas(RIGHT), blind=True)
    # Wobble: +-3 cm noise on the position is damped.
    shift = [np.array([0, 0, n]) for n in rng.normal(0, 0.03, 50)]
    out = [tracker.update(meas(LEFT + d), meas(RIGHT + d), blind=False).left.fit_m[2] for d in shift]
    assert np.std(out) < 0.03 * 0.8
    # A bend tightening over 10 frames (25 fps, 0.4 s) is followed with little lag.
    for k in np.linspace(2e-4, 4e-3, 10):
        t = tracker.update(meas([k, 0.01, -1.8]), meas([k, 0.01, 1.9]), blind=False)
    assert t.left.fit_m[0] == pytest.approx(4e-3, rel=0.25)


def test_the_inferred_line_is_a_lane_width_away_across_a_slanted_lane(tracker):
    slanted = np.array([0.0, 0.5, -1.8])  # the car heads 26.6 degrees off the lane
    left, right = implied_lane(slanted, None, 3.7)
    assert right[2] - left[2] == pytest.approx(3.7 * np.hypot(1.0, 0.5))
    assert right[1] == left[1] and right[0] == left[0]


def _lose(tracker: Tracker) -> None:
    tracker.update(meas(LEFT), meas(RIGHT), blind=True)
    for _ in range(tracker.cfg.hold_gentle_frames + 1):
        t = tracker.update(None, None, blind=True)
    assert t.state == LOST and tracker.track.was_lost


def test_after_the_lane_was_lost_a_weak_start_must_be_confirmed(tracker):
    _lose(tracker)
    # One line, confident enough to start, must be seen start_frames (3) times in the same place.
    for i in range(tracker.cfg.start_frames - 1):
        t = tracker.update(meas(LEFT, 0.5), None, blind=True)
        assert t.state == LOST and "confirming" in t.reasons, i
    t = tracker.update(meas(LEFT, 0.5), None, blind=True)
    assert t.state == REDETECT and t.left.found and t.right.inferred


def test_without_a_lane_a_weak_line_alone_starts_it_once_seen_in_one_place_long_enough(tracker):
    cfg = tracker.cfg
    n, weak = cfg.weak_start_frames, cfg.weak_start_confidence + 0.03
    assert weak < cfg.min_start_confidence
    # A marking seen only near the car (8 m, glare): its fit's far end wanders, its near part does not.
    wander = [np.array([s * 2e-3, 0.0, 0.0]) for s in (1, -1) * n]
    for i in range(n - 1):
        t = tracker.update(meas(LEFT + wander[i], weak, range_m=8.0), None, blind=True)
        assert t.state == LOST and "one-line-start" in t.reasons, i
    t = tracker.update(meas(LEFT + wander[n - 1], weak, range_m=8.0), None, blind=True)
    assert t.state == REDETECT and t.left.found and t.right.inferred and "one-line-start" not in t.reasons
    # Moving 0.6 m a frame near the car: never.
    tracker.reset()
    for i in range(3 * n):
        t = tracker.update(meas(LEFT + [0, 0, 0.6 * i], weak, range_m=8.0), None, blind=True)
        assert t.state == LOST, i
    # Weaker than weak_start_confidence (above min_confidence): never.
    stricter = Tracker(replace(RULES, cfg=cfg.model_copy(update={"weak_start_confidence": 0.35})))
    for i in range(3 * n):
        t = stricter.update(meas(LEFT, 0.33, range_m=8.0), None, blind=True)
        assert t.state == LOST and "one-line-start" in t.reasons, i


def test_a_weak_line_alone_never_starts_sooner_than_a_confident_one_nor_displaces_its_candidate(tracker):
    cfg = tracker.cfg
    _lose(tracker)
    # A confident lone line waits on start_frames (3) sightings; weak lines elsewhere in between
    # are plain misses and do not wipe its count.
    for i in range(cfg.start_frames - 1):
        assert tracker.update(meas(LEFT, 0.5), None, blind=True).state == LOST
        t = tracker.update(meas(LEFT + [0, 0, 1.0], 0.33), None, blind=True)
        assert t.state == LOST and "one-line-start" in t.reasons, i
    t = tracker.update(meas(LEFT, 0.5), None, blind=True)
    assert t.state == REDETECT and t.left.found
    # weak_start_frames = 1 still needs start_frames sightings, at 25 fps and at 5 fps.
    one = Tracker(replace(RULES, cfg=cfg.model_copy(update={"weak_start_frames": 1})))
    states = [one.update(meas(LEFT, 0.33), None, blind=True).state for _ in range(cfg.start_frames)]
    assert states == [LOST] * (cfg.start_frames - 1) + [REDETECT]
    assert at_fps(cfg.model_copy(update={"weak_start_frames": 5}), 5.0).weak_start_frames == 2
    assert at_fps(cfg.model_copy(update={"weak_start_frames": 0}), 5.0).weak_start_frames == 0


def test_a_candidate_pair_is_compared_as_far_as_its_lines_reach(tracker):
    _lose(tracker)
    # A weak pair seen to 8 m whose fits swing by 3.6 m at the view's end (29.6 m): the same
    # lane near the car, so its second sighting starts it.
    for i, bend in enumerate((2e-3, -2e-3)):
        swing = np.array([bend, 0.0, 0.0])
        t = tracker.update(meas(LEFT + swing, 0.35, range_m=8.0), meas(RIGHT + swing, 0.35, range_m=8.0), blind=True)
        assert t.state == (LOST if i == 0 else REDETECT), i


def test_a_candidate_that_moves_is_not_confirmed(tracker):
    _lose(tracker)
    for shift in (0.0, 1.0, 0.0, 1.0):
        t = tracker.update(meas(LEFT + [0, 0, shift], 0.5), None, blind=True)
        assert t.state == LOST
    # A weak pair needs two sightings; a confident pair starts at once.
    t = tracker.update(meas(LEFT, 0.35), meas(RIGHT, 0.35), blind=True)
    assert t.state == LOST and "confirming" in t.reasons
    t = tracker.update(meas(LEFT, 0.35), meas(RIGHT, 0.35), blind=True)
    assert t.state == REDETECT and t.left.found and t.right.found
    tracker.reset()
    assert not tracker.track.was_lost
    t = tracker.update(meas(LEFT, 0.35), meas(RIGHT, 0.35), blind=True)
    assert t.state == REDETECT, "at the start of a clip the first plausible lane is taken"


def test_a_guessed_line_comes_back_elsewhere_only_beside_an_anchored_line(tracker):
    tracker.update(meas(LEFT), meas(RIGHT), blind=True)
    for _ in range(2):  # the right line is only guessed for two frames
        tracker.update(meas(LEFT), None, blind=False)
    moved = RIGHT + np.array([0, 0, -0.6])  # and then measured 0.6 m from the guess
    t = tracker.update(None, meas(moved), blind=False)
    assert not t.right.found and "right-jump" in t.reasons, "a lone line far from the track"
    t = tracker.update(meas(LEFT), meas(moved), blind=False)
    assert t.right.found and t.left.found, "beside the left line, where the track expects it"


def test_re_detecting_after_misses_a_weak_line_alone_does_not_move_the_lane(tracker):
    cfg = tracker.cfg
    tracker.hold_until_blind()
    # 0.6 m away (beyond the jump limit), weak, alone: no jump limit holds while re-detecting,
    # so it must not be taken.
    far = LEFT + np.array([0, 0, -0.6])
    t = tracker.update(meas(far, conf=cfg.min_start_confidence - 0.05), None, blind=True)
    assert not t.left.found and "one-line-start" in t.reasons
    assert t.has_lane and t.left.fit_m[2] == pytest.approx(LEFT[2])  # still the held lane
    # A confident line alone does re-place the lane.
    t = tracker.update(meas(far, conf=0.9), None, blind=True)
    assert t.left.found and t.left.fit_m[2] == pytest.approx(far[2])


def test_re_detecting_a_held_lane_a_weak_pair_elsewhere_does_not_replace_it(tracker):
    cfg = tracker.cfg
    tracker.hold_until_blind()
    # A pair beyond the jump limit to the left (glare edges), one line weaker than a start needs: a miss,
    # seen on every frame, until the held lane is lost; then it starts the lane (seen before).
    shift = np.array([0, 0, -1.5 * cfg.max_offset_jump_m])
    weak = (cfg.min_confidence + cfg.min_start_confidence) / 2
    held = 0
    while tracker.track.has_lane:
        t = tracker.update(meas(LEFT + shift, weak), meas(RIGHT + shift, 0.9), blind=True)
        if tracker.track.has_lane:
            held += 1
            assert "weak-pair" in t.reasons and not t.left.found and not t.right.found
            assert t.left.fit_m[2] == pytest.approx(LEFT[2])  # still the held lane
        assert held < 100
    assert t.state == LOST
    t = tracker.update(meas(LEFT + shift, weak), meas(RIGHT + shift, 0.9), blind=True)
    assert t.state == REDETECT and t.left.found and t.left.fit_m[2] == pytest.approx(LEFT[2] + shift[2])
    # The same weak pair where the held lane is, or a pair elsewhere both of whose lines are sure
    # enough to start a lane (exactly at the threshold too), is taken at once.
    for left, right, conf in ((LEFT, RIGHT, weak), (LEFT + shift, RIGHT + shift, 0.9),
                              (LEFT + shift, RIGHT + shift, cfg.min_start_confidence)):
        tracker.hold_until_blind()
        t = tracker.update(meas(left, conf), meas(right, conf), blind=True)
        assert t.left.found and t.right.found and "weak-pair" not in t.reasons
        assert t.left.fit_m[2] == pytest.approx(left[2])
    # One line of a weak pair beyond the jump limit is enough to be refused.
    tracker.hold_until_blind()
    t = tracker.update(meas(LEFT + shift, weak), meas(RIGHT, 0.9), blind=True)
    assert "weak-pair" in t.reasons and t.left.fit_m[2] == pytest.approx(LEFT[2])


def test_a_lane_seen_far_ahead_ages_slower_while_held_and_is_still_lost(tracker):
    from lanefinder.tracking import seen_far

    cfg = tracker.cfg
    tracker.update(meas(LEFT), meas(RIGHT), blind=True)
    # Nothing in the view, both lines followed beyond it on every frame: searched blind after
    # max_misses, and held past the gentle hold, but lost within three times it.
    frames = 0
    while True:
        t = tracker.update(None, None, blind=tracker.needs_blind_search)
        tracker.track = seen_far(tracker.track, cfg)
        frames += 1
        if t.state == LOST:
            break
        assert frames < 4 * cfg.hold_gentle_frames
        if frames > cfg.max_misses + 1:
            assert tracker.needs_blind_search  # a pair found blind, sure enough, may replace it
    assert cfg.hold_gentle_frames + 1 < frames <= 3 * cfg.hold_gentle_frames + 2
    # Not before the blind search, not in a tight bend, not without a lane.
    held = Track(fits_m=(LEFT.copy(), RIGHT.copy()), misses=2)
    assert seen_far(held, cfg) is held
    hairpin = Track(fits_m=(np.array([0.02, 0.0, -1.8]), np.array([0.02, 0.0, 1.9])), misses=cfg.max_misses + 2)
    assert seen_far(hairpin, cfg) is hairpin
    assert seen_far(replace(held, misses=cfg.max_misses + 2), cfg).misses == cfg.max_misses + 1
    empty = Track()
    assert seen_far(empty, cfg) is empty
    # With no gentle radius (nothing is held longer), nothing is taken back either.
    flat = replace(held, misses=cfg.max_misses + 2)
    assert seen_far(flat, cfg.model_copy(update={"hold_gentle_radius_m": 0.0})) is flat


def test_counts_and_gains_follow_the_frame_rate():
    from lanefinder.config import TrackingConfig
    from lanefinder.tracking import at_fps

    cfg = TrackingConfig()
    assert at_fps(cfg, 25.0) is cfg and at_fps(cfg, 25.4) is cfg  # the reference rate, or within 2%
    assert at_fps(cfg, float("nan")) is cfg and at_fps(cfg, 0.0) is cfg
    fast = at_fps(cfg, 50.0)
    assert (fast.lost_after, fast.hold_gentle_frames, fast.max_misses) == (24, 50, 10)
    # the hold at the car: the same move per second, over the same time
    assert (fast.start_free_m, fast.start_both_frames) == (pytest.approx(0.05), 20)
    assert fast.width_renew_frames == 10
    assert at_fps(cfg, 5.0).width_renew_frames == 2  # never renewed by one refusal
    assert at_fps(TrackingConfig(width_renew_frames=0), 50.0).width_renew_frames == 0  # off stays off
    # A per-frame gain at 50 fps compounds over two frames to the gain of one frame at 25 fps.
    assert 1 - (1 - fast.width_smoothing) ** 2 == pytest.approx(cfg.width_smoothing)
    assert fast.smoothing**2 == pytest.approx(cfg.smoothing)
    assert at_fps(fast, 50.0) is fast  # its reference is now 50 fps: not scaled twice
    slow = at_fps(cfg, 12.5)
    assert (slow.lost_after, slow.start_frames) == (6, 2)
    # At 10 fps a lone line still needs two sightings to start a lane after a lost one.
    assert at_fps(cfg, 10.0).start_frames == 2
    assert at_fps(cfg, 1000.0) is cfg and at_fps(cfg, 1.0) is cfg  # misreported rates: not scaled
    assert isinstance(at_fps(cfg, Fraction(30000, 1001)).reference_fps, float)


def test_at_a_blind_start_a_refused_pairs_sure_line_keeps_its_say_against_a_weak_one(tracker):
    # A sure left line and a weak right one 6.3 m away (the width check refuses the pair): the
    # weak line could not start a lane alone, so the sure one starts it at its own confidence,
    # the right line inferred (synthetic sharp curve, fixed look: its first two frames).
    v = tracker.update(meas(LEFT, 0.9), meas(np.array([0.0, 0.0, 4.5]), 0.35), blind=True)
    assert "width" in v.reasons and v.left.found and v.right.inferred
    assert v.left.confidence == pytest.approx(0.9)
    # A right line sure enough to start a lane alone (0.5) casts doubt on the left: both halve,
    # and the left alone (0.4) is too weak to start one.
    tracker.reset()
    v = tracker.update(meas(LEFT, 0.8), meas(np.array([0.0, 0.0, 4.5]), 0.5), blind=True)
    assert v.left.confidence == pytest.approx(0.4) and not v.left.found and "one-line-start" in v.reasons


def _seen_from(c, start_m: float) -> Line:
    return replace(meas(c), start_m=start_m)


@pytest.mark.parametrize(("start_m", "moved"), [(2.0, None), (10.0, 0.1)])
def test_a_line_seen_only_from_ahead_moves_the_lane_at_the_car_by_little(tracker, start_m, moved):
    # Both lines measured 0.3 m to the right: seen from 2 m ahead, the lane follows as smoothing allows;
    # seen only from 10 m ahead (a dash gap beside the car), at most tracking.start_free_m a frame.
    for _ in range(3):
        tracker.update(meas(LEFT), meas(RIGHT), blind=False)
    shift = np.array([0.0, 0.0, 0.3])
    free = _seen_from(np.add(LEFT, shift), start_m), _seen_from(np.add(RIGHT, shift), start_m)
    t = tracker.update(*free, blind=False)
    step_m = t.left.fit_m[2] - LEFT[2]
    if moved is None:
        assert step_m > 0.15
    else:
        assert 0 < step_m <= moved + 1e-9 and t.right.fit_m[2] - RIGHT[2] <= moved + 1e-9
        # the heading and bend ahead are taken as measured (smoothed); only the offset at the car is held
        np.testing.assert_allclose(t.left.fit_m[:2], LEFT[:2], atol=1e-9)


def test_lines_moving_apart_or_seen_one_at_a_time_are_not_held(tracker):
    for _ in range(3):
        tracker.update(meas(LEFT), meas(RIGHT), blind=False)
    # apart: the lane widens at the car (or the car pitches on a bump): followed as smoothing allows
    t = tracker.update(_seen_from(np.add(LEFT, [0, 0, -0.3]), 10.0), _seen_from(np.add(RIGHT, [0, 0, 0.3]), 10.0),
                       blind=False)
    assert t.left.fit_m[2] - LEFT[2] < -0.12 and t.right.fit_m[2] - RIGHT[2] > 0.12
    # one line at a time for longer than tracking.start_both_frames: the lane goes by the line it sees
    tracker.reset()
    for _ in range(3):
        tracker.update(meas(LEFT), meas(RIGHT), blind=False)
    for _ in range(TrackingConfig().start_both_frames + 1):
        tracker.update(meas(LEFT), None, blind=False)
    t = tracker.update(_seen_from(np.add(LEFT, [0, 0, 0.3]), 10.0), None, blind=False)
    assert t.left.fit_m[2] - LEFT[2] > 0.12


def test_the_parallel_limit_is_looser_only_with_the_configs_own_set_up():
    # On a crest the flat-road view narrows a true lane ahead: with the camera's own set-up the
    # parallel check allows tracking.max_parallel_diff_own_setup_m; on the default set-up (a
    # guess, as for an unknown mount or a self-calibrating run) it keeps max_parallel_diff_m.
    scale = Scale(3.7 / 150, 0.0985, 300, 200.0)
    default = Config()
    own = default.model_copy(update={"birdseye": BirdseyeConfig(src=((580.0, 462.0), (704.0, 462.0),
                                                                     (1034.0, 675.0), (280.5, 675.0)))})
    assert Measurer.build(default, scale).rules.cfg.max_parallel_diff_m == default.tracking.max_parallel_diff_m == 0.9
    assert Measurer.build(own, scale).rules.cfg.max_parallel_diff_m == own.tracking.max_parallel_diff_own_setup_m == 1.3
    # A pair 1.1 m narrower at the view's far end than at the car: refused on the default, kept on its own.
    left, right = np.array([0.0, 0.55 / 30, -1.8]), np.array([0.0, -0.55 / 30, 1.8])
    assert check_parallel(left, right, 30.0, Measurer.build(default, scale).rules.cfg) == "parallel"
    assert check_parallel(left, right, 30.0, Measurer.build(own, scale).rules.cfg) is None


def _started_on_a_wrong_width(tracker: Tracker) -> None:
    """A lane started from the left line alone, then given the wrong partner 4.5 m away (no width to hold it to)."""
    tracker.update(meas(LEFT), None, blind=True)
    assert tracker.track.width_m is None
    wrong = LEFT + np.array([0, 0, 4.5])
    t = tracker.update(meas(LEFT), meas(wrong), blind=False)
    assert t.right.found and tracker.track.width_m == pytest.approx(4.5, abs=0.01)
    tracker.update(meas(LEFT), None, blind=False)  # the right line is a guess again: it may come back elsewhere


def test_a_wrong_tracked_width_is_renewed_by_a_partner_refused_again_and_again_in_one_place(tracker):
    # Synthetic worn paint (tuning seed 1): the lane held a width read once off a wrong line, and
    # refused the true right line for the change of width on its last 23 frames (accuracy 0.62 -> 0.77).
    _started_on_a_wrong_width(tracker)
    k = tracker.cfg.width_renew_frames
    for i in range(k - 1):
        t = tracker.update(meas(LEFT), meas(RIGHT + np.array([0, 0, 0.05 * (i % 2)])), blind=False)
        assert not t.right.found and t.reasons == ("width-change",)
        tracker.update(meas(LEFT), None, blind=False)  # a frame without a pair neither counts nor breaks the row
    t = tracker.update(meas(LEFT), meas(RIGHT), blind=False)
    assert t.left.found and t.right.found and "width-change" not in t.reasons
    assert tracker.track.width_m == pytest.approx(3.7, abs=0.05) and tracker.track.width_doubt[0] == 0
    assert tracker.track.width_pairs == 1  # the renewing pair: a width made afresh


def test_a_pair_refused_for_more_than_the_change_of_width_breaks_the_row(tracker):
    _started_on_a_wrong_width(tracker)
    k = tracker.cfg.width_renew_frames
    for _ in range(k - 1):
        tracker.update(meas(LEFT), meas(RIGHT), blind=False)
    bent = RIGHT + np.array([3e-3, 0, 0])  # refused for its bend too: not a width the track doubts
    t = tracker.update(meas(LEFT), meas(bent), blind=False)
    assert "width-change" in t.reasons and "curvature" in t.reasons and tracker.track.width_doubt[0] == 0
    t = tracker.update(meas(LEFT), meas(RIGHT), blind=False)
    assert not t.right.found and tracker.track.width_doubt[0] == 1, "a new row"


def test_a_tracked_width_is_not_renewed_by_partners_that_wander_or_by_a_few_against_many():
    wide = LEFT + np.array([0, 0, 4.5])
    for cfg, before, partners in (
            (TrackingConfig(), 0, [RIGHT + np.array([0, 0, d]) for d in (0.0, -0.4) * 5]),  # 3.7 and 3.3 m by turns
            (TrackingConfig(width_renew_frames=0), 0, [RIGHT] * 10),  # renewal off
            # a width made from ten pairs: ten refusals in a row do not overturn it (the eleventh would)
            (TrackingConfig(), 9, [RIGHT] * 10)):
        tracker = Tracker(replace(RULES, cfg=cfg))
        _started_on_a_wrong_width(tracker)
        for _ in range(before):
            tracker.update(meas(LEFT), meas(wide), blind=False)
        if before:
            tracker.update(meas(LEFT), None, blind=False)
        for right in partners:
            t = tracker.update(meas(LEFT), meas(right), blind=False)
            assert not t.right.found and "width-change" in t.reasons
        assert tracker.track.width_m == pytest.approx(4.5, abs=0.01)


def test_a_weak_first_pair_does_not_make_the_lanes_width(tracker):
    # Synthetic worn paint (tuning seed 1): a first partner 0.32 sure read a lane 3.5 m wide as
    # 4.5 m, and the right line inferred from the left one stayed 1 m out for 20 frames.
    tracker.update(meas(LEFT), None, blind=True)
    weak = tracker.cfg.min_confidence + 0.05
    assert weak < tracker.cfg.min_start_confidence
    t = tracker.update(meas(LEFT), meas(LEFT + np.array([0, 0, 4.5]), weak), blind=False)
    assert t.right.found  # the pair is taken as it is this frame ...
    assert tracker.track.width_m == pytest.approx(3.7) and tracker.track.width_pairs == 0  # ... not its width
    for _ in range(20):
        t = tracker.update(meas(LEFT), None, blind=False)
    assert t.right.inferred and t.right.fit_m[2] - t.left.fit_m[2] == pytest.approx(3.7, abs=0.05)
    # Later pairs move the width from the default a little at a time.
    tracker.update(meas(LEFT), meas(LEFT + np.array([0, 0, 3.5])), blind=False)
    assert tracker.track.width_m == pytest.approx(3.7 - tracker.cfg.width_smoothing * 0.2, abs=1e-3)
    assert tracker.track.width_pairs == 1


def test_a_sure_first_pair_or_the_setting_off_makes_the_width_as_measured():
    weak = TrackingConfig().min_confidence + 0.05
    for cfg, conf in ((TrackingConfig(), 0.9), (TrackingConfig(sure_first_width=False), weak)):
        tracker = Tracker(replace(RULES, cfg=cfg))
        tracker.update(meas(LEFT), None, blind=True)
        tracker.update(meas(LEFT), meas(LEFT + np.array([0, 0, 4.5]), conf), blind=False)
        assert tracker.track.width_m == pytest.approx(4.5, abs=0.01) and tracker.track.width_pairs == 1


@pytest.mark.parametrize("weak_side", [0, 1])
def test_a_weak_pair_on_a_clips_first_frame_leaves_the_default_width(weak_side):
    tracker = Tracker(replace(RULES, default_width_m=3.5))
    conf = [0.9, 0.9]
    conf[weak_side] = tracker.cfg.min_confidence + 0.05
    t = tracker.update(meas(LEFT, conf[0]), meas(LEFT + np.array([0, 0, 4.5]), conf[1]), blind=True)
    assert t.left.found and t.right.found
    assert tracker.track.width_m == pytest.approx(3.5) and tracker.track.width_pairs == 0


def test_a_weak_pair_confirmed_after_a_lost_lane_makes_its_width(tracker):
    # Seen twice in one place before it is shown: evidence enough to make the width too.
    _lose(tracker)
    weak = tracker.cfg.min_confidence + 0.05
    wide = LEFT + np.array([0, 0, 3.3])
    t = tracker.update(meas(LEFT, weak), meas(wide, weak), blind=True)
    assert t.state == LOST and "confirming" in t.reasons
    t = tracker.update(meas(LEFT, weak), meas(wide, weak), blind=True)
    assert t.state == REDETECT and t.left.found and t.right.found
    assert tracker.track.width_m == pytest.approx(3.3, abs=0.01) and tracker.track.width_pairs == 1


def test_a_weak_pair_after_a_lane_restarted_from_one_line_does_not_make_its_width(tracker):
    _lose(tracker)
    for _ in range(tracker.cfg.start_frames):
        t = tracker.update(meas(LEFT), None, blind=True)
    assert t.state == REDETECT and tracker.track.was_lost and tracker.track.width_m is None
    weak = tracker.cfg.min_confidence + 0.05
    tracker.update(meas(LEFT, weak), meas(LEFT + np.array([0, 0, 3.3]), weak), blind=False)
    assert tracker.track.width_m == pytest.approx(3.7) and tracker.track.width_pairs == 0
