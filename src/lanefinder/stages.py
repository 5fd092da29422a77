"""The intermediate images of one frame, like the figures of a project write-up."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from .io import OutputSet, write_image
from .lane import LaneResult
from .pipeline import LaneFinder
from .render import annotate, search_view
from .threshold import threshold

__all__ = ["inspect_frame", "stage_images", "write_stages"]


def stage_images(frame: np.ndarray, finder: LaneFinder) -> dict[str, np.ndarray]:
    """Return the named stage images of one frame, found blind (no track).

    Parameters
    ----------
    frame : (H, W, 3) uint8 ndarray
        The original frame, BGR.
    finder : LaneFinder
        Gives the configuration, the camera and the set-up in use (after
        :meth:`~lanefinder.pipeline.LaneFinder.process_still`, the still's own, and the frame is
        measured as a still).

    Returns
    -------
    dict of str to ndarray
        ``1_undistorted`` (with the source trapezoid), ``2_binary`` (threshold on the
        undistorted frame), ``3_birdseye``, ``4_birdseye_binary``, ``5_windows`` and ``6_final``.

    Examples
    --------
    >>> import cv2
    >>> from lanefinder import LaneFinder
    >>> images = stage_images(cv2.imread("data/test_images/test3.jpg"), LaneFinder())
    >>> list(images), images["5_windows"].shape
    (['1_undistorted', '2_binary', '3_birdseye', '4_birdseye_binary', '5_windows', '6_final'], (300, 400, 3))
    """
    return inspect_frame(frame, finder)[0]


def inspect_frame(frame: np.ndarray, finder: LaneFinder) -> tuple[dict[str, np.ndarray], LaneResult]:
    """Return the named stage images of one frame, found blind (no track), and its result.

    Parameters
    ----------
    frame : (H, W, 3) uint8 ndarray
        The original frame, BGR.
    finder : LaneFinder
        Gives the configuration, the camera and the set-up in use (after
        :meth:`~lanefinder.pipeline.LaneFinder.process_still`, the still's own, and the frame is
        measured as a still: :attr:`~lanefinder.pipeline.LaneFinder.last_still`).

    Returns
    -------
    images : dict of str to ndarray
        As :func:`stage_images` gives them.
    result : LaneResult
        The frame's result.

    Examples
    --------
    >>> import cv2
    >>> from lanefinder import LaneFinder
    >>> images, result = inspect_frame(cv2.imread("data/test_images/test3.jpg"), LaneFinder())
    >>> len(images), result.left.found
    (6, True)
    """
    size = (frame.shape[1], frame.shape[0])
    debug = LaneFinder(finder.config, camera=finder.camera, keep_debug=True)
    debug.use_birdseye(finder.birdseye(size))  # the set-up in use: a still's own, after process_still
    result = debug.find_as_still(frame) if finder.last_still else debug.process(frame)
    be = debug.birdseye(size)
    undist = be.camera.undistort(frame)
    marked = undist.copy()
    cv2.polylines(marked, [np.round(be.src_px).astype(np.int32)], True, (0, 0, 255), 2, cv2.LINE_AA)
    warped = be.warp(frame)
    cv2.polylines(warped, [np.round(be.dst_px).astype(np.int32)], True, (0, 0, 255), 2, cv2.LINE_AA)
    return {
        "1_undistorted": marked,
        "2_binary": threshold(undist, finder.config.threshold, be.xm_per_px) * 255,
        "3_birdseye": warped,
        "4_birdseye_binary": result.binary * 255,
        "5_windows": search_view(result.binary, result.search, result),
        "6_final": annotate(frame, result, be, finder.config.render),
    }, result


def write_stages(folder: Path, stem: str, frame: np.ndarray, finder: LaneFinder,
                 outputs: OutputSet | None = None) -> list[Path]:
    """Write the stage images of one frame as ``folder/<stem>_<stage>.png``.

    Parameters
    ----------
    folder : Path
        Where to write (created if needed).
    stem : str
        Name prefix, usually the input's stem.
    frame : (H, W, 3) uint8 ndarray
        The original frame, BGR.
    finder : LaneFinder
        Gives the configuration, the camera and the set-up in use (after
        :meth:`~lanefinder.pipeline.LaneFinder.process_still`, the still's own, and the frame is
        measured as a still).
    outputs : OutputSet, optional
        Write the images as part of this set (put in place when the set commits).

    Returns
    -------
    list of Path
        The files written.

    Examples
    --------
    >>> import cv2, tempfile
    >>> from lanefinder import LaneFinder
    >>> with tempfile.TemporaryDirectory() as d:
    ...     paths = write_stages(Path(d), "test3", cv2.imread("data/test_images/test3.jpg"), LaneFinder())
    ...     [p.name for p in paths][:2]
    ['test3_1_undistorted.png', 'test3_2_binary.png']
    """
    out = []
    for name, img in stage_images(frame, finder).items():
        path = Path(folder) / f"{stem}_{name}.png"
        write_image(path, img, outputs=outputs)
        out.append(path)
    return out
