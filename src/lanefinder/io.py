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

__all__ = [
    "IMAGE_SUFFIXES",
    "atomic_path",
    "atomic_write_text",
    "check_not_input",
    "list_images",
    "publish",
    "read_image",
    "write_image",
]

IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".webp")


def read_image(path: str | Path) -> np.ndarray:
    """Read a BGR uint8 image, or raise LaneFinderError saying why not.

    Parameters
    ----------
    path : str or Path
        Any format OpenCV decodes; the path may hold any characters.

    Returns
    -------
    (H, W, 3) uint8 ndarray
        The image, BGR.

    Raises
    ------
    LaneFinderError
        When the file is missing, is a folder, or does not decode as an image.

    Examples
    --------
    >>> read_image("data/test_images/test3.jpg").shape
    (720, 1280, 3)
    >>> read_image("no/such.jpg")
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: image not found: no/such.jpg
    """
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
    """Expand files and folders into image paths.

    Parameters
    ----------
    inputs : iterable of str or Path
        Files (kept as given, whatever their suffix) and folders (their files with an
        image suffix, see ``IMAGE_SUFFIXES``, sorted naturally: ``2.jpg`` before ``10.jpg``).
    what : str, optional
        What the images are, for the error messages.

    Returns
    -------
    list of Path
        In the order given.

    Raises
    ------
    LaneFinderError
        When an input does not exist, a folder holds no images, or nothing is given.

    Examples
    --------
    >>> [p.name for p in list_images(["data/test_images"])][:3]
    ['straight_lines1.jpg', 'straight_lines2.jpg', 'test1.jpg']
    """
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
    """Move a finished temporary file into place with ordinary permissions.

    Parameters
    ----------
    tmp : str or Path
        The finished file (made by ``tempfile.mkstemp``, so readable only by its owner).
    dest : str or Path
        Where it goes, on the same file system; replaced atomically if it exists.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> (d / "t").write_text("done")
    4
    >>> publish(d / "t", d / "out.txt")
    >>> (d / "out.txt").read_text()
    'done'
    """
    os.chmod(tmp, _umask_mode())
    os.replace(tmp, dest)


@contextlib.contextmanager
def atomic_path(path: str | Path, suffix: str | None = None) -> Iterator[Path]:
    """Give a temporary path beside ``path``, moved into place only when the block succeeds.

    Parameters
    ----------
    path : str or Path
        The final file; its folder is created if needed.
    suffix : str, optional
        The temporary file's suffix (writers that pick a format by suffix need the right
        one); default the suffix of ``path``.

    Yields
    ------
    Path
        The temporary file to write.  On an exception it is deleted and ``path`` is untouched.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> with atomic_path(out) as tmp:
    ...     _ = tmp.write_text("all or nothing")
    >>> out.read_text()
    'all or nothing'
    """
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
    """Write a text file atomically: readers see the old file or the whole new one.

    Parameters
    ----------
    path : str or Path
        The file to write.
    text : str
        Its content.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "b.txt"
    >>> atomic_write_text(out, "hello")
    >>> out.read_text()
    'hello'
    """
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def write_image(path: str | Path, image: np.ndarray) -> None:
    """Write an image atomically; the format follows the suffix.

    Parameters
    ----------
    path : str or Path
        The file to write (``.png`` when it has no suffix).
    image : ndarray
        The image, BGR or grey.

    Raises
    ------
    LaneFinderError
        When OpenCV cannot encode the image in that format.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "grey.png"
    >>> write_image(out, np.zeros((4, 6), np.uint8))
    >>> read_image(out).shape
    (4, 6, 3)
    """
    dest = Path(path)
    ok, buf = cv2.imencode(dest.suffix or ".png", image)
    if not ok:
        raise LaneFinderError(f"cannot encode image as {dest.suffix}: {dest}")
    with atomic_path(dest) as tmp:
        buf.tofile(tmp)


def check_not_input(output: str | Path, inputs: Iterable[str | Path]) -> None:
    """Refuse to write an output over one of the inputs.

    Parameters
    ----------
    output : str or Path
        The path about to be written.
    inputs : iterable of str or Path
        The paths being read.

    Raises
    ------
    LaneFinderError
        When ``output`` is one of ``inputs`` (after resolving links and ``..``).

    Examples
    --------
    >>> check_not_input("out.mp4", ["in.mp4"])
    >>> check_not_input("data/../in.mp4", ["in.mp4"])
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: refusing to overwrite the input in.mp4; choose another output path
    """
    out = Path(output).resolve()
    for i in inputs:
        if Path(i).resolve() == out:
            raise LaneFinderError(f"refusing to overwrite the input {i}; choose another output path")
