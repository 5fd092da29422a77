"""Run lanefinder over the three full Udacity videos and print how well it holds the lane.

    python scripts/check_videos.py [--videos DIR] [--out output/check] [--debug] [--only NAME]

Per video: frames; % of frames with both lines tracked (both measured and accepted, or
held by the tracker); lane width mean and std (m); the largest frame-to-frame offset jump (m);
the median radius over each curve; frames per second end to end.  Outputs (annotated video,
telemetry, contact sheet) go under --out.  Exit status 2 when the videos are absent.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from lanefinder.telemetry import read_telemetry
from lanefinder.videojob import process_video

VIDEOS = ("project_video", "challenge_video", "harder_challenge_video")
DEFAULT_DIR = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "udacity" / "videos"


def curves(rows: list[dict], min_s: float = 2.0, straight_m: float = 3000.0) -> list[dict]:
    """Stretches of at least ``min_s`` seconds bending one way with radius below ``straight_m``."""
    out, cur = [], None
    for r in rows:
        k, rad = r.get("curvature_per_m"), r.get("radius_m")
        side = None if k is None or rad is None or rad >= straight_m else ("right" if k > 0 else "left")
        if cur and side == cur["side"]:
            cur["rows"].append(r)
            continue
        if cur and cur["rows"][-1]["time_s"] - cur["rows"][0]["time_s"] >= min_s:
            out.append(cur)
        cur = {"side": side, "rows": [r]} if side else None
    if cur and cur["rows"][-1]["time_s"] - cur["rows"][0]["time_s"] >= min_s:
        out.append(cur)
    return [{"side": c["side"], "from_s": c["rows"][0]["time_s"], "to_s": c["rows"][-1]["time_s"],
             "median_radius_m": float(np.median([r["radius_m"] for r in c["rows"]]))} for c in out]


def video_stats(rows: list[dict]) -> dict:
    n = len(rows)
    shown = sum(1 for r in rows if r["state"] != "lost")
    seen_both = sum(1 for r in rows if r["left_found"] and r["right_found"])
    lost = sum(1 for r in rows if r["state"] == "lost")
    width = np.array([r["width_m"] for r in rows if r.get("width_m") is not None])
    off = np.array([np.nan if r.get("offset_m") is None else r["offset_m"] for r in rows])
    jumps = np.abs(np.diff(off))
    return {
        "frames": n,
        "tracked_pct": 100.0 * shown / n if n else 0.0,
        "both_seen_pct": 100.0 * seen_both / n if n else 0.0,
        "lost_pct": 100.0 * lost / n if n else 0.0,
        "width_mean_m": float(width.mean()) if width.size else float("nan"),
        "width_std_m": float(width.std()) if width.size else float("nan"),
        "max_offset_jump_m": float(np.nanmax(jumps)) if np.isfinite(jumps).any() else float("nan"),
        "curves": curves(rows),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--videos", type=Path, default=DEFAULT_DIR)
    ap.add_argument("--out", type=Path, default=Path("output/check"))
    ap.add_argument("--config", default=None, help="config file for the pipeline")
    ap.add_argument("--debug", action="store_true", help="write debug (picture-in-picture) videos")
    ap.add_argument("--only", choices=VIDEOS, action="append")
    a = ap.parse_args()
    if not a.videos.is_dir():
        print(f"check_videos: the Udacity videos are not at {a.videos} (pass --videos DIR)", file=sys.stderr)
        return 2
    from lanefinder.config import load_config

    cfg = load_config(a.config)
    report = {}
    for name in a.only or VIDEOS:
        src = a.videos / f"{name}.mp4"
        tele = a.out / f"{name}.jsonl"
        s = process_video(src, a.out / f"{name}.mp4", cfg, telemetry=tele, debug=a.debug,
                          contact_sheet_path=a.out / f"{name}_sheet.png", progress=False)
        st = video_stats(read_telemetry(tele))
        st["fps"] = s.fps
        st["redetections"] = s.redetections
        report[name] = st
        print(f"\n== {name}")
        print(f"frames {st['frames']}  fps {s.fps:.1f}  re-detections {s.redetections}")
        print(f"lane tracked {st['tracked_pct']:.1f}%  both lines seen {st['both_seen_pct']:.1f}%  "
              f"lost {st['lost_pct']:.1f}%")
        print(f"lane width {st['width_mean_m']:.3f} m mean, {st['width_std_m']:.3f} m std")
        print(f"largest frame-to-frame offset jump {st['max_offset_jump_m']:.3f} m")
        for c in st["curves"]:
            print(f"  {c['side']:<5} curve {c['from_s']:6.2f}-{c['to_s']:6.2f} s: median radius "
                  f"{c['median_radius_m']:.0f} m")
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "report.json").write_text(json.dumps(report, indent=2) + "\n")
    print(f"\nreport: {a.out / 'report.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
