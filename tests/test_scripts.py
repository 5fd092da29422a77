"""The measuring scripts refuse bad arguments with one line, before any work.

Each runs as ``python SCRIPT`` in a fork of a process that has imported lanefinder (tests/clirun.py).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from clirun import run_script

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(("args", "says"), [
    (["--lens-hfov", "500"], "--lens-hfov must be 1-170 degrees"),
    (["--lens-hfov", "90", "--size", "19x"], "--size must be WxH"),
    (["--lens-hfov", "90", "--size", "10x10"], "--size must be WxH"),
    (["--size", "640x"], "--size must be WxH"),
    (["--frames", "0"], "--frames must be at least 1"),
    (["--config", "nosuch.toml"], "eval_synthetic: error: config file not found: nosuch.toml"),
])
def test_eval_synthetic_refuses_a_lens_it_cannot_render(tmp_path, args, says):
    p = run_script(ROOT / "scripts" / "eval_synthetic.py", "--out", str(tmp_path), *args, timeout=60)
    assert p.returncode == 2
    assert says in p.stderr and "Traceback" not in p.stderr
    assert not any(tmp_path.iterdir())  # nothing rendered


@pytest.mark.parametrize(("setup", "says"), [("none", "run `make stills` first"), ("bad", "run `make stills` first"),
                                             ("no default", "run `make stills` first"),
                                             ("exists", "exists: give a new folder")])
def test_stills_pairs_refuses_a_missing_report_or_an_existing_folder(tmp_path, setup, says):
    report, out = tmp_path / "report.json", tmp_path / "pairs"
    if setup == "bad":
        report.write_text('{"project_video": 3}')
    if setup == "no default":
        report.write_text('{"challenge_video": {"per_still": [{"frame": 15}]}}')
    if setup == "exists":
        out.mkdir()
    p = run_script(ROOT / "scripts" / "stills_pairs.py", "--report", str(report), "--out", str(out), timeout=60)
    assert p.returncode == 2 and says in p.stderr and "Traceback" not in p.stderr
    assert out.exists() == (setup == "exists") and len(list(tmp_path.iterdir())) == (setup != "none")


def test_stills_pairs_refuses_a_report_of_other_footage(tmp_path):
    # a still the video does not hold (frame 99999 of a 4-second clip) is refused, not passed over
    (tmp_path / "videos").mkdir()
    (tmp_path / "videos" / "clip.mp4").symlink_to(ROOT / "data" / "clips" / "challenge_3-7s.mp4")
    (tmp_path / "report.json").write_text('{"clip": {"per_still": [{"frame": 99999, "default": '
                                          '{"lane": true, "agrees": false}}]}}')
    p = run_script(ROOT / "scripts" / "stills_pairs.py", "--report", str(tmp_path / "report.json"), "--videos",
                   str(tmp_path / "videos"), "--out", str(tmp_path / "pairs"))
    assert p.returncode == 2 and "holds no frame 99999" in p.stderr and "Traceback" not in p.stderr
    assert not (tmp_path / "pairs").exists() and not list(tmp_path.glob(".pairs*"))


@pytest.mark.slow  # each reads a video
@pytest.mark.parametrize(("args", "says"), [(["nope.mp4"], "video not found: nope.mp4"),
                                            (["data/clips/project_37-47s.mp4", "--first", "5", "--last", "2"],
                                             "0 <= first <= last"),
                                            (["data/clips/project_37-47s.mp4", "--first", "9999", "--last", "9999"],
                                             "has no frame 9999")])
def test_selfcal_frames_refuses_bad_arguments_with_one_line(args, says):
    p = run_script(ROOT / "scripts" / "selfcal_frames.py", *args, timeout=60, cwd=ROOT)
    assert p.returncode == 2 and says in p.stderr and "Traceback" not in p.stderr


@pytest.mark.slow
def test_selfcal_frames_keeps_the_project_clips_set_up():
    # The default set-up is right for the project video: an estimate on its first frames confirms it.
    p = run_script(ROOT / "scripts" / "selfcal_frames.py", "data/clips/project_37-47s.mp4", "--last", "8", timeout=60,
                   cwd=ROOT)
    assert p.returncode == 0, p.stderr
    assert "an estimate on 4 frames: horizon row 41" in p.stdout and "confirms the set-up in use" in p.stdout
    assert "(+0.0 px), 0 changes" in p.stdout


def _label_clip(path: Path, k: float = 1.0):
    """Write a 3-frame clip at 1280x720 times ``k``: a solid line x = 760 - 0.6 y (rows 440-719), a
    dashed one x = 700 + 0.5 y (720-row pixels, scaled by ``k``).

    The dashed line has a gap on rows 555-625; the hood (rows 686 and below) is dark.
    """
    from fractions import Fraction

    import cv2
    import numpy as np

    from lanefinder.video import VideoInfo, VideoSink

    w, h = round(1280 * k), round(720 * k)
    img = np.full((h, w, 3), 90, np.uint8)
    half = max(2, round(6 * k))
    for yy in range(round(440 * k), round(686 * k)):
        y = yy / k
        cv2.line(img, (round(k * (760 - 0.6 * y)) - half, yy), (round(k * (760 - 0.6 * y)) + half, yy),
                 (235, 235, 235), 1)
        if not 555 <= y <= 625:
            cv2.line(img, (round(k * (700 + 0.5 * y)) - half, yy), (round(k * (700 + 0.5 * y)) + half, yy),
                     (235, 235, 235), 1)
    img[round(686 * k):] = 30
    info = VideoInfo(width=w, height=h, fps=Fraction(25), total_frames=3, duration_s=0.12, codec="h264")
    with VideoSink(path, info) as sink:
        for _ in range(3):
            sink.write(img)


@pytest.mark.slow  # writes and reads a video
def test_label_truth_places_rough_points_on_the_paint(tmp_path):
    import json

    clip = tmp_path / "clip.mp4"
    _label_clip(clip)
    # rough points, 8-12 px off the paint; the right line's span ends at row 470 and at 680 (the hood)
    (tmp_path / "a.txt").write_text("# rough\n1 L 680:362 560:432 450:498\n1 R 680:1050 600:1010 470:925\n2\n")
    p = run_script(ROOT / "scripts" / "label_truth.py", clip, tmp_path / "a.txt", "-o", tmp_path / "t.jsonl",
                   "--check", tmp_path / "check")
    assert p.returncode == 0, p.stderr
    rows = [json.loads(line) for line in (tmp_path / "t.jsonl").read_text().splitlines()]
    assert [r["frame"] for r in rows] == [1, 2]
    hs = rows[0]["h_samples"]
    left, right = dict(zip(hs, rows[0]["left_x"], strict=True)), dict(zip(hs, rows[0]["right_x"], strict=True))
    for y in range(450, 681, 10):  # on the paint, within 1.5 px
        assert abs(left[y] - (760 - 0.6 * y)) < 1.5, (y, left[y])
    for y in range(470, 681, 10):  # in the dash gap (560-620) filled in, along the rough points' shape
        assert abs(right[y] - (700 + 0.5 * y)) < (3.0 if 555 <= y <= 625 else 1.5), (y, right[y])
    assert left[440] == -2 and right[460] == -2  # above the points: not labelled
    assert abs(left[710] - (760 - 0.6 * 710)) < 1.5  # under the hood, straight on
    assert rows[1]["lanes"] == [] and set(rows[1]["left_x"]) == {-2.0}  # a frame with no line seen
    assert sorted(q.name for q in (tmp_path / "check").iterdir()) == ["00001.png", "00002.png"]


@pytest.mark.slow  # writes and reads a video
def test_label_truth_scales_with_the_frame(tmp_path):
    # At 640x360 the window, the ridge's reach and the hood row scale: the same lines, the same labels / 2.
    import json

    clip = tmp_path / "clip.mp4"
    _label_clip(clip, 0.5)
    (tmp_path / "a.txt").write_text("1 L 340:181 280:216 225:249\n")
    p = run_script(ROOT / "scripts" / "label_truth.py", clip, tmp_path / "a.txt", "-o", tmp_path / "t.jsonl")
    assert p.returncode == 0, p.stderr
    row = json.loads((tmp_path / "t.jsonl").read_text())
    left = dict(zip(row["h_samples"], row["left_x"], strict=True))
    for y in range(225, 356, 5):  # on the paint within 1 px, and under the hood (from row 343) straight on
        assert abs(left[y] - 0.5 * (760 - 0.6 * 2 * y)) < 1.0, (y, left[y])
    assert left[220] == -2


@pytest.mark.slow  # writes a video
@pytest.mark.parametrize(("anchors", "says"), [("1 L 680:362\n", "two points or more"),
                                               ("1 X 680:362 560:432\n", "a side L or R"),
                                               ("1 L 680-362 560:432\n", "expected 'FRAME L|R y:x"),
                                               ("1 L 680:362 560:432\n1 L 680:362 560:432\n", "given twice"),
                                               ("9 L 680:362 560:432\n", "frames not in the video: [9]"),
                                               ("# only a comment\n", "no frames listed"),
                                               ("1 L 680:nan 560:432\n", "expected 'FRAME L|R y:x"),
                                               ("1 L 680:2000 560:432\n", "outside the 1280x720 frame")])
def test_label_truth_refuses_bad_points_with_one_line(tmp_path, anchors, says):
    clip = tmp_path / "clip.mp4"
    _label_clip(clip)
    (tmp_path / "a.txt").write_text(anchors)
    p = run_script(ROOT / "scripts" / "label_truth.py", clip, tmp_path / "a.txt", "-o", tmp_path / "t.jsonl")
    assert p.returncode == 2 and says in p.stderr and "Traceback" not in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "t.jsonl").exists()


@pytest.mark.slow  # reads a clip (and runs it where the labels pass)
@pytest.mark.parametrize(("labels", "says"), [
    ("", "no labelled frames"),
    ("{nope\n", "not JSON"),
    ('{"frame": 3}\n', "h_samples must be the TuSimple rows of a 720-row frame"),
    ('{"frame": 3, "h_samples": ROWS, "left_x": [1, 2]}\n', "left_x must be 32 numbers"),
    ('{"frame": 500, "h_samples": ROWS, "left_x": XS, "right_x": XS}\n', "frames the video"),
])
def test_video_truth_refuses_bad_labels_with_one_line(tmp_path, labels, says):
    import json

    (tmp_path / "videos").mkdir()
    (tmp_path / "labels").mkdir()
    (tmp_path / "videos" / "harder_challenge_video.mp4").symlink_to(ROOT / "data" / "clips" /
                                                                    "harder_challenge_0-4s.mp4")
    rows = list(range(400, 720, 10))
    labels = labels.replace("ROWS", json.dumps(rows)).replace("XS", json.dumps([300.0] * 32))
    (tmp_path / "labels" / "harder_challenge_video.jsonl").write_text(labels)
    p = run_script(ROOT / "scripts" / "video_truth.py", "--only", "harder_challenge_video", "--videos",
                   tmp_path / "videos", "--labels", tmp_path / "labels", "--json", tmp_path / "r.json")
    assert p.returncode == 2 and says in p.stderr and "Traceback" not in p.stderr, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "r.json").exists()


def test_video_truth_refuses_a_missing_videos_folder(tmp_path):
    p = run_script(ROOT / "scripts" / "video_truth.py", "--videos", tmp_path / "nope", "--json", tmp_path / "r.json")
    assert p.returncode == 2 and "the Udacity videos are not at" in p.stderr and "Traceback" not in p.stderr
    assert not (tmp_path / "r.json").exists()


@pytest.mark.slow  # writes a video
def test_label_truth_never_writes_over_what_it_reads(tmp_path):
    clip = tmp_path / "clip.mp4"
    _label_clip(clip)
    anchors = tmp_path / "a.txt"
    anchors.write_text("1 L 680:362 560:432 450:498\n")
    for out in (anchors, clip):
        before = out.read_bytes()
        p = run_script(ROOT / "scripts" / "label_truth.py", clip, anchors, "-o", out)
        assert p.returncode == 2 and "refusing to overwrite the input" in p.stderr and "Traceback" not in p.stderr
        assert out.read_bytes() == before


def test_video_truth_never_writes_over_the_labels_it_reads(tmp_path):
    (tmp_path / "videos").mkdir()
    (tmp_path / "labels").mkdir()
    labels = tmp_path / "labels" / "project_video.jsonl"
    labels.write_text("{}\n")
    p = run_script(ROOT / "scripts" / "video_truth.py", "--only", "project_video", "--videos", tmp_path / "videos",
                   "--labels", tmp_path / "labels", "--json", labels)
    assert p.returncode == 2 and "refusing to overwrite the input" in p.stderr and "Traceback" not in p.stderr
    assert labels.read_text() == "{}\n"
