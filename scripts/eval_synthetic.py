"""Measure lanefinder against synthetic ground truth, scenario by scenario (`make eval`).

    python scripts/eval_synthetic.py [--frames 50] [--seeds 101 102] [--out output/eval] [--only NAME ...]
                                     [--fixed] [--same-road] [--config CFG] [--reuse] [--self-calibrate]
                                     [--lens-hfov DEG --size WxH]

For each scenario and seed: render the sequence (lanefinder.synth), run the video job with the
sequence's exact bird's-eye set-up (telemetry only), and score all the seeds' frames together
with lanefinder.evaluate. Two tables: TuSimple accuracy, FP, FN, offset error (median, p90),
curvature error, relative radius error where R < 1 km and the catastrophic-frame rate; then the
accuracy by distance band (0-20, 20-40, 40-70, 70+ m ahead), the lateral error of the lines
6 m and 20 m ahead (median, p90) and the share of frames with paint in view but no lane.

Each sequence's look (asphalt or concrete, light, paint, dash pattern, what bounds the lane,
clutter, vehicles), lane width and camera mount (height 1.1-1.6 m, pitch, yaw) are drawn from
its seed (`lanefinder synth --randomise`); `--fixed` renders each scenario's fixed look instead.
So is where in the scenario's cycle of geometry (`period_s`) the sequence starts
(`synth.road_start_s`): each seed drives its own stretch of road. `--same-road` starts every seed
at the cycle's beginning, as every figure before 2026-11-27 did (the seeds then differed in look
and camera, not in the road's shape: 50 frames show the first 2 s of each cycle).
Seeds: tuning uses seeds 0-2 (`make eval-tune`); `make eval` reports seeds 101 and 102, which no
tuning has used. The truth runs as far as each marking is visible (its farthest paint at least 1.5 px wide) and
leaves out paint hidden behind a vehicle.

`--config CFG` runs the pipeline with that config's settings (the sequences' own camera and
set-up still apply): `--config before.toml` with an older setting gives a before/after on the same
scenes. `--reuse` keeps sequences already rendered in the output folder.

`--self-calibrate` runs each sequence as a user with an unknown camera mount would: with the
lens but without the set-up (`lanefinder video` with no `[birdseye]`), so the default set-up is
used until self-calibration has an estimate of its own (telemetry `telemetry_selfcal.jsonl`,
report `report_selfcal.json`).

`--lens-hfov 90 --size 1920x1080` renders with another lens than the Udacity camera: an ideal
(distortion-free) lens of that horizontal field of view, for frames of that size (with
`--self-calibrate`, the lens is given as a camera file and the set-up is not); `--size 640x360`
alone renders with the Udacity lens scaled to that size. `--reuse` keeps a sequence only when
it was rendered with the same lens.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict
from pathlib import Path

import numpy as np

from lanefinder.camera import CameraModel, load_camera, udacity_camera
from lanefinder.config import Config, load_config
from lanefinder.errors import LaneFinderError
from lanefinder.evaluate import evaluate, read_ground_truth, read_predictions
from lanefinder.synth import SCENARIOS, write_sequence
from lanefinder.videojob import process_video


def _same_lens(folder: Path, camera: CameraModel | None) -> bool:
    """Tell whether the sequence in ``folder`` was rendered with ``camera`` (None: the Udacity camera)."""
    want = camera or udacity_camera()
    try:
        had = load_camera(folder / "camera.json")
    except (OSError, ValueError, LaneFinderError):
        return False
    return (had.image_size == want.image_size and np.allclose(had.camera_matrix, want.camera_matrix, atol=0.5)
            and np.allclose(had.dist_coeffs.ravel(), want.dist_coeffs.ravel(), atol=1e-6))


def made_so(folder: Path, frames: int, seed: int, randomise: bool, camera: CameraModel | None = None,
            road_from_seed: bool = False) -> bool:
    """Tell whether ``folder`` holds a sequence rendered this way (seed, frames, look, lens, road)."""
    meta = folder / "scenario.json"
    if not (meta.is_file() and (folder / "gt.jsonl").is_file() and _same_lens(folder, camera)):
        return False
    try:
        m = json.loads(meta.read_text())
    except (OSError, ValueError):
        return False
    return (m.get("seed") == seed and m.get("frames") == frames and ("appearance" in m) == randomise
            and ("start_s" in m) == road_from_seed)


def sequence(name: str, frames: int, seed: int, folder: Path, randomise: bool, reuse: bool,
             camera: CameraModel | None = None, road_from_seed: bool = False) -> Path:
    """Render a sequence, or keep the one in ``folder`` when it was made the same way (:func:`made_so`)."""
    if reuse and made_so(folder, frames, seed, randomise, camera, road_from_seed):
        return folder
    return write_sequence(name, frames, folder, seed, camera=camera, randomise=randomise,
                          road_from_seed=road_from_seed)


def run(name: str, frames: int, seeds: list[int], out: Path, base: Config, randomise: bool = True,
        reuse: bool = False, own_setup: bool = True, camera: CameraModel | None = None, road_from_seed: bool = False):
    gt, pred = {}, {}
    for seed in seeds:
        folder = sequence(name, frames, seed, out / f"{name}-{seed}", randomise, reuse, camera, road_from_seed)
        own = load_config(folder / "config.toml")
        # With the exact set-up, or (own_setup False) with the camera's lens only, as a user with an
        # unknown mount runs `lanefinder video`: the default set-up, then self-calibration.
        update = {"camera": own.camera, "birdseye": own.birdseye} if own_setup else {"camera": own.camera}
        cfg = base.model_copy(update=update)
        tele = folder / ("telemetry.jsonl" if own_setup else "telemetry_selfcal.jsonl")
        process_video(folder / "video.mp4", None, cfg, telemetry=tele, progress=False)
        gt.update({f"{seed}/{k}": v for k, v in read_ground_truth(folder / "gt.jsonl").items()})
        pred.update({f"{seed}/{k}": v for k, v in read_predictions(tele).items()})
    return evaluate(gt, pred)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=50, help="frames per seed")
    ap.add_argument("--seeds", type=int, nargs="+", default=[101, 102])
    ap.add_argument("--out", type=Path, default=Path("output/eval"))
    ap.add_argument("--only", action="append", choices=list(SCENARIOS))
    ap.add_argument("--fixed", action="store_true",
                    help="the fixed look and camera mount of each scenario instead of a look drawn from the seed")
    ap.add_argument("--config", type=Path, help="pipeline settings (the sequences' camera and set-up still apply)")
    ap.add_argument("--reuse", action="store_true", help="keep sequences already rendered under --out")
    ap.add_argument("--same-road", action="store_true",
                    help="every seed on the same stretch of road, the first seconds of each scenario's cycle "
                         "(as before 2026-11-27); by default each seed starts at its own point of the cycle")
    ap.add_argument("--self-calibrate", action="store_true",
                    help="run without each sequence's set-up (its lens only): the default set-up and self-calibration")
    ap.add_argument("--lens-hfov", type=float, help="an ideal lens of this horizontal field of view, degrees")
    ap.add_argument("--size", help="frame size WxH (default 1280x720): the Udacity lens scaled to it, or --lens-hfov's")
    a = ap.parse_args()
    camera = None
    if a.frames < 1:
        ap.error(f"--frames must be at least 1, not {a.frames}")
    if a.lens_hfov is not None and not 1.0 <= a.lens_hfov <= 170.0:
        ap.error(f"--lens-hfov must be 1-170 degrees, not {a.lens_hfov:g}")
    size = (1280, 720)
    if a.size is not None:
        try:
            size = tuple(int(v) for v in a.size.lower().split("x"))
            if len(size) != 2 or min(size) < 64:
                raise ValueError
        except ValueError:
            ap.error(f"--size must be WxH in pixels, each at least 64 (e.g. 1920x1080), not {a.size!r}")
    if a.lens_hfov is not None:
        camera = CameraModel.ideal(size, hfov_deg=a.lens_hfov)
    elif size != (1280, 720):
        camera = udacity_camera().scaled_to(size)
    base = load_config(a.config) if a.config else Config()
    results = {}
    for name in a.only or SCENARIOS:
        results[name] = run(name, a.frames, a.seeds, a.out, base, randomise=not a.fixed, reuse=a.reuse,
                            own_setup=not a.self_calibrate, camera=camera,
                            road_from_seed=not (a.fixed or a.same_road))
        head, row = results[name].table(name).split("\n")
        if len(results) == 1:
            print(head)
        print(row, flush=True)
    print()
    for i, (name, rep) in enumerate(results.items()):
        print(rep.band_table(name, header=i == 0))
    a.out.mkdir(parents=True, exist_ok=True)
    report = a.out / ("report_selfcal.json" if a.self_calibrate else "report.json")
    report.write_text(json.dumps({k: asdict(v) for k, v in results.items()}, indent=2) + "\n")
    seeds = ", ".join(map(str, a.seeds))
    if a.fixed:
        look = "fixed look"
    elif a.same_road:
        look = "look and camera drawn from each seed, the same stretch of road"
    else:
        look = "look, camera and stretch of road drawn from each seed"
    if a.lens_hfov is not None:
        look += f", an ideal {a.lens_hfov:g}-degree lens at {size[0]}x{size[1]}"
    elif camera is not None:
        look += f", the Udacity lens at {size[0]}x{size[1]}"
    setup = "the default set-up and self-calibration" if a.self_calibrate else "each sequence's exact set-up"
    print(f"\n{a.frames} frames per scenario and seed, seeds {seeds}, {look}, {setup}; report: {report}")
    return 0


def cli() -> int:
    """Run :func:`main`; a refusal (a config that does not load, an output folder that cannot be made) is one line."""
    try:
        return main()
    except LaneFinderError as e:
        print(f"eval_synthetic: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(cli())
