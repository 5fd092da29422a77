"""Synthetic scenes: exact geometry, correct lens model, and accuracy regression per hard condition."""

from __future__ import annotations

import math
from dataclasses import asdict, replace

import cv2
import numpy as np
import pytest

from lanefinder.camera import udacity_camera
from lanefinder.config import load_config
from lanefinder.pipeline import LaneFinder
from lanefinder.synth import (
    DASH_PATTERNS_M,
    LEFT_KINDS,
    SCENARIOS,
    Appearance,
    Mount,
    NightLight,
    Renderer,
    Vehicle,
    road_start_s,
    write_sequence,
)
from lanefinder.telemetry import make_row

from clirun import run_lanefinder
from conftest import ROOT


@pytest.fixture(scope="module")
def camera():
    return udacity_camera()


@pytest.mark.slow
def test_undistorting_a_frame_gives_the_pinhole_rendering_back(camera):
    pinhole = replace(camera, dist_coeffs=np.zeros(5))
    distorted = Renderer(camera, Mount(), SCENARIOS["curve"], seed=1).render(1.0)
    ideal = Renderer(pinhole, Mount(), SCENARIOS["curve"], seed=1).render(1.0)
    back = cv2.undistort(distorted, camera.camera_matrix, camera.dist_coeffs)
    # Compare the road, away from the borders that undistortion leaves empty.
    diff = np.abs(back[440:680, 200:1080].astype(int) - ideal[440:680, 200:1080].astype(int))
    assert np.median(diff) <= 2 and diff.mean() < 4
    # Without undoing the lens the frames differ clearly.
    raw = np.abs(distorted[440:680, 200:1080].astype(int) - ideal[440:680, 200:1080].astype(int))
    assert raw.mean() > 2 * diff.mean()


def test_ground_truth_lines_sit_on_the_painted_markings(camera):
    r = Renderer(camera, Mount(), SCENARIOS["straight"], seed=0)
    img = r.render(0.0)
    truth = r.truth(0, 0.0, r.geometry(0.0))
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    for x, y in zip(truth.left_x, truth.h_samples, strict=True):
        if x >= 0 and y >= 560:  # near rows, where the marking is several pixels wide
            h, s, _v = hsv[y, round(x)]
            assert 15 <= h <= 35 and s > 120, (x, y, hsv[y, round(x)])  # yellow paint
    assert truth.width_m == pytest.approx(3.7 + 0.1 * np.sin(0.4), abs=1e-6)
    assert truth.radius_m is None and truth.curvature_per_m == 0.0


@pytest.mark.slow
@pytest.mark.parametrize("seed", [2, 3, 4, 5])
def test_a_straight_synthetic_frame_gives_both_lines_within_2_px(tmp_path, camera, seed):
    # One frame, no tracking: the dashed line's few dashes limit a single frame; over seeds 0-11
    # the dashed line's worst row error ranges 0.8-8.7 px (closing note of the ground-truth issue).
    folder = write_sequence("straight", 1, tmp_path, seed=seed)
    cfg = load_config(folder / "config.toml")
    r = Renderer(camera, Mount(), SCENARIOS["straight"], seed=seed)
    img, truth = next(r.frames(1))
    finder = LaneFinder(cfg)
    result = finder.process(img)
    row = make_row(0, 0.0, result, finder.birdseye((1280, 720)))
    for pred, gt in ((row["left_x"], truth.left_x), (row["right_x"], truth.right_x)):
        p, g = np.array(pred), np.array(gt)
        both = (p >= 0) & (g >= 0)
        assert both.sum() >= 20
        assert np.abs(p[both] - g[both]).max() < 2.0
    assert result.offset_m == pytest.approx(truth.offset_m, abs=0.03)
    assert result.width_m == pytest.approx(truth.width_m, abs=0.05)


@pytest.mark.slow
def test_synth_command_writes_a_complete_sequence(tmp_path):
    import json

    p = run_lanefinder("synth", "--scenario", "worn", "--frames", "3",
                       "--seed", "2", "-o", str(tmp_path))
    assert p.returncode == 0, p.stderr
    assert {"video.mp4", "gt.jsonl", "camera.json", "config.toml", "scenario.json"} <= {
        f.name for f in tmp_path.iterdir()}
    import re

    text = (tmp_path / "config.toml").read_text()
    assert set(re.findall(r"^\[([^].]+)", text, re.M)) == {"camera", "birdseye", "events"}  # set-up, events' truth
    rows = [json.loads(x) for x in (tmp_path / "gt.jsonl").read_text().splitlines()]
    assert len(rows) == 3 and {"curvature_per_m", "radius_m", "offset_m", "width_m", "lanes", "h_samples",
                               "raw_file"} <= set(rows[0])
    rnd = run_lanefinder("synth", "--scenario", "curve-entry", "--frames", "1",
                         "--seed", "5", "--randomise", "--quiet", "-o", str(tmp_path / "r"))
    assert rnd.returncode == 0, rnd.stderr
    meta = json.loads((tmp_path / "r" / "scenario.json").read_text())
    assert meta["mount"] == {k: v for k, v in asdict(Appearance.random(5).mount).items()}
    assert meta["appearance"]["dash_m"] == Appearance.random(5).dash_m
    bad = run_lanefinder("synth", "--scenario", "moon", "-o", str(tmp_path))
    assert bad.returncode == 2 and "unknown scenario" in bad.stderr and "Traceback" not in bad.stderr


@pytest.mark.slow
@pytest.mark.parametrize(("name", "seed"), [("straight", 7), ("curve", 8), ("sharp-curve", 9)])
def test_lines_are_followed_beyond_the_view_to_where_the_paint_is_seen(tmp_path, camera, name, seed):
    # The truth runs to where a marking is 1.5 px wide (rows 440-450 at 720p, 46-68 m ahead);
    # the bird's-eye view ends at row 460 (35 m). Measured on these seeds: every far truth
    # point within 6 px, but in the sharp curve (R 90 m) the left line at row 440 lies 31 m to
    # the side, beyond the far view's 20 m: there only the nearer far row is asked for.
    folder = write_sequence(name, 1, tmp_path, seed=seed)
    finder = LaneFinder(load_config(folder / "config.toml"))
    r = Renderer(camera, Mount(), SCENARIOS[name], seed=seed)
    img, truth = next(r.frames(1))
    result = finder.process(img)
    row = make_row(0, 0.0, result, finder.birdseye((1280, 720)))
    far_rows = 0
    for side, gt in (("left", truth.left_x), ("right", truth.right_x)):
        pred = np.array(row[f"{side}_x"])
        g = np.array(gt)
        far = (np.array(truth.h_samples) < 460) & (g >= 0)
        if name == "sharp-curve" and not far.any():
            continue
        assert far.any()
        if name == "sharp-curve":
            far &= np.array(truth.h_samples) >= 450
        assert (pred[far] >= 0).all(), (side, pred[far], g[far])
        assert np.abs(pred[far] - g[far]).max() < 8.0, (side, pred[far], g[far])
        far_rows += int(far.sum())
        # In the sharp curve's still the right line is one dash in the near view: it is inferred
        # (no range of its own) since the texture test keeps the speckle around it out; its far
        # points above are still checked.
        if name != "sharp-curve" or side == "left":
            assert row[f"{side}_range_m"] > 40.0
        conf = np.array(row[f"{side}_x_conf"])
        assert conf[far].max() < conf[np.array(truth.h_samples) > 600].min()  # confidence falls with distance
    assert far_rows >= 2


# -- randomised appearance and camera (issue 12: a self-measure that cannot flatter us) ------------
def test_randomised_looks_cover_the_ranges_asked_for():
    looks = [Appearance.random(seed) for seed in range(60)]
    assert all(3.0 <= a.lane_width_m <= 3.9 for a in looks)
    assert all(1.1 <= a.mount.height_m <= 1.6 and abs(a.mount.yaw_deg) <= 2.0 for a in looks)
    assert {a.left for a in looks} == set(LEFT_KINDS)
    assert {(a.dash_m, a.gap_m) for a in looks} == set(DASH_PATTERNS_M)
    assert any(a.concrete_joints for a in looks) and not all(a.concrete_joints for a in looks)
    assert any(not a.right_edge_paint for a in looks) and any(a.vehicles for a in looks)
    assert min(a.paint for a in looks) < 0.7 and min(a.marking_m for a in looks) < 0.12
    assert Appearance.random(7) == Appearance.random(7) and Appearance.random(7) != Appearance.random(8)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [3, 10])
def test_randomised_truth_sits_on_the_paint_with_the_camera_turned(camera, seed):
    look = replace(Appearance.random(seed), left="yellow", vehicles=(), tar_seams=0.0, streaks=0.0, paint=1.0)
    assert abs(look.mount.yaw_deg) > 0.3  # these seeds turn the camera
    r = Renderer(camera, look.mount, replace(SCENARIOS["straight"], width_m=(look.lane_width_m, 0.1)), seed,
                 appearance=look)
    img = r.render(0.0)
    truth = r.truth(0, 0.0, r.geometry(0.0))
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    near = [(x, y) for x, y in zip(truth.left_x, truth.h_samples, strict=True) if x >= 0 and y >= 560]
    assert len(near) >= 8
    for x, y in near:
        h, s, _v = hsv[y, round(x)]
        assert 12 <= h <= 38 and s > 90, (x, y, hsv[y, round(x)])  # on the yellow paint


@pytest.mark.slow
def test_a_vehicle_ahead_hides_the_truth_behind_it_and_a_bare_edge_has_none(camera):
    look = replace(Appearance(), vehicles=(Vehicle(lane=0, z0_m=20.0, closing_mps=0.0, grey=40.0),))
    r = Renderer(camera, Mount(), SCENARIOS["straight"], appearance=look)
    truth = r.truth(0, 0.0, r.geometry(0.0))
    free = Renderer(camera, Mount(), SCENARIOS["straight"]).truth(0, 0.0, r.geometry(0.0))
    hidden = [i for i, (a, b) in enumerate(zip(truth.left_x + truth.right_x, free.left_x + free.right_x,
                                                   strict=True)) if a < 0 <= b]
    assert hidden  # the far paint behind the car is not labelled
    img = r.render(0.0)
    rows = [truth.h_samples[i % len(truth.h_samples)] for i in hidden]
    assert all(row < 470 for row in rows)  # only beyond the car, which stands 20 m ahead (row ~470)
    assert img[460, 640].max() < 60  # and the car is drawn there
    edge = Renderer(camera, Mount(), SCENARIOS["straight"], appearance=replace(Appearance(), left="edge"))
    t = edge.truth(0, 0.0, edge.geometry(0.0))
    assert all(x < 0 for x in t.left_x) and any(x >= 0 for x in t.right_x)


def test_a_line_with_no_paint_in_view_has_no_truth_and_a_dashed_one_ends_at_its_farthest_dash(camera):
    gone = Renderer(camera, Mount(), SCENARIOS["straight"], appearance=replace(Appearance(), missing_dashes=1.0))
    t = gone.truth(0, 0.0, gone.geometry(0.0))
    assert all(x < 0 for x in t.right_x) and any(x >= 0 for x in t.left_x)  # every dash missing; the solid left stays
    # Dashes 3 m long every 12 m: the truth ends at the farthest dash in view, not at the end of visibility.
    r = Renderer(camera, Mount(), SCENARIOS["straight"])
    g = r.geometry(0.0)
    z = np.geomspace(0.5, r.visible_m, 1500)
    painted = z[r.paint_along(z + g["travelled"], dashed=True) > 0]
    t = r.truth(0, 0.0, g)
    far_row = min(h for h, x in zip(t.h_samples, t.right_x, strict=True) if x >= 0)
    row, _ = r._line_image_at(g, float(painted.max()))
    assert abs(far_row - row) <= 10  # TuSimple rows are 10 px apart


def test_paint_washed_out_by_glare_is_not_labelled(camera):
    glare = SCENARIOS["glare"]
    clear = replace(glare, conditions=replace(glare.conditions, glare=False))
    look = Appearance.random(101)
    r, c = (Renderer(camera, Mount(), sc, seed=101, appearance=look) for sc in (glare, clear))
    tg, tc = (x.truth(0, 0.0, x.geometry(0.0)) for x in (r, c))
    seen = lambda t: sum(x >= 0 for x in t.left_x + t.right_x)  # noqa: E731
    assert 0 < seen(tg) < seen(tc)  # the glare ahead hides the far paint; what is left is labelled
    far_row, far_x = next((h, x) for h, x in zip(tg.h_samples, tg.left_x, strict=True) if x >= 0)
    assert not r.washed_out(0.0, np.array([far_x]), np.array([far_row], float), look.yellow).any()


def test_at_night_paint_beyond_the_beams_is_not_labelled(camera):
    night = SCENARIOS["night"]
    day = replace(night, conditions=replace(night.conditions, night=False))
    rn, rd = (Renderer(camera, Mount(), sc, seed=3) for sc in (night, day))
    rn.night = NightLight(ambient=0.0, reach_m=6.0, retro=1.0, exposure=0.3, noise=0.0)  # dim beams, no lamps
    tn, td = (x.truth(0, 0.0, x.geometry(0.0)) for x in (rn, rd))
    far = lambda t: min(h for h, x in zip(t.h_samples, t.left_x, strict=True) if x >= 0)  # noqa: E731
    assert far(tn) > far(td) + 20  # the solid left line is labelled only as far as the beams show it
    # What is labelled can be seen: where the truth ends the paint is still 6 grey levels lighter.
    g = rn.geometry(0.0)
    z = np.geomspace(1.0, rn.visible_m, 400)
    x = rn.centre(g, z) - 0.5 * g["width"]
    hidden = rn.unlit(x, z, rn.look.yellow, rn.paint_along(z + g["travelled"], False), z + g["travelled"],
                      x - rn.centre(g, z))
    assert not hidden[:50].any() and hidden[-50:].all()


def test_a_wet_night_mirrors_the_lights_in_the_road(camera):
    night = SCENARIOS["night"]
    dry, wet = (Renderer(camera, Mount(), night, seed=2, supersample=1) for _ in range(2))
    lamps = NightLight(lamp_spacing_m=30.0, lamp_rel_m=5.0, noise=0.0)
    dry.night, wet.night = lamps, replace(lamps, wet=True)
    a, b = (r.render(0.5).astype(np.int16) for r in (dry, wet))
    h = a.shape[0]
    brighter = (b - a).max(axis=2)[h // 2:] > 20  # below the horizon only: the reflections
    assert brighter.sum() > 500
    cols = np.flatnonzero(brighter.any(axis=0))
    assert cols.min() > a.shape[1] // 2  # the lamps stand right of the road, and so do their reflections


def test_on_a_level_road_the_rays_meet_it_where_the_flat_model_says(camera):
    r = Renderer(camera, Mount(), SCENARIOS["straight"])
    rays = np.array([[0.1, -0.2, 0.0], [0.05, 0.01, -0.02], [1.0, 1.0, 1.0]])  # x, y, z rows: three rays
    t = r.meet_road(r.geometry(0.0), rays)
    assert t[:2] == pytest.approx(Mount().height_m / rays[1, :2])
    assert np.isnan(t[2])  # a ray at the horizon never meets a level road (nor beyond HILL_VIEW_M)


def _hill_truth(camera, crest: bool):
    """A frame of the hills scenario at its crest or its sag, with the level-road truth of the same lane."""
    hills = SCENARIOS["hills"]
    r = Renderer(camera, Mount(), hills, supersample=1)
    # vertical curvature amp * sin(2 pi t / period + 2.7): +amp (crest) and -amp (sag) at these times
    t = (math.pi / 2 + (0 if crest else math.pi) - 2.7) % (2 * math.pi) * hills.period_s / (2 * math.pi)
    g = r.geometry(t)
    assert abs(g["vertical_curvature"]) == pytest.approx(hills.vertical_curvature[1], rel=1e-6)
    level = {**g, "vertical_curvature": 0.0}
    return r, t, g, r.truth(0, t, g), r.truth(0, t, level)


def test_a_crest_hides_the_road_beyond_it(camera):
    _r, _t, g, truth, level = _hill_truth(camera, crest=True)
    farthest = max(d for d, x in zip(truth.row_distance_m, truth.left_x, strict=True) if x >= 0)
    behind = math.sqrt(2 * Mount().height_m / g["vertical_curvature"])  # the slope down to the road is least there
    assert farthest <= behind + 3
    seen = lambda t: sum(x >= 0 for x in t.left_x + t.right_x)  # noqa: E731
    assert seen(truth) < seen(level)


def test_a_sag_shows_road_above_the_level_horizon_and_its_truth_sits_on_the_paint(camera):
    r, t, _g, truth, level = _hill_truth(camera, crest=False)
    top = min(h for h, x in zip(truth.h_samples, truth.left_x, strict=True) if x >= 0)
    assert top < min(h for h, x in zip(level.h_samples, level.left_x, strict=True) if x >= 0)
    img = r.render(t)
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    on = [15 <= hsv[y, round(x)][0] <= 35 and hsv[y, round(x)][1] > 120
          for x, y in zip(truth.left_x, truth.h_samples, strict=True) if x >= 0 and y >= 500]
    assert len(on) >= 10 and all(on)  # the solid yellow line, where it is a few pixels wide


def test_a_vehicle_behind_a_crest_shows_only_above_its_edge(camera):
    hills = SCENARIOS["hills"]
    look = replace(Appearance(), vehicles=(Vehicle(lane=0, z0_m=85.0, closing_mps=0.0, grey=60.0),))
    r = Renderer(camera, Mount(), hills, supersample=1, appearance=look)
    t = (math.pi / 2 - 2.7) % (2 * math.pi) * hills.period_s / (2 * math.pi)  # the crest
    g = r.geometry(t)
    [(_, poly)] = r.vehicles(t, g)
    truth = r.truth(0, t, g)
    edge_row = min(h for h, x in zip(truth.h_samples, truth.left_x, strict=True) if x >= 0)
    assert poly[:2, 1].max() <= edge_row + 10  # its foot is cut at the crest's edge (rows 10 px apart)
    assert poly[2:, 1].max() < poly[:2, 1].min()  # and its top shows above it
    flat = Renderer(camera, Mount(), SCENARIOS["straight"], supersample=1, appearance=look)
    [(_, whole)] = flat.vehicles(0.0, flat.geometry(0.0))
    assert whole[:2, 1].min() > whole[2:, 1].max()  # on a level road the rear is drawn whole


def _stills_synthetic():
    """scripts/stills_synthetic.py as a module."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("stills_synthetic", ROOT / "scripts" / "stills_synthetic.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_stills_of_a_synthetic_scene_are_scored_against_its_truth(tmp_path):
    # scripts/stills_synthetic.py (make stills-synthetic): blind stills, default set-up. Measured on
    # a straight road of seed 3 at 640x360: 0.984 at frames 10 and 35 (seeds 5 and 7: 0.94-1.0).
    mod = _stills_synthetic()
    folder = write_sequence("straight", 36, tmp_path, seed=3, camera=udacity_camera().scaled_to((640, 360)),
                            randomise=True)
    scores = mod.score(folder, [10, 35], LaneFinder())
    assert len(scores) == 2 and all(s is not None and s >= 0.95 for s in scores)


def test_synthetic_stills_see_the_road_make_eval_renders(tmp_path, monkeypatch):
    # make stills-synthetic renders (or reuses) each seed's sequence as make eval does: on the
    # seed's own stretch of road. Until 2026-11-29 it rendered every seed on the same stretch and
    # re-rendered make eval's folders under it.
    mod = _stills_synthetic()
    seen = []
    monkeypatch.setattr(mod, "sequence", lambda *a, **k: seen.append(k) or a[3])
    mod._sequence("straight", 101, tmp_path)
    mod._sequence("straight", 101, tmp_path, same_road=True)
    assert [k["road_from_seed"] for k in seen] == [True, False]


def test_the_renderers_remainder_is_numpys():
    # The renderer takes remainders in float64, pass by pass (about four times as fast as float32's
    # fmod); its frames must stay those NumPy's remainder gave, bit for bit (checked on 52 frames of
    # every scenario, randomised looks, at 640x360 and 1280x720, when it changed).
    from lanefinder.synth import _remainder, _remainder_below

    rng = np.random.default_rng(0)
    multiples = np.float32(4.5) * np.arange(1, 2000, dtype=np.float32)
    a = np.concatenate([(rng.standard_normal(600_000) * 50).astype(np.float32),  # more than two passes
                        (rng.random(100_000) * 5000).astype(np.float32), multiples,
                        np.nextafter(multiples, np.float32(0)), np.nextafter(multiples, np.float32(1e9)),
                        np.float32([0.0, -0.0, 3.7, -3.7, 7.4, -1e-8, 1e-8, 0.06, 14.0, 90.0, 3e9, -7e12,
                                    1.234e15])])
    for b in (3.7, 4.5, 90.0, 0.3):
        expected = a % b
        got = _remainder(a.copy(), b)
        assert got.dtype == np.float32 and np.array_equal(got.view(np.int32), expected.view(np.int32))
    u = np.abs(a)
    assert np.array_equal(np.fmod(u, 4.5), u % 4.5)  # non-negative distances: fmod is the remainder
    for period, limit in ((4.5, 0.06), (90.0, 14.0)):
        assert np.array_equal(_remainder_below(u, period, limit), np.fmod(u, period) < limit)
    with pytest.raises(TypeError):
        _remainder(a.astype(np.float64), 3.7)


def test_each_seed_can_drive_its_own_stretch_of_road(tmp_path):
    import json

    # Without it, every seed drives the first seconds of the scenario's cycle (the same road, looks apart).
    camera = udacity_camera().scaled_to((320, 180))
    winding = SCENARIOS["winding"]
    starts = {road_start_s(winding, seed) for seed in range(20)}
    assert len(starts) == 20 and all(0 <= x < winding.period_s for x in starts)
    later = Renderer(camera, Mount(), winding, start_s=2.5).geometry(0.0)
    same = Renderer(camera, Mount(), winding).geometry(2.5)
    for key in ("curvature", "curvature_rate", "heading", "offset", "width"):
        assert later[key] == pytest.approx(same[key])
    assert later["travelled"] == 0.0  # the road's texture keeps its own clock
    folder = write_sequence("winding", 1, tmp_path / "w", seed=3, camera=camera, randomise=True, road_from_seed=True)
    meta = json.loads((folder / "scenario.json").read_text())
    assert meta["start_s"] == pytest.approx(road_start_s(winding, 3))
    plain = write_sequence("winding", 1, tmp_path / "p", seed=3, camera=camera, randomise=True)
    assert "start_s" not in json.loads((plain / "scenario.json").read_text())
    truth = [json.loads((f / "gt.jsonl").read_text().splitlines()[0])["curvature_per_m"] for f in (folder, plain)]
    assert truth[0] != pytest.approx(truth[1])
