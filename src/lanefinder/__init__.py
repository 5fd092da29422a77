"""lanefinder: lane finding on a car's forward camera."""

import os as _os

# OpenCV refuses to decode an image with more pixels than this before allocating it (read when
# OpenCV is first imported, so set before it is): the largest frame taken, 16384 x 16384
# (``config.FrameSide``), rather than OpenCV's 2**30.  A value already set is kept.
_os.environ.setdefault("OPENCV_IO_MAX_IMAGE_PIXELS", str(16384 * 16384))

from .camera import CameraModel, calibrate, load_camera, save_camera
from .config import Config, load_config
from .errors import LaneFinderError
from .lane import LaneResult, Line
from .pipeline import LaneFinder

__version__ = "0.1.1"

__all__ = [
    "CameraModel",
    "Config",
    "LaneFinder",
    "LaneFinderError",
    "LaneResult",
    "Line",
    "calibrate",
    "load_camera",
    "load_config",
    "save_camera",
]
