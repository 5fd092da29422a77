"""lanefinder: lane finding on a car's forward camera."""

from .camera import CameraModel, calibrate, load_camera, save_camera
from .config import Config, load_config
from .errors import LaneFinderError
from .pipeline import LaneFinder, LaneResult

__version__ = "0.1.0"

__all__ = [
    "CameraModel",
    "Config",
    "LaneFinder",
    "LaneFinderError",
    "LaneResult",
    "calibrate",
    "load_camera",
    "load_config",
    "save_camera",
]
