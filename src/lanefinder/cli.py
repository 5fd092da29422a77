"""The ``lanefinder`` command: a thin layer over the Python API that parses and prints.

Every command's work lives in the library (the jobs :mod:`lanefinder.imagejob` and
:mod:`lanefinder.videojob`, and the stage modules); errors in what the user gives end in one
``lanefinder: error:`` line and exit status 2.
"""

from __future__ import annotations

import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import click

from . import __version__
from .errors import LaneFinderError

__all__ = ["main"]


def _fail(msg: str) -> None:
    click.echo(f"lanefinder: error: {msg}", err=True)


class _Group(click.Group):
    """Turn every failure into one line: exit 2 for bad input or a full disk, 130 for Ctrl-C, 1 for a bug.

    Nothing escapes as a traceback unless ``--verbose`` asks for it.
    """

    def main(self, *args, **kwargs):
        """Run the command line; a usage error is one line too (exit 2)."""
        kwargs["standalone_mode"] = False
        try:
            rv = super().main(*args, **kwargs)
        except click.exceptions.NoArgsIsHelpError as e:
            click.echo(e.ctx.get_help() if e.ctx else "", err=True)
            sys.exit(2)
        except click.ClickException as e:
            hint = f" (see '{e.ctx.command_path} --help')" if getattr(e, "ctx", None) is not None else ""
            _fail(f"{e.format_message()}{hint}")
            sys.exit(e.exit_code)
        except click.exceptions.Abort:
            _fail("interrupted")
            sys.exit(130)
        sys.exit(rv if isinstance(rv, int) else 0)

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except (click.exceptions.Exit, click.ClickException, click.exceptions.Abort):
            raise
        except LaneFinderError as e:
            _fail(str(e))
            sys.exit(2)
        except KeyboardInterrupt:
            _fail("interrupted")
            sys.exit(130)
        except OSError as e:
            _verbose_traceback(ctx)
            where = f": {e.filename}" if getattr(e, "filename", None) else ""
            _fail(f"{e.strerror or e}{where}")
            sys.exit(2)
        except MemoryError:
            _verbose_traceback(ctx)
            _fail("out of memory (see limits.memory_mb in the config)")
            sys.exit(2)
        except Exception as e:  # a bug: say so in one line, never silently
            _verbose_traceback(ctx)
            _fail(f"internal error ({type(e).__name__}: {e}); run with --verbose for the traceback "
                  "and please report it")
            sys.exit(1)


def _verbose_traceback(ctx: click.Context) -> None:
    if (ctx.obj or {}).get("verbose"):
        import traceback

        traceback.print_exc()


class _Finite(click.ParamType):
    """A finite float within bounds (NaN and infinities are refused with the option's name)."""

    name = "float"

    def __init__(self, lo: float | None = None, hi: float | None = None):
        self.lo, self.hi = lo, hi

    def convert(self, value, param, ctx) -> float:
        import math

        try:
            v = float(value)
        except (TypeError, ValueError):
            self.fail(f"{value!r} is not a number", param, ctx)
        if not math.isfinite(v):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        if (self.lo is not None and v < self.lo) or (self.hi is not None and v > self.hi):
            self.fail(f"{v:g} is not in the range {self.lo:g} to {self.hi:g}", param, ctx)
        return v

    def get_metavar(self, param, ctx=None) -> str:
        lo = "" if self.lo is None else f"{self.lo:g}"
        hi = "" if self.hi is None else f"{self.hi:g}"
        return f"FLOAT {lo}..{hi}" if lo or hi else "FLOAT"


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="lanefinder")
@click.option("--verbose", is_flag=True, help="Print the traceback of an internal error.")
@click.pass_context
def main(ctx: click.Context, verbose: bool) -> None:
    """Find the lane on a car's forward camera: calibrate, process images and videos.

    \f

    Examples
    --------
    >>> from click.testing import CliRunner
    >>> CliRunner().invoke(main, ["--version"]).output.strip()
    'lanefinder, version 0.1.1'
    """  # noqa: D301 (click cuts the help at the form feed, before the examples)
    ctx.obj = {"verbose": verbose}


def _not_empty(_ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    """Refuse an empty output path (it was taken as the current folder, or named nothing in the message)."""
    if value is not None and not value.strip():
        raise click.BadParameter("is empty: name a file or folder", param=param)
    return value


def _config(path: str | None):
    """Load a config; the camera file it names must exist and describe a lens (checked before any work)."""
    from .pipeline import load_checked_config

    return load_checked_config(path)


def _board(text: str) -> tuple[int, int]:
    try:
        cols, rows = (int(v) for v in text.lower().split("x"))
        if not (3 <= cols <= 30 and 3 <= rows <= 30):
            raise ValueError
    except ValueError:
        raise LaneFinderError(f"--board takes COLSxROWS of inner corners, 3 to 30 each, like 9x6 "
                              f"(got {text!r})") from None
    return cols, rows


# -- calibrate ---------------------------------------------------------------------------
@main.command()
@click.argument("photos", nargs=-1, required=True)
@click.option("--board", default="9x6", show_default=True, help="Inner corners, COLSxROWS.")
@click.option("-o", "--output", callback=_not_empty,
              default="camera.json", show_default=True, help="Camera file to write (JSON).")
def calibrate(photos: tuple[str, ...], board: str, output: str) -> None:
    """Calibrate the camera from chessboard PHOTOS (files or folders)."""
    from .camera import calibrate as run
    from .camera import calibration_photos, save_camera
    from .io import check_distinct, check_not_input

    if Path(output).suffix.lower() != ".json":
        raise LaneFinderError(f"the camera file is written as JSON: name it .json, not {Path(output).name or output}")
    paths = calibration_photos(photos)
    check_distinct(paths, "photo")
    check_not_input(output, paths)
    t0 = time.perf_counter()
    cam = run(paths, _board(board))
    click.echo(f"{'photo':<24} {'used':<5} {'board':<6} {'error px':>8}  note")
    for v in cam.views:
        pattern = f"{v.pattern[0]}x{v.pattern[1]}" if v.pattern else "-"
        err = f"{v.error_px:.3f}" if v.error_px is not None else "-"
        click.echo(f"{Path(v.path).name:<24} {'yes' if v.used else 'no':<5} {pattern:<6} {err:>8}  {v.reason}")
    used = sum(v.used for v in cam.views)
    k = cam.camera_matrix
    click.echo(f"\nused {used} of {len(cam.views)} photos in {time.perf_counter() - t0:.1f} s; "
               f"image size {cam.image_size[0]}x{cam.image_size[1]}")
    click.echo(f"RMS reprojection error: {cam.rms_px:.3f} px")
    click.echo(f"fx={k[0, 0]:.1f} fy={k[1, 1]:.1f} cx={k[0, 2]:.1f} cy={k[1, 2]:.1f}  "
               f"dist={', '.join(f'{d:.4f}' for d in cam.dist_coeffs)}")
    save_camera(cam, output)
    click.echo(f"wrote {output}")


# -- config ------------------------------------------------------------------------------
@main.command("config")
@click.option("--default", "default", is_flag=True, help="Print the full default configuration.")
@click.option("--check", "check", type=click.Path(), help="Validate a config file and print it in full.")
@click.option("--format", "fmt", type=click.Choice(["toml", "yaml", "json"]),
              help="The format (default: the output file's, else toml).")
@click.option("-o", "--output", callback=_not_empty,
              type=click.Path(), help="Write to this file (.toml/.yaml/.json) instead of standard "
              "output.")
def config_cmd(default: bool, check: str | None, fmt: str | None, output: str | None) -> None:
    """Print (or check) the configuration that -c takes."""
    from .config import Config, dump_config
    from .io import atomic_write_text, check_not_input

    if not default and not check:
        raise LaneFinderError("say --default to print the defaults, or --check FILE to validate a config")
    if output:
        wanted = _config_format(output)
        if fmt and fmt != wanted:
            raise LaneFinderError(f"--format {fmt} does not suit {output}, which -c would read as {wanted}")
        fmt = wanted
        if check:
            check_not_input(output, [check])
    cfg = _config(check) if check else Config()
    text = dump_config(cfg, fmt or "toml")  # type: ignore[arg-type]
    if output:
        atomic_write_text(output, text)
        click.echo(f"wrote {output}", err=True)
    else:
        click.echo(text, nl=False)


def _config_format(path: str) -> str:
    """Give the format a config file of this name is read in (``-c``), or refuse a name -c cannot read."""
    fmt = {".toml": "toml", ".yaml": "yaml", ".yml": "yaml", ".json": "json"}.get(Path(path).suffix.lower())
    if fmt is None:
        raise LaneFinderError(f"a config is written as .toml, .yaml (.yml) or .json (so that -c can read it), "
                              f"not {path}")
    return fmt


# -- image -------------------------------------------------------------------------------
def _line_word(row: dict, side: str) -> str:
    return "yes" if row[f"{side}_found"] else ("infer" if row[f"{side}_inferred"] else "no")


def _cell(v: float | None, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


@main.command()
@click.argument("images", nargs=-1, required=True)
@click.option("-c", "--config", "config_path", type=click.Path(), help="Config file (TOML/YAML/JSON).")
@click.option("-o", "--outdir", callback=_not_empty,
              required=True, type=click.Path(), help="Folder for the annotated images.")
@click.option("--stages", "stages_dir", type=click.Path(), help="Also write the intermediate images here.")
def image(images: tuple[str, ...], config_path: str | None, outdir: str, stages_dir: str | None) -> None:
    """Find the lane in single IMAGES (files or folders) and write annotated copies."""
    from .imagejob import process_images
    from .io import list_images

    cfg = _config(config_path)
    paths = list_images(images)
    shown = []

    def show(row: dict) -> None:
        if not shown:  # the header with the first row: output names are checked before it
            click.echo(f"{'image':<22} {'left':<5} {'right':<5} {'radius m':>9} {'offset m':>9} {'width m':>8} "
                       f"{'ms':>6}")
            shown.append(True)
        click.echo(f"{Path(row['image']).name:<22} {_line_word(row, 'left'):<5} {_line_word(row, 'right'):<5} "
                   f"{_cell(row['radius_m'], '9.0f'):>9} {_cell(row['offset_m'], '9.3f'):>9} "
                   f"{_cell(row['width_m'], '8.3f'):>8} {row['ms']:>6.1f}")

    run = process_images(paths, outdir, cfg, stages_dir, on_row=show)
    for src, name in run.renamed:
        click.echo(f"note: {src} -> {name} (another input has the same name)")
    if run.results:
        click.echo(f"wrote {len(run.rows)} image(s) and {Path(run.results).name} to {outdir}")
    if run.failures:
        src, reason = run.failures[0]
        first = reason if src in reason else f"{src}: {reason}"
        more = f"{len(run.failures)} of {len(paths)} images failed, the first: " if len(run.failures) > 1 else ""
        _fail(f"{more}{first}; nothing was written (all or nothing)")
        sys.exit(2)


# -- video -------------------------------------------------------------------------------
@main.command()
@click.argument("src", type=click.Path())
@click.option("-o", "--output", callback=_not_empty, type=click.Path(),
              help="Annotated video to write (.mp4, H.264); leave out for telemetry only.")
@click.option("-c", "--config", "config_path", type=click.Path(), help="Config file (TOML/YAML/JSON).")
@click.option("--start", "start_s", type=_Finite(0, 1e7), default=0.0, show_default=True, help="Start, seconds.")
@click.option("--end", "end_s", type=_Finite(0, 1e7), default=None, help="End, seconds (default: the end).")
@click.option("--telemetry", type=click.Path(), help="Per-frame numbers: .csv, .jsonl or .parquet (typed columns).")
@click.option("--debug", is_flag=True, help="Picture-in-picture of the bird's-eye search in every frame.")
@click.option("--contact-sheet", "sheet", type=click.Path(), help="Write a PNG grid of frames spread over the run.")
@click.option("--sheet-frames", type=click.IntRange(1, 200), default=None,
              help="Frames on the contact sheet, evenly spread (default 20).")
@click.option("--preset", type=click.Choice(["ultrafast", "superfast", "veryfast", "faster", "fast", "medium"]),
              help="x264 preset (default from config: superfast).")
@click.option("--crf", type=click.IntRange(0, 51), help="x264 quality, lower is better (default from config: 23).")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@click.option("--events", "events_path", type=click.Path(),
              help="Lane events (departures, lane changes, lost stretches): .csv, .jsonl or .parquet.")
def video(src: str, output: str | None, config_path: str | None, start_s: float, end_s: float | None,
          telemetry: str | None, debug: bool, sheet: str | None, sheet_frames: int | None, preset: str | None,
          crf: int | None, quiet: bool, events_path: str | None) -> None:
    """Find the lane in every frame of the video SRC; write an annotated H.264 MP4, telemetry and/or events."""
    from .videojob import process_video

    cfg = _config(config_path)
    if preset or crf is not None:
        v = cfg.video.model_copy(update={k: val for k, val in (("preset", preset), ("crf", crf)) if val is not None})
        cfg = cfg.model_copy(update={"video": v})
    if output is None and telemetry is None and events_path is None:
        raise LaneFinderError("give -o OUT.mp4 for an annotated video, --telemetry FILE for the numbers, "
                              "--events FILE for the lane events, or several")
    if output is not None and Path(output).suffix.lower() != ".mp4":
        raise LaneFinderError(f"the output must be an .mp4 file: {output}")
    if sheet_frames is not None and sheet is None:
        raise LaneFinderError("--sheet-frames needs --contact-sheet FILE.png")
    summary = process_video(src, output, cfg, start_s=start_s, end_s=end_s, telemetry=telemetry, debug=debug,
                            contact_sheet_path=sheet, sheet_frames=sheet_frames or 20, progress=not quiet,
                            events=events_path)
    for line in summary.lines():
        if line:
            click.echo(line)
    if summary.interrupted:
        sys.exit(130)


# -- plot --------------------------------------------------------------------------------
@main.command()
@click.argument("telemetry", type=click.Path())
@click.option("-o", "--output", callback=_not_empty,
              required=True, type=click.Path(), help="Plot to write (.png, .pdf or .svg).")
def plot(telemetry: str, output: str) -> None:
    """Plot radius, offset, width and confidence over time from a TELEMETRY file."""
    from .io import check_not_input
    from .plot import plot_telemetry
    from .telemetry import read_telemetry

    check_not_input(output, [telemetry])
    plot_telemetry(read_telemetry(telemetry), output)
    click.echo(f"wrote {output}")


# -- synth / eval ------------------------------------------------------------------------
@main.command()
@click.option("--scenario", default="straight", show_default=True,
              help="straight, curve, shadows, pavement, glare, worn, double-yellow, curve-entry, sharp-curve, "
                   "lane-change, drift, hills, winding, night (see --list).")
@click.option("--frames", "n_frames", type=click.IntRange(1, 100000), default=100, show_default=True)
@click.option("--seed", type=click.IntRange(0, 2**32 - 1), default=0, show_default=True)
@click.option("--camera", "camera_path", type=click.Path(), help="Camera file (default: the Udacity camera).")
@click.option("--height", "height_m", type=_Finite(0.5, 4.0), default=None, help="Camera height above the road, m.")
@click.option("--pitch", "pitch_deg", type=_Finite(-10.0, 15.0), default=None, help="Camera pitch, degrees down.")
@click.option("-o", "--outdir", callback=_not_empty,
              type=click.Path(), help="Folder for the sequence (required unless --list).")
@click.option("--list", "list_only", is_flag=True, help="List the scenarios and exit.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@click.option("--randomise", is_flag=True,
              help="Draw the road's look (surface, light, paint, dashes, clutter, vehicles), the lane width and "
                   "the camera mount (height 1.1-1.6 m, pitch, yaw) from the seed.")
@click.option("--road-from-seed", is_flag=True,
              help="Start at a point of the scenario's cycle of geometry drawn from the seed (as `make eval` does); "
                   "without it the sequence drives the cycle's first seconds.")
def synth(scenario: str, n_frames: int, seed: int, camera_path: str | None, height_m: float | None,
          pitch_deg: float | None, outdir: str, list_only: bool, quiet: bool, randomise: bool,
          road_from_seed: bool) -> None:
    """Render a synthetic dashcam sequence with exact ground truth.

    Writes video.mp4, gt.jsonl (per frame: curvature, radius, offset, width, TuSimple lanes),
    events_gt.jsonl (the true lane events), camera.json, config.toml (the exact bird's-eye
    set-up, for `lanefinder video -c`) and scenario.json (the scenario, look and mount drawn).
    """
    from .camera import load_camera
    from .synth import SCENARIOS, Appearance, Mount, write_sequence

    if list_only:
        for s in SCENARIOS.values():
            click.echo(f"{s.name:<14} {s.description}")
        return
    if outdir is None:
        raise LaneFinderError("give the folder for the sequence with -o/--outdir")
    mount = Appearance.random(seed).mount if randomise else Mount()
    if height_m is not None or pitch_deg is not None or not randomise:
        mount = replace(mount, height_m=height_m if height_m is not None else mount.height_m,
                        pitch_deg=pitch_deg if pitch_deg is not None else mount.pitch_deg)
    cam = load_camera(camera_path) if camera_path else None
    out = write_sequence(scenario, n_frames, outdir, seed, cam, mount, progress=not quiet, randomise=randomise,
                         road_from_seed=road_from_seed)
    click.echo(f"wrote {out}/video.mp4, gt.jsonl, events_gt.jsonl, camera.json, config.toml, scenario.json")


@main.command("eval")
@click.option("--gt", "gt_path", required=True, type=click.Path(), help="Ground truth: gt.jsonl or TuSimple labels.")
@click.option("--pred", "pred_path", required=True, type=click.Path(),
              help="Predictions: lanefinder telemetry (.csv/.parquet/.jsonl) or TuSimple predictions.")
@click.option("--json", "json_path", type=click.Path(), help="Also write the figures as JSON.")
@click.option("--name", default="", help="Row label in the table (default: the predictions' file name).")
def eval_cmd(gt_path: str, pred_path: str, json_path: str | None, name: str) -> None:
    """Score predictions: TuSimple accuracy/FP/FN, offset and curvature errors, catastrophic frames."""
    from dataclasses import asdict

    from .evaluate import evaluate, read_ground_truth, read_predictions
    from .io import atomic_write_text, check_outputs

    if json_path:
        check_outputs([json_path], [gt_path, pred_path])  # before the table: not an input, not a folder
    predictions = read_predictions(pred_path)
    if not predictions:
        raise LaneFinderError(f"{pred_path} holds no predictions (no rows)")
    report = evaluate(read_ground_truth(gt_path), predictions)
    name = name or Path(pred_path).stem
    click.echo(report.table(name))
    if any(v is not None for v in report.band_accuracy.values()) or report.lateral_err_6m_median is not None:
        # the truth gives distances (TuSimple labels do not)
        click.echo(report.band_table(name))
    if report.missing_frames:
        click.echo(f"{report.missing_frames} ground-truth frame(s) had no prediction (scored as no lane)")
    if json_path:
        atomic_write_text(json_path, json.dumps(asdict(report), indent=2) + "\n")
        click.echo(f"wrote {json_path}")


def _quiet_interrupted_cluster() -> None:
    """Silence what a local Dask cluster stopped while it started says as this process exits.

    distributed closes its clusters at exit and asserts on one stopped half-way, and asyncio
    reports the nannies' start-up tasks that never finished: tracebacks after the one line
    that says the run was interrupted.
    """
    import logging

    sys.unraisablehook = lambda unraisable: None  # "Exception ignored in atexit callback"
    for name in ("asyncio", "distributed", "tornado"):
        logging.getLogger(name).setLevel(logging.CRITICAL)


# -- setup -------------------------------------------------------------------------------
@main.command()
@click.option("--straight", "straight", multiple=True, type=click.Path(),
              help="A straight-road frame (repeat, or give a folder).")
@click.option("--video", "video_path", type=click.Path(), help="Find straight-road frames in this video.")
@click.option("--camera", "camera_path", type=click.Path(), help="Camera file (JSON or OpenCV YAML).")
@click.option("--lookahead", "lookahead_m", type=_Finite(5.0, 150.0), default=35.0, show_default=True,
              help="How far ahead the view reaches, m (with a camera file).")
@click.option("--bottom", "bottom_fraction", type=_Finite(0.5, 1.0), default=0.9375, show_default=True,
              help="Bottom row of the view as a fraction of the height (above the hood).")
@click.option("--lane-width", "lane_width_m", type=_Finite(2.0, 6.0), default=3.7, show_default=True,
              help="The lane's width between line centres, m.")
@click.option("--dash-period", "dash_period_m", type=_Finite(1.0, 50.0), default=12.2, show_default=True,
              help="Dash + gap length, m: fixes the focal length without a camera file (12.2: US federal; "
                   "California paints 14.6).")
@click.option("-o", "--output", callback=_not_empty,
              required=True, type=click.Path(), help="Config to write (.toml/.yaml/.json).")
def setup(straight: tuple[str, ...], video_path: str | None, camera_path: str | None, lookahead_m: float,
          bottom_fraction: float, lane_width_m: float, dash_period_m: float, output: str) -> None:
    """Find the bird's-eye view and its scale for a new camera, from straight-road frames."""
    from .autosetup import SetupOptions, auto_setup, preview, straight_frames_from_video
    from .camera import load_camera
    from .config import SETUP_SECTIONS, dump_config
    from .io import (
        OutputSet,
        atomic_write_text,
        check_distinct,
        check_outputs,
        input_file,
        list_images,
        read_image,
        write_image,
    )

    if bool(straight) == bool(video_path):
        raise LaneFinderError("give straight-road frames with --straight, or a video with --video")
    fmt = _config_format(output)
    prev = Path(output).with_name(Path(output).stem + "_preview.png")
    paths = [Path(video_path)] if video_path else list_images(straight)
    check_distinct(paths, "frame")
    check_outputs([output, prev], _setup_inputs(paths, camera_path))  # before any work
    camera = load_camera(camera_path) if camera_path else None
    opts = SetupOptions(lane_width_m=lane_width_m, lookahead_m=lookahead_m, bottom_fraction=bottom_fraction,
                        dash_period_m=dash_period_m)
    if video_path:
        input_file(video_path, "video")
        click.echo(f"looking for straight-road frames in {video_path} ...")
        images = straight_frames_from_video(video_path, opts)
        if not images:
            raise LaneFinderError(f"no frame could be read from {video_path}")
        click.echo(f"{len(images)} frames sampled from the video (numbered 1-{len(images)} below)")
    else:
        images = [read_image(p) for p in paths]
    ref = "none"
    if camera_path:
        ref = str(Path(camera_path).resolve().relative_to(Path(output).resolve().parent)) \
            if Path(camera_path).resolve().is_relative_to(Path(output).resolve().parent) \
            else str(Path(camera_path).resolve())
    result = auto_setup(images, camera, opts, camera_ref=ref)
    for note in result.notes:
        click.echo(f"note: {note}")
    b = result.birdseye
    click.echo(f"frame size {b.reference_size[0]}x{b.reference_size[1]}")
    click.echo(f"vanishing point: ({result.vp[0]:.1f}, {result.vp[1]:.1f}); horizon row {result.horizon_row:.1f}; "
               f"focal length {result.focal_px:.0f} px ({result.ym_source}); camera {result.height_m:.2f} m "
               "over the road")
    click.echo("src: " + ", ".join(f"({x:.1f}, {y:.1f})" for x, y in b.src))
    click.echo("dst: " + ", ".join(f"({x:.0f}, {y:.0f})" for x, y in b.dst) + f" in a {b.size[0]}x{b.size[1]} view")
    click.echo(f"xm_per_px = {b.xm_per_px:.6f} (lane width {lane_width_m} m over {b.dst[1][0] - b.dst[0][0]:.0f} px); "
               f"ym_per_px = {b.ym_per_px:.6f}")
    click.echo(f"straightness: the accepted frames' lines bend by at most {result.straightness_px:.1f} px over the "
               "view")
    quality = result.quality.lines() if result.quality else []
    for line in quality:
        click.echo(line)
    with OutputSet(inputs=_setup_inputs(paths, camera_path)) as together:
        text = dump_config(result.config(), fmt, sections=SETUP_SECTIONS)  # type: ignore[arg-type]
        if fmt != "json":  # JSON has no comments: the report is printed above
            text = "".join(f"# set-up {line}\n" for line in quality[:3]) + text
        atomic_write_text(output, text, outputs=together)
        write_image(prev, preview(images[0], result, camera), outputs=together)
    click.echo(f"wrote {output} and {prev}; use it with: lanefinder video IN.mp4 -o OUT.mp4 -c {output}")


# -- batch -------------------------------------------------------------------------------
@main.command()
@click.argument("inputs", nargs=-1, required=True)
@click.option("-o", "--outdir", callback=_not_empty,
              required=True, help="Output folder (a path or an fsspec URL); a re-run resumes.")
@click.option("-c", "--config", "config_path", type=click.Path(), help="Config file (TOML/YAML/JSON).")
@click.option("--workers", type=click.IntRange(1, 512), default=None,
              help="Local Dask workers (default: one per core).")
@click.option("--scheduler", default=None, help="Use a running Dask scheduler, e.g. tcp://127.0.0.1:8786.")
@click.option("--video", "write_video", is_flag=True, help="Also write annotated videos (OUTDIR/videos/).")
@click.option("--quiet", is_flag=True, help="No progress bar.")
def batch(inputs: tuple[str, ...], outdir: str, config_path: str | None, workers: int | None,
          scheduler: str | None, write_video: bool, quiet: bool) -> None:
    """Process a fleet of videos on Dask: INPUTS are videos, folders or text files of paths (or URLs).

    Writes a Parquet dataset partitioned by video (OUTDIR/telemetry/), events.parquet,
    summary.parquet and summary.csv; exit status 2 when any video failed.
    """
    from .batch import run_batch

    if workers is not None and scheduler:
        raise LaneFinderError("give --workers for a local cluster or --scheduler for a running one, not both")
    # After a Ctrl-C, multiprocessing's resource tracker (a process of its own, started with the
    # local workers) warns of the semaphores of the workers it then removes itself: noise, not ours.
    quiet_tracker = "ignore::UserWarning:multiprocessing.resource_tracker"
    before = os.environ.get("PYTHONWARNINGS")
    os.environ["PYTHONWARNINGS"] = ",".join(filter(None, (before, quiet_tracker)))
    try:
        report = run_batch(list(inputs), outdir, _config(config_path), workers=workers, scheduler=scheduler,
                           write_video=write_video, progress=not quiet, echo=click.echo)
    except KeyboardInterrupt:
        _quiet_interrupted_cluster()
        raise
    finally:
        if before is None:
            os.environ.pop("PYTHONWARNINGS", None)
        else:
            os.environ["PYTHONWARNINGS"] = before
    for line in report.lines():
        click.echo(line)
    if report.failed:
        _fail(f"{report.failed} of {report.videos} videos failed: their reasons are in "
              f"{outdir.rstrip('/')}/summary.csv")
        sys.exit(2)


# -- review ------------------------------------------------------------------------------
@main.command()
@click.argument("path", type=click.Path())
@click.option("--port", type=click.IntRange(0, 65535), default=8765, show_default=True, help="Port (0: any free one).")
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Address to bind; anything but this machine prints a warning.")
@click.option("-c", "--config", "config_path", type=click.Path(), help="Config the inspector starts from.")
@click.option("--telemetry", type=click.Path(), help="The video's telemetry (default: beside it, same name).")
def review(path: str, port: int, host: str, config_path: str | None, telemetry: str | None) -> None:
    """Serve a local page to browse PATH (a batch folder, or a video with its telemetry) and tune live."""
    from .review import load_review, serve

    serve(load_review(path, config_path, telemetry), host=host, port=port, echo=click.echo)


def _setup_inputs(paths: list[Path], camera_path: str | None) -> list[Path]:
    """Give the inputs a set-up reads: its frames (or video) and its camera file."""
    return [*paths, *([Path(camera_path)] if camera_path else [])]


if __name__ == "__main__":  # pragma: no cover
    main()
