"""Generalisation on randomised synthetic roads (issue 12): no lag in a curve entry, the lane held on worn paint.

Seeds 3-6 were never used for tuning (tuning used seeds 0-2; `make eval` reports 101-102); the
far-field test uses tuning seeds 0 and 2, as it checks the change tuned on them, and the faint far
paint test tuning seed 4 of ``straight``, on which ``far.faint_contrast_max`` was chosen.
Measured on 100 frames (4 s) at 640x360, each with a look and camera drawn from its seed:
worn seed 3, no frame without a lane, lateral error 6 m ahead p90 0.022 m; curve-entry
(R down to 250 m and back in tree shadow, lateral drift) seeds 3 and 6, p90 0.022 and 0.036 m
(on 2026-11-27: 0.021 and 0.044 m). Curve-entry seed 4 measured 0.119 m, and on 2026-11-27 0.097 m,
0.084 m with ``tracking.start_gap_m``: over the 0.08 m target, it is not among these tests, and the
closing note of issue 12 says so. The wet-night tests use tuning seeds 7 and 9 of the ``night`` scenario,
on which the streak removal (``threshold.streaks``) and its guard beside the car were chosen.
"""

from __future__ import annotations

import pytest

from lanefinder.camera import udacity_camera
from lanefinder.config import load_config
from lanefinder.evaluate import evaluate, read_ground_truth, read_predictions
from lanefinder.synth import write_sequence
from lanefinder.videojob import process_video


def _run(tmp_path, scenario: str, seed: int, frames: int = 100, size: tuple[int, int] = (640, 360),
         streaks: bool = True, streak_side_m: float | None = None, own_road: bool = False,
         far_hold: bool = True, parallel_own_m: float | None = None, bend: bool = True, far_faint: bool = True):
    # 4 s at 640x360 by default (the pipeline works in metres at any size; a quarter of the rendering time).
    folder = tmp_path / f"{scenario}-{seed}"
    if not (folder / "video.mp4").exists():
        camera = udacity_camera().scaled_to(size)
        write_sequence(scenario, frames, folder, seed=seed, camera=camera, randomise=True, road_from_seed=own_road)
    cfg = load_config(folder / "config.toml")
    if not far_hold:
        cfg = cfg.model_copy(update={"far": cfg.far.model_copy(update={"hold": False})})
    if not far_faint:
        cfg = cfg.model_copy(update={"far": cfg.far.model_copy(update={"faint_contrast_max": 255})})
    if parallel_own_m is not None:
        cfg = cfg.model_copy(update={"tracking": cfg.tracking.model_copy(
            update={"max_parallel_diff_own_setup_m": parallel_own_m})})
    if not bend:
        cfg = cfg.model_copy(update={"search": cfg.search.model_copy(update={"bend_max_per_m": 0.0})})
    change = {"enabled": False} if not streaks else {}
    if streak_side_m is not None:
        change["min_side_m"] = streak_side_m
    if change:
        cfg = cfg.model_copy(update={"threshold": cfg.threshold.model_copy(
            update={"streaks": cfg.threshold.streaks.model_copy(update=change)})})
    process_video(folder / "video.mp4", None, cfg, telemetry=folder / "t.jsonl", progress=False)
    return evaluate(read_ground_truth(folder / "gt.jsonl"), read_predictions(folder / "t.jsonl"))


@pytest.mark.slow
def test_worn_paint_keeps_the_lane_while_a_line_is_visible(tmp_path):
    rep = _run(tmp_path, "worn", 3)
    assert rep.no_lane_rate is not None and rep.no_lane_rate <= 0.02
    assert rep.accuracy >= 0.95


@pytest.mark.slow
@pytest.mark.parametrize("seed", [3, 6])
def test_a_curve_entry_in_shade_is_followed_without_lag(tmp_path, seed):
    rep = _run(tmp_path, "curve-entry", seed)
    assert rep.lateral_err_6m_p90 is not None and rep.lateral_err_6m_p90 <= 0.08
    assert rep.no_lane_rate == 0.0


@pytest.mark.slow
def test_worn_paint_on_light_concrete_is_found_by_the_second_look(tmp_path):
    # Tuning seed 4: worn white dashes on light concrete (grey 182), 15-25 levels lighter than the
    # road. Measured at 720p over 50 frames: without the second look for faint paint
    # (faint_contrast_max = 255) no frame had a lane (accuracy 0); with it, accuracy 0.750 and no
    # lane on 18% of the frames (dash gaps near the car).
    after = _run(tmp_path, "worn", 4, frames=50, size=(1280, 720))
    assert after.accuracy >= 0.72 and after.no_lane_rate is not None and after.no_lane_rate <= 0.2


@pytest.mark.slow
def test_worn_paint_with_far_dashes_keeps_the_lane_held(tmp_path):
    # Tuning seed 2 on its own stretch of road, 50 frames at 720p: the ego lines' near dashes are
    # gone for about 20 frames while dashes 40-60 m ahead still show where the held lane runs on.
    # Measured: without far.hold the lane is lost on 20% of the frames (accuracy 0.7525); with it,
    # on none (accuracy 0.8834).
    before = _run(tmp_path, "worn", 2, frames=50, size=(1280, 720), own_road=True, far_hold=False)
    after = _run(tmp_path, "worn", 2, frames=50, size=(1280, 720), own_road=True)
    assert before.no_lane_rate is not None and before.no_lane_rate >= 0.15
    assert after.no_lane_rate is not None and after.no_lane_rate <= 0.02 and after.accuracy >= 0.87


@pytest.mark.slow
@pytest.mark.parametrize(("seed", "band", "least"), [(0, "70+", 0.90), (2, "40-70", 0.95)])
def test_dashed_lines_are_followed_far_ahead_across_missed_dashes(tmp_path, seed, band, least):
    # Tuning seeds 0 and 2 (straight, dashed lines), 30 frames at 720p. Far ahead a dash spans a
    # frame row or two and is often missed: before the far search crossed 40 m of missing paint
    # and held to the near fit's extension (far.anchor_m), seed 0 scored 0.583 at 70+ m and seed 2
    # 0.367 at 40-70 m; measured after, 0.950 and 1.000.
    rep = _run(tmp_path, "straight", seed, frames=30, size=(1280, 720))
    assert rep.band_accuracy[band] is not None and rep.band_accuracy[band] >= least


@pytest.mark.slow
def test_faint_far_dashes_on_light_concrete_are_followed_by_a_second_look(tmp_path):
    # Tuning seed 4 of `straight` on its own stretch of road (light concrete, white dashes 0.10 m
    # wide, a camera pitched 2.3 degrees down), 30 frames at 720p with the sequence's own set-up.
    # Beyond 40 m the dashes are a pixel or two wide and blurred, less than rel_contrast of the
    # road lighter than it: the far strips found none.  The second look at far.faint_contrast_max
    # (and a far part that ends soon, far.faint_short_m) follows them. Measured: at 40-70 m 0.017
    # -> 1.000 (0.617 with the second look only for lines without a far part), 70+ m 0 -> 0.788,
    # accuracy 0.922 -> 0.994.
    before = _run(tmp_path, "straight", 4, frames=30, size=(1280, 720), own_road=True, far_faint=False)
    after = _run(tmp_path, "straight", 4, frames=30, size=(1280, 720), own_road=True)
    assert before.band_accuracy["40-70"] is not None and before.band_accuracy["40-70"] <= 0.05
    assert after.band_accuracy["40-70"] is not None and after.band_accuracy["40-70"] >= 0.97
    assert after.band_accuracy["70+"] is not None and after.band_accuracy["70+"] >= 0.75
    assert before.accuracy <= 0.93 and after.accuracy >= 0.98


@pytest.mark.slow
def test_reflections_on_a_wet_night_are_not_taken_for_lines(tmp_path):
    # Tuning seed 7 of the night scenario: a wet road, street lamps on the right whose
    # reflections run down the frame beside the dashed right line. 30 frames at 640x360,
    # measured: 0.959 with the streaks pointing at the camera taken out, 0.820 without (at 720p
    # 0.960 and 0.452).
    without = _run(tmp_path, "night", 7, frames=30, streaks=False)
    with_ = _run(tmp_path, "night", 7, frames=30)
    assert with_.accuracy >= 0.93 and without.accuracy <= 0.86


@pytest.mark.slow
def test_reflections_of_lamps_far_ahead_are_taken_out_under_the_car(tmp_path):
    # Tuning seed 9 of the night scenario: a wet road, lamps 5.6 m to the left every 49 m; the
    # reflections of the far ones run down the lane almost straight at the camera, within 0.6 m
    # of the car's line at the view's bottom row, and were kept (and taken for a marking inside the
    # lane: no lane on its first 22 frames at 720p).  30 frames at 640x360, measured: 0.947 and no frame
    # without a lane with the fans kept from 0.1 m beside the car's line; 0.282 and 70% with 0.6 m.
    before = _run(tmp_path, "night", 9, frames=30, streak_side_m=0.6)
    after = _run(tmp_path, "night", 9, frames=30)
    assert after.accuracy >= 0.93 and after.no_lane_rate is not None and after.no_lane_rate <= 0.05
    assert before.accuracy <= 0.4


@pytest.mark.slow
def test_a_lane_over_crests_and_sags_keeps_both_lines_with_its_own_set_up(tmp_path):
    # Tuning seed 6 of `hills` on its own stretch of road (vertical radius 900 m, a winding
    # two-lane road), 50 frames at 720p with the sequence's own set-up.  Over a crest the flat-road
    # view narrows the lane ahead; with the parallel check at 0.9 m (the limit on a set-up not of
    # the config's own) the true right line was refused for 25 frames and drawn inferred 0.5 m
    # wide of its marking: accuracy 0.678; at 1.3 m (tracking.max_parallel_diff_own_setup_m) 0.960.
    before = _run(tmp_path, "hills", 6, frames=50, size=(1280, 720), own_road=True, parallel_own_m=0.9)
    after = _run(tmp_path, "hills", 6, frames=50, size=(1280, 720), own_road=True)
    assert before.accuracy <= 0.72
    assert after.accuracy >= 0.94


@pytest.mark.slow
def test_a_tight_curve_seen_as_one_dash_a_line_is_bent_on_to_its_next_dashes(tmp_path):
    # Tuning seed 4 of `sharp-curve` on its own stretch of road (radius 72-90 m, short dashes and
    # long gaps), 50 frames at 720p with the sequence's own set-up.  The near view holds one dash of
    # each line, so each was fitted straight and the lane read straight on most frames; the bend
    # probe (search.bend_max_per_m) bends the dashes on to the next ones: accuracy 0.635 -> 0.723.
    before = _run(tmp_path, "sharp-curve", 4, frames=50, size=(1280, 720), own_road=True, bend=False)
    after = _run(tmp_path, "sharp-curve", 4, frames=50, size=(1280, 720), own_road=True)
    assert before.accuracy <= 0.66
    assert after.accuracy >= 0.70
