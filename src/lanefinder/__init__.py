"""lanefinder: lane finding on a car's forward camera.

The names below are imported when first used, so that ``import lanefinder`` (and the command
line's start, where Ctrl-C must end in one line) does not wait for OpenCV and NumPy.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

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

#: Where each public name lives.
_HOMES = {"CameraModel": "camera", "calibrate": "camera", "load_camera": "camera", "save_camera": "camera",
          "Config": "config", "load_config": "config", "LaneFinderError": "errors", "LaneResult": "lane",
          "Line": "lane", "LaneFinder": "pipeline"}

if TYPE_CHECKING:
    from .camera import CameraModel, calibrate, load_camera, save_camera
    from .config import Config, load_config
    from .errors import LaneFinderError
    from .lane import LaneResult, Line
    from .pipeline import LaneFinder


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'lanefinder' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{home}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
