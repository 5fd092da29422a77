"""lanefinder: lane finding on a car's forward camera."""

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
