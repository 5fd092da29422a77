"""Fuzz and fault suite: whatever it is given, lanefinder answers with a result or one clear line.

- Property-based tests (Hypothesis) over configs, frames, telemetry and label files: the
  library raises ``LaneFinderError`` and nothing else.
- Generated corrupt media (cut at several points, bytes flipped, wrong containers, odd sizes,
  one frame) through ``lanefinder video`` in a process of its own.
- The CLI in a process of its own for each bad-input case: the exit status, a single
  ``lanefinder: error:`` line, every input's bytes unchanged and no file left behind.
- A full disk: a small tmpfs when the tests run as root, else a writer that raises ENOSPC.

Every loop is bounded in count (``max_examples``) and every process in time. The commands run in
forks of a process that has imported lanefinder (tests/clirun.py: their own processes, exit status
and output, without Python's start each time); the Ctrl-C tests start ``python -m lanefinder``.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import math
import os
import select
import shutil
import signal
import subprocess
import sys
import time
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lanefinder import LaneFinder
from lanefinder.config import config_from_dict
from lanefinder.errors import LaneFinderError
from lanefinder.evaluate import evaluate, read_ground_truth, read_predictions
from lanefinder.pipeline import MIN_FRAME_PX
from lanefinder.telemetry import read_telemetry
from lanefinder.video import VideoInfo

from clirun import run_lanefinder
from conftest import CAL, CLIPS, TEST_IMAGES, faststart_copy

CLIP = CLIPS / "project_37-47s.mp4"
#: The corrupt-media cases are cut from the 4-second clip (120 frames): what is tested is the reading.
MEDIA_CLIP = CLIPS / "challenge_3-7s.mp4"
CAMERA = Path(__file__).resolve().parents[1] / "src" / "lanefinder" / "data" / "udacity_camera.json"
FUZZ = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
RUN_TIMEOUT_S = 120

# -- property-based: the library ---------------------------------------------------------------
json_scalars = st.none() | st.booleans() | st.integers(-10**12, 10**12) | st.floats() | st.text(max_size=8)
json_values = st.recursive(json_scalars, lambda c: st.lists(c, max_size=4) | st.dictionaries(st.text(max_size=8), c,
                                                                                            max_size=4), max_leaves=12)
SECTIONS = ["camera", "birdseye", "threshold", "search", "fit", "tracking", "render", "video", "limits"]
KEYS = ["size", "src", "dst", "xm_per_px", "line_thickness", "n_windows", "method", "crf", "memory_mb", "model",
        "max_misses", "reference_size", "alpha"]


@FUZZ
@given(st.dictionaries(
    st.sampled_from(SECTIONS) | st.text(max_size=6),
    st.dictionaries(st.sampled_from(KEYS) | st.text(max_size=6), json_values, max_size=3) | json_values,
    max_size=3))
def test_any_config_is_accepted_or_refused_with_a_lanefinder_error(data):
    try:
        cfg = config_from_dict(data, "fuzz")
    except LaneFinderError as e:
        assert str(e).startswith("invalid config (fuzz)") or "fuzz" in str(e)
        return
    # Whatever is accepted is finite and within the bounds.
    assert all(8192 >= v >= 16 for v in cfg.birdseye.size)
    assert 1 <= cfg.render.line_thickness <= 50


FRAME_SHAPES = st.sampled_from([(0, 0, 3), (36, 64, 3), (72, 128, 3), (90, 160, 3), (72, 128), (72, 128, 4),
                                (1, 1, 3), (3, 5, 3), (720, 1280, 1)])
FRAME_DTYPES = st.sampled_from([np.uint8, np.float32, np.float64, np.int16, np.bool_])


@FUZZ
@given(FRAME_SHAPES, FRAME_DTYPES, st.integers(0, 2**32 - 1))
def test_any_array_gives_a_result_or_a_lanefinder_error(shape, dtype, seed):
    frame = np.random.default_rng(seed).integers(0, 256, shape).astype(dtype)
    try:
        result = LaneFinder().process(frame)
    except LaneFinderError:
        # Refused only when not a BGR uint8 frame of the camera's shape, or smaller than MIN_FRAME_PX.
        assert not (frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3 and frame.size
                    and abs(frame.shape[1] / frame.shape[0] / (16 / 9) - 1) < 0.01
                    and frame.shape[1] >= MIN_FRAME_PX[0] and frame.shape[0] >= MIN_FRAME_PX[1])
        return
    assert result.state in ("tracking", "re-detect", "lost")


@pytest.mark.parametrize("thing", [None, [1, 2, 3], "frame.jpg", 3.0, np.zeros((720, 1280, 3), np.float32)])
def test_things_that_are_not_frames_are_refused(thing):
    with pytest.raises(LaneFinderError, match="BGR uint8"):
        LaneFinder().process(thing)


def test_a_frame_too_small_to_hold_a_marking_is_refused():
    # (a 16x9 still, the camera's shape, once gave a "lane": radius 87 m, offset 0.59 m)
    tiny = cv2.resize(cv2.imread(str(TEST_IMAGES / "test3.jpg")), (16, 9), interpolation=cv2.INTER_AREA)
    with pytest.raises(LaneFinderError, match="16x9 pixels is too small"):
        LaneFinder().process_still(tiny)


@FUZZ
@given(st.binary(max_size=400) | st.text(max_size=400).map(str.encode), st.sampled_from([".csv", ".jsonl", ".parquet"]))
def test_any_telemetry_file_is_read_or_refused(tmp_path, data, suffix):
    path = tmp_path / f"t{suffix}"
    path.write_bytes(data)
    try:
        rows = read_telemetry(path)
    except LaneFinderError:
        return
    assert all(isinstance(r, dict) for r in rows)


label_rows = st.fixed_dictionaries(
    {"raw_file": st.sampled_from(["a", "b"]),
     "lanes": st.lists(st.lists(st.integers(-2, 1300) | st.floats() | st.text(max_size=2), max_size=4), max_size=3),
     "h_samples": st.lists(st.integers(0, 720) | st.text(max_size=2), max_size=4)},
    optional={"offset_m": json_scalars, "run_time": json_scalars, "radius_m": json_scalars})


@FUZZ
@given(st.lists(label_rows | json_values, min_size=1, max_size=4), st.lists(label_rows | json_values, max_size=4))
def test_any_label_and_prediction_files_are_scored_or_refused(tmp_path, gt_rows, pred_rows):
    gt, pred = tmp_path / "gt.jsonl", tmp_path / "pred.jsonl"
    gt.write_text("".join(json.dumps(r) + "\n" for r in gt_rows))
    pred.write_text("".join(json.dumps(r) + "\n" for r in pred_rows))
    try:
        report = evaluate(read_ground_truth(gt), read_predictions(pred))
    except LaneFinderError:
        return
    assert 0.0 <= report.accuracy <= 1.0 and math.isfinite(report.fp)


# -- the CLI in a process of its own ----------------------------------------------------------
def _sha(paths: list[Path]) -> dict[Path, str]:
    return {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in paths if p.is_file()}


def run_cli(*args: str, cwd: Path | None = None, timeout: float = RUN_TIMEOUT_S) -> subprocess.CompletedProcess:
    """Run ``lanefinder ARGS`` in a process of its own (forked: tests/clirun.py), bounded in time."""
    return run_lanefinder(*args, cwd=cwd, timeout=timeout)


def assert_one_error_line(p: subprocess.CompletedProcess, status: int = 2, says: str = "") -> str:
    # Progress bars (tqdm, on stderr) may come before the message; nothing else may.
    lines = [line for line in p.stderr.strip().splitlines() if line.strip() and "%|" not in line]
    assert p.returncode == status, (p.returncode, p.stderr[-2000:])
    assert len(lines) == 1 and lines[0].startswith("lanefinder: error: "), p.stderr[-2000:]
    assert says in lines[0], lines[0]
    return lines[0]


def assert_nothing_hidden(*folders: Path) -> None:
    for f in folders:
        if f.is_dir():
            assert not [p.name for p in f.iterdir() if p.name.startswith(".")], list(f.iterdir())


@pytest.fixture()
def work(tmp_path):
    """A folder with copies of the inputs the cases read (so a write over one would show)."""
    shutil.copy(CLIP, tmp_path / "clip.mp4")
    shutil.copy(CLIP, tmp_path / "clip.png")  # a video with an image's name, for the contact-sheet case
    shutil.copy(TEST_IMAGES / "test3.jpg", tmp_path / "test3.jpg")
    shutil.copy(TEST_IMAGES / "straight_lines1.jpg", tmp_path / "straight.jpg")
    shutil.copy(TEST_IMAGES / "straight_lines1.jpg", tmp_path / "s_preview.png")  # where `setup -o s.toml` previews
    (tmp_path / "a_file").write_text("I am a file, not a folder\n")
    (tmp_path / "t.csv").write_text("frame,time_s,state,radius_m\n0,0.0,tracking,900\n1,0.04,tracking,950\n")
    (tmp_path / "bad.csv").write_text("frame,time_s,state,radius_m\n0,abc,tracking,900\n")
    (tmp_path / "gt.jsonl").write_text(json.dumps({"raw_file": "a", "lanes": [[1, 2]], "h_samples": [700, 710]}) + "\n")
    (tmp_path / "strs.jsonl").write_text(json.dumps({"raw_file": "a", "lanes": [["x", 2]]}) + "\n")
    (tmp_path / "garbage.toml").write_bytes(bytes(range(256)) * 4)
    (tmp_path / "big.toml").write_text("[birdseye]\nsize = [20000, 15000]\n")
    (tmp_path / "thick.toml").write_text("[render]\nline_thickness = 100000\n")
    (tmp_path / "cam.jpg.yaml").write_bytes((TEST_IMAGES / "test1.jpg").read_bytes())
    cam = json.loads(CAMERA.read_text())
    cam["camera_matrix"] = [[0, 0, 0], [0, 0, 0], [0, 0, 0]]
    (tmp_path / "zero_cam.json").write_text(json.dumps(cam))
    cam["camera_matrix"] = [[2, 0, 640], [0, 2, 360], [0, 0, 1]]  # a mistyped focal length: 179.6 degrees
    (tmp_path / "f2_cam.json").write_text(json.dumps(cam))
    (tmp_path / "f2.toml").write_text('[camera]\nmodel = "none"\nfocal_px = 2\n')
    (tmp_path / "focal_udacity.toml").write_text("[camera]\nfocal_px = 800\n")
    return tmp_path


# (case id, arguments with {w} for the work folder, the words the error line must hold)
CASES = [
    ("video -o under a file", "video {w}/clip.mp4 -o {w}/a_file/o.mp4 --end 0.2 --quiet", "a_file is a file"),
    ("video --telemetry under a file", "video {w}/clip.mp4 --telemetry {w}/a_file/t.csv --end 0.2", "a_file is a file"),
    ("video -o = input", "video {w}/clip.mp4 -o {w}/clip.mp4", "refusing to overwrite the input"),
    ("video --telemetry = another output", "video {w}/clip.mp4 -o {w}/o.mp4 --telemetry {w}/o.mp4",
     "telemetry file must end"),
    ("video --contact-sheet = input", "video {w}/clip.png --telemetry {w}/x.csv --contact-sheet {w}/clip.png",
     "refusing to overwrite the input"),
    ("video --contact-sheet .mp4", "video {w}/clip.mp4 --telemetry {w}/x.csv --contact-sheet {w}/s.mp4",
     "cannot write an image as .mp4"),
    ("video --telemetry .txt", "video {w}/clip.mp4 -o {w}/o.mp4 --telemetry {w}/t.txt",
     "must end in .csv, .jsonl or .parquet"),
    ("video -o /proc", "video {w}/clip.mp4 -o /proc/lanefinder_test.mp4 --end 0.2 --quiet", "/proc"),
    ("video --start nan", "video {w}/clip.mp4 -o {w}/o.mp4 --start nan", "not a finite number"),
    ("video --end -1", "video {w}/clip.mp4 -o {w}/o.mp4 --end -1", "not in the range"),
    ("video still image", "video {w}/test3.jpg -o {w}/o.mp4", "still image, not a video"),
    ("video folder", "video {w} -o {w}/o.mp4", "not a file"),
    ("video huge view", "video {w}/clip.mp4 -o {w}/o.mp4 -c {w}/big.toml", "less than or equal to 8192"),
    ("config binary garbage", "config --check {w}/garbage.toml", "garbage.toml"),
    ("config --check X -o X", "config --check {w}/thick.toml -o {w}/thick.toml", "refusing to overwrite"),
    ("config thickness", "config --check {w}/thick.toml", "render.line_thickness"),
    ("image -o under a file", "image {w}/test3.jpg -o {w}/a_file/out", "a_file is a file"),
    ("image camera is a JPEG", "synth --camera {w}/cam.jpg.yaml -o {w}/s --frames 1", "cannot read it as JSON"),
    ("synth zero camera", "synth --camera {w}/zero_cam.json -o {w}/s --frames 1", "camera_matrix is not"),
    ("synth camera of 179.6 degrees", "synth --camera {w}/f2_cam.json -o {w}/s --frames 1", "field of view"),
    ("config focal_px 2", "config --check {w}/f2.toml", "camera.focal_px 2 px over 1280 px"),
    ("config focal_px for udacity", "config --check {w}/focal_udacity.toml", "for model 'none' only"),
    ("setup --video missing", "setup --video {w}/nope.mp4 -o {w}/s.toml", "video not found"),
    ("synth camera is a folder", "synth --camera {w} -o {w}/s --frames 1", "is a folder"),
    ("synth --pitch -30", "synth --pitch -30 -o {w}/s", "not in the range"),
    ("synth --seed -1", "synth --seed -1 -o {w}/s", "-1"),
    ("synth -o under a file", "synth --frames 1 -o {w}/a_file/s", "a_file is a file"),
    ("synth no -o", "synth --frames 1", "-o/--outdir"),
    ("setup --lane-width -3", "setup --straight {w}/straight.jpg --lane-width -3 -o {w}/s.toml", "not in the range"),
    ("setup --lane-width nan", "setup --straight {w}/straight.jpg --lane-width nan -o {w}/s.toml", "finite"),
    ("setup preview = input", "setup --straight {w}/s_preview.png -o {w}/s.toml", "refusing to overwrite the input"),
    ("plot abc", "plot {w}/bad.csv -o {w}/p.png", "time_s is not a number"),
    ("plot binary", "plot {w}/garbage.toml -o {w}/p.png", "garbage.toml"),
    ("plot -o = input", "plot {w}/t.csv -o {w}/t.csv", "refusing to overwrite the input"),
    ("eval strings", "eval --gt {w}/gt.jsonl --pred {w}/strs.jsonl", "lanes must be lists of numbers"),
    ("eval --json = gt", "eval --gt {w}/gt.jsonl --pred {w}/gt.jsonl --json {w}/gt.jsonl", "refusing to overwrite"),
    ("setup --bottom nan", "setup --straight {w}/straight.jpg --bottom nan -o {w}/s.toml", "finite"),
    ("eval binary truth", "eval --gt {w}/garbage.toml --pred {w}/gt.jsonl", "not JSON Lines"),
    ("eval binary predictions", "eval --gt {w}/gt.jsonl --pred {w}/garbage.toml", "not JSON Lines"),
    ("image one bad of two", "image {w}/test3.jpg {w}/garbage.toml -o {w}/out", "nothing was written"),
    ("calibrate huge board", "calibrate {w}/test3.jpg --board 1000000x1000000 -o {w}/c.json", "3 to 30"),
    ("calibrate no board", "calibrate {w}/test3.jpg {w}/straight.jpg -o {w}/c.json", "no 9x6 chessboard"),
]


@pytest.mark.slow
@pytest.mark.parametrize(("case", "args", "says"), CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_exit_2_and_no_input_is_touched(work, case, args, says):
    inputs = sorted(p for p in work.iterdir() if p.is_file())
    before = _sha(inputs)
    p = run_cli(*args.format(w=work).split())
    assert "Traceback" not in p.stderr
    assert_one_error_line(p, 2, says)
    assert _sha(inputs) == before
    assert_nothing_hidden(work, work / "s", work / "out")
    assert not (work / "o.mp4").exists() and not (work / "x.csv").exists()


@pytest.mark.slow
def test_an_input_camera_in_the_output_folder_is_not_written_over(tmp_path):
    cam = tmp_path / "camera.json"
    shutil.copy(CAMERA, cam)
    before = _sha([cam])
    p = run_cli("synth", "--frames", "1", "--quiet", "--camera", cam, "-o", tmp_path)
    assert_one_error_line(p, 2, "refusing to overwrite the input")
    assert _sha([cam]) == before
    assert sorted(f.name for f in tmp_path.iterdir()) == ["camera.json"]


@pytest.mark.slow
def test_a_failed_image_run_replaces_nothing_and_leaves_no_folder(work):
    out = work / "out"
    out.mkdir()
    (out / "test3.jpg").write_bytes(b"old")
    (out / "results.jsonl").write_text("old\n")
    p = run_cli("image", work / "test3.jpg", work / "garbage.toml", "-o", out, "--stages", work / "new" / "stages")
    assert_one_error_line(p, 2, "nothing was written")
    assert (out / "test3.jpg").read_bytes() == b"old" and (out / "results.jsonl").read_text() == "old\n"
    assert not (work / "new").exists()  # the folders made for the outputs are gone again


@pytest.mark.slow
def test_synth_list_needs_no_folder():
    p = run_cli("synth", "--list")
    assert p.returncode == 0 and "sharp-curve" in p.stdout


@pytest.mark.slow
def test_images_with_the_same_name_do_not_overwrite_each_other(tmp_path):
    for sub in ("a", "b"):
        (tmp_path / sub).mkdir()
        shutil.copy(TEST_IMAGES / f"test{1 if sub == 'a' else 3}.jpg", tmp_path / sub / "x.jpg")
    p = run_cli("image", tmp_path / "a" / "x.jpg", tmp_path / "b" / "x.jpg", "-o", tmp_path / "out")
    assert p.returncode == 0, p.stderr
    assert sorted(f.name for f in (tmp_path / "out").iterdir()) == ["results.jsonl", "x.jpg", "x_2.jpg"]
    assert "x_2.jpg" in p.stdout


@pytest.mark.slow
def test_a_failing_command_leaves_an_existing_output_as_it_was(work):
    (work / "o.mp4").write_bytes(b"the user's old video")
    (work / "t2.csv").write_text("old telemetry\n")
    # The contact sheet's name is refused before any work: neither output is touched.
    p = run_cli("video", work / "clip.mp4", "-o", work / "o.mp4", "--telemetry", work / "t2.csv",
                "--contact-sheet", work / "sheet.txt")
    assert_one_error_line(p, 2, "cannot write an image as .txt")
    assert (work / "o.mp4").read_bytes() == b"the user's old video"
    assert (work / "t2.csv").read_text() == "old telemetry\n"


# -- generated corrupt media ------------------------------------------------------------------
def _encode(path: Path, size: tuple[int, int], n: int, codec: str, fmt: str | None = None) -> None:
    w, h = size
    with av.open(str(path), "w", format=fmt) as c:
        s = c.add_stream(codec, rate=25)
        s.width, s.height = w, h
        s.pix_fmt = "yuv420p"
        rng = np.random.default_rng(0)
        for i in range(n):
            img = np.full((h, w, 3), 60 + 10 * (i % 5), np.uint8)
            img[h // 2:, :] = rng.integers(70, 110, (h - h // 2, w, 3))
            f = av.VideoFrame.from_ndarray(img, format="bgr24")
            f.pts = i
            for pkt in s.encode(f):
                c.mux(pkt)
        for pkt in s.encode(None):
            c.mux(pkt)


def _media(kind: str, folder: Path) -> Path:
    data = MEDIA_CLIP.read_bytes()
    if kind.startswith("cut-end-"):  # the clip keeps its index at the end
        p = folder / f"{kind}.mp4"
        p.write_bytes(data[: int(len(data) * int(kind.rsplit("-", 1)[1]) / 100)])
    elif kind.startswith("cut-front-"):
        whole = folder / "whole.mp4"
        if not whole.exists():
            faststart_copy(MEDIA_CLIP, whole)
        p = folder / f"{kind}.mp4"
        b = whole.read_bytes()
        p.write_bytes(b[: int(len(b) * int(kind.rsplit("-", 1)[1]) / 100)])
    elif kind == "flipped":
        b = bytearray(data)
        rng = np.random.default_rng(1)
        for i in rng.integers(len(b) // 4, 3 * len(b) // 4, 400):
            b[i] ^= 0xFF
        p = folder / "flipped.mp4"
        p.write_bytes(bytes(b))
    elif kind == "jpeg-as-mp4":
        p = folder / "still.mp4"
        shutil.copy(TEST_IMAGES / "test1.jpg", p)
    elif kind == "empty":
        p = folder / "empty.mp4"
        p.write_bytes(b"")
    elif kind == "random":
        p = folder / "random.mp4"
        p.write_bytes(np.random.default_rng(2).integers(0, 256, 100_000, dtype=np.uint8).tobytes())
    elif kind == "odd-size":
        p = folder / "odd.mkv"
        _encode(p, (641, 361), 10, "ffv1")
    elif kind == "one-frame":
        p = folder / "one.mp4"
        _encode(p, (640, 360), 1, "libx264")
    else:
        raise AssertionError(kind)
    return p


MEDIA = ["cut-end-10", "cut-end-50", "cut-end-90", "cut-front-10", "cut-front-50", "cut-front-90", "flipped",
         "jpeg-as-mp4", "empty", "random", "odd-size", "one-frame"]


@pytest.mark.slow
@pytest.mark.parametrize("kind", MEDIA)
def test_corrupt_and_odd_media_give_frames_or_one_clear_line(tmp_path, kind):
    src = _media(kind, tmp_path)
    before = _sha([src])
    out, tele = tmp_path / "out" / "o.mp4", tmp_path / "out" / "t.csv"
    p = run_cli("video", src, "-o", out, "--telemetry", tele, "--quiet")
    assert "Traceback" not in p.stderr
    assert _sha([src]) == before
    assert_nothing_hidden(tmp_path, tmp_path / "out")
    if p.returncode == 0:  # the frames that could be read, video and telemetry in step
        info = VideoInfo.from_path(out)
        rows = read_telemetry(tele)
        assert info.total_frames == len(rows) > 0
        if kind == "odd-size":
            assert info.size == (642, 362) and "padded by one pixel" in p.stdout
    else:
        assert_one_error_line(p, 2)
        assert not out.exists() and not tele.exists()
    expected_ok = {"cut-front-50", "cut-front-90", "odd-size", "one-frame", "flipped"}
    expected_error = {"cut-end-10", "cut-end-50", "cut-end-90", "jpeg-as-mp4", "empty", "random"}
    if kind in expected_ok:
        assert p.returncode == 0, p.stderr
    if kind in expected_error:
        assert p.returncode == 2, p.stdout
    if kind.startswith("cut-end-"):
        assert "cut short before its index" in p.stderr


# -- faults: a full disk, Ctrl-C twice --------------------------------------------------------
@pytest.fixture()
def full_disk(tmp_path):
    """A 3 MB file system (tmpfs) when the tests run as root; skip otherwise (see the ENOSPC test)."""
    mnt = tmp_path / "full"
    mnt.mkdir()
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("a small tmpfs needs root; the ENOSPC writer test covers this case")
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=3m", "tmpfs", str(mnt)], capture_output=True).returncode:
        pytest.skip("cannot mount a tmpfs here; the ENOSPC writer test covers this case")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


@pytest.mark.slow
@pytest.mark.parametrize("command", ["video", "telemetry", "image", "synth"])
def test_a_full_disk_is_one_clear_line_and_leaves_nothing(full_disk, work, command):
    (full_disk / "old.csv").write_text("old\n")
    # Each case fills the disk to leave what its writer needs to get going (for time: the video's
    # writer fails within a second, the synthetic sequence's after a few frames).
    if command == "video":
        (full_disk / "filler").write_bytes(b"\0" * (2 * 2**20))
        args = ["video", work / "clip.mp4", "-o", full_disk / "o.mp4", "--telemetry", full_disk / "old.csv",
                "--quiet"]
    elif command == "telemetry":
        (full_disk / "filler").write_bytes(b"\0" * (3 * 2**20 - 64 * 1024))
        args = ["video", work / "clip.mp4", "--telemetry", full_disk / "old.csv", "--quiet"]
    elif command == "image":
        args = ["image", TEST_IMAGES, "-o", full_disk / "out", "--stages", full_disk / "stages"]
    else:
        (full_disk / "filler").write_bytes(b"\0" * (3 * 2**20 - 128 * 1024))
        args = ["synth", "--frames", "30", "-o", full_disk / "s"]
    p = run_cli(*args)
    assert p.returncode == 2, (p.returncode, p.stderr[-2000:])
    line = assert_one_error_line(p, 2, "No space left on device")
    if command == "video":  # the video's writer or the telemetry's, whichever meets the full disk first
        assert "cannot write the video" in line or "cannot write the telemetry" in line, line
    if command == "synth":  # the video's writer, as frames flow
        assert "cannot write the video" in line, line
    assert (full_disk / "old.csv").read_text() == "old\n"
    left = sorted(str(f.relative_to(full_disk)) for f in full_disk.rglob("*") if f.is_file())
    assert left in (["old.csv"], ["filler", "old.csv"]), left


def test_a_writer_that_hits_a_full_disk_leaves_nothing(tmp_path, monkeypatch):
    from lanefinder import io as lio
    from lanefinder.telemetry import TelemetryWriter

    writer = TelemetryWriter(tmp_path / "t.jsonl")

    def full(*_a, **_k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(writer._f, "write", full)
    with pytest.raises(LaneFinderError, match="No space left on device"):
        writer.write({"frame": 0})
    assert list(tmp_path.iterdir()) == []
    # And a set whose commit fails leaves nothing half in place.
    monkeypatch.setattr(lio, "publish", full)
    with pytest.raises(LaneFinderError, match="No space left"), lio.OutputSet() as outs:
        outs.add(tmp_path / "a.txt").write_text("a")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_ctrl_c_twice_leaves_no_hidden_file(tmp_path):
    out, tele = tmp_path / "o.mp4", tmp_path / "t.csv"
    proc = subprocess.Popen([sys.executable, "-m", "lanefinder", "video", str(CLIP), "-o", str(out),
                             "--telemetry", str(tele), "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    deadline = time.time() + 60
    while time.time() < deadline and not any(f.stat().st_size > 100_000 for f in tmp_path.glob(".o.*")):
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert not list(tmp_path.glob(".*"))
    assert not out.exists() and not tele.exists()  # an interrupted run's outputs are partial: named so
    partial = tmp_path / "o.partial.mp4"
    if partial.exists():  # the first Ctrl-C finished the outputs before the second arrived
        assert VideoInfo.from_path(partial).total_frames == len(read_telemetry(tmp_path / "t.partial.csv"))


def test_an_odd_frame_size_is_padded_when_encoded(tmp_path):
    from lanefinder.video import VideoSink

    info = VideoInfo(width=641, height=361, fps=Fraction(25), total_frames=3, duration_s=0.12, codec="h264")
    with VideoSink(tmp_path / "o.mp4", info) as sink:
        for _ in range(3):
            sink.write(np.zeros((361, 641, 3), np.uint8))
    assert sink.padded and VideoInfo.from_path(tmp_path / "o.mp4").size == (642, 362)


def test_photos_without_a_board_are_passed_over_by_the_quick_look():
    import cv2

    from lanefinder.camera import board_visible

    # The quick look (about 60 ms a photo) sees no board in any road photo, and every Udacity board.
    assert not any(board_visible(cv2.imread(str(p), 0)) for p in sorted(TEST_IMAGES.glob("*.jpg")))
    assert all(board_visible(cv2.imread(str(p), 0)) for p in sorted(CAL.glob("*.jpg"))[:5])


def test_a_wrong_board_size_is_refused_quickly():
    from lanefinder.camera import calibrate

    # (Two photos: each shows a board, so the classic search for the wrong size runs to its end, ~0.8 s a photo.)
    with pytest.raises(LaneFinderError, match="no 7x7 chessboard was found in any of the 2 photos"):
        calibrate(sorted(CAL.glob("*.jpg"))[:2], (7, 7))


def test_partial_names_are_checked_before_any_work(tmp_path):
    from lanefinder import io as lio
    from lanefinder.errors import LaneFinderError

    (tmp_path / "a.partial.mp4").write_text("an input")
    with pytest.raises(LaneFinderError, match="which is an input"):
        lio.OutputSet(inputs=[tmp_path / "a.partial.mp4"], partial=True).add(tmp_path / "a.mp4")
    outs = lio.OutputSet(partial=True)
    outs.add(tmp_path / "t.csv")
    with pytest.raises(LaneFinderError, match="share a name"):
        outs.add(tmp_path / "t.partial.csv")
    outs.discard()
    # A set not made partial is never committed so.
    plain = lio.OutputSet()
    plain.add(tmp_path / "x.txt").write_text("x")
    with pytest.raises(LaneFinderError, match="not made to be kept as partial"):
        plain.commit(partial=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.partial.mp4"]


# -- every number of the config is bounded, and its bounds run in bounded time -----------------
def _bounds(annotation: object, metadata: list) -> list[tuple[object, object]]:
    """The (lower, upper) bounds of each number an annotation holds (tuples: each element's)."""
    from typing import Annotated, Literal, get_args, get_origin

    from annotated_types import Ge, Gt, Le, Lt

    if get_origin(annotation) is Literal:
        return []  # a choice among listed values is bounded by its list
    if get_origin(annotation) is Annotated:
        inner, *more = get_args(annotation)
        return _bounds(inner, [*metadata, *(m for x in more for m in getattr(x, "metadata", [x]))])
    if get_origin(annotation) is tuple:
        return [b for arg in get_args(annotation) for b in _bounds(arg, [])]
    if annotation not in (int, float):
        return []
    lo = hi = None
    for m in metadata:
        lo = m.gt if isinstance(m, Gt) else m.ge if isinstance(m, Ge) else lo
        hi = m.lt if isinstance(m, Lt) else m.le if isinstance(m, Le) else hi
    return [(lo, hi)]


def _numbers(model: object, prefix: str = ""):
    """Each numeric field of a config section (recursively): its path, value and the bounds of its numbers."""
    for name, field in type(model).model_fields.items():
        value = getattr(model, name)
        if hasattr(type(value), "model_fields"):
            yield from _numbers(value, f"{prefix}{name}.")
            continue
        bounds = _bounds(field.annotation, list(field.metadata))
        if bounds:
            yield f"{prefix}{name}", value, bounds


def _with(path: str, value: float) -> dict:
    section, _, key = path.rpartition(".")
    out: dict = {}
    node = out
    for part in section.split("."):
        node = node.setdefault(part, {})
    node[key] = value
    return out


NUMBERS = list(_numbers(config_from_dict({}, "defaults")))
#: The single numbers, with their bounds, that the bounded-time test sets.
SCALARS = [(p, v, *b[0]) for p, v, b in NUMBERS if isinstance(v, (int, float)) and not isinstance(v, bool)]


def test_every_number_of_the_config_is_bounded_both_ways():
    # An unbounded size once hung a run (threshold.ridge.width_m = 1e6: a window a kilometre wide)
    # or overflowed (search.margin_m = 1e308); a tiny step multiplied the work (heading_step_deg).
    unbounded = [p for p, _, bounds in NUMBERS if any(lo is None or hi is None for lo, hi in bounds)]
    assert not unbounded, f"config numbers without both bounds: {unbounded}"
    assert len(SCALARS) > 130 and any(p == "birdseye.src" for p, _, _ in NUMBERS)  # the walk sees them all


@pytest.mark.parametrize(("path", "value"), [("search.heading_step_deg", 1e-9), ("threshold.ridge.width_m", 1e6),
                                             ("search.margin_m", 1e308), ("search.peak_smoothing_m", 1e12),
                                             ("tracking.interior_strip_m", 1e-6), ("search.bend_step_per_m", 1e-9)])
def test_values_that_hung_or_crashed_a_run_are_refused(path, value):
    with pytest.raises(LaneFinderError, match=path.rpartition(".")[2]):
        config_from_dict(_with(path, value), "x")


@pytest.mark.slow
def test_every_config_number_at_its_bounds_runs_in_bounded_time():
    frame = cv2.resize(cv2.imread(str(TEST_IMAGES / "test3.jpg")), (640, 360))
    slow = []
    for path, value, lo, hi in SCALARS:
        # A still's own set-up (a look of 40-100 ms) depends on the selfcal numbers only: the others
        # are run without it (so they no longer go through a still's second look under another
        # set-up), which about halves this test and leaves the stage each number sets.
        base = {} if path.startswith("selfcal.") else {"selfcal": {"enabled": False}}
        for bound in (lo, hi):
            v = type(value)(bound) if isinstance(value, int) else float(bound)
            step = 1 if isinstance(value, int) else 1e-6 * max(1.0, abs(v))
            cfg = None  # an open bound is itself refused; a hair inside it is what a user could give
            for tried in (v, v + step if bound == lo else v - step):
                with contextlib.suppress(LaneFinderError):  # (or another setting's rule refuses it)
                    cfg = cfg or config_from_dict({**base, **_with(path, tried)}, "x")
            if cfg is None:
                continue
            t = time.perf_counter()
            try:
                finder = LaneFinder(cfg)
                finder.process_still(frame)
                finder.reset()
                for _ in range(3):
                    finder.process(frame)
            except LaneFinderError:
                pass
            if time.perf_counter() - t > 5.0:
                slow.append((path, bound, round(time.perf_counter() - t, 1)))
    assert not slow, f"settings that run for over 5 s on four small frames: {slow}"


@pytest.mark.parametrize("side", [17000, 60000])
def test_an_image_too_large_to_decode_is_one_clear_line_before_it_is_decoded(tmp_path, monkeypatch, side):
    # (cv2 is imported before lanefinder here, as in many notebooks: OpenCV's own limit, 2**30
    # pixels, would let 17000 x 17000 through)
    from lanefinder import io

    data = bytearray((TEST_IMAGES / "test1.jpg").read_bytes())
    sof = next(i for i in range(len(data) - 9) if data[i] == 0xFF and data[i + 1] in (0xC0, 0xC2))
    data[sof + 5:sof + 9] = side.to_bytes(2, "big") * 2  # the header claims side x side
    (tmp_path / "huge.jpg").write_bytes(bytes(data))
    monkeypatch.setattr(io.cv2, "imdecode", lambda *a: pytest.fail("decoded"))
    with pytest.raises(LaneFinderError, match="too large to decode"):
        io.read_image(tmp_path / "huge.jpg")


def test_an_image_over_the_memory_budget_is_refused_before_it_is_decoded(tmp_path, monkeypatch):
    from lanefinder import imagejob, io

    cv2.imwrite(str(tmp_path / "big.png"), np.zeros((3000, 4000), np.uint8))
    monkeypatch.setattr(io.cv2, "imdecode", lambda *a: pytest.fail("decoded"))
    assert io.image_size(tmp_path / "big.png") == (4000, 3000)
    run = imagejob.process_images([tmp_path / "big.png"], tmp_path / "out",
                                  config_from_dict({"limits": {"memory_mb": 64}}, "x"))
    assert not run.rows and "needs about" in run.failures[0][1]


def test_a_line_cut_short_is_named_by_its_line_number(tmp_path):
    path = tmp_path / "t.jsonl"
    path.write_text('{"frame": 0, "state": "lost"}\n{"frame": 1, "state": "lo')
    with pytest.raises(LaneFinderError, match=r"line 2, cut short"):
        read_telemetry(path)
    # (truth is checked as it is read: a first row that is truth, then the cut one)
    path.with_name("gt.jsonl").write_text('{"frame": 0, "h_samples": [700], "lanes": [[1]]}\n{"frame": 1, "h_sa')
    with pytest.raises(LaneFinderError, match=r"not JSON Lines \(line 2, cut short"):
        read_ground_truth(path.with_name("gt.jsonl"))
    from lanefinder.events import read_events

    with pytest.raises(LaneFinderError, match=r"line 2, cut short"):
        read_events(path)


def test_a_csv_row_with_fewer_values_than_its_header_is_refused(tmp_path):
    # (plot once drew an empty figure from it and exited 0); an empty value is not a missing one
    (tmp_path / "t.csv").write_text("frame,time_s,state,offset_m\n0,0.0,lost,\n1,2\n")
    with pytest.raises(LaneFinderError, match="row 2 has fewer values than the header"):
        read_telemetry(tmp_path / "t.csv")


def test_a_telemetry_csv_with_a_byte_order_mark_is_read(tmp_path):
    # (its first column was named "\ufeffframe": "each row needs raw_file (TuSimple) or frame")
    (tmp_path / "t.csv").write_text("\ufeffframe,time_s,state,offset_m\n0,0.0,lost,\n", encoding="utf-8")
    assert read_telemetry(tmp_path / "t.csv")[0]["frame"] == 0


@pytest.mark.parametrize("text", ['{"frame": 0, "left_x": [1, 2], "right_x": [3, 4]}\n', '\ufeff[{"frame": 0}]\n'])
def test_json_named_csv_is_called_json(tmp_path, text):
    # (its first record was read as a CSV header: "holds no predictions", or an empty plot)
    from lanefinder.evaluate import read_predictions

    (tmp_path / "p.csv").write_text(text)
    with pytest.raises(LaneFinderError, match=r"p.csv: holds JSON, not CSV: name it .jsonl"):
        read_predictions(tmp_path / "p.csv")


@pytest.mark.slow
@pytest.mark.parametrize("after_s", [0.05, 0.15, 0.3, 0.6])
def test_ctrl_c_while_starting_is_one_line(tmp_path, after_s):
    # (importing lanefinder once loaded OpenCV and NumPy first: a Ctrl-C in its first 0.3 s printed
    # a 24-line traceback from the imports; they now load inside the command, and a Ctrl-C while
    # the command line itself loads is caught by lanefinder._entry)
    # The time counts from when Python has started and runs `-m lanefinder` (as runpy does): a
    # Ctrl-C before that, in Python's own start (30-60 ms on a busy machine), or at once, while
    # runpy looks for the package, is Python's (a traceback from runpy or importlib: seen once
    # each), before any of lanefinder runs.
    start = ("import runpy, sys; print('started', flush=True); "
             "runpy.run_module('lanefinder', run_name='__main__', alter_sys=True)")
    proc = subprocess.Popen([sys.executable, "-c", start, "video", str(CLIP), "-o", str(tmp_path / "o.mp4"),
                             "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    if not select.select([proc.stdout], [], [], 60)[0]:  # bounded: a start that hangs fails the test
        proc.kill()
        proc.communicate(timeout=30)
        pytest.fail("python did not start within 60 s")
    assert proc.stdout.readline() == "started\n"
    time.sleep(after_s)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    # Before the run starts: one error line; once frames flow: the partial outputs, said on stdout.
    # (Exit status 130, or death by SIGINT after the line, which a shell shows as 130 too.)
    assert proc.returncode in (130, -signal.SIGINT) and "Traceback" not in err, err
    assert err.strip() in ("lanefinder: error: interrupted", "") and (err.strip() or "interrupted:" in out), (out, err)
    assert not list(tmp_path.glob(".*"))


def test_ctrl_c_wrapped_while_a_class_loads_is_one_line(monkeypatch, capsys):
    # (`make test` once caught a Ctrl-C at 0.05 s inside ipaddress's class body: Python wraps it as
    # "RuntimeError: Error calling __set_name__", caused by the KeyboardInterrupt, and it printed a traceback)
    import builtins

    from lanefinder import _entry

    real_import = builtins.__import__

    def loading(name, globals=None, locals=None, fromlist=(), level=0):
        if name == "cli" and level == 1:
            try:
                raise KeyboardInterrupt
            except KeyboardInterrupt as k:
                raise RuntimeError("Error calling __set_name__ on 'cached_property' instance") from k
        return real_import(name, globals, locals, fromlist, level)

    monkeypatch.setattr(builtins, "__import__", loading)
    with pytest.raises(SystemExit) as exit_:
        _entry.main()
    assert exit_.value.code == 130 and capsys.readouterr().err == "lanefinder: error: interrupted\n"
    assert not _entry._caused_by_ctrl_c(RuntimeError("another"))


# -- found by a second bad-input campaign (2026-11-27): the library's functions called with what they do not take


def test_functions_given_what_they_do_not_take_say_so(tmp_path):
    from lanefinder.events import detect_events
    from lanefinder.imagejob import process_images
    from lanefinder.stats import check_counts, curves, video_stats
    from lanefinder.videojob import process_video

    calls = [
        (lambda: process_video(CLIP, None, telemetry=tmp_path / "t.csv", max_frames=0), "max_frames must be"),
        (lambda: process_video(CLIP, None, telemetry=tmp_path / "t.csv", start_s="0"), "start_s must be a number"),
        (lambda: process_video(CLIP, None, {}, telemetry=tmp_path / "t.csv"), "config must be a lanefinder Config"),
        (lambda: process_images(str(CLIP), tmp_path / "o"), "give \\[path\\] for one image"),
        (lambda: detect_events(None, 25.0), "rows must be a list"),
        # rows read_telemetry gives from files edited by hand (these raised TypeError, AttributeError, KeyError)
        (lambda: curves([{"time_s": None, "curvature_per_m": 0.01, "radius_m": 100.0}]), "time_s is missing"),
        (lambda: check_counts([{"checks": ["left-jump"]}]), "checks must be text"),
        (lambda: video_stats([{"left_found": True, "right_found": True}]), "has no state"),
    ]
    for call, says in calls:
        with pytest.raises(LaneFinderError, match=says):
            call()
    assert not list(tmp_path.iterdir())


def test_a_lens_too_wide_for_a_still_s_own_setup_gives_no_lane_not_an_error():
    # A 172-degree lens (focal_px 37 over 1280 px) is allowed; the still's own set-up then made an
    # invalid trapezoid and raised pydantic's ValidationError (an internal error on the command line).
    cfg = config_from_dict({"camera": {"model": "none", "focal_px": 37}}, "f37")
    r = LaneFinder(cfg).process_still(cv2.imread(str(TEST_IMAGES / "test3.jpg")))
    assert r.setup in ("default", "horizon", "lines")


def test_a_camera_that_sees_no_road_is_refused_by_synth(tmp_path):
    from lanefinder.camera import CameraModel
    from lanefinder.synth import write_sequence

    tele = CameraModel(np.array([[9000.0, 0, 160], [0, 9000.0, 90], [0, 0, 1]]), np.zeros(5), (320, 180))
    with pytest.raises(LaneFinderError, match="no road is in view"):  # was an OpenCV assertion
        write_sequence("straight", 2, tmp_path / "s", seed=0, camera=tele)


def test_the_largest_video_stream_is_read(tmp_path):
    from lanefinder.video import VideoInfo, frames

    path = tmp_path / "two.mp4"  # a small black preview first, the road second
    road = [f.image for _, f in zip(range(5), frames(CLIP), strict=False)]
    with av.open(str(path), "w") as c:
        small, big = c.add_stream("libx264", rate=25), c.add_stream("libx264", rate=25)
        small.width, small.height, big.width, big.height = 320, 180, 1280, 720
        for img in road:
            for st, im in ((small, np.zeros((180, 320, 3), np.uint8)), (big, img)):
                for packet in st.encode(av.VideoFrame.from_ndarray(im, format="bgr24")):
                    c.mux(packet)
        for st in (small, big):
            for packet in st.encode():
                c.mux(packet)
    assert VideoInfo.from_path(path).size == (1280, 720)
    got = [f.image for f in frames(path)]
    assert len(got) == 5 and got[0].shape == (720, 1280, 3) and got[0].mean() > 30


@pytest.mark.parametrize(("rotation", "size", "block_at"), [(180, (320, 180), (160, 290)), (90, (180, 320), (290, 20)),
                                                             (-90, (180, 320), (30, 160))])
def test_a_video_s_rotation_metadata_is_applied(tmp_path, rotation, size, block_at):
    # (an upside-down recording with its rotation in the file was read upside down: no lane on any frame)
    from lanefinder.video import VideoInfo, frames

    img = np.zeros((180, 320, 3), np.uint8)
    img[:40, :60] = 255  # a block in the stored frame's top-left corner
    path = tmp_path / "r.mp4"
    with av.open(str(path), "w") as c:
        st = c.add_stream("libx264", rate=25)
        st.width, st.height = 320, 180
        st.set_display_rotation(rotation)  # shown turned this many degrees counter-clockwise
        for _ in range(3):
            for packet in st.encode(av.VideoFrame.from_ndarray(img, format="bgr24")):
                c.mux(packet)
        for packet in st.encode():
            c.mux(packet)
    assert VideoInfo.from_path(path).size == size
    shown = next(frames(path)).image
    ys, xs = np.nonzero(shown[..., 0] > 128)
    assert shown.shape[:2] == size[::-1] and (round(ys.mean()), round(xs.mean())) == block_at
