"""lanefinder speed benchmark: per-stage times, end-to-end fps, the decode+encode floor, a naive baseline.

    python benchmarks/bench.py [--clip data/clips/project_37-47s.mp4] [--frames 250] [--json output/bench.json]
                               [--memory PATH_TO_LONG_VIDEO]

Per-frame stages run on one core (cv2.setNumThreads(1)) over every frame of the clip; the
table gives the median and p90 ms per frame.  End to end, `lanefinder video` (threads for
decode, processing and encode) is timed against a bare decode+encode loop with the same
encoder settings, in the same run.  With --memory, the resident set size is sampled while a
long video is processed, to show it stays flat.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from lanefinder.config import Config  # noqa: E402
from lanefinder.geometry import fit_lane  # noqa: E402
from lanefinder.pipeline import LaneFinder  # noqa: E402
from lanefinder.render import annotate  # noqa: E402
from lanefinder.search import Pixels, blind_search, search_around  # noqa: E402
from lanefinder.threshold import threshold  # noqa: E402
from lanefinder.video import VideoInfo, VideoSink, frames  # noqa: E402
from lanefinder.videojob import process_video  # noqa: E402
from naive import NaivePipeline  # noqa: E402


def _stats(ms: list[float]) -> dict:
    a = np.asarray(ms)
    return {"median_ms": float(np.median(a)), "p90_ms": float(np.percentile(a, 90)), "fps": 1000 / float(np.median(a))}


def _timed(fn, items) -> list[float]:
    out = []
    for it in items:
        t = time.perf_counter()
        fn(it)
        out.append((time.perf_counter() - t) * 1000)
    return out


def rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def bare_loop(clip: Path, out: Path, cfg: Config, n: int) -> float:
    """fps of decode + H.264 encode with the same settings and nothing else."""
    info = VideoInfo.from_path(clip)
    t = time.perf_counter()
    count = 0
    with VideoSink(out, info, cfg.video.preset, cfg.video.crf, cfg.video.threads) as sink:
        for f in frames(clip, threads=cfg.video.threads):
            sink.write(f.image)
            count += 1
            if count >= n:
                break
    return count / (time.perf_counter() - t)


def decode_loop(clip: Path, n: int) -> float:
    """fps of a bare PyAV decode to BGR arrays (what the pipeline is given), nothing else."""
    t = time.perf_counter()
    count = 0
    for _ in frames(clip):
        count += 1
        if count >= n:
            break
    return count / (time.perf_counter() - t)


def bench_batch() -> dict:
    """Fleet fps of `lanefinder batch` over 8 clips with 1 and 2 local workers (telemetry only)."""
    import shutil

    from lanefinder.batch import run_batch

    clips = sorted((ROOT / "data" / "clips").glob("*.mp4"))
    out: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        fleet = Path(tmp) / "fleet"
        fleet.mkdir()
        for i in range(8):
            shutil.copy(clips[i % len(clips)], fleet / f"clip{i}.mp4")
        for workers in (1, 2):
            r = run_batch([fleet], Path(tmp) / f"out{workers}", workers=workers, progress=False)
            out[f"workers_{workers}"] = {"frames": r.frames, "seconds": r.seconds, "fps": r.frames / r.seconds}
    one, two = out["workers_1"]["fps"], out["workers_2"]["fps"]
    out["scaling_2_over_1"] = two / one
    print(f"batch over 8 clips ({out['workers_1']['frames']} frames, wall time incl. cluster start): "
          f"1 worker {one:.1f} fps, 2 workers {two:.1f} fps, scaling {two / one:.2f}x")
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--clip", type=Path, default=ROOT / "data" / "clips" / "project_37-47s.mp4")
    ap.add_argument("--frames", type=int, default=250)
    ap.add_argument("--json", type=Path, default=ROOT / "output" / "bench.json")
    ap.add_argument("--memory", type=Path, help="a long video to watch memory on (e.g. the project video)")
    ap.add_argument("--repeat", type=int, default=3, help="end-to-end runs; the best is kept")
    ap.add_argument("--no-batch", action="store_true", help="skip the fleet benchmark (8 clips on 1 and 2 workers)")
    a = ap.parse_args()
    cfg = Config()
    report: dict = {"clip": str(a.clip), "cpu_count": os.cpu_count(), "preset": cfg.video.preset, "crf": cfg.video.crf}

    # -- decode (all threads, as in the real run) -------------------------------------------
    t = time.perf_counter()
    imgs = [f.image for _, f in zip(range(a.frames), frames(a.clip), strict=False)]
    decode_ms = (time.perf_counter() - t) * 1000 / len(imgs)
    n = len(imgs)
    print(f"{n} frames of {a.clip.name}, {imgs[0].shape[1]}x{imgs[0].shape[0]}")

    # -- per-frame stages on one core -----------------------------------------------------------
    cv2.setNumThreads(1)
    finder = LaneFinder(cfg)
    be = finder.birdseye((imgs[0].shape[1], imgs[0].shape[0]))
    sp, fp = finder.measurer.search, finder.measurer.fit
    warped = [be.warp(im) for im in imgs]
    binaries = [threshold(w, cfg.threshold, be.xm_per_px) for w in warped]
    results = []
    for im in imgs:
        results.append(finder.process(im))
    stages: dict[str, list[float]] = {}
    stages["remap (undistort+warp)"] = _timed(be.warp, imgs)
    stages["threshold"] = _timed(lambda w: threshold(w, cfg.threshold, be.xm_per_px), warped)

    def search(i: int):
        px = Pixels.of(binaries[i])
        r = results[i - 1] if i else None
        if r is not None and r.lane_found:
            return search_around(binaries[i], r.left.fit_px, r.right.fit_px, sp.around_margin_px, px)
        return blind_search(binaries[i], sp, be.car_x_px, px)

    found = [search(i) for i in range(n)]
    stages["search"] = _timed(search, range(n))
    stages["fit"] = _timed(lambda s: fit_lane((s.left.x, s.left.y), (s.right.x, s.right.y), be.size[1], fp), found)
    copies = [im.copy() for im in imgs]
    stages["render"] = _timed(lambda i: annotate(copies[i], results[i], be, cfg.render, inplace=True), range(n))
    tracker_finder = LaneFinder(cfg)
    tracker_finder.birdseye(be.frame_size)
    stages["search+fit+track (pipeline)"] = _timed(lambda b: tracker_finder.process_binary(b, be), binaries)
    far_finder = LaneFinder(cfg)
    far_finder.birdseye(be.frame_size)
    stages["far field (remap+threshold+follow)"] = _timed(lambda i: far_finder.extend_far(imgs[i], results[i], be),
                                                          range(n))
    whole = LaneFinder(cfg)
    whole.birdseye(be.frame_size)
    copies = [im.copy() for im in imgs]
    stages["per-frame total: frame in -> result + overlay"] = _timed(
        lambda im: annotate(im, whole.process(im), be, cfg.render, inplace=True), copies)

    # -- encode alone -----------------------------------------------------------------------
    cv2.setNumThreads(0)
    with tempfile.TemporaryDirectory() as tmp:
        info = VideoInfo.from_path(a.clip)
        t = time.perf_counter()
        with VideoSink(Path(tmp) / "enc.mp4", info, cfg.video.preset, cfg.video.crf, cfg.video.threads) as sink:
            for im in imgs:
                sink.write(im)
        encode_ms = (time.perf_counter() - t) * 1000 / n

        # -- naive baseline, same frames, one core ----------------------------------------------
        cv2.setNumThreads(1)
        naive = NaivePipeline(be.camera.camera_matrix, be.camera.dist_coeffs, be.src_px)
        naive_ms = _timed(naive.process, imgs[: min(n, 100)])
        cv2.setNumThreads(0)

        # -- end to end vs the decode+encode floor, same run ---------------------------------
        e2e, floor = [], []
        for _ in range(a.repeat):
            floor.append(bare_loop(a.clip, Path(tmp) / "bare.mp4", cfg, n))
            s = process_video(a.clip, Path(tmp) / "e2e.mp4", cfg, progress=False, max_frames=n)
            e2e.append(s.fps)
        # -- telemetry only (no video written) vs a bare PyAV decode loop, same run ------------------
        tele, decode_only = [], []
        for _ in range(a.repeat):
            decode_only.append(decode_loop(a.clip, n))
            s = process_video(a.clip, None, cfg, telemetry=Path(tmp) / "t.parquet", progress=False, max_frames=n)
            tele.append(s.fps)
    e2e_fps, floor_fps = max(e2e), max(floor)
    tele_fps, decode_fps = max(tele), max(decode_only)

    print(f"\n{'stage':<46} {'median ms':>10} {'p90 ms':>8} {'fps':>8}")
    rows = {"decode (threaded)": {"median_ms": decode_ms, "p90_ms": float("nan"), "fps": 1000 / decode_ms}}
    rows.update({k: _stats(v) for k, v in stages.items()})
    rows["encode (x264, threaded)"] = {"median_ms": encode_ms, "p90_ms": float("nan"), "fps": 1000 / encode_ms}
    rows["naive baseline per frame (one core)"] = _stats(naive_ms)
    for k, v in rows.items():
        print(f"{k:<46} {v['median_ms']:>10.3f} {v['p90_ms']:>8.3f} {v['fps']:>8.1f}")
    total = rows["per-frame total: frame in -> result + overlay"]["median_ms"]
    speedup = rows["naive baseline per frame (one core)"]["median_ms"] / total
    print(f"\nper-frame pipeline: {total:.3f} ms median on one core (target <= 2.5 ms); "
          f"{speedup:.1f}x faster than the naive baseline")
    print(f"end to end `lanefinder video`: {e2e_fps:.1f} fps (best of {a.repeat}: "
          f"{', '.join(f'{x:.1f}' for x in e2e)})")
    print(f"bare decode+encode loop ({cfg.video.preset}, crf {cfg.video.crf}): {floor_fps:.1f} fps "
          f"(best of {a.repeat}: {', '.join(f'{x:.1f}' for x in floor)})")
    print(f"ratio to the floor: {e2e_fps / floor_fps:.2f} (target >= 0.8)")
    print(f"telemetry only (`lanefinder video IN --telemetry T.parquet`): {tele_fps:.1f} fps; bare PyAV decode "
          f"loop: {decode_fps:.1f} fps; ratio {tele_fps / decode_fps:.2f} (target >= 0.8)")
    report.update({"telemetry_only_fps": tele_fps, "decode_only_fps": decode_fps,
                   "telemetry_ratio_to_decode": tele_fps / decode_fps})
    if not a.no_batch:
        report["batch"] = bench_batch()
    report.update({"stages": rows, "per_frame_ms": total, "naive_speedup": speedup, "end_to_end_fps": e2e_fps,
                   "floor_fps": floor_fps, "ratio_to_floor": e2e_fps / floor_fps, "end_to_end_runs": e2e,
                   "floor_runs": floor})

    if a.memory:
        import gc

        del imgs, copies, warped, binaries, results, found
        gc.collect()
        samples: list[tuple[int, float]] = []

        def watch(frame_index: int, _result) -> None:
            if frame_index % 100 == 0:
                samples.append((frame_index, rss_mb()))

        with tempfile.TemporaryDirectory() as tmp:
            process_video(a.memory, Path(tmp) / "m.mp4", cfg, progress=False, on_result=watch)
        print("\nresident memory while processing", a.memory.name)
        for i, mb in samples:
            print(f"  frame {i:5d}: {mb:7.1f} MB")
        growth = samples[-1][1] - samples[1][1] if len(samples) > 2 else float("nan")
        print(f"growth from frame {samples[1][0]} to {samples[-1][0]}: {growth:+.1f} MB")
        report["memory_mb"] = samples

    a.json.parent.mkdir(parents=True, exist_ok=True)
    a.json.write_text(json.dumps(report, indent=2) + "\n")
    print(f"\nwrote {a.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
