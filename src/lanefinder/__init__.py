"""lanefinder: lane finding on a car's forward camera.

The names below are imported when first used, so that ``import lanefinder`` (and the command
line's start, where Ctrl-C must end in one line) does not wait for OpenCV and NumPy.
"""

from __future__ import annotations

import importlib as _importlib
import importlib.util as _importlib_util

TYPE_CHECKING = False  # (typing is not imported: the command line starts sooner)

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

if TYPE_CHECKING:  # for type checkers: the names, as imported when used
    from .camera import CameraModel, calibrate, load_camera, save_camera
    from .config import Config, load_config
    from .errors import LaneFinderError
    from .lane import LaneResult, Line
    from .pipeline import LaneFinder


def __getattr__(name: str) -> object:
    home = _HOMES.get(name)
    if home is not None:
        value = getattr(_importlib.import_module(f".{home}", __name__), name)
    elif not name.startswith("_") and _importlib_util.find_spec(f"{__name__}.{name}") is not None:
        value = _importlib.import_module(f".{name}", __name__)  # a submodule: lanefinder.search, ...
    else:
        raise AttributeError(f"module 'lanefinder' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*__all__, "__version__", "__doc__", "__name__", "__path__"})
