"""Measure lanefinder against synthetic ground truth, scenario by scenario (`make eval`).

    python scripts/eval_synthetic.py [--frames 100] [--seed 0] [--out output/eval] [--only NAME ...]

For each scenario: render the sequence (lanefinder.synth), run `lanefinder video` with the
sequence's exact bird's-eye set-up, score the telemetry with `lanefinder eval`, and print one
table: TuSimple accuracy, FP, FN, offset error (median, p90), curvature error (median |d(1/R)|),
relative radius error where R < 1 km, and the catastrophic-frame rate.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict
from pathlib import Path

from lanefinder.config import load_config
from lanefinder.evaluate import evaluate, read_ground_truth, read_predictions
from lanefinder.synth import SCENARIOS, write_sequence
from lanefinder.videojob import process_video


def run(name: str, frames: int, seed: int, out: Path):
    folder = write_sequence(name, frames, out / name, seed)
    cfg = load_config(folder / "config.toml")
    process_video(folder / "video.mp4", folder / "annotated.mp4", cfg, telemetry=folder / "telemetry.jsonl",
                  progress=False)
    return evaluate(read_ground_truth(folder / "gt.jsonl"), read_predictions(folder / "telemetry.jsonl"))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("output/eval"))
    ap.add_argument("--only", action="append", choices=list(SCENARIOS))
    a = ap.parse_args()
    results = {}
    header_done = False
    for name in a.only or SCENARIOS:
        rep = run(name, a.frames, a.seed, a.out)
        head, row = rep.table(name).split("\n")
        if not header_done:
            print(head)
            header_done = True
        print(row, flush=True)
        results[name] = asdict(rep)
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "report.json").write_text(json.dumps(results, indent=2) + "\n")
    print(f"\n{a.frames} frames per scenario, seed {a.seed}; report: {a.out / 'report.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
