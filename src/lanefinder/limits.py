"""Resource limits: refuse a frame or view size that would need too much memory, before allocating.

The estimate counts what a run holds at once: the frames queued between the decoder, the
processing loop and the encoder (3 bytes a pixel each), a few frame-size working images
(undistortion, drawing), and the bird's-eye view's remap tables and working images.
"""

from __future__ import annotations

from .config import Config
from .errors import LaneFinderError

__all__ = ["check_memory", "memory_needed_mb"]

# Frame-size working images besides the frames held (drawing, the undistorted frame, copies).
_WORKING_FRAMES = 6
# Bytes per bird's-eye pixel: remap tables (4 + 2), the view (3), binaries and channels (~50).
_VIEW_BYTES_PER_PX = 64


def memory_needed_mb(frame_size: tuple[int, int], view_size: tuple[int, int], frames_held: int = 1) -> float:
    """Estimate the memory a run needs for its frames and its bird's-eye view.

    Parameters
    ----------
    frame_size : tuple of int
        (width, height) of the frames, pixels.
    view_size : tuple of int
        (width, height) of the bird's-eye view, pixels.
    frames_held : int, optional
        Frames held at once (queued between threads).

    Returns
    -------
    float
        MB (2**20 bytes).

    Examples
    --------
    >>> round(memory_needed_mb((1280, 720), (400, 300), frames_held=32))
    108
    """
    fw, fh = frame_size
    vw, vh = view_size
    return (fw * fh * 3 * (frames_held + _WORKING_FRAMES) + vw * vh * _VIEW_BYTES_PER_PX) / 2**20


def check_memory(config: Config, frame_size: tuple[int, int], frames_held: int = 1) -> None:
    """Refuse a run whose frames and view would need more than ``config.limits.memory_mb``.

    Parameters
    ----------
    config : Config
        Gives the view size (``birdseye.size``) and the budget (``limits.memory_mb``).
    frame_size : tuple of int
        (width, height) of the frames, pixels.
    frames_held : int, optional
        Frames held at once.

    Raises
    ------
    LaneFinderError
        When the estimate is over the budget; the message gives both.

    Examples
    --------
    >>> check_memory(Config(), (1280, 720))
    >>> big = Config.model_validate({"birdseye": {"size": [8000, 8000]}})
    >>> check_memory(big, (1280, 720))
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: a 1280x720 frame with a 8000x8000 bird's-eye view needs about 3925 MB, ...
    """
    need = memory_needed_mb(frame_size, config.birdseye.size, frames_held)
    if need > config.limits.memory_mb:
        (fw, fh), (vw, vh) = frame_size, config.birdseye.size
        raise LaneFinderError(
            f"a {fw}x{fh} frame with a {vw}x{vh} bird's-eye view needs about {need:.0f} MB, over the "
            f"{config.limits.memory_mb} MB of limits.memory_mb; use a smaller birdseye.size or raise the limit")
