"""Blind pairs for judging the stills that disagree with the tracked video (after `make stills`).

    python scripts/stills_pairs.py [--report output/stills/report.json] [--videos DIR]
                                   [--out output/stills/pairs] [--seed 7]

`make stills` scores a blind still against the tracked video at the same frame, but the tracked
video is a reference, not the truth. For every still in the report that shows a lane and
disagrees with the video (default set-up), this writes one PNG to --out: the lower part of the
frame twice, panel A above panel B, one with the still's lines and one with the tracked
video's (red: the left line, magenta: the right), in an order drawn from --seed. Which panel is
which is written to `key.json` in the same folder (`{"file": {"A": "still", "B": "video"}}`):
give a judge the PNGs only, ask which panel's lines lie on the painted markings, then read the
answers against the key. The report must come from `make stills` on the same videos (default
config); a still it names that the video does not hold is refused.

The videos are run again with tracking, as `make stills` runs them (about 40 s). --out must not
exist yet; it is written whole or not at all.
"""

from __future__ import annotations

import argparse
import json
import random
import shutil
import sys
import tempfile
from pathlib import Path

import cv2

from lanefinder.config import Config
from lanefinder.errors import LaneFinderError
from lanefinder.pipeline import LaneFinder
from lanefinder.video import frames

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the sibling scripts, also when loaded from a file
from stills_vs_video import still_row, tracked

ROOT = Path(__file__).resolve().parents[1]
#: Rows of a 720-row frame shown: the road.
TOP_FRACTION = 380 / 720


def _draw(image, row: dict, label: str):
    """The frame's road with one set of lines drawn as dots and the panel's label."""
    out = image.copy()
    for key, colour in (("left_x", (0, 0, 255)), ("right_x", (255, 0, 255))):
        for x, y in zip(row[key], row["h_samples"], strict=True):
            if x >= 0:
                cv2.circle(out, (round(x), round(y)), 3, colour, -1)
    out = out[round(TOP_FRACTION * image.shape[0]):]
    cv2.putText(out, label, (20, 60), cv2.FONT_HERSHEY_SIMPLEX, 2, (0, 255, 255), 4)
    return out


def pairs(report: dict, videos: Path, out: Path, seed: int) -> dict:
    """Write the pairs into ``out``; give the key (file name -> which panel is the still, which the video)."""
    rng = random.Random(seed)
    key: dict[str, dict[str, str]] = {}
    cfg = Config()
    todo = {name: {s["frame"] for s in rep["per_still"] if s["default"]["lane"] and not s["default"]["agrees"]}
            for name, rep in report.items()}
    todo = {name: wanted for name, wanted in todo.items() if wanted}
    for name in todo:  # every video before any work
        if not (videos / f"{name}.mp4").is_file():
            raise LaneFinderError(f"video not found: {videos / f'{name}.mp4'}")
    for name, wanted in todo.items():
        src = videos / f"{name}.mp4"
        reference = tracked(src, cfg)  # a row for every frame the video holds
        if missing := wanted - set(reference):
            raise LaneFinderError(f"{src} holds no frame {min(missing)}: is the report from these videos?")
        finder = LaneFinder(cfg)
        for f in frames(src):
            if f.index not in wanted:
                continue
            _, still = still_row(finder, f.image)  # as `make stills` scores it
            order = ["still", "video"]
            rng.shuffle(order)
            panels = [_draw(f.image, still if who == "still" else reference[f.index], label)
                      for label, who in zip("AB", order, strict=True)]
            file = f"{name}_{f.index:04d}.png"
            if not cv2.imwrite(str(out / file), cv2.vconcat(panels)):
                raise LaneFinderError(f"cannot write {out / file}")
            key[file] = dict(zip("AB", order, strict=True))
    return key


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--report", type=Path, default=ROOT / "output" / "stills" / "report.json")
    ap.add_argument("--videos", type=Path, default=ROOT.parent / "shared" / "data" / "udacity" / "videos")
    ap.add_argument("--out", type=Path, default=ROOT / "output" / "stills" / "pairs")
    ap.add_argument("--seed", type=int, default=7)
    a = ap.parse_args()
    try:
        if a.out.exists():
            raise LaneFinderError(f"{a.out} exists: give a new folder")
        try:
            report = json.loads(a.report.read_text())
            if not all(isinstance(s, dict) and isinstance(s.get("frame"), int) and isinstance(s.get("default"), dict)
                       and {"lane", "agrees"} <= set(s["default"]) for v in report.values() for s in v["per_still"]):
                raise ValueError("its stills lack frame or default.lane/agrees")
        except (OSError, ValueError, AttributeError, TypeError, KeyError) as e:
            raise LaneFinderError(f"cannot read the stills report {a.report} (run `make stills` first): {e}") from None
        a.out.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{a.out.name}.", dir=a.out.parent))
        try:
            key = pairs(report, a.videos, tmp, a.seed)
            (tmp / "key.json").write_text(json.dumps(key, indent=1) + "\n")
            tmp.rename(a.out)  # whole or not at all
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    except LaneFinderError as e:
        print(f"stills_pairs: error: {e}", file=sys.stderr)
        return 2
    print(f"{len(key)} pairs in {a.out} (the key, not for the judge: {a.out / 'key.json'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
