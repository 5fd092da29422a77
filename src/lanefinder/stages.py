"""The intermediate images of one frame, like the figures of a project write-up."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from .io import write_image
from .pipeline import LaneFinder
from .render import annotate, search_view
from .threshold import threshold


def stage_images(frame: np.ndarray, finder: LaneFinder) -> dict[str, np.ndarray]:
    """Named stage images: undistorted, binary, birdseye, birdseye_binary, windows, final."""
    debug = LaneFinder(finder.config, camera=finder._camera, keep_debug=True)
    result = debug.process(frame)
    be = debug.birdseye((frame.shape[1], frame.shape[0]))
    undist = be.camera.undistort(frame)
    marked = undist.copy()
    cv2.polylines(marked, [np.round(be.src_px).astype(np.int32)], True, (0, 0, 255), 2, cv2.LINE_AA)
    warped = be.warp(frame)
    cv2.polylines(warped, [np.round(be.dst_px).astype(np.int32)], True, (0, 0, 255), 2, cv2.LINE_AA)
    return {
        "1_undistorted": marked,
        "2_binary": threshold(undist, finder.config.threshold) * 255,
        "3_birdseye": warped,
        "4_birdseye_binary": result.binary * 255,
        "5_windows": search_view(result.binary, result.search, result),
        "6_final": annotate(frame, result, be, finder.config.render),
    }


def write_stages(folder: Path, stem: str, frame: np.ndarray, finder: LaneFinder) -> list[Path]:
    """Write the stage images as ``folder/<stem>_<stage>.png``."""
    out = []
    for name, img in stage_images(frame, finder).items():
        path = Path(folder) / f"{stem}_{name}.png"
        write_image(path, img)
        out.append(path)
    return out
