"""Set-up error, before and after: vanishing point (px), xm and ym (%), car position (m).

Cases: straight_lines1/2, the project clip, the challenge video (when ../shared is there) and
synthetic straight roads from several cameras (960x540 and 1920x1080, focal lengths, heights,
pitches), each with and without the camera file.  Truth: the exact set-up for synthetic
footage; for the Udacity camera the hand-tuned default set-up (vanishing point 639.2, 418.6),
and for the challenge video (its camera sits differently) the camera-file set-up of the
version being measured.  "before" runs the set-up of another commit (default becf45c).

    python scripts/setup_errors.py [--before COMMIT] [--quick]
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from lanefinder import autosetup as after
from lanefinder.birdseye import src_vanishing_point
from lanefinder.camera import CameraModel, udacity_camera
from lanefinder.config import Config
from lanefinder.evaluate import setup_error
from lanefinder.pipeline import birdseye_from_config, camera_from_config
from lanefinder.synth import Mount, Renderer, Scenario, level_to_camera

ROOT = Path(__file__).resolve().parents[1]
CHALLENGE = ROOT.parent / "shared/data/udacity/videos/challenge_video.mp4"


def load_before(commit: str):
    src = subprocess.run(["git", "show", f"{commit}:src/lanefinder/autosetup.py"], cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout
    path = Path(tempfile.mkdtemp()) / "_autosetup_before.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location("lanefinder._autosetup_before", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def birdseye_of(result, size, camera=None):
    """The set-up a result's config gives, with the camera file it was found with (if any)."""
    cfg = result.config()
    return birdseye_from_config(cfg, camera if camera is not None else camera_from_config(cfg, size), size)


def video_frames(mod, path):
    """A video's frames for the set-up (the version before took a camera it did not need)."""
    if mod is after:
        return after.straight_frames_from_video(path, after.SetupOptions())
    try:
        return mod.straight_frames_from_video(path, mod.SetupOptions())
    except TypeError:  # versions that also took a camera
        return mod.straight_frames_from_video(path, None, mod.SetupOptions())


def row(name, mod, frames, camera, truth_be, truth_vp, size, **opts):
    label = "file" if camera is not None else "none"
    t0 = time.perf_counter()
    try:
        r = mod.auto_setup(frames, camera, mod.SetupOptions(**opts), camera_ref=label)
    except Exception as e:  # a refusal is a result here
        return f"| {name} | {label} | refused: {str(e)[:90]} | | | | |"
    err = setup_error(birdseye_of(r, size, camera), truth_be)
    dvp = float(np.hypot(*(np.array(r.vp) - truth_vp)))
    return (f"| {name} | {label} | {dvp:.1f} | {err['xm_pct']:+.1f} | {err['ym_pct']:+.1f} | {err['car_m']:+.2f} | "
            f"{r.frames_used} ({time.perf_counter() - t0:.1f} s) |")


def synthetic_cases(quick: bool):
    cams = [((960, 540), 700.0, 1.2, -1.0), ((960, 540), 1000.0, 1.6, 3.0), ((960, 540), 500.0, 1.4, 1.0),
            ((1920, 1080), 1400.0, 1.3, 0.0), ((1920, 1080), 2100.0, 1.5, 2.0), ((1920, 1080), 1100.0, 1.1, -2.0)]
    if quick:
        cams = cams[:2]
    for (w, h), f, height, pitch in cams:
        k = np.array([[f, 0, (w - 1) / 2], [0, f, (h - 1) / 2], [0, 0, 1.0]])
        cam = CameraModel(k, np.zeros(5), (w, h), source="synthetic")
        mount = Mount(height_m=height, pitch_deg=pitch)
        r = Renderer(cam, mount, Scenario("straight-setup", width_m=(3.7, 0.0)), seed=11)
        frames = [r.render(t) for t in np.linspace(0, 4, 8)]
        b = r.birdseye_config()
        truth_cfg = Config.model_validate({"camera": {"model": "none"}, "birdseye": b})
        truth_be = birdseye_from_config(truth_cfg, cam, (w, h))
        v = k @ level_to_camera(pitch) @ [0, 0, 1.0]
        yield f"synthetic {w}x{h} f={f:.0f} h={height} pitch={pitch:+}", frames, cam, truth_be, v[:2] / v[2], (w, h)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", default="becf45c")
    ap.add_argument("--quick", action="store_true", help="two synthetic cameras, no challenge video")
    args = ap.parse_args()
    before = load_before(args.before)
    ucam = udacity_camera()
    default_be = birdseye_from_config(Config(), ucam, (1280, 720))
    default_vp = np.array(src_vanishing_point(Config().birdseye.src))
    straight = [cv2.imread(str(ROOT / f"data/test_images/straight_lines{i}.jpg")) for i in (1, 2)]
    clip = ROOT / "data/clips/project_37-47s.mp4"
    cases = [("straight_lines1/2", lambda m: straight, default_be, default_vp, (1280, 720)),
             ("project clip", lambda m: video_frames(m, clip), default_be,
              default_vp, (1280, 720))]
    header = ("| case | camera file | vanishing point error, px | xm error, % | ym error, % | car position error, m "
              "| frames used |\n|---|---|---|---|---|---|---|")
    for label, mod in (("before", before), ("after", after)):
        print(f"\n### {label}\n\n{header}")
        for name, get, tbe, tvp, size in cases:
            frames = get(mod)
            for cam in (ucam, None):
                print(row(name, mod, frames, cam, tbe, tvp, size), flush=True)
                if cam is None and mod is after:
                    print(row(name + " (dash period 14.6 m)", mod, frames, cam, tbe, tvp, size, dash_period_m=14.63),
                          flush=True)
        if CHALLENGE.is_file() and not args.quick:
            frames = video_frames(mod, CHALLENGE)
            ref = after.auto_setup(video_frames(after, CHALLENGE), ucam)
            tbe = birdseye_of(ref, (1280, 720), ucam)
            for cam in (ucam, None):
                print(row("challenge video", mod, frames, cam, tbe, np.array(ref.vp), (1280, 720)), flush=True)
            if mod is after:
                print(row("challenge video (dash period 14.6 m)", mod, frames, None, tbe, np.array(ref.vp),
                          (1280, 720), dash_period_m=14.63), flush=True)
        for name, frames, cam, tbe, tvp, size in synthetic_cases(args.quick):
            for c in (cam, None):
                print(row(name, mod, frames, c, tbe, tvp, size, dash_period_m=12.0), flush=True)


if __name__ == "__main__":
    main()
