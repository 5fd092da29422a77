"""Cut a short clip from a video (re-encoded H.264), for the sample data in data/clips/.

    python scripts/cut_clip.py IN OUT --start S --end E [--crf 26]
"""

from __future__ import annotations

import argparse

from lanefinder.video import VideoInfo, VideoSink, frames


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("src")
    ap.add_argument("dst")
    ap.add_argument("--start", type=float, required=True)
    ap.add_argument("--end", type=float, required=True)
    ap.add_argument("--crf", type=int, default=26)
    ap.add_argument("--preset", default="slow")
    a = ap.parse_args()
    info = VideoInfo.from_path(a.src)
    with VideoSink(a.dst, info, a.preset, a.crf) as sink:
        for f in frames(a.src, a.start, a.end):
            sink.write(f.image)
    print(f"wrote {a.dst}: {sink.frames_written} frames")


if __name__ == "__main__":
    main()
