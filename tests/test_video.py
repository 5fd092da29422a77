"""The video job: output, telemetry, sub-clips, damaged input and interrupted runs."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import av
import numpy as np
import pytest

from lanefinder.errors import LaneFinderError
from lanefinder.telemetry import FIELDS, read_telemetry
from lanefinder.video import VideoInfo, frames
from lanefinder.videojob import process_video

from clirun import run_lanefinder
from conftest import CLIPS, faststart_copy

# Every test here decodes and encodes video, most in a subprocess.
pytestmark = pytest.mark.slow

PROJECT = CLIPS / "project_37-47s.mp4"
CHALLENGE = CLIPS / "challenge_3-7s.mp4"


def count_frames(path) -> int:
    with av.open(str(path)) as c:
        return sum(1 for _ in c.decode(video=0))


@pytest.fixture(scope="module")
def run_csv(tmp_path_factory):
    out = tmp_path_factory.mktemp("video")
    summary = process_video(CHALLENGE, out / "out.mp4", end_s=1.0, telemetry=out / "t.csv",
                            contact_sheet_path=out / "sheet.png", debug=True, progress=False)
    return out, summary


def test_video_output_matches_input(run_csv):
    out, summary = run_csv
    info = VideoInfo.from_path(out / "out.mp4")
    assert (info.width, info.height) == (1280, 720)
    assert info.fps == VideoInfo.from_path(CHALLENGE).fps  # 29.97 kept exactly
    assert info.codec == "h264"
    assert count_frames(out / "out.mp4") == summary.frames == 30
    assert summary.tracked == 30


def test_telemetry_rows_and_fields(run_csv):
    out, summary = run_csv
    rows = read_telemetry(out / "t.csv")
    assert len(rows) == summary.frames
    assert list(rows[0]) == FIELDS
    r = rows[10]
    assert r["h_samples"] == list(range(400, 720, 10))
    assert len(r["left_x"]) == len(r["right_x"]) == 32
    # Above the horizon the lines are absent (-2); near the car both are in the frame, left < right.
    assert r["left_x"][0] == -2 and r["right_x"][0] == -2
    i = r["h_samples"].index(650)
    assert 0 <= r["left_x"][i] < r["right_x"][i] < 1280
    assert len(r["left_fit_m"]) == 3 and r["state"] in ("tracking", "re-detect", "lost")
    assert rows[0]["time_s"] == pytest.approx(0.0) and rows[-1]["frame"] == 29


def test_contact_sheet_and_plot(run_csv, tmp_path):
    import cv2

    out, summary = run_csv
    sheet = cv2.imread(str(out / "sheet.png"))
    assert sheet is not None and sheet.shape[1] > 1000
    # The frames on the sheet, by their place in the run: 20 spread over the 30, first and last included.
    assert len(summary.sheet_frames) == 20 and summary.sheet_frames[0] == 0 and summary.sheet_frames[-1] == 29
    p = run_lanefinder("plot", str(out / "t.csv"), "-o", str(tmp_path / "p.png"))
    assert p.returncode == 0, p.stderr
    assert cv2.imread(str(tmp_path / "p.png")).shape[0] > 300


def test_jsonl_telemetry_and_sub_clip_timing(tmp_path):
    summary = process_video(PROJECT, tmp_path / "o.mp4", start_s=2.0, end_s=3.0, telemetry=tmp_path / "t.jsonl",
                            progress=False)
    rows = read_telemetry(tmp_path / "t.jsonl")
    assert summary.frames == len(rows) == 25 == count_frames(tmp_path / "o.mp4")
    assert rows[0]["frame"] == 50 and rows[0]["time_s"] == pytest.approx(2.0)
    assert rows[-1]["time_s"] == pytest.approx(2.96)
    assert all(r["left_found"] and r["right_found"] for r in rows)


def test_frames_generator_seeks(tmp_path):
    got = [(f.index, round(f.time_s, 2)) for f in frames(PROJECT, 4.0, 4.2)]
    assert got == [(100, 4.0), (101, 4.04), (102, 4.08), (103, 4.12), (104, 4.16)]


def test_never_writes_over_its_input(tmp_path):
    clip = tmp_path / "clip.mp4"
    clip.write_bytes(CHALLENGE.read_bytes())
    with pytest.raises(LaneFinderError, match="refusing to overwrite"):
        process_video(clip, clip, progress=False)
    assert clip.read_bytes() == CHALLENGE.read_bytes()


def test_corrupt_video_is_a_clear_error(tmp_path):
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(np.random.default_rng(0).integers(0, 255, 200_000, dtype=np.uint8).tobytes())
    p = run_lanefinder("video", str(bad), "-o", str(tmp_path / "o.mp4"))
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.startswith("lanefinder: error: cannot open video")
    assert not (tmp_path / "o.mp4").exists()


@pytest.mark.slow
def test_truncated_video_with_its_index_in_front_gives_the_frames_that_could_be_read(tmp_path):
    whole, cut = tmp_path / "whole.mp4", tmp_path / "cut.mp4"
    faststart_copy(CHALLENGE, whole)
    data = whole.read_bytes()
    cut.write_bytes(data[: int(len(data) * 0.6)])
    p = run_lanefinder("video", str(cut), "-o", str(tmp_path / "o.mp4"),
                       "--telemetry", str(tmp_path / "t.csv"), "--quiet")
    assert p.returncode == 0, p.stderr
    assert "the input ended early" in p.stdout
    n = count_frames(tmp_path / "o.mp4")
    assert 30 < n < 110 and len(read_telemetry(tmp_path / "t.csv")) == n


@pytest.mark.slow
def test_truncated_video_with_its_index_at_the_end_is_a_clear_error(tmp_path):
    cut = tmp_path / "cut.mp4"
    data = CHALLENGE.read_bytes()
    assert data.find(b"moov") > len(data) // 2  # the clip keeps its index at the end
    cut.write_bytes(data[: int(len(data) * 0.6)])
    p = run_lanefinder("video", str(cut), "-o", str(tmp_path / "o.mp4"),
                       "--telemetry", str(tmp_path / "t.csv"), "--quiet")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.startswith("lanefinder: error: cannot open video") and len(p.stderr.strip().splitlines()) == 1
    assert not list(tmp_path.glob("o.mp4")) and not list(tmp_path.glob("t.csv")) and not list(tmp_path.glob(".*"))


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_interrupted_run_leaves_a_playable_video_and_matching_telemetry(tmp_path, sig):
    out, tele = tmp_path / "o.mp4", tmp_path / "t.csv"
    out.write_text("an earlier run's output")  # kept as it is: the partial outputs get names of their own
    proc = subprocess.Popen([sys.executable, "-m", "lanefinder", "video", str(PROJECT), "-o", str(out),
                             "--telemetry", str(tele), "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    # Wait until frames are being written (the hidden partial file grows), then interrupt.
    deadline = time.time() + 60
    while time.time() < deadline and not any(f.stat().st_size > 200_000 for f in tmp_path.glob(".o.*")):
        time.sleep(0.05)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert "Traceback" not in err
    assert proc.returncode == 130, err
    n = count_frames(tmp_path / "o.partial.mp4")
    assert 0 < n < 250
    assert len(read_telemetry(tmp_path / "t.partial.csv")) == n
    assert out.read_text() == "an earlier run's output" and not tele.exists()
    assert not list(tmp_path.glob(".*"))  # no temporary files left behind


def test_variable_frame_rate_gives_increasing_frame_numbers(tmp_path):
    from fractions import Fraction

    from lanefinder.events import detect_events
    from lanefinder.video import frames

    path = tmp_path / "vfr.mp4"
    with av.open(str(path), "w") as o:
        s = o.add_stream("libx264", rate=25, options={"bframes": "0"})
        s.width, s.height, s.pix_fmt = 64, 48, "yuv420p"
        s.codec_context.time_base = s.time_base = Fraction(1, 1000)
        for i, t_ms in enumerate([0, 40, 70, 75, 120, 200, 210, 240, 280, 330]):
            f = av.VideoFrame.from_ndarray(np.full((48, 64, 3), 10 * i, np.uint8), format="rgb24")
            f.pts, f.time_base = t_ms, Fraction(1, 1000)
            o.mux(s.encode(f))
        o.mux(s.encode(None))
    got = list(frames(path))
    idx = [f.index for f in got]
    assert len(idx) == 10 and idx == sorted(set(idx))
    rows = [{"frame": f.index, "time_s": f.time_s, "state": "tracking", "offset_m": 0.0, "width_m": 3.7} for f in got]
    assert detect_events(rows, 25.0) == []


def test_a_contact_sheet_of_a_negative_number_of_frames_is_refused(tmp_path):
    from lanefinder.errors import LaneFinderError

    with pytest.raises(LaneFinderError, match="whole number of frames"):
        process_video(CHALLENGE, None, telemetry=tmp_path / "t.csv", contact_sheet_path=tmp_path / "s.png",
                      sheet_frames=-3, progress=False)
    assert not any(tmp_path.iterdir())  # refused before anything was written
