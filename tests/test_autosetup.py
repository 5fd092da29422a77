"""A new camera in one step: automatic bird's-eye set-up and scale."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from lanefinder.autosetup import SetupOptions, auto_setup
from lanefinder.birdseye import make_birdseye
from lanefinder.camera import CameraModel
from lanefinder.config import Config
from lanefinder.errors import LaneFinderError
from lanefinder.pipeline import LaneFinder
from lanefinder.synth import Mount, Renderer, Scenario
from lanefinder.threshold import threshold

from clirun import run_lanefinder
from conftest import CAL, TEST_IMAGES, shared_video


@pytest.fixture(scope="module")
def udacity_auto(test_images, udacity_camera):
    return auto_setup([test_images["straight_lines1"], test_images["straight_lines2"]], udacity_camera,
                      camera_ref="udacity")


def test_auto_setup_agrees_with_the_hand_tuned_default(udacity_auto):
    auto, default = udacity_auto.birdseye, Config().birdseye
    # The two photos' own vanishing rows differ by 2.3 px (camera pitch), and the hand set-up
    # fits lines to marking pixels while this one votes rays from the vanishing point: 6 px at
    # the trapezoid corners is 0.8% of the 760 px lane at the bottom (3 cm), and 5% of the
    # 122 px lane at the top row.  Measured: at most 4.0 px.
    for (_, ya), (_, yd) in zip(auto.src, default.src, strict=True):
        # The new view's edges run square to the road, not along image rows: the camera's yaw
        # (vanishing point 27 px left of the principal point) tilts them by 2 px each way.
        assert abs(ya - yd) <= 3.5
    # Each side of the trapezoid, read at the hand set-up's rows.
    for top, bottom in ((0, 3), (1, 2)):
        (x0, y0), (x1, y1) = auto.src[top], auto.src[bottom]
        for corner in (top, bottom):
            xd, yd = default.src[corner]
            assert abs(x0 + (x1 - x0) * (yd - y0) / (y1 - y0) - xd) <= 6, (auto.src, default.src)
    assert udacity_auto.vp[1] == pytest.approx(418.6, abs=2.5)
    # Along-road scale from the camera geometry: within 1% of the default (measured 0.4%).
    assert auto.ym_per_px == pytest.approx(default.ym_per_px, rel=0.01)
    assert auto.xm_per_px == pytest.approx(default.xm_per_px)


def test_auto_setup_lines_come_out_vertical_and_parallel(udacity_auto, test_images, udacity_camera):
    b = udacity_auto.birdseye
    be = make_birdseye(udacity_camera, np.array(b.src), np.array(b.dst), b.size, b.xm_per_px, b.ym_per_px)
    drifts = []
    for name in ("straight_lines1", "straight_lines2"):
        mask = threshold(be.warp(test_images[name]), Config().threshold, be.xm_per_px)
        for x0 in (125, 275):
            ys, xs = np.nonzero(mask[:, x0 - 20:x0 + 20])
            slope, _ = np.polyfit(ys, xs, 1)
            drifts.append(slope * b.size[1])
    # Per photo within 4 px over 300 rows (the photos' pitch differs); on average within 2 px.
    assert max(abs(d) for d in drifts) <= 4
    assert abs(np.mean(drifts[0::2])) <= 2 and abs(np.mean(drifts[1::2])) <= 2


def _synthetic_camera() -> CameraModel:
    f = 900.0
    k = np.array([[f, 0, 479.5], [0, f, 269.5], [0, 0, 1]])
    return CameraModel(k, np.zeros(5), (960, 540), source="synthetic")


def _true_scale(cam: CameraModel, mount: Mount, cfg) -> tuple[float, float]:
    """Metres per bird's-eye pixel of a set-up, measured by projecting known road points."""
    from lanefinder.synth import level_to_camera

    rot = level_to_camera(mount.pitch_deg)
    be = make_birdseye(cam, np.array(cfg.src), np.array(cfg.dst), cfg.size, cfg.xm_per_px, cfg.ym_per_px)
    pts = np.array([[-1.0, mount.height_m, 15.0], [1.0, mount.height_m, 15.0], [0.0, mount.height_m, 10.0],
                    [0.0, mount.height_m, 20.0]])
    cam_pts = pts @ rot.T
    img = (cam_pts @ cam.camera_matrix.T)[:, :2] / (cam_pts @ cam.camera_matrix.T)[:, 2:]
    bev = cv2.perspectiveTransform(img.reshape(-1, 1, 2), be.matrix).reshape(-1, 2)
    xm = 2.0 / np.linalg.norm(bev[1] - bev[0])
    ym = 10.0 / np.linalg.norm(bev[3] - bev[2])
    return float(xm), float(ym)


@pytest.mark.slow
def test_a_camera_with_other_height_pitch_and_focal_length_is_set_up_correctly():
    cam = _synthetic_camera()
    mount = Mount(height_m=1.6, pitch_deg=3.0)
    straight = Scenario("straight-fixed", offset_m=(0.2, 0.0), heading=(0.0, 0.0), width_m=(3.7, 0.0))
    r = Renderer(cam, mount, straight, seed=5)
    frames = [r.render(t) for t in (0.0, 0.16, 0.32)]
    result = auto_setup(frames, cam, SetupOptions(lookahead_m=30.0), camera_ref="camera.json")
    xm_true, ym_true = _true_scale(cam, mount, result.birdseye)
    assert result.birdseye.xm_per_px == pytest.approx(xm_true, rel=0.05)
    assert result.birdseye.ym_per_px == pytest.approx(ym_true, rel=0.05)
    # And without the camera file: no distortion model, the along-road scale from the dashes.
    blind = auto_setup(frames, None, SetupOptions())
    xm_b, ym_b = _true_scale(cam, mount, blind.birdseye)
    assert blind.birdseye.xm_per_px == pytest.approx(xm_b, rel=0.05)
    assert blind.birdseye.ym_per_px == pytest.approx(ym_b, rel=0.05)
    assert "dash period" in blind.ym_source and blind.notes


def test_curved_road_and_non_road_frames_are_refused(test_images, udacity_camera):
    with pytest.raises(LaneFinderError, match=r"not straight-road frames|not a straight road"):
        auto_setup([test_images["test2"]], udacity_camera)
    board = cv2.imread(str(CAL / "calibration2.jpg"))
    with pytest.raises(LaneFinderError):
        auto_setup([board], udacity_camera)


@pytest.mark.parametrize("size", [(960, 540), (1920, 1080), (640, 360)])
def test_other_frame_sizes_work_with_the_defaults(size, test_images):
    img = cv2.resize(test_images["test3"], size, interpolation=cv2.INTER_AREA if size[0] < 1280 else cv2.INTER_CUBIC)
    r = LaneFinder(Config()).process(img)
    assert r.left.found and r.right.found
    assert 3.5 < r.width_m < 3.95  # 3.71 m at 1280x720
    assert abs(r.offset_m - (-0.19)) < 0.06


@pytest.mark.slow
def test_setup_command(tmp_path):
    out = tmp_path / "cam.toml"
    p = run_lanefinder("setup",
                       "--straight", str(TEST_IMAGES / "straight_lines1.jpg"),
                       "--straight", str(TEST_IMAGES / "straight_lines2.jpg"), "-o", str(out))
    assert p.returncode == 0, p.stderr
    assert "no distortion model" in p.stdout and "vanishing point" in p.stdout
    assert out.is_file() and (tmp_path / "cam_preview.png").is_file()
    # The set-up only: every other setting is left to the defaults of the lanefinder that reads it.
    import re

    assert set(re.findall(r"^\[([^].]+)", out.read_text(), re.M)) == {"camera", "birdseye"}
    check = run_lanefinder("image", str(TEST_IMAGES / "test3.jpg"), "-c", str(out),
                           "-o", str(tmp_path / "o"))
    assert check.returncode == 0 and "yes   yes" in check.stdout
    bad = run_lanefinder("setup", "--straight", str(TEST_IMAGES / "test2.jpg"),
                         "-o", str(tmp_path / "bad.toml"))
    assert bad.returncode == 2 and "Traceback" not in bad.stderr and not (tmp_path / "bad.toml").exists()


@pytest.mark.slow
def test_auto_setup_meets_the_project_video_bars(tmp_path, test_images, udacity_camera):
    from lanefinder.stats import video_stats
    from lanefinder.telemetry import read_telemetry
    from lanefinder.videojob import process_video

    src = shared_video("project_video")
    auto = auto_setup([test_images["straight_lines1"], test_images["straight_lines2"]], udacity_camera)
    cfg = Config(birdseye=auto.birdseye)
    # The first 26 s (the first curve and the first pale concrete bridge); test_full_videos runs the
    # whole video with the default set-up.
    process_video(src, None, cfg, end_s=26, telemetry=tmp_path / "p.jsonl", progress=False)
    rows = read_telemetry(tmp_path / "p.jsonl")
    st = video_stats(rows)
    assert len(rows) == 650
    assert all(r["state"] != "lost" for r in rows)
    assert sum(r["left_found"] and r["right_found"] for r in rows) >= 648  # measured 650
    assert st["width_std_m"] < 0.15  # measured 0.134 m
    first = sorted(r["radius_m"] for r in rows if r["time_s"] < 10)
    assert 500 < first[len(first) // 2] < 1500


def test_a_seam_running_under_the_car_is_not_taken_for_an_ego_line():
    import cv2

    from lanefinder.autosetup import SetupOptions, frame_lines

    img = np.full((720, 1280, 3), 90, np.uint8)
    img[:400] = (200, 170, 140)
    vp = (640, 400)
    cv2.line(img, vp, (300, 719), (230, 230, 230), 6)  # the left line, solid
    cv2.line(img, vp, (690, 719), (230, 230, 230), 4)  # a bright seam under the camera, solid
    for a, b in ((0.05, 0.12), (0.25, 0.32), (0.45, 0.52)):  # the right line: three far dashes only
        cv2.line(img, (round(640 + 360 * a), round(400 + 319 * a)), (round(640 + 360 * b), round(400 + 319 * b)),
                 (230, 230, 230), 8)
    # The bottom row (674): the left line crosses it at 348, the seam at 682, the right line at 949.
    assert frame_lines(img, SetupOptions(min_line_offset=0.0)).right_bottom_x == pytest.approx(682, abs=5)
    fl = frame_lines(img, SetupOptions())
    # Measured: 348 and 958 (the right ray is read from three far dashes: extended, 9 px off).
    assert fl.left_bottom_x == pytest.approx(348, abs=5) and fl.right_bottom_x == pytest.approx(949, abs=15)


def test_footage_upside_down_or_sideways_is_refused_not_set_up_in_the_sky():
    # (a still upside down gave a set-up from the tree line, "1 of 1 accepted", the camera 1.18 m up)
    from lanefinder.camera import udacity_camera

    img = cv2.imread(str(TEST_IMAGES / "straight_lines1.jpg"))
    assert auto_setup([img], udacity_camera()).quality.frames_used == 1
    with pytest.raises(LaneFinderError, match="upside down or sideways"):
        auto_setup([img[::-1].copy()], udacity_camera())
