"""Single stills of the synthetic scenes against their truth: the blind path on unknown mounts.

    python scripts/stills_synthetic.py [--seeds 101 102] [--out DIR] [--at 10 35]
                                       [--same-road] [--config FILE] [--json output/stills_synthetic.json]

For each flat scenario (every one but `hills`) and seed, frames 10 and 35 of the randomised
50-frame sequence in `OUT/<scenario>-<seed>` are found as stills, blind, with no history and
without the sequence's set-up: `lanefinder image` with the default config (or `--config`), as a
user with an unknown dashcam mount would run it. A sequence missing, or made otherwise, is
rendered as `make eval` renders it: each seed on its own stretch of road (`--same-road`: every
seed on the same stretch, as `eval_synthetic.py --same-road`, into `output/eval-same-road` unless
`--out` says otherwise). Each still is scored by TuSimple's rule against the truth (frames whose
truth shows no paint are left out and counted). It prints the mean accuracy per scenario and
over all stills.

Seeds 0-10 are the ones tuning may look at; 101 and up are held out (see the README).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from lanefinder.config import Config, load_config
from lanefinder.errors import LaneFinderError
from lanefinder.pipeline import LaneFinder
from lanefinder.synth import SCENARIOS
from lanefinder.video import frames

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the sibling scripts, also when loaded from a file
from eval_synthetic import made_so, sequence
from stills_vs_video import find_still

FRAMES = 50  # the sequences of `make eval`


def _sequence(name: str, seed: int, folder: Path, same_road: bool = False) -> Path:
    """The 50-frame randomised sequence in ``folder``, rendered as `make eval` does when missing or made otherwise.

    As `make eval` renders it means each seed on its own stretch of road (``road_from_seed``), so
    that a folder `make eval` rendered is used as it is, and one this script renders is the one
    `make eval` scores; ``same_road`` renders every seed on the same stretch instead.
    """
    if made_so(folder, FRAMES, seed, randomise=True, road_from_seed=not same_road):
        return folder
    print(f"  rendering {folder} ...", flush=True)
    return sequence(name, FRAMES, seed, folder, randomise=True, reuse=False, road_from_seed=not same_road)


def score(folder: Path, at: list[int], finder: LaneFinder) -> list[float | None]:
    """TuSimple accuracy of each still (None where the truth shows no paint)."""
    truth = [json.loads(line) for line in (folder / "gt.jsonl").read_text().splitlines()]
    out: list[float | None] = []
    for f in frames(folder / "video.mp4"):
        if f.index not in at:
            continue
        gt = truth[f.index]
        gt_lanes = [gt[k] for k in ("left_x", "right_x") if any(v >= 0 for v in gt[k])]
        out.append(find_still(finder, f.image, gt, gt_lanes)["accuracy"] if gt_lanes else None)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, nargs="+", default=[101, 102])
    ap.add_argument("--out", type=Path, default=None,
                    help="the sequences' folder (default output/eval, output/eval-same-road with --same-road)")
    ap.add_argument("--at", type=int, nargs="+", default=[10, 35], help="frames of each sequence (0-49)")
    ap.add_argument("--same-road", action="store_true",
                    help="every seed on the same stretch of road (as eval_synthetic.py --same-road)")
    ap.add_argument("--config", type=Path, default=None, help="settings for the stills (default: the defaults)")
    ap.add_argument("--json", type=Path, default=Path("output/stills_synthetic.json"))
    a = ap.parse_args()
    if a.out is None:  # the same-road renders never replace make eval's
        a.out = Path("output/eval-same-road" if a.same_road else "output/eval")
    try:
        if any(not 0 <= i < FRAMES for i in a.at):
            raise LaneFinderError(f"--at takes frames 0-{FRAMES - 1}")
        cfg = load_config(a.config) if a.config else Config()
    except LaneFinderError as e:
        print(f"stills_synthetic: error: {e}", file=sys.stderr)
        return 2
    finder = LaneFinder(cfg)
    report: dict[str, dict] = {}
    scores: list[float] = []
    no_paint = 0
    print(f"{'scenario':<15} {'stills':>6} {'accuracy':>9}")
    for name in SCENARIOS:
        if name == "hills":
            continue
        got: list[float] = []
        for seed in a.seeds:
            for s in score(_sequence(name, seed, a.out / f"{name}-{seed}", a.same_road), a.at, finder):
                if s is None:
                    no_paint += 1
                else:
                    got.append(s)
        report[name] = {"stills": len(got), "accuracy": sum(got) / len(got) if got else None}
        scores += got
        print(f"{name:<15} {len(got):>6} {report[name]['accuracy'] or 0:>9.4f}", flush=True)
    mean = sum(scores) / len(scores) if scores else 0.0
    print(f"{'all':<15} {len(scores):>6} {mean:>9.4f}")
    settings = f"the settings of {a.config}" if a.config else "the default settings"
    print(f"\nframes {', '.join(map(str, a.at))} of seeds {', '.join(map(str, a.seeds))}, blind, {settings}, "
          f"no set-up of their own; {no_paint} frame(s) whose truth shows no paint left out; report: {a.json}")
    a.json.parent.mkdir(parents=True, exist_ok=True)
    report["all"] = {"stills": len(scores), "accuracy": mean, "no_paint": no_paint}
    a.json.write_text(json.dumps(report, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
