"""Single stills against the tracked video: does `lanefinder image` (blind, no history) agree? (`make stills`)

    python scripts/stills_vs_video.py [--videos DIR] [--every-s 1.0] [--offset-s S]
                                      [--json output/stills/report.json] [--config FILE]

For each of the three Udacity videos: the video is run once with tracking (telemetry only);
then one frame a second (the middle frame of each second, about 0.5 s, 1.5 s, ...; `--offset-s`
moves them, to choose a setting on other stills than those reported) is found again as a still,
blind, with no history, exactly as `lanefinder image` does. The tracked video's two lines are the reference
(frames where the video shows no lane are left out and counted). A still *agrees* when each
of the video's lines is matched by one of the still's lines by TuSimple's rule (20 px / cos(angle)
per row, 85% of the rows), over the TuSimple rows where the video has the line. The table gives
per video: stills compared, stills with a lane, stills that agree, and the mean TuSimple accuracy;
the JSON report also lists every still (frame, time, whether the video measured each of its
lines there or drew it inferred or held, and per set-up: lane, agreement, accuracy, the set-up
used and the checks that fired).

Each still is found twice: with the default set-up (`lanefinder image` with no config, as a
user with an unknown camera would run it) and with the camera's own set-up (`lanefinder setup
--video` on that video with the Udacity camera file, then `lanefinder image -c`): the challenge
video's camera is mounted differently from the default's.

The videos are what the project was tuned on; the stills are the same footage seen without
history, so this measures the blind path, not generalisation to new roads.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from pathlib import Path

from lanefinder.autosetup import SetupOptions, auto_setup, straight_frames_from_video
from lanefinder.camera import udacity_camera
from lanefinder.config import Config, load_config
from lanefinder.errors import LaneFinderError
from lanefinder.evaluate import bench_frame
from lanefinder.pipeline import LaneFinder
from lanefinder.telemetry import BlownOut, h_samples, lane_row, read_telemetry
from lanefinder.video import VideoInfo, frames
from lanefinder.videojob import process_video

ROOT = Path(__file__).resolve().parents[1]
VIDEOS = ("project_video", "challenge_video", "harder_challenge_video")
TARGETS = {"project_video": 0.95, "challenge_video": 0.95, "harder_challenge_video": 0.80}


def own_setup(src: Path, cfg: Config) -> Config:
    """The config with the set-up `lanefinder setup --video SRC --camera <Udacity>` finds."""
    found = auto_setup(straight_frames_from_video(src, SetupOptions()), udacity_camera(), camera_ref="udacity")
    own = found.config()
    return cfg.model_copy(update={"camera": own.camera, "birdseye": own.birdseye})


def tracked(src: Path, cfg: Config) -> dict[int, dict]:
    """The tracked video's telemetry rows by frame (the reference), run telemetry only."""
    with tempfile.TemporaryDirectory() as tmp:
        tele = Path(tmp) / "t.jsonl"
        process_video(src, None, cfg, telemetry=tele, progress=False)
        return {r["frame"]: r for r in read_telemetry(tele)}


def still_row(finder: LaneFinder, image):
    """Find one still blind; give its result and its row, as `lanefinder image` writes it."""
    result = finder.process_still(image)
    row = lane_row(result, finder.birdseye((image.shape[1], image.shape[0])),
                   blown=BlownOut.of(image, h_samples(image.shape[0])))
    return result, row


def find_still(finder: LaneFinder, image, ref: dict, ref_lanes: list) -> dict:
    """Find one still blind: whether it has a lane, whether it agrees, its accuracy, set-up and checks."""
    result, row = still_row(finder, image)
    lanes = [row[k] for k in ("left_x", "right_x") if any(v >= 0 for v in row[k])]
    acc, _, fn = bench_frame(lanes, ref_lanes, ref["h_samples"])
    return {"lane": result.lane_found, "agrees": result.lane_found and fn == 0, "accuracy": acc,
            "setup": result.setup, "checks": list(result.checks)}


def compare(src: Path, every_s: float, cfg: Config, offset_s: float | None = None) -> dict:
    """Agreement of blind stills with the tracked video for one video, with both set-ups."""
    reference = tracked(src, cfg)
    fps = float(VideoInfo.from_path(src).fps)
    step = max(1, round(every_s * fps))
    # the reported set: the middle frame of each step; an offset moves the first still to that time
    first = step // 2 if offset_s is None else round(offset_s * fps) % step
    finders = {"default": LaneFinder(cfg), "own": LaneFinder(own_setup(src, cfg))}
    n = no_reference = 0
    counts = {k: {"with_lane": 0, "agree": 0, "acc": 0.0} for k in finders}
    per_still: list[dict] = []
    for f in frames(src):
        if f.index % step != first:
            continue
        ref = reference.get(f.index)
        ref_lanes = [ref[k] for k in ("left_x", "right_x") if ref and any(v >= 0 for v in ref[k])]
        if ref is None or ref["state"] == "lost" or len(ref_lanes) < 2:
            no_reference += 1
            continue
        n += 1
        record: dict = {"frame": f.index, "time_s": round(f.index / fps, 2),
                        # whether the video measured each line at that frame (else it drew it inferred or held)
                        "reference_measured": [bool(ref["left_found"]), bool(ref["right_found"])]}
        for name, finder in finders.items():
            s = record[name] = find_still(finder, f.image, ref, ref_lanes)
            c = counts[name]
            c["with_lane"] += s["lane"]
            c["agree"] += s["agrees"]
            c["acc"] += s["accuracy"]
            s["accuracy"] = round(s["accuracy"], 4)
        per_still.append(record)
    out: dict = {"stills": n, "no_reference": no_reference, "every_s": every_s,
                 "offset_s": round(first / fps, 3), "per_still": per_still}
    for name, c in counts.items():
        out[name] = {"with_lane": c["with_lane"], "agree": c["agree"], "agree_share": c["agree"] / n if n else None,
                     "mean_accuracy": c["acc"] / n if n else None}
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--videos", type=Path, default=ROOT.parent / "shared" / "data" / "udacity" / "videos")
    ap.add_argument("--every-s", type=float, default=1.0)
    ap.add_argument("--offset-s", type=float, default=None,
                    help="time of the first still, s, 0 <= S < every-s (default: the middle frame of each step, "
                         "the reported set)")
    ap.add_argument("--json", type=Path, default=ROOT / "output" / "stills" / "report.json")
    ap.add_argument("--config", type=Path, default=None, help="a config file for both the video and the stills")
    a = ap.parse_args()
    if not (math.isfinite(a.every_s) and a.every_s > 0):
        ap.error(f"--every-s must be a positive number of seconds, got {a.every_s:g}")
    if a.offset_s is not None and not (math.isfinite(a.offset_s) and 0 <= a.offset_s < a.every_s):
        ap.error(f"--offset-s must be at least 0 and less than --every-s ({a.every_s:g} s), got {a.offset_s:g}")
    try:
        cfg = load_config(a.config)
    except LaneFinderError as e:
        print(f"stills_vs_video: error: {e}", file=sys.stderr)
        return 2
    report = {}
    print(f"{'video':<24} {'stills':>6} {'set-up':>8} {'lane':>6} {'agree':>6} {'agree %':>8} {'target':>7} "
          f"{'mean acc':>9}")
    for name in VIDEOS:
        src = a.videos / f"{name}.mp4"
        if not src.is_file():
            print(f"{name:<24} skipped: {src} not found")
            continue
        r = compare(src, a.every_s, cfg, a.offset_s)
        report[name] = r
        for setup in ("default", "own"):
            c = r[setup]
            print(f"{name:<24} {r['stills']:>6} {setup:>8} {c['with_lane']:>6} {c['agree']:>6} "
                  f"{100 * (c['agree_share'] or 0):>7.1f}% {100 * TARGETS[name]:>6.0f}% "
                  f"{c['mean_accuracy'] or 0:>9.4f}", flush=True)
    a.json.parent.mkdir(parents=True, exist_ok=True)
    a.json.write_text(json.dumps(report, indent=2) + "\n")
    start = "the middle of each step" if a.offset_s is None else f"{a.offset_s:g} s"
    print(f"\none still every {a.every_s:g} s from {start}; frames where the video shows no lane are left "
          "out; set-up 'default': the default set-up, 'own': `lanefinder setup --video` on that video; "
          f"report: {a.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
