"""Small file helpers: reading images with clear errors, and atomic writes."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

import cv2
import numpy as np

from .errors import LaneFinderError

IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".webp")


def read_image(path: str | Path) -> np.ndarray:
    """Read a BGR uint8 image, or raise LaneFinderError saying why not."""
    p = Path(path)
    if not p.exists():
        raise LaneFinderError(f"image not found: {p}")
    if not p.is_file():
        raise LaneFinderError(f"not a file: {p}")
    data = np.fromfile(p, dtype=np.uint8)
    image = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
    if image is None:
        raise LaneFinderError(f"cannot read image (unsupported or damaged file): {p}")
    return image


def list_images(inputs: Iterable[str | Path], what: str = "images") -> list[Path]:
    """Expand files and folders into image paths (folders: their images, sorted naturally)."""
    out: list[Path] = []
    for item in inputs:
        p = Path(item)
        if p.is_dir():
            found = sorted((f for f in p.iterdir() if f.suffix.lower() in IMAGE_SUFFIXES), key=_natural_key)
            if not found:
                raise LaneFinderError(f"no {what} in folder {p} (looked for {', '.join(IMAGE_SUFFIXES)})")
            out.extend(found)
        elif p.exists():
            out.append(p)
        else:
            raise LaneFinderError(f"not found: {p}")
    if not out:
        raise LaneFinderError(f"no {what} given")
    return out


def _natural_key(p: Path) -> tuple:
    import re

    return tuple(int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.name))


def _umask_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def publish(tmp: str | Path, dest: str | Path) -> None:
    """Move a finished temporary file into place with ordinary permissions."""
    os.chmod(tmp, _umask_mode())
    os.replace(tmp, dest)


@contextlib.contextmanager
def atomic_path(path: str | Path, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it into place only on success."""
    dest = Path(path)
    dest.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{dest.stem}.", suffix=suffix or dest.suffix, dir=dest.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        publish(tmp_path, dest)
    finally:
        tmp_path.unlink(missing_ok=True)


def atomic_write_text(path: str | Path, text: str) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def write_image(path: str | Path, image: np.ndarray) -> None:
    """Write an image atomically; the format follows the suffix."""
    dest = Path(path)
    ok, buf = cv2.imencode(dest.suffix or ".png", image)
    if not ok:
        raise LaneFinderError(f"cannot encode image as {dest.suffix}: {dest}")
    with atomic_path(dest) as tmp:
        buf.tofile(tmp)


def check_not_input(output: str | Path, inputs: Iterable[str | Path]) -> None:
    """Refuse to write an output over one of the inputs."""
    out = Path(output).resolve()
    for i in inputs:
        if Path(i).resolve() == out:
            raise LaneFinderError(f"refusing to overwrite the input {i}; choose another output path")
