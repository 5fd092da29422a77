"""The command line: real outcomes, and bad input ends in one line (never a traceback)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from lanefinder.errors import LaneFinderError

from clirun import run_lanefinder
from conftest import CAL, CLIPS, TEST_IMAGES

CLIP = CLIPS / "project_37-47s.mp4"

# Every test here runs the command in a process of its own: forked from one that has imported
# lanefinder (tests/clirun.py), save the first, which starts `python -m lanefinder` itself.
pytestmark = pytest.mark.slow


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return run_lanefinder(*args, cwd=cwd, timeout=300)


def assert_one_line_error(p: subprocess.CompletedProcess, *needles: str) -> None:
    assert p.returncode == 2, (p.returncode, p.stderr)
    assert "Traceback" not in p.stderr
    err = p.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("lanefinder: error:"), p.stderr
    for n in needles:
        assert n in err[0], err[0]


def test_image_command_writes_annotated_images_and_results(tmp_path):
    # `python -m lanefinder` itself, in a fresh interpreter (the other tests fork one: tests/clirun.py)
    p = subprocess.run([sys.executable, "-m", "lanefinder", "image", str(TEST_IMAGES / "test3.jpg"),
                        str(TEST_IMAGES / "straight_lines1.jpg"), "-o", str(tmp_path / "out"), "--stages",
                        str(tmp_path / "stages")], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "out" / "test3.jpg").is_file()
    rows = [json.loads(x) for x in (tmp_path / "out" / "results.jsonl").read_text().splitlines()]
    assert [r["left_found"] and r["right_found"] for r in rows] == [True, True]
    stages = sorted(f.name for f in (tmp_path / "stages").iterdir())
    assert len(stages) == 12 and "test3_5_windows.png" in stages and "test3_1_undistorted.png" in stages


def test_calibrate_command(tmp_path):
    # The command's wiring, on six of the photos (a partial board and two cropped ones among them);
    # the calibration itself on all 20 is tests/test_camera.py's.
    photos = tmp_path / "photos"
    photos.mkdir()
    for n in (1, 2, 3, 6, 7, 15):
        shutil.copy(CAL / f"calibration{n}.jpg", photos)
    p = run("calibrate", str(photos), "-o", str(tmp_path / "cam.json"))
    assert p.returncode == 0, p.stderr
    assert "RMS reprojection error" in p.stdout and "partial board 9x5" in p.stdout and "cropped" in p.stdout
    cam = json.loads((tmp_path / "cam.json").read_text())
    assert len(cam["views"]) == 6 and cam["rms_px"] < 1.3  # measured 1.265 px on these six


def test_config_round_trip(tmp_path):
    p = run("config", "--default")
    assert p.returncode == 0 and "[threshold]" in p.stdout
    cfg = tmp_path / "my.toml"
    cfg.write_text(p.stdout.replace('strategy = "ridge"', 'strategy = "color"'))
    p = run("config", "--check", str(cfg), "--format", "json")
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["threshold"]["strategy"] == "color"
    yml = run("config", "--default", "--format", "yaml")
    assert yml.returncode == 0 and "birdseye:" in yml.stdout


def test_a_set_up_written_alone_reads_back_as_the_defaults_with_that_set_up(tmp_path):
    from lanefinder.config import SETUP_SECTIONS, Config, dump_config, load_config

    cfg = Config().model_copy(update={"birdseye": Config().birdseye.model_copy(update={"size": (500, 300)})})
    for fmt in ("toml", "yaml", "json"):
        path = tmp_path / f"setup.{'yml' if fmt == 'yaml' else fmt}"
        path.write_text(dump_config(cfg, fmt, sections=SETUP_SECTIONS))
        assert load_config(path) == cfg
    with pytest.raises(ValueError, match="no config section cameras"):
        dump_config(cfg, sections=("cameras",))


def test_missing_image(tmp_path):
    assert_one_line_error(run("image", str(tmp_path / "nope.jpg"), "-o", str(tmp_path)), "not found")


def test_unreadable_image(tmp_path):
    bad = tmp_path / "bad.jpg"
    bad.write_text("not a picture")
    assert_one_line_error(run("image", str(bad), "-o", str(tmp_path / "out")), "cannot read image")
    assert not (tmp_path / "out" / "bad.jpg").exists()


def test_images_with_the_same_name_in_two_folders_do_not_overwrite_each_other(tmp_path):
    for d in ("a", "b"):
        (tmp_path / d).mkdir()
        (tmp_path / d / "x.jpg").write_bytes((TEST_IMAGES / "test3.jpg").read_bytes())
    p = run("image", str(tmp_path / "a" / "x.jpg"), str(tmp_path / "b" / "x.jpg"), "-o", str(tmp_path / "out"))
    assert p.returncode == 0, p.stderr
    assert "x_2.jpg" in p.stdout
    rows = [json.loads(x) for x in (tmp_path / "out" / "results.jsonl").read_text().splitlines()]
    assert [Path(r["output"]).name for r in rows] == ["x.jpg", "x_2.jpg"]
    assert len(rows[0]["left_x"]) == len(rows[0]["h_samples"]) == 32 and rows[0]["left_range_m"] > 20


def test_folder_with_no_images(tmp_path):
    assert_one_line_error(run("image", str(tmp_path), "-o", str(tmp_path / "o")), "no images in folder")
    (tmp_path / "day1").mkdir()  # images one level down are not searched: the error says so
    shutil.copy(TEST_IMAGES / "test1.jpg", tmp_path / "day1")
    assert_one_line_error(run("image", str(tmp_path), "-o", str(tmp_path / "o")), "sub-folders (day1) are not searched")


def test_frame_size_that_does_not_match_the_camera(tmp_path):
    odd = tmp_path / "square.png"
    cv2.imwrite(str(odd), np.zeros((500, 500, 3), np.uint8))
    p = run("image", str(odd), "-o", str(tmp_path / "out"))
    assert p.returncode != 0 and "Traceback" not in p.stderr and "aspect ratio" in p.stderr
    assert not (tmp_path / "out" / "square.jpg").exists()


def test_no_chessboard_in_any_photo(tmp_path):
    assert_one_line_error(run("calibrate", str(TEST_IMAGES), "-o", str(tmp_path / "c.json")),
                          "no 9x6 chessboard was found")
    assert not (tmp_path / "c.json").exists()


def test_black_frame_is_reported_as_no_lane(tmp_path):
    black = tmp_path / "black.png"
    cv2.imwrite(str(black), np.zeros((720, 1280, 3), np.uint8))
    p = run("image", str(black), "-o", str(tmp_path / "out"))
    assert p.returncode == 0 and "Traceback" not in p.stderr
    row = json.loads((tmp_path / "out" / "results.jsonl").read_text())
    assert row["left_found"] is False and row["radius_m"] is None


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("[search]\nn_windows = 0\n", "search.n_windows"),
        ("[threshold]\nstrategy = \"magic\"\n", "threshold.strategy"),
        ("[tracking]\nmin_widht_m = 3\n", "tracking.min_widht_m: unknown key"),
        ("[birdseye]\nxm_per_px = -1\n", "birdseye.xm_per_px"),
        ("[search]\nn_windows = true\n", "search.n_windows: expected a number, not true/false"),
        ("[search]\nn_windows = \"9\"\n", "search.n_windows: expected a number, not the text '9'"),
    ],
)
def test_invalid_config_value_names_the_key(tmp_path, text, key):
    cfg = tmp_path / "bad.toml"
    cfg.write_text(text)
    assert_one_line_error(run("image", str(TEST_IMAGES / "test1.jpg"), "-c", str(cfg), "-o", str(tmp_path)), key)


@pytest.mark.parametrize(
    ("data", "needle"),
    [
        ({"search": {"n_windows": "9"}}, "search.n_windows: expected a number, not the text '9'"),
        ({"fit": {"huber_m": "0.1"}}, "fit.huber_m: expected a number, not the text '0.1'"),
        ({"selfcal": {"enabled": "off"}}, "selfcal.enabled: expected true or false, not the text 'off'"),
        ({"render": {"hud": "yes"}}, "render.hud: expected true or false, not the text 'yes'"),
        ({"selfcal": {"still_height_m": [1.0, "1.8"]}},
         "selfcal.still_height_m: expected a number, not the text '1.8'"),
        ({"threshold": {"sobel_hls": {"kernel": "5"}}}, "threshold.sobel_hls.kernel: expected a number"),
    ],
)
def test_config_refuses_text_for_numbers_and_switches(data, needle):
    # pydantic's lax mode read "9" as 9 and "off" as false: a quoted number or a spelled switch is refused
    from lanefinder.config import config_from_dict

    with pytest.raises(LaneFinderError, match=re.escape(needle)):
        config_from_dict(data, "x.toml")


def test_yaml_numbers_with_an_exponent_are_numbers(tmp_path):
    # YAML 1.1 (PyYAML) reads 1e4 and 5e-2 as text, which the config now refuses for a number
    from lanefinder.config import load_config

    (tmp_path / "c.yaml").write_text("fit:\n  max_radius_m: 1e4\n  huber_m: 5e-2\nsearch:\n  n_windows: 9\n")
    cfg = load_config(tmp_path / "c.yaml")
    assert (cfg.fit.max_radius_m, cfg.fit.huber_m, cfg.search.n_windows) == (10000.0, 0.05, 9)
    (tmp_path / "q.yaml").write_text("fit:\n  max_radius_m: '1e4'\n")  # quoted: text
    with pytest.raises(LaneFinderError, match=re.escape("fit.max_radius_m: expected a number, not the text '1e4'")):
        load_config(tmp_path / "q.yaml")


def test_text_for_a_section_says_it_must_be_a_table():
    from lanefinder.config import config_from_dict

    with pytest.raises(LaneFinderError, match="search: Input should be a valid dictionary"):
        config_from_dict({"search": "x"}, "x.toml")


def test_config_still_takes_its_words():
    from lanefinder.config import config_from_dict

    cfg = config_from_dict({"threshold": {"strategy": "color", "sobel_hls": {"kernel": 5}}, "camera": {"model": "none"},
                            "video": {"preset": "fast"}, "selfcal": {"still_height_m": [1, 2]}}, "x.toml")
    assert (cfg.threshold.strategy, cfg.threshold.sobel_hls.kernel, cfg.camera.model) == ("color", 5, "none")


def test_config_that_is_not_toml(tmp_path):
    cfg = tmp_path / "bad.toml"
    cfg.write_text("[search\n")
    assert_one_line_error(run("config", "--check", str(cfg)), "not valid TOML")


def test_bad_board_argument(tmp_path):
    assert_one_line_error(run("calibrate", str(CAL), "--board", "nine", "-o", str(tmp_path / "c.json")), "--board")


def _camera_file(tmp_path: Path, **change) -> Path:
    from lanefinder.camera import save_camera, udacity_camera

    path = tmp_path / "cam.json"
    save_camera(udacity_camera(), path)
    d = json.loads(path.read_text())
    d.update(change)
    path.write_text(json.dumps(d))
    return path


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        # scales so fine that the threshold's filters would be millions of pixels wide (it hung)
        (["image", str(TEST_IMAGES / "test1.jpg"), "-o", "out", "-c", "tiny.toml"], "birdseye.xm_per_px"),
        # files the tool would write and -c could not read
        (["config", "--default", "-o", "c.txt"], "not c.txt"),
        (["config", "--default", "--format", "json", "-o", "c.toml"], "--format json does not suit c.toml"),
        (["setup", "--straight", str(TEST_IMAGES / "straight_lines1.jpg"), "-o", "s.txt"], "not s.txt"),
        (["config", "--check", "."], "is a folder"),
        # a plot under a name whose format it is not, and a table that is not telemetry
        (["plot", "t.csv", "-o", "p.jpg"], "not p.jpg"),
        (["plot", "ab.csv", "-o", "p.png"], "not lanefinder telemetry"),
        (["eval", "--gt", "gt.jsonl", "--pred", "empty.csv"], "holds no predictions"),
        (["config", "--check", "nocam.toml"], "camera file not found"),
        # a lens whose distortion shrinks the frame to a point, and frames too large to render
        (["synth", "--frames", "1", "--camera", "cam.json", "-o", "seq"], "dist_coeffs do not describe a lens"),
        (["synth", "--frames", "1", "--camera", "big.json", "-o", "seq"], "needs about"),
        # found by a bad-input campaign (2026-11-27): a camera file that calibrate wrote but could not read
        # back, a plot of telemetry whose times are all NaN (it was written blank), segments of a millisecond
        (["calibrate", str(CAL), "-o", "cam.yaml"], "name it .json"),
        (["plot", "nan_t.csv", "-o", "p.png"], "time_s is not a number in any row"),
        (["config", "--check", "seg.toml"], "segment_s must be 0 (never split) or at least 1 s"),
        # a contact sheet's size without the sheet
        (["video", str(CLIP), "--telemetry", "t.jsonl", "--sheet-frames", "40"], "needs --contact-sheet"),
        # a third campaign: offsets of 1e308 made the plot's scaling fail (LinAlgError, an internal error)
        (["plot", "huge.jsonl", "-o", "p.png"], "offset_m is beyond +-1e+09 in row 1"),
        (["calibrate", *[str(CAL / "calibration2.jpg")] * 3, "-o", "c.json"], "the same photo"),
        (["setup", "--straight", str(TEST_IMAGES / "straight_lines1.jpg"), "--straight",
          str(TEST_IMAGES / "straight_lines1.jpg"), "-o", "s.toml"], "the same frame"),
        (["config", "--check", "twice.json"], "'n_windows' is given twice"),  # JSON and YAML kept the last
        (["config", "--check", "twice.yaml"], "'n_windows' is given twice"),
        (["config", "--check", "band.toml"], "a band is (low, high): 200 is above 100"),  # it selected nothing
        (["synth", "--frames", "1", "-o", ""], "is empty"),  # it wrote into the current folder
        (["eval", "--gt", "gt.jsonl", "--pred", "gt.jsonl", "--json", "."], "is a folder"),  # after the table
        (["eval", "--gt", ".", "--pred", "gt.jsonl"], "is a folder, not a file"),  # was "not found"
        (["eval", "--gt", "lanes.jsonl", "--pred", "short.jsonl"], "the prediction of frame 'frame/000000' has a"),
        (["plot", "t.csv", "-o", "."], "not ."),  # the message named nothing
        (["synth", "--frames", "1", "--camera", "tiny.json", "-o", "seq"], "too small to find a lane in"),
    ],
)
def test_bad_values_that_used_to_hang_crash_or_write_unreadable_files(tmp_path, args, needle):
    (tmp_path / "tiny.toml").write_text("[birdseye]\nxm_per_px = 1e-9\n")
    (tmp_path / "t.csv").write_text("frame,time_s,radius_m\n0,0.0,500\n")
    (tmp_path / "ab.csv").write_text("a,b\n1,2\n")
    (tmp_path / "nan_t.csv").write_text("frame,time_s,radius_m\n0,nan,500\n1,nan,600\n")
    (tmp_path / "seg.toml").write_text("[batch]\nsegment_s = 0.001\n")
    (tmp_path / "huge.jsonl").write_text('{"frame": 0, "time_s": 0, "offset_m": 1e308}\n')
    (tmp_path / "twice.json").write_text('{"search": {"n_windows": 7, "n_windows": 9}}')
    (tmp_path / "twice.yaml").write_text("search:\n  n_windows: 7\n  n_windows: 9\n")
    (tmp_path / "band.toml").write_text("[threshold.sobel_hls]\nx_thresh = [200, 100]\n")
    (tmp_path / "lanes.jsonl").write_text('{"frame": 0, "h_samples": [700, 710], "lanes": [[300, 301]]}\n')
    (tmp_path / "short.jsonl").write_text('{"frame": 0, "lanes": [[300]]}\n')  # the message named no frame
    (tmp_path / "empty.csv").write_text("")
    (tmp_path / "nocam.toml").write_text('[camera]\nmodel = "nope.json"\n')
    (tmp_path / "gt.jsonl").write_text(json.dumps({"frame": 0, "h_samples": [700], "left_x": [300],
                                                   "right_x": [900]}) + "\n")
    _camera_file(tmp_path, dist_coeffs=[1e9, 0, 0, 0, 0])
    big = json.loads((tmp_path / "cam.json").read_text())
    big.update(dist_coeffs=[0, 0, 0, 0, 0], image_size=[16384, 16384],
               camera_matrix=[[14000, 0, 8191.5], [0, 14000, 8191.5], [0, 0, 1]])
    (tmp_path / "big.json").write_text(json.dumps(big))
    big.update(image_size=[64, 36], camera_matrix=[[58, 0, 31.5], [0, 58, 17.5], [0, 0, 1]])
    (tmp_path / "tiny.json").write_text(json.dumps(big))  # `video` refused the frames synth wrote with it
    before = sorted(p.name for p in tmp_path.iterdir())
    assert_one_line_error(run(*args, cwd=tmp_path), needle)
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written


def test_a_contact_sheet_of_as_many_frames_as_asked(tmp_path):
    p = run("video", str(CLIP), "--telemetry", "t.csv", "--contact-sheet", "s.png", "--sheet-frames", "12",
            "--end", "1", "--quiet", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    sheet = cv2.imread(str(tmp_path / "s.png"))
    row_h, col_w = (sheet.shape[0] - 4) // 3, (sheet.shape[1] - 4) // 5  # 12 thumbnails, 5 a row: 3 rows
    assert sheet.shape[0] == 3 * row_h + 4 and sheet.shape[1] == 5 * col_w + 4
    # The last row holds 2 thumbnails; the rest of it is the sheet's grey.
    filled = [float(sheet[4 + 2 * row_h:, 4 + c * col_w:(c + 1) * col_w].std()) > 5 for c in range(5)]
    assert filled == [True, True, False, False, False]


def test_eval_reads_parquet_telemetry_and_names_its_row(tmp_path):
    seq = tmp_path / "seq"
    assert run("synth", "--frames", "8", "-o", str(seq), "--quiet").returncode == 0
    for ext in ("csv", "parquet"):
        p = run("video", str(seq / "video.mp4"), "--telemetry", str(tmp_path / f"drive.{ext}"), "-c",
                str(seq / "config.toml"), "--quiet")
        assert p.returncode == 0, p.stderr
    csv, parquet = (run("eval", "--gt", str(seq / "gt.jsonl"), "--pred", str(tmp_path / f"drive.{ext}"))
                    for ext in ("csv", "parquet"))
    assert parquet.returncode == 0, parquet.stderr
    assert parquet.stdout == csv.stdout and "\ndrive " in parquet.stdout


def test_batch_and_review_refuse_a_config_whose_camera_file_is_missing(tmp_path):
    # A bad-input campaign: `video` refused such a config, but `batch` started its cluster and
    # failed every video, and `review` served a page whose every inspection failed (and whose
    # Save wrote a config no command could load).
    (tmp_path / "c.toml").write_text('[camera]\nmodel = "camera.json"\n')
    clip = str(CLIPS / "challenge_3-7s.mp4")
    for args in (("batch", clip, "-o", str(tmp_path / "out"), "-c", str(tmp_path / "c.toml"), "--workers", "1"),
                 ("review", clip, "-c", str(tmp_path / "c.toml"), "--port", "0")):
        assert_one_line_error(run(*args), "camera file not found")
    assert not (tmp_path / "out").exists()


def test_a_config_saved_with_a_byte_order_mark_is_read(tmp_path):
    # Windows Notepad starts UTF-8 files with one; the config was refused as invalid TOML at line 1.
    (tmp_path / "c.toml").write_bytes(b"\xef\xbb\xbf[search]\nn_windows = 7\n")
    p = run("config", "--check", str(tmp_path / "c.toml"))
    assert p.returncode == 0 and "n_windows = 7" in p.stdout, p.stderr


def test_a_yaml_config_may_merge_a_mapping_and_override_it(tmp_path):
    # The check for keys given twice must leave YAML's merge key (<<) working, overrides included.
    (tmp_path / "c.yaml").write_text("search:\n  <<: {n_windows: 9, around_margin_m: 0.5}\n  n_windows: 7\n")
    p = run("config", "--check", str(tmp_path / "c.yaml"))
    assert p.returncode == 0 and "n_windows = 7" in p.stdout and "around_margin_m = 0.5" in p.stdout, p.stderr
