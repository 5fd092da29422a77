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
import sys
import tempfile
from pathlib import Path

from lanefinder.config import Config, load_config
from lanefinder.errors import LaneFinderError
from lanefinder.pipeline import LaneFinder
from lanefinder.stats import labelled_stats
from lanefinder.telemetry import BlownOut, h_samples, lane_row, read_telemetry
from lanefinder.video import frames
from lanefinder.videojob import process_video

ROOT = Path(__file__).resolve().parents[1]
VIDEOS = ("project_video", "challenge_video", "harder_challenge_video")


def read_labels(path: Path) -> list[dict]:
    """Read a labels file (JSON Lines, one labelled frame a line)."""
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def tracked_rows(src: Path, cfg: Config) -> dict[int, dict]:
    """Run the video with tracking, telemetry only; give its rows by frame."""
    with tempfile.TemporaryDirectory() as tmp:
        tele = Path(tmp) / "t.jsonl"
        process_video(src, None, cfg, telemetry=tele, progress=False)
        return {r["frame"]: r for r in read_telemetry(tele)}


def still_rows(src: Path, cfg: Config, wanted: set[int]) -> dict[int, dict]:
    """Find each wanted frame alone and blind, as `lanefinder image` does; give the rows by frame."""
    finder, out = LaneFinder(cfg), {}
    last = max(wanted)
    for f in frames(src):
        if f.index > last:
            break
        if f.index in wanted:
            result = finder.process_still(f.image)
            size = (f.image.shape[1], f.image.shape[0])
            out[f.index] = lane_row(result, finder.birdseye(size), blown=BlownOut.of(f.image, h_samples(size[1])))
    return out


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
    except LaneFinderError as e:
        print(f"video_truth: error: {e}", file=sys.stderr)
        return 2
    report: dict = {}
    print(f"{'video':<24} {'mode':<7} {'frames':>6} {'shown':>6} {'accuracy':>9} {'FP':>6} {'FN':>6} "
          f"{'off>0.5m':>9} {'not drawn':>10}")
    for name in a.only or VIDEOS:
        src, labels_path = a.videos / f"{name}.mp4", a.labels / f"{name}.jsonl"
        if not (src.is_file() and labels_path.is_file()):
            print(f"{name:<24} skipped: {src if not src.is_file() else labels_path} not found")
            continue
        labels = read_labels(labels_path)
        be = LaneFinder().birdseye((1280, 720))  # the ruler: the default set-up's road plane
        runs = {"video": tracked_rows(src, cfg), "stills": still_rows(src, cfg, {int(r["frame"]) for r in labels})}
        report[name] = {}
        for mode, rows in runs.items():
            s = report[name][mode] = labelled_stats(labels, rows, be)
            print(f"{name:<24} {mode:<7} {s['frames']:>6} {s['shown']:>6} {s['accuracy']:>9.4f} {s['fp']:>6.3f} "
                  f"{s['fn']:>6.3f} {len(s['off_frames']):>9} {s['lines_not_drawn']:>10}", flush=True)
    print()
    for name, modes in report.items():
        for mode, s in modes.items():
            worst = {r["frame"]: max(v for v in (r["left_m"], r["right_m"]) if v is not None)
                     for r in s["per_frame"] if r["frame"] in s["off_frames"]}
            listed = ", ".join(f"{f} ({m:.2f} m)" for f, m in worst.items()) or "none"
            print(f"{name} {mode}: a line more than 0.5 m off at frames {listed}")
    a.json.parent.mkdir(parents=True, exist_ok=True)
    a.json.write_text(json.dumps(report, indent=2) + "\n")
    print(f"\nreport: {a.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
