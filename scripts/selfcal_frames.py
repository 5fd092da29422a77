"""What set-up would self-calibration take from these frames alone? (a diagnostic)

    python scripts/selfcal_frames.py VIDEO [--first 0] [--last 300] [--config FILE]

Offers the frames FIRST..LAST of VIDEO (and only those) to a fresh self-calibrator
(:class:`lanefinder.selfcal.SelfCalibrator`), at its own cadence, as if every one read
straight (no curvature gate: the pipeline skips frames it reads as curving tighter than
``selfcal.skip_radius_m``); a LAST past the video's end offers frames to its end. Prints every
estimate it makes (frame, the frames it rests on, horizon row, camera height, expected errors,
and whether it was taken, confirmed the set-up in use or was not sure enough), then the set-up
in use at the end against the one the config starts from. The pipeline's frame check
(``selfcal.estimate_check``: an estimate refused when the frame it came with looks worse with it)
is not made here, so an estimate shown as taken may be refused in a run. On a hilly road an estimate resting
on a few frames of one slope can move the horizon by tens of pixels (see README, Known
limitations):

    python scripts/selfcal_frames.py ../shared/data/udacity/videos/harder_challenge_video.mp4 --first 100 --last 250
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from lanefinder.config import load_config
from lanefinder.errors import LaneFinderError
from lanefinder.io import input_file
from lanefinder.pipeline import LaneFinder
from lanefinder.selfcal import SelfCalibrator
from lanefinder.video import VideoInfo, frames


def probe(video: Path, first: int, last: int, config: Path | None) -> int:
    """Offer frames ``first``..``last`` of ``video`` to a fresh self-calibrator and print every estimate.

    Parameters
    ----------
    video : Path
        The video.
    first, last : int
        The first and last frame offered (0-based; ``last`` past the end: to the end).
    config : Path or None
        A config file (its set-up is the starting point); None: the defaults.

    Returns
    -------
    int
        0.

    Raises
    ------
    LaneFinderError
        For a config that does not load, or a video that has no frame ``first``.
    """
    cfg = load_config(config)
    finder = LaneFinder(cfg)
    cal = None
    start = math.nan
    fps = VideoInfo.from_path(video).fps
    # Seek to a frame before FIRST (a FIRST past the end is then told at once, not after decoding the video).
    for f in frames(video, start_s=max(0.0, (first - 1) / fps) if fps > 0 else 0.0):
        if f.index < first:
            continue
        if f.index > last:
            break
        if cal is None:
            be = finder.birdseye((f.image.shape[1], f.image.shape[0]))
            cal = SelfCalibrator(cfg, be.camera, be)
            start = cal.state.horizon_px
            print(f"frames {first}-{last} of {video.name}; the config's set-up: horizon row {start:.1f}")
        before = cal.last_estimate
        cal.offer(f.image, math.nan)
        est = cal.last_estimate
        if est is not None and est is not before and est.quality is not None:
            q = est.quality
            what = {"taken": "taken", "confirms": "confirms the set-up in use",
                    "unsure": "not sure enough: the set-up in use stays"}[cal.last_verdict]
            print(f"frame {f.index}: an estimate on {q.frames_used} frame{'s' * (q.frames_used != 1)}: horizon row "
                  f"{est.horizon_px:.1f}, camera {est.height_m:.2f} m over the road (expected error xm "
                  f"{q.xm_error_pct:.1f}%, car {q.car_error_m:.3f} m); {what}")
    if cal is None:
        raise LaneFinderError(f"{video} has no frame {first}")
    s = cal.state
    print(f"at the end: {s.source}, horizon row {s.horizon_px:.1f} ({s.horizon_px - start:+.1f} px), "
          f"{s.updates} change{'s' * (s.updates != 1)}")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("video", type=Path)
    ap.add_argument("--first", type=int, default=0, help="first frame offered (0)")
    ap.add_argument("--last", type=int, default=300, help="last frame offered (300)")
    ap.add_argument("--config", type=Path, default=None, help="a config file (its set-up is the starting point)")
    a = ap.parse_args()
    try:
        if not 0 <= a.first <= a.last:
            raise LaneFinderError("--first and --last must be frame numbers with 0 <= first <= last")
        input_file(a.video, "video")
        return probe(a.video, a.first, a.last, a.config)
    except LaneFinderError as e:
        print(f"selfcal_frames: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
