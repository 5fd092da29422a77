"""Set-ups of unknown cameras: from frames without a camera file, and online while a video runs."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from lanefinder.autosetup import SetupOptions, auto_setup
from lanefinder.camera import CameraModel
from lanefinder.config import BirdseyeConfig, Config
from lanefinder.evaluate import read_ground_truth, setup_error
from lanefinder.pipeline import LaneFinder, birdseye_from_config, camera_from_config
from lanefinder.selfcal import wanted
from lanefinder.synth import Mount, Renderer, Scenario

from conftest import DATA


def _camera(size: tuple[int, int], f: float) -> CameraModel:
    w, h = size
    return CameraModel(np.array([[f, 0, (w - 1) / 2], [0, f, (h - 1) / 2], [0, 0, 1.0]]), np.zeros(5), size,
                       source="synthetic")


def _truth(r: Renderer, cam: CameraModel):
    cfg = Config.model_validate({"camera": {"model": "none"}, "birdseye": r.birdseye_config()})
    return birdseye_from_config(cfg, cam, cam.image_size)


# Cameras the defaults were never tuned on: sizes, focal lengths, heights and pitches.
CAMERAS = [((960, 540), 700.0, 1.2, -1.0), ((960, 540), 1000.0, 1.6, 3.0), ((1920, 1080), 1400.0, 1.3, 0.0)]


@pytest.mark.slow
@pytest.mark.parametrize(("size", "f", "height", "pitch"), CAMERAS)
def test_frames_of_an_unknown_camera_give_its_setup_without_a_camera_file(size, f, height, pitch):
    cam = _camera(size, f)
    r = Renderer(cam, Mount(height_m=height, pitch_deg=pitch), Scenario("straight", width_m=(3.7, 0.0)), seed=11)
    frames = [r.render(t) for t in np.linspace(0, 4, 8)]
    result = auto_setup(frames, None, SetupOptions(dash_period_m=12.0))  # the renderer paints 3 m + 9 m
    cfg = result.config()
    assert cfg.camera.model == "none" and cfg.camera.focal_px == pytest.approx(f, rel=0.03)
    err = setup_error(birdseye_from_config(cfg, camera_from_config(cfg, size), size), _truth(r, cam))
    # Measured: ym within 0.6%, car within 0.01 m, xm within 0.7% on these three cameras.
    assert abs(err["ym_pct"]) < 3 and abs(err["car_m"]) < 0.1 and abs(err["xm_pct"]) < 2
    assert result.quality.frames_used == 8 and result.quality.car_error_m < 0.1


def test_a_refused_frame_does_not_sink_the_set(test_images):
    frames = [test_images["straight_lines1"], test_images["test2"], test_images["straight_lines2"]]
    result = auto_setup(frames, None, SetupOptions(dash_period_m=14.63))
    assert result.quality.frames_used == 2
    assert len(result.quality.refusals) == 1 and "curves" in result.quality.refusals[0]
    # California dashes (48 ft) give the Udacity camera's focal length (1156 px calibrated).
    assert result.focal_px == pytest.approx(1156, rel=0.03)


def test_self_calibration_is_asked_for_only_without_a_setup():
    assert wanted(Config())
    assert not wanted(Config.model_validate({"selfcal": {"enabled": False}}))
    assert not wanted(Config.model_validate({"birdseye": {"ym_per_px": 0.05}}))


@pytest.mark.slow
def test_online_self_calibration_converges_within_five_seconds():
    size, fps = (960, 540), 25
    cam = _camera(size, 800.0)
    r = Renderer(cam, Mount(height_m=1.5, pitch_deg=2.0), Scenario("straight", width_m=(3.7, 0.0)), seed=3)
    finder = LaneFinder(Config(), self_calibrate=True)
    default_be = finder.birdseye(size)
    widths = []
    for i in range(5 * fps):
        res = finder.process(r.render(i / fps))
        if res.setup != "default":
            widths.append(res.width_m)
    # (The first frame's own set-up was near enough that the estimate confirmed it: no update.)
    assert finder.selfcal.state.source == "estimated"
    # The default set-up (another camera's) misreads this road (measured: widths by 17.8%, distances
    # ahead by 404%, as the estimate reads it); the estimate reads the lane right.
    err = setup_error(default_be, finder.birdseye(size))
    assert abs(err["xm_pct"]) > 15 and abs(err["ym_pct"]) > 100
    last = [w for w in widths[-25:] if not math.isnan(w)]
    assert len(last) >= 20 and abs(np.median(last) - 3.7) < 0.15
    assert finder.selfcal.state.height_m == pytest.approx(1.5, rel=0.05)


@pytest.mark.slow
def test_a_still_of_a_camera_mounted_otherwise_is_seen_with_its_own_setup(test_images):
    from lanefinder.camera import udacity_camera

    cam = udacity_camera()  # the default camera's lens, mounted higher and pitched down
    r = Renderer(cam, Mount(height_m=1.5, pitch_deg=1.0), Scenario("straight", width_m=(3.7, 0.0)), seed=5)
    still = r.render(1.0)
    plain, own = LaneFinder().process(still), LaneFinder().process_still(still)
    assert plain.setup == "config" and own.setup == "estimated"
    # Measured: 4.68 m with the default set-up, 3.7 m with the still's own.
    assert abs(plain.width_m - 3.7) > 0.5 and abs(own.width_m - 3.7) < 0.1
    # ... and a still of the camera the default set-up was made for keeps it.
    assert LaneFinder().process_still(test_images["straight_lines2"]).setup == "default"
    # ... and a still whose one-frame estimate puts the camera too high keeps it (test1, a curve: 1.82 m).
    assert LaneFinder().process_still(test_images["test1"]).setup == "default"


def test_a_frame_the_pipeline_reads_as_curved_is_not_looked_at(test_images):
    from lanefinder.selfcal import SelfCalibrator

    be = LaneFinder().birdseye((1280, 720))
    still = test_images["straight_lines1"]
    cal = SelfCalibrator(Config(), be.camera, be)
    cal.offer(still, curvature_per_m=1 / 100)  # its turn, but R 100 m: the straightness test would refuse it
    assert len(cal._frames) == 0
    cal = SelfCalibrator(Config(), be.camera, be)
    cal.offer(still, curvature_per_m=1 / 5000)
    assert len(cal._frames) == 1


def test_an_unsure_estimate_does_not_end_the_fast_looks_and_a_sure_one_does(test_images):
    from lanefinder.selfcal import SelfCalibrator

    be = LaneFinder().birdseye((1280, 720))
    still = test_images["straight_lines1"]
    # A bar no estimate can pass: every estimate is unsure, and one frame in 2 is still looked at.
    strict = Config().model_copy(update={"selfcal": Config().selfcal.model_copy(update={"change_xm_pct": 0.01})})
    cal = SelfCalibrator(strict, be.camera, be)
    for _ in range(20):
        cal.offer(still, 0.0)
    assert cal.last_verdict == "unsure" and cal.state.source == "default" and cal.searching
    assert len(cal._frames) == 10
    # With the default bar the first estimate (on 4 frames) is sure: one frame in 50 from then on.
    cal = SelfCalibrator(Config(), be.camera, be)
    for _ in range(20):
        cal.offer(still, 0.0)
    assert cal.last_verdict == "confirms" and not cal.searching
    assert len(cal._frames) == 4
    # However long no estimate is sure, the fast looks end after fast_frames frames.
    bounded = strict.model_copy(update={"selfcal": strict.selfcal.model_copy(update={"fast_frames": 12})})
    cal = SelfCalibrator(bounded, be.camera, be)
    for _ in range(60):
        cal.offer(still, 0.0)
    assert not cal.searching and cal.state.source == "default"
    assert len(cal._frames) == 7  # frames 1, 3, ..., 11, then 51


def test_the_road_read_from_two_lines_near_the_car_is_the_true_one_on_a_curve_too():
    from lanefinder.autosetup import road_from_lines, road_homography
    from lanefinder.errors import LaneFinderError

    k = np.array([[1160.0, 0, 640], [0, 1160.0, 360], [0, 0, 1]])
    g = road_homography(k, (660.0, 450.0), 1.4)  # pitched down, yawed a little
    z = np.linspace(5, 18, 40)

    def image(x_m: np.ndarray) -> np.ndarray:
        p = np.column_stack([x_m, z, np.ones_like(z)]) @ g.T
        return p[:, :2] / p[:, 2:]

    for curvature in (0.0, 1 / 150, -1 / 150):  # straight, and concentric arcs either way
        bend = curvature * z ** 2 / 2
        est = road_from_lines(image(-1.6 + bend), image(2.1 + bend), k, 684.0, 3.7)
        # Measured: the horizon within 0.03 px, the height within 0.3% (the chords of concentric
        # arcs over the same stretch are parallel); on a curve the column takes the curve's heading.
        assert est.vp[1] == pytest.approx(450.0, abs=1.0)
        assert est.height_m == pytest.approx(1.4, rel=0.01)
        if curvature == 0:
            assert est.vp[0] == pytest.approx(660.0, abs=1.0) and est.centre_m == pytest.approx(0.25, abs=0.01)
    with pytest.raises(LaneFinderError, match="too few"):
        road_from_lines(image(-1.6 + 0 * z)[:5], image(2.1 + 0 * z), k, 684.0)
    with pytest.raises(LaneFinderError, match="right of"):
        road_from_lines(image(2.1 + 0 * z), image(-1.6 + 0 * z), k, 684.0)
    parallel = image(-1.6 + 0 * z)
    with pytest.raises(LaneFinderError, match="do not meet"):
        road_from_lines(parallel, parallel + (300.0, 0.0), k, 684.0)
    bad = image(-1.6 + 0 * z)
    bad[3, 1] = np.nan
    with pytest.raises(LaneFinderError, match="finite"):
        road_from_lines(bad, image(2.1 + 0 * z), k, 684.0)
    with pytest.raises(LaneFinderError, match="finite"):
        road_from_lines(np.ones((40, 3)), image(2.1 + 0 * z), k, 684.0)
    with pytest.raises(LaneFinderError, match="positive"):
        road_from_lines(image(-1.6 + 0 * z), image(2.1 + 0 * z), k, 684.0, lane_width_m=0.0)
    y = np.linspace(500, 700, 40)  # two lines crossing at row 600, among their own pixels
    with pytest.raises(LaneFinderError, match="not above"):
        road_from_lines(np.column_stack([600 + (y - 600), y]), np.column_stack([600 - (y - 600), y]), k, 684.0)
    # With a known column, only the row comes from the lines.
    est = road_from_lines(image(-1.6 + 0 * z), image(2.1 + 0 * z), k, 684.0, 3.7, vp_x=640.0)
    assert est.vp == pytest.approx((640.0, 450.0), abs=0.5)


def test_a_still_reading_that_is_implausible_or_too_close_to_the_setup_in_use_is_not_taken():
    from lanefinder.search import LinePixels
    from lanefinder.selfcal import lines_setup

    be = LaneFinder().birdseye((1280, 720))
    y = np.arange(100.0, 300.0)

    def reading(left_x: np.ndarray, right_x: np.ndarray):
        return lines_setup(be, LinePixels(x=left_x, y=y), LinePixels(x=right_x, y=y))

    assert reading(np.full(200, 125.0), np.full(200, 275.0)) is None  # parallel: the set-up in use is right
    assert reading(125 + (y - 100), 275 - (y - 100)) is None  # lines crossing among their own pixels
    assert reading(125 - (y - 100) / 2, 275 + (y - 100) / 2) is None  # a camera 0.46 m high
    assert reading(130 - (y - 100) / 16, 270 + (y - 100) / 16) is not None  # 11 px lower, 1.10 m high
    # ... and a still's pixels are kept when the caller asks for them.
    still = LaneFinder(keep_debug=True).process_still(np.zeros((720, 1280, 3), np.uint8))
    assert still.binary is not None and still.search is not None


@pytest.mark.slow
@pytest.mark.parametrize("pitch", [-2.5, -3.5])
def test_a_still_of_a_curve_is_seen_with_the_setup_its_lines_give(pitch):
    from lanefinder.birdseye import setup_of
    from lanefinder.camera import udacity_camera

    cam = udacity_camera()  # the default camera's lens, pitched further down, on a curve of R 250 m
    scenario = Scenario("curve", curvature=(1 / 250, 0.0), width_m=(3.7, 0.0), heading=(0.0, 0.0))
    r = Renderer(cam, Mount(height_m=1.3, pitch_deg=pitch), scenario, seed=5)
    still = r.render(1.0)
    true_horizon = setup_of(_truth(r, cam))[0]
    off = LaneFinder(Config.model_validate({"selfcal": {"still_lines": False, "still_horizon": False}}))
    on = LaneFinder(Config.model_validate({"selfcal": {"still_horizon": False}}))
    plain, lines = off.process_still(still), on.process_still(still)
    assert plain.setup == "default" and lines.setup == "lines"  # a curve: no vanishing point of its own
    exact_cfg = Config.model_validate({"camera": {"model": "none"}, "birdseye": r.birdseye_config()})
    exact = LaneFinder(exact_cfg, camera=cam).process(still)
    # Measured: the default horizon 21 and 41 px off, the lines' 2 and 1 px; the default reads
    # R 79 m or finds no lane, the lines' set-up R 274 and 258 m, the lane 3.76 and 3.70 m wide,
    # the car 0.18 and 0.20 m from where the exact set-up puts it (the column kept: the lines'
    # own column put it 0.4-0.7 m off).
    assert abs(setup_of(off.birdseye((1280, 720)))[0] - true_horizon) > 20
    assert abs(setup_of(on.birdseye((1280, 720)))[0] - true_horizon) < 5
    assert not plain.lane_found or abs(plain.radius_m - 250) > 100
    assert lines.lane_found and abs(lines.radius_m - 250) < 50 and abs(lines.width_m - 3.7) < 0.15
    assert abs(lines.offset_m - exact.offset_m) < 0.25
    assert plain.search is None and lines.search is None  # the pixels are kept only when asked for
    # With the horizon's set-up tried first (the default): measured, at -2.5 degrees its lines
    # meet too close to the default horizon to change it and the lines' set-up is kept; at -3.5
    # they meet 4.1 px above the true horizon, and the lane (R 224 m, 3.42 m wide, the car
    # 0.16 m from the exact set-up's place) is surer than the lines' set-up's, so it is kept.
    both = LaneFinder()
    seen = both.process_still(still)
    if pitch == -2.5:
        assert seen.setup == "lines"
    else:
        assert seen.setup == "horizon" and abs(setup_of(both.birdseye((1280, 720)))[0] - true_horizon) < 5
        assert seen.lane_found and abs(seen.radius_m - 250) < 40 and abs(seen.width_m - 3.7) < 0.35
        assert abs(seen.offset_m - exact.offset_m) < 0.2


@pytest.mark.slow
def test_a_still_whose_horizon_and_lines_agree_on_the_pitch_is_seen_with_the_horizon():
    from lanefinder.birdseye import setup_of
    from lanefinder.telemetry import lane_row

    # Frame 412 of the challenge video (a tuning still: 0.75 s into its second), whose camera is
    # pitched further down than the default set-up's.  The yellow line is solid, the right line
    # dashed; the default set-up splays the lane in the view and the dashed line takes the
    # yellow one's splayed shape.  The tracked video's lines there (`make stills`' reference),
    # x at rows 500, 550, 600, 650, 700:
    rows = [500, 550, 600, 650, 700]
    video = {"left_x": [582.9, 505.8, 430.6, 355.6, 280.5], "right_x": [749.9, 813.2, 878.3, 944.2, 1010.5]}
    still = cv2.imread(str(DATA / "stills" / "challenge_412.jpg"))

    def seen(cfg: Config) -> tuple[str, float, dict[str, list[float]]]:
        finder = LaneFinder(cfg)
        result = finder.process_still(still)
        row = lane_row(result, finder.birdseye((1280, 720)))
        at = {k: [row[k][row["h_samples"].index(y)] for y in rows] for k in video}
        return result.setup, setup_of(finder.birdseye((1280, 720)))[0], at

    # Measured: its road lines meet on row 437.9 and the lines the default set-up finds on
    # 438.9 (the default's horizon: 418.6).  Without the agreement the horizon's set-up is
    # refused (its lines' mean confidence 0.813 against the default's 0.846) and the dashed
    # line ends 144 px inside the video's at row 700; with it, within 12 px (the yellow line
    # within 3 px either way).
    setup_off, _, off = seen(Config.model_validate({"selfcal": {"still_horizon_agree": 0}}))
    setup_on, horizon_on, on = seen(Config())
    assert setup_off == "default" and video["right_x"][-1] - off["right_x"][-1] > 100
    assert setup_on == "horizon" and abs(horizon_on - 437.9) < 2
    for side in video:
        assert max(abs(a - b) for a, b in zip(on[side], video[side], strict=True)) < 20


@pytest.mark.slow
def test_a_still_whose_own_setup_is_refused_is_seen_with_the_horizon_its_road_lines_meet_on():
    from dataclasses import replace

    from lanefinder.birdseye import setup_of
    from lanefinder.camera import udacity_camera
    from lanefinder.evaluate import bench_frame
    from lanefinder.selfcal import look_at_still
    from lanefinder.synth import SCENARIOS, Appearance
    from lanefinder.telemetry import lane_row

    # Tuning seed 10's random look and mount (a camera 1.34 m high, pitched up: horizon row 398
    # against the default set-up's 419), a straight road, frame 10 as `make eval` renders it.
    look, cam = Appearance.random(10), udacity_camera()
    scenario = replace(SCENARIOS["straight"], width_m=(look.lane_width_m, 0.1))
    r = Renderer(cam, look.mount, scenario, 10, appearance=look)
    still, truth = r.render(0.4), r.truth(10, 0.4, r.geometry(0.4)).to_json()
    true_horizon = setup_of(_truth(r, cam))[0]
    default = LaneFinder().birdseye((1280, 720))
    seen = look_at_still(still, Config(), default)
    # Measured: its ego lines read a camera 2.03 m high (outside still_height_m: no set-up of its
    # own) but meet 0.3 px from the true horizon; the default set-up scores 0.672, the horizon's 1.0.
    assert seen.own is None and abs(setup_of(seen.horizon)[0] - true_horizon) < 2

    def accuracy(finder: LaneFinder) -> tuple[str, float]:
        result = finder.process_still(still)
        row = lane_row(result, finder.birdseye((1280, 720)))
        lanes = [row[k] for k in ("left_x", "right_x") if any(v >= 0 for v in row[k])]
        return result.setup, bench_frame(lanes, [truth["left_x"], truth["right_x"]], truth["h_samples"])[0]

    setup_off, acc_off = accuracy(LaneFinder(Config.model_validate({"selfcal": {"still_horizon": False}})))
    setup_on, acc_on = accuracy(LaneFinder())
    assert setup_off == "default" and acc_off < 0.75
    assert setup_on == "horizon" and acc_on > 0.95


@pytest.mark.slow
def test_a_still_starts_its_lane_from_one_sure_line():
    from dataclasses import replace

    from lanefinder.camera import udacity_camera
    from lanefinder.evaluate import bench_frame
    from lanefinder.synth import SCENARIOS, Appearance
    from lanefinder.telemetry import lane_row

    # Tuning seed 7's look in glare, frame 10 as `make eval` renders it: a double yellow line in
    # plain sight on the left, the right line washed out.
    look = Appearance.random(7)
    scenario = replace(SCENARIOS["glare"], width_m=(look.lane_width_m, min(SCENARIOS["glare"].width_m[1], 0.1)))
    r = Renderer(udacity_camera(), look.mount, scenario, 7, appearance=look)
    still, truth = r.render(0.4), r.truth(10, 0.4, r.geometry(0.4)).to_json()

    def seen(cfg: Config):
        finder = LaneFinder(cfg)
        result = finder.process_still(still)
        row = lane_row(result, finder.birdseye((1280, 720)))
        lanes = [row[k] for k in ("left_x", "right_x") if any(v >= 0 for v in row[k])]
        return result, bench_frame(lanes, [truth["left_x"], truth["right_x"]], truth["h_samples"])[0]

    # Measured: with a video's start rule (0.45) no lane ('one-line-start'), accuracy 0; with the
    # still's (0.3) the lane, its right line inferred, accuracy 0.69.
    video_rule, acc_video_rule = seen(Config.model_validate({"tracking": {"still_start_confidence": 0.45}}))
    still_rule, acc_still_rule = seen(Config())
    assert not video_rule.lane_found and "one-line-start" in video_rule.checks and acc_video_rule == 0
    assert still_rule.lane_found and (still_rule.left.inferred or still_rule.right.inferred)
    assert acc_still_rule > 0.65


@pytest.mark.slow
def test_a_video_starting_on_a_curve_takes_its_first_frames_horizon():
    from dataclasses import replace

    from lanefinder.camera import udacity_camera
    from lanefinder.evaluate import bench_frame
    from lanefinder.synth import SCENARIOS, Appearance
    from lanefinder.telemetry import lane_row

    # Tuning seed 10's random look and mount on a curve, as `make eval-unknown` runs it: the
    # road curves, so no frame gives a set-up of its own and self-calibration has no estimate.
    look = Appearance.random(10)
    scenario = replace(SCENARIOS["curve"], width_m=(look.lane_width_m, 0.1))
    r = Renderer(udacity_camera(), look.mount, scenario, 10, appearance=look)
    shots = [(r.render(i / 25), r.truth(i, i / 25, r.geometry(i / 25)).to_json()) for i in range(8)]

    def run(cfg: Config) -> tuple[set, float]:
        finder, accuracy, setups = LaneFinder(cfg, self_calibrate=True), [], set()
        for image, truth in shots:
            result = finder.process(image)
            row = lane_row(result, finder.last_birdseye)
            lanes = [row[k] for k in ("left_x", "right_x") if any(v >= 0 for v in row[k])]
            accuracy.append(bench_frame(lanes, [truth["left_x"], truth["right_x"]], truth["h_samples"])[0])
            setups.add(result.setup)
        return setups, float(np.mean(accuracy))

    # Measured: with the default set-up 0.654 over the first 8 frames (0.541 before a line's lone
    # specks were left out of its fit, fit.piece_min_marking_m), with the first frame's horizon 0.979.
    setups_off, acc_off = run(Config.model_validate({"selfcal": {"still_horizon": False}}))
    setups_on, acc_on = run(Config())
    assert setups_off == {"default"} and acc_off < 0.7
    assert setups_on == {"first-frame"} and acc_on > 0.95


@pytest.mark.slow
@pytest.mark.parametrize(("pitch", "yaw", "height"), [(0.8, -0.9, 1.48), (-3.0, -1.0, 1.16)])
def test_a_video_of_an_unknown_mount_is_seen_right_within_half_a_second(pitch, yaw, height):
    from lanefinder.camera import udacity_camera

    r = Renderer(udacity_camera(), Mount(height_m=height, pitch_deg=pitch, yaw_deg=yaw),
                 Scenario("straight", width_m=(3.7, 0.0)), seed=7)
    finder = LaneFinder(Config(), self_calibrate=True)
    results = [finder.process(r.render(i / 25)) for i in range(50)]
    first = next(i for i, res in enumerate(results) if res.setup == "estimated")
    late = results[20:]
    # Measured: the estimate in use from frame 7 on, then both lines seen on every frame and the lane
    # read 3.70 m wide.  Before (one frame in 4, 8 accepted, the track kept across the change):
    # from frame 28, and both lines seen on 93% and 77% of frames 20-49.
    assert first <= 10
    assert np.mean([res.left.found and res.right.found for res in late]) >= 0.95
    assert abs(np.nanmedian([res.width_m for res in late]) - 3.7) < 0.1
    assert finder.selfcal.state.height_m == pytest.approx(height, rel=0.05)


def test_while_unsure_of_the_setup_lines_are_not_pulled_parallel_on_a_road_read_as_straight(
        test_images, monkeypatch):
    import lanefinder.pipeline as pipeline

    used = []
    real = pipeline.measure
    monkeypatch.setattr(pipeline, "measure", lambda *a, **k: used.append(a[3]) or real(*a, **k))
    image, cfg = test_images["straight_lines1"], Config()

    def relaxed(finder: LaneFinder, n: int) -> list[bool]:
        used.clear()
        for _ in range(n):
            finder.process(image)
        return [m.fit.parallel == cfg.selfcal.unsure_parallel and m.rules.cfg.max_parallel_diff_m
                == cfg.selfcal.unsure_parallel_diff_m and m.rules.cfg.max_curvature_diff
                == cfg.selfcal.unsure_curvature_diff for m in used]

    assert relaxed(LaneFinder(cfg, self_calibrate=True), 2) == [True, True]  # no estimate yet
    assert relaxed(LaneFinder(cfg), 2) == [False, False]  # not self-calibrating
    own = Config.model_validate({"birdseye": {"xm_per_px": 0.025}})  # a set-up of its own
    assert relaxed(LaneFinder(own, self_calibrate=True), 2) == [False, False]
    brief = Config.model_validate({"selfcal": {"fast_frames": 3, "min_frames": 1000}})
    assert relaxed(LaneFinder(brief, self_calibrate=True), 5) == [True, True, True, False, False]
    finder = LaneFinder(cfg, self_calibrate=True)
    finder.process(image)
    assert finder.measurer.fit.parallel == cfg.fit.parallel  # the public settings stay as configured
    # After a frame read as a sharp curve, the next keeps the shared shape and the usual checks.
    finder._curvature_per_m = 2 / cfg.selfcal.unsure_radius_m
    assert relaxed(finder, 1) == [False]


@pytest.mark.slow
def test_before_its_first_estimate_a_straight_road_of_an_unknown_mount_is_drawn_on_its_paint():
    from lanefinder.camera import udacity_camera
    from lanefinder.telemetry import lane_row

    r = Renderer(udacity_camera(), Mount(height_m=1.16, pitch_deg=-3.0, yaw_deg=-1.0),
                 Scenario("straight", width_m=(3.7, 0.0)), seed=7)
    exact = LaneFinder(Config.model_validate({"birdseye": r.birdseye_config()}))
    never = {"min_frames": 1000, "first_frame": False}  # every frame is seen with the default set-up
    strict = {**never, "unsure_parallel": 1.0, "unsure_parallel_diff_m": 0.9, "unsure_curvature_diff": 0.004}
    worst = {}
    for name, selfcal in (("relaxed", never), ("strict", strict)):
        finder, errors = LaneFinder(Config.model_validate({"selfcal": selfcal}), self_calibrate=True), []
        exact.reset()
        for i in range(20):
            frame = r.render(i / 25)
            got = lane_row(finder.process(frame), finder.birdseye((1280, 720)))
            want = lane_row(exact.process(frame), exact.birdseye((1280, 720)))
            for side in ("left_x", "right_x"):  # rows 600-710, near the car
                x, t = np.array(got[side][20:]), np.array(want[side][20:])
                errors.append(np.max(np.abs(x - t)) if (x >= 0).all() and (t >= 0).all() else np.inf)
        worst[name] = float(np.median(errors))
    # Measured: 0.35 px from the exact set-up's lines; pulled parallel and held to parallel
    # checks, the default set-up's lines bend away from the paint by 105 px at the car.
    assert worst["relaxed"] < 3
    assert worst["strict"] > 50


def test_the_stages_of_a_still_are_drawn_with_the_setup_it_was_found_with(test_images):
    from lanefinder.render import annotate
    from lanefinder.stages import stage_images

    finder, image = LaneFinder(), test_images["test4"]
    result = finder.process_still(image)
    assert result.setup == "estimated"
    images = stage_images(image, finder)
    own = finder.birdseye((1280, 720))
    assert np.array_equal(images["6_final"], annotate(image, result, own, finder.config.render))
    assert not np.array_equal(own.src_px, LaneFinder().birdseye((1280, 720)).src_px)

def test_frames_found_after_a_still_with_its_own_setup_are_labelled_with_it(test_images):
    finder, image = LaneFinder(), test_images["test4"]
    assert finder.process_still(image).setup == "estimated"
    assert finder.process(image).setup == "estimated"  # the still's set-up is still in use
    finder.use_birdseye(LaneFinder().birdseye((1280, 720)))
    assert finder.process(image).setup == "config"
    assert finder.process_still(test_images["straight_lines1"]).setup == "default"
    assert finder.process(test_images["straight_lines1"]).setup == "config"
    finder.process_still(image)
    small = cv2.resize(image, (640, 360))
    assert finder.process(small).setup == "config"  # another frame size: the config's set-up again
    # A self-calibrating finder labels a still by the set-up it was found with, too.
    assert LaneFinder(self_calibrate=True).process_still(image).setup == "estimated"


@pytest.mark.slow
def test_a_video_of_an_unknown_mount_is_seen_with_its_first_frame_s_setup_until_the_estimate():
    from lanefinder.camera import udacity_camera

    r = Renderer(udacity_camera(), Mount(height_m=1.5, pitch_deg=1.0), Scenario("straight", width_m=(3.7, 0.0)),
                 seed=7)
    runs = {}
    for first_frame in (True, False):
        finder = LaneFinder(Config.model_validate({"selfcal": {"first_frame": first_frame}}), self_calibrate=True)
        runs[first_frame] = [finder.process(r.render(i / 25)) for i in range(7)]  # before any estimate
    # Measured: from the first frame the lane 3.65-3.77 m wide; with the default set-up no lane on
    # frames 0-1, then 2.85-3.70 m.
    assert [res.setup for res in runs[True]] == ["first-frame"] * 7
    assert all(res.lane_found and abs(res.width_m - 3.7) < 0.12 for res in runs[True])
    assert [res.setup for res in runs[False]] == ["default"] * 7
    assert not runs[False][0].lane_found and min(res.width_m for res in runs[False][2:]) < 3.2


@pytest.mark.slow
def test_the_first_frame_s_telemetry_is_mapped_with_the_setup_it_was_seen_with(tmp_path):
    from lanefinder.camera import udacity_camera
    from lanefinder.synth import write_sequence
    from lanefinder.telemetry import read_telemetry
    from lanefinder.videojob import process_video

    folder = write_sequence("straight", 3, tmp_path, seed=4, camera=udacity_camera(), randomise=True)
    cfg = Config.model_validate({"camera": {"model": str(folder / "camera.json")}})
    process_video(folder / "video.mp4", None, cfg, telemetry=tmp_path / "t.jsonl", progress=False)
    rows, truth = read_telemetry(tmp_path / "t.jsonl"), read_ground_truth(folder / "gt.jsonl")
    assert rows[0]["setup"] == "first-frame" and rows[0]["horizon_px"] == rows[1]["horizon_px"]
    for side in ("left_x", "right_x"):  # measured: within 1 px (63 and 72 px when mapped with the default)
        x, t = np.array(rows[0][side]), np.array(truth["frame/000000"][side])
        both = (x >= 0) & (t >= 0)
        assert both.sum() >= 10 and np.abs(x[both] - t[both]).mean() < 3


def test_a_lens_of_its_own_without_a_setup_starts_from_that_lens_mounted_as_the_default_camera(tmp_path):
    from lanefinder.birdseye import setup_of
    from lanefinder.camera import save_camera, udacity_camera

    save_camera(udacity_camera(), tmp_path / "udacity.json")
    save_camera(CameraModel.ideal((1920, 1080), hfov_deg=90.0), tmp_path / "wide.json")
    default = LaneFinder().birdseye((1280, 720))
    same = LaneFinder(Config.model_validate({"camera": {"model": str(tmp_path / "udacity.json")}}))
    assert np.array_equal(same.birdseye((1280, 720)).src_px, default.src_px)  # the Udacity lens: the default
    # camera.model none guesses its principal point: the default trapezoid (a pitch from the guessed
    # axis scored 0.602 against 0.756 on synthetic Udacity-lens footage, seeds 0-2)
    guessed = LaneFinder(Config.model_validate({"camera": {"model": "none"}}))
    assert np.array_equal(guessed.birdseye((1280, 720)).src_px, default.src_px)
    wide = LaneFinder(Config.model_validate({"camera": {"model": str(tmp_path / "wide.json")}})).birdseye((1920, 1080))
    horizon_px, height_m, focal_px = setup_of(wide)
    d_horizon, d_height, _ = setup_of(default)
    k = default.camera.camera_matrix
    pitch = math.atan((d_horizon - k[1, 2]) / k[1, 1])  # the default set-up's camera: 1.45 degrees down
    assert focal_px == pytest.approx(960.0) and height_m == pytest.approx(d_height, rel=1e-3)
    assert horizon_px == pytest.approx(539.5 + 960.0 * math.tan(pitch), abs=0.5)  # (the Udacity trapezoid: 628)


@pytest.mark.parametrize("first_frame", [True, False])
def test_a_wide_lens_given_without_a_setup_finds_the_lane_before_any_estimate(tmp_path, first_frame):
    from lanefinder.camera import save_camera
    from lanefinder.evaluate import bench_frame
    from lanefinder.telemetry import lane_row

    cam = CameraModel.ideal((960, 540), hfov_deg=90.0)
    save_camera(cam, tmp_path / "wide.json")
    r = Renderer(cam, Mount(height_m=1.35, pitch_deg=0.5), Scenario("straight", width_m=(3.7, 0.0)), seed=4)
    cfg = Config.model_validate({"camera": {"model": str(tmp_path / "wide.json")},
                                 "selfcal": {"first_frame": first_frame}})
    finder = LaneFinder(cfg, self_calibrate=True)
    accuracy = []
    for i in range(7):  # before self-calibration's first estimate
        truth = r.truth(i, i / 25, r.geometry(i / 25)).to_json()
        result = finder.process(r.render(i / 25))
        row = lane_row(result, finder.last_birdseye)
        lanes = [row[k] for k in ("left_x", "right_x") if any(v >= 0 for v in row[k])]
        accuracy.append(bench_frame(lanes, [truth["left_x"], truth["right_x"]], truth["h_samples"])[0])
        assert result.setup == ("first-frame" if first_frame else "default")
    # Measured: 1.0 on every frame with the first frame's set-up, 0.58-0.98 (mean 0.88) on the
    # lens's own starting set-up alone; with the Udacity lens's trapezoid (before), 0.0 on each.
    assert np.mean(accuracy) > (0.95 if first_frame else 0.8)


def _lines_in_view(be, horizon_px: float, height_m: float = 1.3) -> tuple:
    """Two straight lines 3.5 m apart as a camera whose horizon is at ``horizon_px`` sees them, in ``be``'s view."""
    from lanefinder.autosetup import road_homography
    from lanefinder.birdseye import src_vanishing_point
    from lanefinder.search import LinePixels

    g = road_homography(be.camera.camera_matrix, (src_vanishing_point(be.src_px)[0], horizon_px), height_m)
    z = np.linspace(5.0, 40.0, 400)
    lines = []
    for x_m in (-1.75, 1.75):
        p = np.column_stack([np.full_like(z, x_m), z, np.ones_like(z)]) @ g.T
        img = (p[:, :2] / p[:, 2:]).reshape(-1, 1, 2)
        v = cv2.perspectiveTransform(img, be.matrix).reshape(-1, 2)
        inside = (v[:, 1] >= 0) & (v[:, 1] < be.size[1])
        lines.append(LinePixels(x=v[inside, 0], y=v[inside, 1]))
    return lines[0], lines[1]


def test_the_lane_lines_measured_pitch_the_setup_to_where_they_meet():
    from lanefinder.birdseye import setup_of
    from lanefinder.selfcal import SelfCalibrator

    be = LaneFinder().birdseye((1280, 720))
    horizon = setup_of(be)[0]
    cfg = Config()
    n = cfg.selfcal.lines_min_frames
    cal = SelfCalibrator(cfg, be.camera, be)
    left, right = _lines_in_view(be, horizon + 6.0)  # a camera pitched 0.3 degrees further up
    assert all(cal.offer_lines(left, right, 0.0) is None for _ in range(n - 1))
    assert np.isnan(cal.lines_horizon())
    new = cal.offer_lines(left, right, 0.0)  # the n-th frame: the lines meet 6 px below the set-up's horizon
    assert new is not None and cal.state.source == "lines" and cal.current is new
    assert setup_of(new)[0] == pytest.approx(horizon + 6.0, abs=0.3)
    assert setup_of(new)[1] == pytest.approx(setup_of(be)[1], rel=0.01)  # the height kept
    # Seen with the new set-up the same road gives the same row: nothing more to change.
    left2, right2 = _lines_in_view(new, horizon + 6.0)
    assert all(cal.offer_lines(left2, right2, 0.0) is None for _ in range(n)) and cal.current is new

    # A winding or hilly road, whose lines meet 10 px above or below by turns: too spread to tell.
    cal = SelfCalibrator(cfg, be.camera, be)
    up, down = _lines_in_view(be, horizon - 4.0), _lines_in_view(be, horizon + 16.0)
    assert all(cal.offer_lines(*(up if i % 2 else down), 0.0) is None for i in range(2 * n))
    assert np.isnan(cal.lines_horizon()) and cal.state.source == "default"
    # A frame read as curving tighter than skip_radius_m, or with no lane read, is not taken ...
    cal = SelfCalibrator(cfg, be.camera, be)
    cal.offer_lines(left, right, 1 / 100)
    cal.offer_lines(left, right, math.nan)
    assert len(cal._horizons) == 0
    # ... nor is any with lines_horizon off; and a shift within lines_min_shift_px changes nothing.
    off = Config.model_validate({"selfcal": {"lines_horizon": False}})
    cal = SelfCalibrator(off, be.camera, be)
    assert all(cal.offer_lines(left, right, 0.0) is None for _ in range(n + 1)) and len(cal._horizons) == 0
    cal = SelfCalibrator(cfg, be.camera, be)
    near = _lines_in_view(be, horizon + 1.0)
    assert all(cal.offer_lines(*near, 0.0) is None for _ in range(n + 1))
    assert cal.lines_horizon() == pytest.approx(horizon + 1.0, abs=0.3)


@pytest.mark.slow
def test_a_video_whose_frames_give_no_estimate_is_pitched_by_its_lane_lines():
    from lanefinder.birdseye import setup_of
    from lanefinder.camera import udacity_camera

    cam = udacity_camera()
    r = Renderer(cam, Mount(height_m=1.3, pitch_deg=-1.85, yaw_deg=1.36), Scenario("straight", width_m=(3.6, 0.0)),
                 seed=4)
    true_horizon = setup_of(_truth(r, cam))[0]
    # No look at the frames themselves (no first frame, one look at frame 1 and none after): only the lines.
    only_lines = {"first_frame": False, "fast_frames": 0, "refine_every_frames": 100_000}
    runs = {}
    for lines in (False, True):
        finder = LaneFinder(Config.model_validate({"selfcal": {**only_lines, "lines_horizon": lines}}),
                            self_calibrate=True)
        default = setup_of(finder.birdseye(cam.image_size))[0]
        setups = [finder.process(r.render(i / 25)).setup for i in range(112)]
        runs[lines] = (setups, setup_of(finder.birdseye(cam.image_size))[0])
    assert abs(default - true_horizon) > 5  # the default set-up's horizon is 8.2 px off
    setups, horizon = runs[True]
    first = setups.index("lines")
    # Measured: pitched at frame 100 (lines_min_frames: every frame had both lines), 0.01 px from the truth.
    assert 100 <= first <= 105 and abs(horizon - true_horizon) < 1.0
    assert set(runs[False][0]) == {"default"} and runs[False][1] == default


def test_a_lines_horizon_that_could_never_be_given_is_refused_in_the_config():
    from pydantic import ValidationError

    with pytest.raises(ValidationError, match="lines_min_frames"):
        Config.model_validate({"selfcal": {"lines_min_frames": 2000, "lines_window_frames": 1500}})
    assert Config.model_validate({"selfcal": {"lines_min_frames": 50, "lines_window_frames": 50}})


@pytest.fixture(scope="module")
def shadows_6(tmp_path_factory):
    """Tuning seed 6 of ``shadows`` on its own stretch of road: 12 frames at 720p, the Udacity lens."""
    from lanefinder.camera import udacity_camera
    from lanefinder.config import load_config
    from lanefinder.synth import write_sequence
    from lanefinder.video import frames

    folder = tmp_path_factory.mktemp("seq") / "shadows-6"
    write_sequence("shadows", 12, folder, seed=6, camera=udacity_camera(), randomise=True, road_from_seed=True)
    truth_cfg = load_config(folder / "config.toml")
    truth = birdseye_from_config(truth_cfg, camera_from_config(truth_cfg, (1280, 720)), (1280, 720))
    return [f.image for f in frames(folder / "video.mp4")], truth


@pytest.mark.slow
@pytest.mark.parametrize("check", [False, True])
def test_an_estimate_that_shows_the_lane_worse_than_the_setup_in_use_is_refused(shadows_6, check):
    # An unknown mount 1.41 m high: the first frame's set-up reads widths 17.7% off; the first
    # estimate (telemetry frame 6) rests on three frames whose right ego line was taken on a
    # shadow's edge, reading the lane 42% narrow and the camera 2.88 m high (104% off). Found
    # blind, that frame shows a surer lane with the set-up in use, so the estimate is refused.
    # Measured on the 50-frame sequence: accuracy 0.2462 without the check, 0.9363 with it.
    images, truth = shadows_6
    finder = LaneFinder(Config.model_validate({"selfcal": {"estimate_check": check}}), self_calibrate=True)
    for image in images:
        finder.process(image)
    err = setup_error(finder.birdseye((1280, 720)), truth)
    cal = finder.selfcal
    assert cal.last_verdict == ("refused" if check else "taken")
    assert cal.last_estimate is not None and cal.last_estimate.height_m > 2.5
    assert (cal.state.updates, cal.state.refused) == ((0, 1) if check else (1, 0))
    assert abs(err["xm_pct"]) < 25 if check else abs(err["xm_pct"]) > 60


def test_the_run_summary_says_when_the_starting_setup_was_kept_against_refused_estimates():
    from lanefinder.selfcal import SetupState
    from lanefinder.videojob import _setup_lines

    kept = _setup_lines(SetupState(source="estimated", frames=3, refused=1, horizon_px=402.0, height_m=1.66,
                                   focal_px=1161.0))
    assert "was kept" in kept[0] and "1 sure estimate(s)" in kept[0] and "1.66 m" in kept[0]
    changed = _setup_lines(SetupState(source="estimated", frames=7, updates=2, refused=1, horizon_px=418.0,
                                      height_m=1.22, focal_px=1161.0))
    assert "2 change(s)" in changed[0] and "1 sure estimate(s) refused" in changed[1]


def _with_height(be, horizon_px: float, height_m: float):
    """A set-up of ``be``'s camera pitched to a horizon row and mounted at another height."""
    from lanefinder.autosetup import RoadEstimate
    from lanefinder.birdseye import src_vanishing_point
    from lanefinder.selfcal import _setup_from

    est = RoadEstimate(camera_matrix=be.camera.camera_matrix, vp=(src_vanishing_point(be.src_px)[0], horizon_px),
                       height_m=height_m, centre_m=0.0, focal_source="camera file", evidence=())
    return _setup_from(be, est)


def _early_looks(monkeypatch, owns, cfg=None):
    """Run a calibrator's early looks over frames 1.. with ``owns[i]`` as frame i's own set-up (None: none)."""
    import lanefinder.selfcal as selfcal_mod
    from lanefinder.selfcal import SelfCalibrator, StillLook

    config = cfg or Config()
    be = LaneFinder(config).birdseye((1280, 720))
    cal = SelfCalibrator(config, be.camera, be)
    frame = np.zeros((720, 1280, 3), np.uint8)
    looked, taken = [], []
    for i, own in enumerate(owns):
        monkeypatch.setattr(selfcal_mod, "look_at_still",
                            lambda *_a, own=own, i=i: looked.append(i) or StillLook(own=own, horizon=None))
        if i:
            taken.append(cal.look_again(frame))
        cal.offer(frame)  # (a black frame: no evidence, no estimate)
    return cal, looked, taken


def test_early_frames_own_setups_are_taken_once_two_agree(monkeypatch):
    from lanefinder.selfcal import horizon_setup, setup_of

    be = LaneFinder().birdseye((1280, 720))
    a, b, far = (horizon_setup(be, row) for row in (440.0, 441.5, 430.0))
    # Frames looked at: 2, 4, 6, ... (every_frames 2); frame 2 alone is not enough, frame 4 agrees with it.
    cal, looked, taken = _early_looks(monkeypatch, [None, None, a, None, b, None, a])
    assert looked == [2, 4]  # and none once a set-up is taken
    assert [t is not None for t in taken] == [False, False, False, True, False, False]
    assert cal.state.source == "first-frame" and setup_of(cal.current)[0] == pytest.approx(441.5, abs=0.5)
    # Two that disagree (10 px apart) are not taken; the next that agrees with the latter is.
    cal, _, taken = _early_looks(monkeypatch, [None, None, a, None, far, None, far])
    assert [t is not None for t in taken] == [False, False, False, False, False, True]
    # A look that gives none leaves the candidate: frame 6 agrees with frame 2.
    cal, looked, taken = _early_looks(monkeypatch, [None, None, a, None, None, None, a])
    assert looked == [2, 4, 6] and [t is not None for t in taken] == [False] * 5 + [True]
    # Horizons that agree but camera heights 15% apart are not taken.
    high = _with_height(be, 440.0, setup_of(a)[1] * 1.15)
    cal, _, taken = _early_looks(monkeypatch, [None, None, a, None, high])
    assert not any(t is not None for t in taken) and cal.state.source == "default"
    # Not beyond first_look_frames, and not at all with 0.
    cal, looked, _ = _early_looks(monkeypatch, [None, None, a, None, a], Config.model_validate(
        {"selfcal": {"first_look_frames": 3}}))
    assert looked == [2] and cal.state.source == "default"
    cal, looked, _ = _early_looks(monkeypatch, [None, None, a, None, a], Config.model_validate(
        {"selfcal": {"first_look_frames": 0}}))
    assert looked == [] and cal.state.source == "default"


def test_a_video_takes_the_setup_two_early_frames_agree_on(monkeypatch):
    import lanefinder.selfcal as selfcal_mod
    from lanefinder.selfcal import StillLook, horizon_setup, setup_of

    be = LaneFinder().birdseye((1280, 720))
    own = horizon_setup(be, 440.0)
    seen = []

    def look(frame, config, current):
        seen.append(len(seen))
        return StillLook(own=None if len(seen) == 1 else own, horizon=None)  # the first frame gives none

    monkeypatch.setattr(selfcal_mod, "look_at_still", look)
    finder = LaneFinder(self_calibrate=True)
    frame = np.zeros((720, 1280, 3), np.uint8)
    sources = [finder.process(frame).setup for _ in range(6)]
    # Frame 0 gives none; frames 2 and 4 give the same set-up: from frame 4 on it is in use.
    assert sources == ["default"] * 4 + ["first-frame"] * 2
    assert setup_of(finder.birdseye((1280, 720)))[0] == pytest.approx(440.0, abs=0.5)


def test_a_self_calibrating_finder_keeps_a_weak_first_width():
    # Its set-up (the default one, then estimates) reads the road's metres only as well as the
    # estimate: the default width is no better a guess than a weak pair's (tracking.sure_first_width).
    for self_calibrate, want in ((False, True), (True, False)):
        finder = LaneFinder(Config(), self_calibrate=self_calibrate)
        finder.birdseye((1280, 720))
        assert finder.measurer.rules.cfg.sure_first_width is want
    finder = LaneFinder(Config(), self_calibrate=True)
    finder.birdseye((1280, 720))
    relaxed = finder._frame_measurer()  # no lane yet, still searching: the relaxed settings
    assert relaxed is not finder.measurer and relaxed.rules.cfg.sure_first_width is False
    own = Config().model_copy(update={"birdseye": BirdseyeConfig(src=((580.0, 462.0), (704.0, 462.0),
                                                                      (1034.0, 675.0), (280.5, 675.0)))})
    finder = LaneFinder(own, self_calibrate=True)  # a config with its own set-up does not self-calibrate
    finder.birdseye((1280, 720))
    assert finder.measurer.rules.cfg.sure_first_width is True
