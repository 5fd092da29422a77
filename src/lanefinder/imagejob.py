"""The image job: single frames in, annotated copies and ``results.jsonl`` out.

Every image is found blind (the track is reset between images).  Its row in
``results.jsonl`` is ``image``, ``output``, then the telemetry row format
(:func:`~lanefinder.telemetry.lane_row`: state, per-line found/inferred/confidence/fits/x at
the TuSimple rows/range, and the lane numbers), then ``ms``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .config import Config, config_arg
from .errors import LaneFinderError
from .io import OutputSet, atomic_write_text, check_outputs, read_image, write_image
from .limits import check_memory
from .pipeline import LaneFinder
from .render import annotate
from .stages import write_stages
from .telemetry import BlownOut, h_samples, lane_row

__all__ = ["RESULTS_NAME", "ImageRun", "output_names", "process_images"]

#: The per-image results file written into the output folder.
RESULTS_NAME = "results.jsonl"


@dataclass(frozen=True)
class ImageRun:
    """What an image run did.

    Attributes
    ----------
    rows : list of dict
        One row per image, as written to ``results.jsonl``; none when any image failed (all
        or nothing: then no output is written).
    failures : list of (str, str)
        (image, reason) of each image that could not be done.
    renamed : list of (str, str)
        (image, output) where an output was renamed so that it does not overwrite another.
    results : str or None
        The results file, when it was written.

    Examples
    --------
    >>> ImageRun(rows=[], failures=[("a.jpg", "cannot read image")]).ok
    False
    """

    rows: list[dict[str, Any]]
    failures: list[tuple[str, str]] = field(default_factory=list)
    renamed: list[tuple[str, str]] = field(default_factory=list)
    results: str | None = None

    @property
    def ok(self) -> bool:
        """Whether every image was done."""
        return not self.failures


def output_names(paths: Sequence[Path], suffix: str = ".jpg") -> list[str]:
    """Give each input image an output file name that no other input's takes.

    Names are the input's stem with ``suffix``; a stem seen before gets ``_2``, ``_3``, ...

    Parameters
    ----------
    paths : sequence of Path
        The input images.
    suffix : str
        The output suffix.

    Returns
    -------
    list of str
        One file name per input, all different.

    Examples
    --------
    >>> output_names([Path("a/x.jpg"), Path("b/x.jpg"), Path("y.png")])
    ['x.jpg', 'x_2.jpg', 'y.jpg']
    """
    taken: set[str] = set()
    out = []
    for p in paths:
        name, k = f"{p.stem}{suffix}", 1
        while name.lower() in taken:
            k += 1
            name = f"{p.stem}_{k}{suffix}"
        taken.add(name.lower())
        out.append(name)
    return out


def process_images(paths: Sequence[Path], outdir: str | Path, config: Config | None = None,
                   stages_dir: str | Path | None = None,
                   on_row: Callable[[dict[str, Any]], None] | None = None) -> ImageRun:
    """Find the lane in single images; write annotated copies and ``results.jsonl``.

    Parameters
    ----------
    paths : sequence of Path
        The images (see :func:`lanefinder.io.list_images` to expand folders).
    outdir : str or Path
        Folder for the annotated images and ``results.jsonl``.
    config : Config, optional
        The configuration (defaults when omitted).
    stages_dir : str or Path, optional
        Also write each image's intermediate stage images here.
    on_row : callable, optional
        Called with each image's row as soon as it is done (for printing).

    Returns
    -------
    ImageRun
        The rows, the failures with their reasons, and the renamed outputs.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     run = process_images([Path("data/test_images/test3.jpg")], d)
    >>> run.ok, run.rows[0]["left_found"], run.rows[0]["output"].endswith("test3.jpg")
    (True, True, True)
    """
    cfg = config_arg(config)
    if isinstance(paths, (str, Path)):
        raise LaneFinderError("paths must be a list of image paths (give [path] for one image)")
    paths = [Path(p) for p in paths]
    finder = LaneFinder(cfg)
    out = Path(outdir)
    results = out / RESULTS_NAME
    rows: list[dict[str, Any]] = []
    failures: list[tuple[str, str]] = []
    names = output_names(paths)
    renamed = [(str(p), n) for p, n in zip(paths, names, strict=True) if n != f"{p.stem}.jpg"]
    check_outputs([results, *(out / n for n in names)], paths)
    # Every output is put in place together at the end; a failure to write drops them all.
    with OutputSet(inputs=paths) as outs:
        for p, name in zip(paths, names, strict=True):
            dest = out / name
            try:  # an image that cannot be read or served is reported, and the others go on
                # (an image too large for the memory budget is refused from its header, undecoded)
                frame = read_image(p, check=lambda size: check_memory(finder.config, size))
                t0 = time.perf_counter()
                result = finder.process_still(frame)
                ms = (time.perf_counter() - t0) * 1000
                be = finder.birdseye((frame.shape[1], frame.shape[0]))
            except LaneFinderError as e:
                failures.append((str(p), str(e)))
                continue
            write_image(dest, annotate(frame, result, be, cfg.render), outputs=outs)
            if stages_dir:
                write_stages(Path(stages_dir), dest.stem, frame, finder, outputs=outs)
            blown = BlownOut.of(frame, h_samples(frame.shape[0]))
            row = {"image": str(p), "output": str(dest), **lane_row(result, be, cfg.far.confidence_decay_m, blown),
                   "ms": round(ms, 2)}
            rows.append(row)
            if on_row:
                on_row(row)
        if failures:  # all or nothing: a bad input leaves every output as it was
            outs.discard()
            rows = []
        elif rows:
            atomic_write_text(results, "".join(json.dumps(r) + "\n" for r in rows), outputs=outs)
    return ImageRun(rows=rows, failures=failures, renamed=renamed, results=str(results) if rows else None)
