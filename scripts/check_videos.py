"""Run lanefinder over the three full Udacity videos and print how well it holds the lane.

    python scripts/check_videos.py [--videos DIR] [--out output/check] [--debug] [--only NAME]

Per video: frames; % of frames with a lane shown (measured, or held by the tracker) and %
with both lines measured and accepted; lane width mean and std (m); the largest frame-to-frame offset jump (m);
the median radius over each curve; frames per second end to end; the checks that refused lines most
often on frames without both lines (the telemetry's `checks` column).  Outputs (annotated video,
telemetry, contact sheet) go under --out.  Exit status 2 when the videos are absent.

The contact sheet has --sheet-frames frames (40, as issue 12 asks: no frame of it with a drawn
line more than 0.5 m off its marking), spread evenly over the video; the same frames, full size,
go to --out/NAME_sheet/ (JPEG, named by frame number) to be judged by eye.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from lanefinder.stats import unchecked_frames, video_stats
from lanefinder.telemetry import read_telemetry
from lanefinder.videojob import process_video

VIDEOS = ("project_video", "challenge_video", "harder_challenge_video")
DEFAULT_DIR = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "udacity" / "videos"


def sheet_frames_full_size(video: Path, folder: Path, at: tuple[int, ...]) -> None:
    """Write the frames ``at`` (places in ``video``: the contact sheet's) full size, as JPEGs named by frame number."""
    import cv2

    from lanefinder.video import frames

    if not at:
        return
    wanted, last = set(at), max(at)
    folder.mkdir(parents=True, exist_ok=True)
    for f in frames(video):
        if f.index in wanted:
            cv2.imwrite(str(folder / f"{f.index:05d}.jpg"), f.image, [cv2.IMWRITE_JPEG_QUALITY, 90])
        if f.index >= last:
            break


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--videos", type=Path, default=DEFAULT_DIR)
    ap.add_argument("--out", type=Path, default=Path("output/check"))
    ap.add_argument("--config", default=None, help="config file for the pipeline")
    ap.add_argument("--debug", action="store_true", help="write debug (picture-in-picture) videos")
    ap.add_argument("--only", choices=VIDEOS, action="append")
    ap.add_argument("--sheet-frames", type=int, default=40, help="frames on each contact sheet (40)")
    a = ap.parse_args()
    if a.sheet_frames < 0:
        ap.error(f"--sheet-frames must be 0 or more (got {a.sheet_frames})")
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
                          contact_sheet_path=a.out / f"{name}_sheet.png", sheet_frames=a.sheet_frames,
                          progress=False)
        sheet_frames_full_size(a.out / f"{name}.mp4", a.out / f"{name}_sheet", s.sheet_frames)
        rows = read_telemetry(tele)
        st = video_stats(rows)
        st["fps"] = s.fps
        st["redetections"] = s.redetections
        report[name] = st
        print(f"\n== {name}")
        print(f"frames {st['frames']}  fps {s.fps:.1f}  re-detections {s.redetections}")
        print(f"lane tracked {st['tracked_pct']:.1f}%  both lines seen {st['both_seen_pct']:.1f}%  "
              f"lost {st['lost_pct']:.1f}%")
        print(f"lane width {st['width_mean_m']:.3f} m mean, {st['width_std_m']:.3f} m std")
        print(f"largest frame-to-frame offset jump {st['max_offset_jump_m']:.3f} m")
        unseen = unchecked_frames(rows)
        why = [f"{k} {v['not_both']}" for k, v in st["checks"].items() if v["not_both"]][:6]
        if why or unseen:
            print(f"checks on frames without both lines (frames): {', '.join(why) or 'none'}; "
                  f"no check, a line not there at all: {unseen}")
        for c in st["curves"]:
            print(f"  {c['side']:<5} curve {c['from_s']:6.2f}-{c['to_s']:6.2f} s: median radius "
                  f"{c['median_radius_m']:.0f} m")
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "report.json").write_text(json.dumps(report, indent=2) + "\n")
    print(f"\nreport: {a.out / 'report.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
