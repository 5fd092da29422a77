"""lanefinder batch: a fleet on Dask (local cluster, a scheduler and worker started as processes),
failure isolation, segment stitching against a sequential run, resume after a kill, fsspec URLs."""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow.dataset as ds
import pyarrow.parquet as pq
import pytest

from lanefinder import Config
from lanefinder.batch import find_inputs, plan_segments, run_batch
from lanefinder.telemetry import read_telemetry
from lanefinder.videojob import process_video

from clirun import run_lanefinder
from conftest import CLIPS, remux

pytestmark = pytest.mark.slow

PROJECT = CLIPS / "project_37-47s.mp4"
CHALLENGE = CLIPS / "challenge_3-7s.mp4"
HARDER = CLIPS / "harder_challenge_0-4s.mp4"
#: For the plumbing tests (URLs, a scheduler of its own, a killed run): no self-calibration, which
#: on these short clips would look at every 4th frame and cost four times the lane finding.
PLUMBING = Config.model_validate({"selfcal": {"enabled": False}})


def _plumbing_toml(folder: Path) -> str:
    path = folder / "plumbing.toml"
    path.write_text("[selfcal]\nenabled = false\n")
    return str(path)
# Short segments, so the 10 s project clip is cut in four and stitched.
# Self-calibration off: the segments of a split video would each calibrate on their own (see
# the README's limitations); these tests are about cutting and stitching.
SPLIT = Config.model_validate({"batch": {"segment_s": 3.0, "warmup_s": 2.0}, "selfcal": {"enabled": False}})
CLI = [sys.executable, "-m", "lanefinder"]


def rows_of(outdir: Path, video: str) -> list[dict]:
    table = ds.dataset(outdir / "telemetry", format="parquet", partitioning="hive").to_table()
    return [r for r in table.sort_by("frame").to_pylist() if r.pop("video") == video]


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    d = tmp_path_factory.mktemp("fleet")
    inputs = d / "in"
    (inputs / "day2").mkdir(parents=True)
    shutil.copy(PROJECT, inputs / "project.mp4")
    shutil.copy(CHALLENGE, inputs / "day2" / "challenge.mp4")
    (inputs / "day2" / "broken.mp4").write_bytes(b"\x00not a video" * 500)
    report = run_batch([inputs], d / "out", SPLIT, workers=2, progress=False)
    return d, report


def test_a_fleet_on_two_local_workers_isolates_the_broken_video(fleet):
    d, report = fleet
    assert (report.videos, report.done, report.failed) == (3, 2, 1)
    summary = {r["video"]: r for r in pq.read_table(d / "out" / "summary.parquet").to_pylist()}
    assert summary["broken"]["status"] == "failed" and "cannot open video" in summary["broken"]["error"]
    assert summary["project"]["frames"] == 250 and summary["project"]["pct_lane"] == 100.0
    # Without self-calibration the default set-up reads the challenge camera's lanes as about 2.9 m.
    assert summary["challenge"]["status"] == "done" and 2.6 < summary["challenge"]["mean_width_m"] < 3.1
    assert (d / "out" / "summary.csv").read_text().splitlines()[0].startswith("video,input,status,error,frames")
    assert pq.read_table(d / "out" / "events.parquet").column_names[:2] == ["video", "kind"]


def test_stitched_segments_match_a_sequential_run(fleet, tmp_path):
    d, _ = fleet
    process_video(PROJECT, None, SPLIT, telemetry=tmp_path / "seq.parquet", progress=False)
    seq, got = read_telemetry(tmp_path / "seq.parquet"), rows_of(d / "out", "project")
    assert [r["frame"] for r in got] == list(range(250))  # every frame once: the warm-up overlap dropped
    # Measured: with a 2 s warm-up every row of the project clip is identical to the sequential run's.
    assert [r["state"] for r in got] == [r["state"] for r in seq]
    offsets = np.array([[a["offset_m"], b["offset_m"]] for a, b in zip(seq, got, strict=True)], float)
    assert np.abs(offsets[:, 0] - offsets[:, 1]).max() < 0.01


def test_a_rerun_skips_what_is_done_and_retries_what_failed(fleet):
    d, _ = fleet
    again = run_batch([d / "in"], d / "out", SPLIT, workers=1, progress=False)
    assert (again.done, again.skipped, again.failed, again.redone_failed, again.frames) == (0, 2, 1, 1, 0)
    changed = run_batch([d / "in" / "day2" / "challenge.mp4"], d / "out",
                        SPLIT.model_copy(update={"batch": SPLIT.batch.model_copy(update={"warmup_s": 1.0})}),
                        workers=1, progress=False)
    assert (changed.done, changed.redone_changed) == (1, 1)
    frames = [r["frame"] for r in rows_of(d / "out", "challenge")]
    summary = {r["video"]: r for r in pq.read_table(d / "out" / "summary.parquet").to_pylist()}
    assert len(frames) == len(set(frames)) == summary["challenge"]["frames"] > 100


def test_inputs_from_folders_and_lists_and_segment_plans(tmp_path):
    lst = tmp_path / "videos.txt"
    lst.write_text(f"# fleet\n{PROJECT}\n\n{CHALLENGE.name}\n")
    shutil.copy(CHALLENGE, tmp_path / CHALLENGE.name)
    assert find_inputs([lst]) == [str(PROJECT), str(tmp_path / CHALLENGE.name)]
    segs = plan_segments("v", "v.mp4", 3600.0, 25.0, 120.0, 4.0)
    assert len(segs) == 30 and segs[1].run_from_s == 116.0 and segs[-1].end_s is None


def test_memory_and_file_urls(tmp_path):
    import fsspec

    fs = fsspec.filesystem("memory")
    fs.pipe("/fleet/in/harder.mp4", HARDER.read_bytes())
    report = run_batch(["memory://fleet/in"], "memory://fleet/out", PLUMBING, workers=1, progress=False)
    assert (report.done, report.failed) == (1, 0)
    summary = pq.read_table("fleet/out/summary.parquet", filesystem=fs).to_pylist()
    assert summary[0]["video"] == "harder" and summary[0]["frames"] == 100
    parts = fs.ls("/fleet/out/telemetry/video=harder", detail=False)
    assert parts and not fs.exists("/fleet/out/.staging")
    # A damaged part is noticed on a re-run (its footer is read), and the video redone.
    fs.pipe(parts[0], b"garbage")
    again = run_batch(["memory://fleet/in"], "memory://fleet/out", PLUMBING, workers=1, progress=False)
    assert (again.done, again.skipped, again.redone_changed) == (1, 0, 1)
    assert pq.read_table("/fleet/out/telemetry", filesystem=fs).num_rows == 100
    fs.rm("/fleet", recursive=True)
    url = run_batch([f"file://{HARDER}"], f"file://{tmp_path}/out", PLUMBING, workers=1, progress=False)
    assert url.done == 1 and (tmp_path / "out" / "telemetry" / "video=harder_challenge_0-4s").is_dir()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait(cond, seconds: float) -> bool:
    deadline = time.time() + seconds
    while time.time() < deadline:
        if cond():
            return True
        time.sleep(0.1)
    return False


def test_batch_on_a_scheduler_and_worker_started_as_processes(tmp_path):
    port = _free_port()
    bin_dir = Path(sys.executable).parent
    addr = f"tcp://127.0.0.1:{port}"
    procs = [subprocess.Popen([str(bin_dir / "dask"), "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        procs.append(subprocess.Popen([str(bin_dir / "dask"), "worker", addr, "--nworkers", "1", "--nthreads", "1",
                                       "--host", "127.0.0.1", "--no-dashboard"],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from distributed import Client

        with Client(addr, timeout="30s") as c:
            assert _wait(lambda: len(c.scheduler_info()["workers"]) == 1, 60)
        out = subprocess.run([*CLI, "batch", str(HARDER), "-o", str(tmp_path / "out"), "--scheduler", addr,
                              "--quiet", "-c", _plumbing_toml(tmp_path)], capture_output=True, text=True, timeout=120)
        assert out.returncode == 0, out.stderr
        assert "1 video: 1 processed" in out.stdout
        assert len(rows_of(tmp_path / "out", "harder_challenge_0-4s")) == 100
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


def _three_clips(tmp_path: Path) -> Path:
    """A folder of three copies of the harder challenge clip (100 frames each)."""
    inputs = tmp_path / "in"
    inputs.mkdir()
    for name in ("a", "b", "c"):
        shutil.copy(HARDER, inputs / f"{name}.mp4")
    return inputs


def test_a_killed_batch_resumes_without_duplicate_rows(tmp_path):
    inputs = _three_clips(tmp_path)
    out = tmp_path / "out"
    manifest = out / "manifest.json"

    def finished() -> int:
        try:
            return sum(v["status"] == "done" for v in json.loads(manifest.read_text())["videos"].values())
        except (OSError, ValueError, KeyError):
            return 0

    cfg = _plumbing_toml(tmp_path)
    proc = subprocess.Popen([*CLI, "batch", str(inputs), "-o", str(out), "--workers", "1", "--quiet", "-c", cfg],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        assert _wait(lambda: finished() >= 1, 120)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate(timeout=30)
    done_before = finished()
    assert 1 <= done_before < 3
    again = subprocess.run([*CLI, "batch", str(inputs), "-o", str(out), "--workers", "1", "--quiet", "-c", cfg],
                           capture_output=True, text=True, timeout=180)
    assert again.returncode == 0, again.stderr
    assert f"3 videos: {3 - done_before} processed, {done_before} skipped" in again.stdout
    table = ds.dataset(out / "telemetry", format="parquet", partitioning="hive").to_table()
    keys = list(zip(table["video"].to_pylist(), table["frame"].to_pylist(), strict=True))
    assert len(keys) == len(set(keys)) == 300


def test_ctrl_c_stops_a_batch_in_one_line(tmp_path):
    inputs = _three_clips(tmp_path)
    out = tmp_path / "out"
    (tmp_path / "split.toml").write_text("[batch]\nsegment_s = 1.0\nwarmup_s = 0.5\n")  # 4 segments a video
    proc = subprocess.Popen([*CLI, "batch", str(inputs), "-o", str(out), "--workers", "2", "--quiet",
                             "-c", str(tmp_path / "split.toml")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        # Stopped once a video has parts staged (some of its segments done, not all).
        assert _wait(lambda: any(out.glob(".staging/*/part-*.parquet")), 120)
        os.killpg(proc.pid, signal.SIGINT)  # as a terminal's Ctrl-C: to every process of the group
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate(timeout=30)
    # Before: each local worker died printing a traceback, and so did distributed's clean-up.
    assert proc.returncode == 130, err
    assert err.strip().splitlines() == ["lanefinder: error: interrupted"], err
    # The parts of the videos not finished are gone (a query of telemetry/ never saw them; a re-run redoes them).
    assert not (out / ".staging").exists() and not list(out.glob("telemetry/.*"))


def test_bad_batch_inputs_are_one_line(tmp_path):
    out = run_lanefinder("batch", str(tmp_path / "missing"), "-o", str(tmp_path / "o"), timeout=60)
    assert out.returncode == 2 and out.stderr.strip().splitlines() == [
        f"lanefinder: error: input not found: {tmp_path / 'missing'}"]
    (tmp_path / "file").write_text("x")
    out = run_lanefinder("batch", str(HARDER), "-o", str(tmp_path / "file"), timeout=60)
    assert out.returncode == 2 and "the output folder is a file" in out.stderr


def _cut_mkv(src: Path, dst: Path, fraction: float) -> None:
    """Remux to Matroska (which states the duration up front) and cut the file short."""
    whole = dst.with_suffix(".whole.mkv")
    remux(src, whole)
    data = whole.read_bytes()
    dst.write_bytes(data[: int(len(data) * fraction)])
    whole.unlink()


def test_a_video_cut_short_gives_the_frames_that_could_be_read(tmp_path):
    (tmp_path / "in").mkdir()
    _cut_mkv(PROJECT, tmp_path / "in" / "cut.mkv", 0.5)
    cfg = Config.model_validate({"batch": {"segment_s": 2.0, "warmup_s": 1.0}})
    report = run_batch([tmp_path / "in"], tmp_path / "out", cfg, workers=1, progress=False)
    assert (report.done, report.failed) == (1, 0)
    summary = pq.read_table(tmp_path / "out" / "summary.parquet").to_pylist()[0]
    assert summary["truncated"] and 60 < summary["frames"] < 200
    frames = [r["frame"] for r in rows_of(tmp_path / "out", "cut")]
    assert frames == sorted(set(frames)) and frames[0] == 0


def test_the_summary_s_setup_is_the_one_the_run_started_from(tmp_path):
    from lanefinder.batch import _EVENT_COLUMNS, _summarise
    from lanefinder.camera import CameraModel, save_camera
    from lanefinder.pipeline import birdseye_config_used, camera_from_config

    save_camera(CameraModel.ideal((1280, 720), hfov_deg=90.0), tmp_path / "wide.json")
    empty = {"columns": {k: [] for k in _EVENT_COLUMNS}, "both_found": 0, "damaged": 0, "truncated": False,
             "seconds": 1.0}
    for cfg in (Config(), Config.model_validate({"camera": {"model": str(tmp_path / "wide.json")}})):
        setup = json.loads(_summarise([empty], 25.0, cfg, (1280, 720))[0]["setup"])
        used = birdseye_config_used(cfg, camera_from_config(cfg, (1280, 720)), (1280, 720))
        assert setup["src"] == [list(p) for p in used.src]  # for another lens, its nominal set-up
    assert used.src != Config().birdseye.src


def test_odd_file_names_and_lists_and_an_output_inside_the_input(tmp_path):
    # A bad-input campaign: a legal 250-character name failed its video ("File name too long" for
    # OUT/.staging/video=<id>); a name in another script became the id "_"; a list saved with a
    # byte-order mark lost its first video; and with the output folder inside the input folder,
    # the re-run of a `--video` batch found its own output video and refused.
    from lanefinder.batch import _video_ids

    long_name, other = "x" * 250, "日本語"
    ids = _video_ids([f"/v/{long_name}.mp4", f"/v/{other}.mp4", "/w/ünï cödé.mp4"], {})
    assert len(ids[f"/v/{long_name}.mp4"]) <= 130 and ids[f"/v/{long_name}.mp4"].startswith("x" * 120 + "-")
    assert ids[f"/v/{other}.mp4"].startswith("video-") and ids["/w/ünï cödé.mp4"] == "_n_c_d_"
    clash = _video_ids(["/v/a.mp4", "/w/a.mp4"], {})  # a clash: the second takes its path's tag, as before
    assert clash["/v/a.mp4"] == "a" and len(clash["/w/a.mp4"]) == 8 and clash["/w/a.mp4"].startswith("a-")

    src = tmp_path / "in"
    (src / "out" / "videos").mkdir(parents=True)
    shutil.copy(CLIPS / "challenge_3-7s.mp4", src / "a.mp4")
    shutil.copy(CLIPS / "challenge_3-7s.mp4", src / "out" / "videos" / "a.mp4")  # what --video wrote
    assert [Path(p).name for p in find_inputs([src], skip=src / "out")] == ["a.mp4"]
    assert len(find_inputs([src])) == 2
    listing = tmp_path / "list.txt"
    listing.write_bytes(b"\xef\xbb\xbf" + str(src / "a.mp4").encode() + b"\r\n")
    assert find_inputs([listing]) == [str(src / "a.mp4")]
