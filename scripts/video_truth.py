"""The Udacity videos against hand labels: the tracked video and blind stills, frame by frame (`make truth`).

    python scripts/video_truth.py [--videos DIR] [--labels data/truth] [--only NAME]
                                  [--json output/truth/report.json] [--config FILE]

The labels (`data/truth/NAME.jsonl`; `data/truth/README.md` says how they were made) give the
two lines of the car's own lane where their paint is seen, on 20 to 43 frames of each video.
For each video with labels, two things are judged on those frames:

- `video`: the video run once with tracking, as `lanefinder video` runs it (telemetry only);
- `stills`: each labelled frame found again alone and blind, as `lanefinder image` finds it.

The table gives the frames labelled, those with a lane shown, TuSimple accuracy, FP and FN
(as `lanefinder eval` scores them), and the frames where a drawn line lies more than 0.5 m from
its marking on the road at some labelled row (distances on the default set-up's road plane:
`lanefinder.stats.labelled_stats`); the frames themselves are listed below it.

These videos are what lanefinder is tuned on: this measures how right the lanes it shows
are, not how it does on roads it has never seen.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from lanefinder.config import Config, load_config
from lanefinder.errors import LaneFinderError
from lanefinder.io import atomic_write_text, check_outputs
from lanefinder.pipeline import LaneFinder
from lanefinder.stats import labelled_stats
from lanefinder.telemetry import h_samples, is_number_list
from lanefinder.video import VideoInfo, frames

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the sibling scripts, also when loaded from a file
from stills_vs_video import still_row, tracked

ROOT = Path(__file__).resolve().parents[1]
VIDEOS = ("project_video", "challenge_video", "harder_challenge_video")


def read_labels(path: Path, height: int) -> list[dict]:
    """Read and check a labels file for frames ``height`` rows high; a ValueError names the first bad line."""
    rows = h_samples(height)
    out = []
    for n, line in enumerate(path.read_text().splitlines(), 1):
        if not line.strip():
            continue
        try:
            r = json.loads(line)
        except json.JSONDecodeError as e:
            raise ValueError(f"{path}:{n}: not JSON ({e.msg})") from None
        if not (isinstance(r, dict) and isinstance(r.get("frame"), int) and r["frame"] >= 0):
            raise ValueError(f"{path}:{n}: each line needs a frame number (a whole number, 0 or more)")
        if r.get("h_samples") != rows:
            raise ValueError(f"{path}:{n}: h_samples must be the TuSimple rows of a {height}-row frame "
                             f"({rows[0]}, {rows[1]}, ..., {rows[-1]})")
        for k in ("left_x", "right_x"):
            if not (is_number_list(r.get(k)) and len(r[k]) == len(rows)):
                raise ValueError(f"{path}:{n}: {k} must be {len(rows)} numbers (x per row, -2 where not labelled)")
        out.append(r)
    if not out:
        raise ValueError(f"{path}: no labelled frames")
    return out


def still_rows(src: Path, cfg: Config, wanted: set[int]) -> dict[int, dict]:
    """Find each wanted frame alone and blind, as `lanefinder image` does; give the rows by frame."""
    finder, out = LaneFinder(cfg), {}
    last = max(wanted)
    for f in frames(src):
        if f.index > last:
            break
        if f.index in wanted:
            out[f.index] = still_row(finder, f.image)[1]
    return out


def score(src: Path, labels_path: Path, cfg: Config) -> dict:
    """Score one video's tracked run and blind stills against its labels."""
    info = VideoInfo.from_path(src)
    labels = read_labels(labels_path, info.size[1])
    ruler = LaneFinder().birdseye(info.size)  # the default set-up's road plane, at the video's size
    video = tracked(src, cfg)
    beyond = sorted({int(r["frame"]) for r in labels} - set(video))
    if beyond:
        raise ValueError(f"{labels_path}: frames the video {src} does not have: {beyond[:10]}")
    runs = {"video": video, "stills": still_rows(src, cfg, {int(r["frame"]) for r in labels})}
    return {mode: labelled_stats(labels, rows, ruler) for mode, rows in runs.items()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--videos", type=Path, default=ROOT.parent / "shared" / "data" / "udacity" / "videos")
    ap.add_argument("--labels", type=Path, default=ROOT / "data" / "truth", help="the folder of NAME.jsonl labels")
    ap.add_argument("--only", choices=VIDEOS, action="append")
    ap.add_argument("--json", type=Path, default=ROOT / "output" / "truth" / "report.json")
    ap.add_argument("--config", type=Path, default=None, help="a config file for the video and the stills")
    a = ap.parse_args()
    try:
        cfg = load_config(a.config)
        if not a.videos.is_dir():
            raise ValueError(f"the Udacity videos are not at {a.videos} (pass --videos DIR)")
        if a.json.exists() and a.json.is_dir():
            raise ValueError(f"--json {a.json} is a folder: name the file to write")
        a.json.parent.mkdir(parents=True, exist_ok=True)
        if not os.access(a.json.parent, os.W_OK | os.X_OK):
            raise ValueError(f"cannot write in {a.json.parent}")
        names = a.only or VIDEOS  # never written over what it reads
        check_outputs([a.json], [p for n in names for p in (a.videos / f"{n}.mp4", a.labels / f"{n}.jsonl")]
                      + ([a.config] if a.config else []))
    except (ValueError, LaneFinderError) as e:
        print(f"video_truth: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"video_truth: error: cannot make {a.json.parent}: {e.strerror or e}", file=sys.stderr)
        return 2
    report: dict = {}
    skipped = []
    print(f"{'video':<24} {'mode':<7} {'frames':>6} {'shown':>6} {'accuracy':>9} {'FP':>6} {'FN':>6} "
          f"{'off>0.5m':>9} {'not drawn':>10}")
    for name in a.only or VIDEOS:
        src, labels_path = a.videos / f"{name}.mp4", a.labels / f"{name}.jsonl"
        if not (src.is_file() and labels_path.is_file()):
            print(f"{name:<24} skipped: {src if not src.is_file() else labels_path} not found")
            skipped.append(name)
            continue
        try:
            report[name] = score(src, labels_path, cfg)
        except (ValueError, LaneFinderError) as e:
            print(f"video_truth: error: {e}", file=sys.stderr)
            return 2
        for mode, st in report[name].items():
            acc = "n/a" if st["accuracy"] is None else f"{st['accuracy']:.4f}"
            print(f"{name:<24} {mode:<7} {st['frames']:>6} {st['shown']:>6} {acc:>9} {st['fp']:>6.3f} "
                  f"{st['fn']:>6.3f} {len(st['off_frames']):>9} {st['lines_not_drawn']:>10}", flush=True)
    print()
    for name, modes in report.items():
        for mode, st in modes.items():
            worst = {r["frame"]: max(v for v in (r["left_m"], r["right_m"]) if v is not None)
                     for r in st["per_frame"] if r["frame"] in st["off_frames"]}
            listed = ", ".join(f"{f} ({m:.2f} m)" for f, m in worst.items()) or "none"
            print(f"{name} {mode}: a line more than 0.5 m off at frames {listed}")
    if not report:
        print(f"video_truth: error: nothing scored: {', '.join(skipped)} (a video or its labels not found)",
              file=sys.stderr)
        return 2
    try:
        atomic_write_text(a.json, json.dumps(report, indent=2) + "\n")
    except LaneFinderError as e:
        print(f"video_truth: error: {e}", file=sys.stderr)
        return 2
    print(f"\nreport: {a.json}")
    if a.only and skipped:
        print(f"video_truth: error: not scored: {', '.join(skipped)} (a video or its labels not found)",
              file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
