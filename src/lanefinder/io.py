"""Small file helpers: reading images with clear errors, and atomic writes."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import signal
import tempfile
import threading
import warnings
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import cv2
import numpy as np

from .errors import LaneFinderError

__all__ = [
    "IMAGE_SUFFIXES",
    "MAX_IMAGE_PIXELS",
    "OutputSet",
    "atomic_path",
    "atomic_write_text",
    "check_distinct",
    "check_not_input",
    "check_outputs",
    "encode_image",
    "image_size",
    "input_file",
    "iter_json_lines",
    "json_lines",
    "list_images",
    "partial_name",
    "publish",
    "read_image",
    "signals_held",
    "write_image",
]

IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".webp")


#: The most pixels an image may have to be decoded: the largest frame taken (``config.FrameSide``).
MAX_IMAGE_PIXELS = 16384 * 16384


def input_file(path: str | Path, what: str) -> Path:
    """Give an input's path, or raise LaneFinderError when it is missing or is not a file.

    Parameters
    ----------
    path : str or Path
        The input.
    what : str
        What it is, for the message (``image``, ``video``).

    Returns
    -------
    Path
        The path.

    Raises
    ------
    LaneFinderError
        ``{what} not found: path``, or ``not a file: path`` (a folder, say).

    Examples
    --------
    >>> input_file("data", "video")
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: not a file: data
    """
    p = Path(path)
    if not p.is_file():
        raise LaneFinderError(f"not a file: {p}" if p.exists() else f"{what} not found: {p}")
    return p


def read_image(path: str | Path, check: Callable[[tuple[int, int]], None] | None = None) -> np.ndarray:
    """Read a BGR uint8 image, or raise LaneFinderError saying why not.

    Parameters
    ----------
    path : str or Path
        Any format OpenCV decodes; the path may hold any characters.  An image whose header
        (:func:`image_size`) gives more than ``MAX_IMAGE_PIXELS`` pixels is refused before it
        is decoded.
    check : callable, optional
        Given the header's (width, height) before decoding, when the header gives one: raises
        LaneFinderError to refuse the image (a memory budget, say).

    Returns
    -------
    (H, W, 3) uint8 ndarray
        The image, BGR.

    Raises
    ------
    LaneFinderError
        When the file is missing, is a folder, does not decode as an image, or is too large.

    Examples
    --------
    >>> read_image("data/test_images/test3.jpg").shape
    (720, 1280, 3)
    >>> read_image("no/such.jpg")
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: image not found: no/such.jpg
    """
    p = input_file(path, "image")
    size = image_size(p)
    if size is not None and size[0] * size[1] > MAX_IMAGE_PIXELS:
        raise LaneFinderError(f"image too large to decode: {p} is {size[0]}x{size[1]}, over 16384x16384 pixels")
    if size is not None and check is not None:
        check(size)
    data = np.fromfile(p, dtype=np.uint8)
    try:
        image = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
    except cv2.error as e:  # OpenCV refuses, before allocating, an image over its own decoding limit
        if "CV_IO_MAX_IMAGE_PIXELS" in str(e):
            raise LaneFinderError(f"image too large to decode: {p}") from None
        raise LaneFinderError(f"cannot read image (unsupported or damaged file): {p}") from None
    if image is None:
        raise LaneFinderError(f"cannot read image (unsupported or damaged file): {p}")
    return image


def image_size(path: str | Path) -> tuple[int, int] | None:
    """Read an image file's width and height from its header, without decoding it.

    Parameters
    ----------
    path : str or Path
        The image file.

    Returns
    -------
    tuple of int or None
        (width, height), pixels (Pillow reads the header alone); None when Pillow does not
        know the format or cannot read the header.

    Raises
    ------
    LaneFinderError
        When the header gives more pixels than Pillow takes as an image (about 179 million:
        ``PIL.Image.MAX_IMAGE_PIXELS`` twice), far over any frame's.

    Examples
    --------
    >>> image_size("data/test_images/test3.jpg")
    (1280, 720)
    """
    from PIL import Image, UnidentifiedImageError

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path) as im:
                w, h = im.size
    except Image.DecompressionBombError:
        raise LaneFinderError(f"image too large to decode: {path} (its header gives over "
                              f"{2 * (Image.MAX_IMAGE_PIXELS or 0)} pixels)") from None
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError):
        return None
    return (int(w), int(h)) if w > 0 and h > 0 else None


def json_lines(text: str, path: str | Path) -> list:
    r"""Parse JSON Lines text, one value per non-blank line, saying which line is not JSON.

    Parameters
    ----------
    text : str
        The file's text.
    path : str or Path
        The file, for the message.

    Returns
    -------
    list
        The values, in order.

    Raises
    ------
    LaneFinderError
        At the first line that is not JSON: its line number in the file, and why.

    Examples
    --------
    >>> json_lines('{"a": 1}\n\n[2]\n', "x.jsonl")
    [{'a': 1}, [2]]
    >>> json_lines('{"a": 1}\n{"b": ', "x.jsonl")
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: x.jsonl: not JSON Lines (line 2, cut short?: Expecting value, column 7)
    """
    return list(_json_values([text], path))


def iter_json_lines(path: str | Path) -> Iterator[object]:
    r"""Read a JSON Lines file one line at a time, saying which line is not JSON (as :func:`json_lines`).

    The file is never held whole: a truth file of a hundred thousand frames is read in the
    memory of one line.  Lines end at ``\n``, ``\r\n`` or ``\r`` (as text files are read).

    Parameters
    ----------
    path : str or Path
        The file.

    Yields
    ------
    object
        Each non-blank line's value, in order.

    Raises
    ------
    LaneFinderError
        At the first line that is not JSON (its line number, and why), or that is not UTF-8.
    OSError
        When the file cannot be read.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = Path(d) / "x.jsonl"
    ...     _ = p.write_text('{"a": 1}\n\n[2]\n')
    ...     list(iter_json_lines(p))
    [{'a': 1}, [2]]
    """
    with open(path, "rb") as f:  # (not text mode: a decoding error is then named by its line)
        yield from _json_values(f, path)


def _json_values(chunks: Iterable[str | bytes], path: str | Path) -> Iterator[object]:
    r"""Give the values of JSON Lines text given in chunks (a file's raw lines, or the whole text).

    Lines end at ``\n``, ``\r\n`` or ``\r`` (not at U+2028, which JSON strings may hold); a chunk
    must not split a ``\r\n``.  Bytes are read as UTF-8; a byte-order mark opens the text.
    """
    n = 0
    for chunk in chunks:
        if isinstance(chunk, bytes):
            try:
                chunk = chunk.decode("utf-8")
            except UnicodeDecodeError as e:
                raise LaneFinderError(f"{path}: not JSON Lines (line {n + 1}: not UTF-8 text: {e.reason})") from None
        if n == 0:
            chunk = chunk.removeprefix("\ufeff")
        pieces = chunk.replace("\r\n", "\n").replace("\r", "\n").split("\n")
        ended = len(pieces) - 1  # the pieces a line end follows; the last one is what the last line end leaves
        for i, line in enumerate(pieces if pieces[-1] else pieces[:-1]):
            n += 1
            if line.strip():
                # The last line of a file that does not end a line was likely cut short (a copy or run stopped).
                yield _json_line(line, path, n, cut=i >= ended)


def _json_line(line: str, path: str | Path, n: int, cut: bool) -> object:
    """Parse one line of a JSON Lines file, naming the line (and whether it looks cut short) when it is not JSON."""
    try:
        return json.loads(line)
    except json.JSONDecodeError as e:
        short = ", cut short?" if cut else ""
        raise LaneFinderError(f"{path}: not JSON Lines (line {n}{short}: {e.msg}, column {e.colno})") from None
    except ValueError:  # an integer of more digits than Python reads (4300)
        raise LaneFinderError(f"{path}: not JSON Lines (line {n}: a number of more digits than can be read)") from None
    except RecursionError:
        raise LaneFinderError(f"{path}: not JSON Lines (line {n}: nested too deeply)") from None


def check_distinct(paths: Iterable[Path], what: str = "photo") -> None:
    """Refuse a file given twice: under two names, through a link, or as a copy (the same bytes).

    A photo or frame counted twice makes a calibration or a set-up look surer than it is (and
    passes a rule of "at least three").

    Parameters
    ----------
    paths : iterable of Path
        The files.
    what : str, optional
        What they are, for the message.

    Raises
    ------
    LaneFinderError
        Naming the first two that are the same.

    Examples
    --------
    >>> check_distinct([Path("data/test_images/test1.jpg"), Path("data/test_images/test2.jpg")])
    >>> check_distinct([Path("data/test_images/test1.jpg")] * 2)
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: data/test_images/test1.jpg and data/test_images/test1.jpg are the same photo: ...
    """
    by_size: dict[int, list[Path]] = {}
    for p in paths:
        with contextlib.suppress(OSError):  # unreadable: the reader that needs it says so
            by_size.setdefault(p.stat().st_size, []).append(p)
    for same_size in by_size.values():
        if len(same_size) < 2:  # only files of one size can be the same: no other is read
            continue
        seen: dict[str, Path] = {}
        for p in same_size:
            digest = hashlib.blake2b(digest_size=16)
            try:
                with open(p, "rb") as f:
                    for block in iter(lambda f=f: f.read(1 << 20), b""):
                        digest.update(block)
            except OSError:
                continue
            key = digest.hexdigest()
            if key in seen:
                raise LaneFinderError(f"{seen[key]} and {p} are the same {what}: give each once")
            seen[key] = p


def list_images(inputs: Iterable[str | Path], what: str = "images") -> list[Path]:
    """Expand files and folders into image paths.

    Parameters
    ----------
    inputs : iterable of str or Path
        Files (kept as given, whatever their suffix) and folders (their files with an
        image suffix, see ``IMAGE_SUFFIXES``, sorted naturally: ``2.jpg`` before ``10.jpg``;
        their sub-folders are not searched).
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
                subs = sorted(d.name for d in p.iterdir() if d.is_dir())
                named = ", ".join(subs[:3]) + (", ..." if len(subs) > 3 else "")
                hint = f"; its sub-folders ({named}) are not searched: give them" if subs else ""
                raise LaneFinderError(f"no {what} in folder {p} (looked for {', '.join(IMAGE_SUFFIXES)}){hint}")
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
def signals_held() -> Iterator[None]:
    """Hold Ctrl-C and SIGTERM back for the duration of the block (main thread only).

    Used where a signal must not split a step in two: files put in place or removed together,
    or a video frame and its telemetry row written together.  A signal that arrives meanwhile,
    in any thread, is recorded and acted on (as the handler before the block would have) when
    the block ends.  In other threads it does nothing.

    Yields
    ------
    None

    Examples
    --------
    >>> with signals_held():
    ...     pass
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    old = {sig: signal.signal(sig, lambda signum, _frame: caught.append(signum)) for sig in _HELD}
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
        for signum in dict.fromkeys(caught):
            _replay(signum, old[signum])


_HELD = (signal.SIGINT, signal.SIGTERM)


def _replay(signum: int, handler) -> None:
    """Act on a signal that was held, as ``handler`` (the one in force before) would have."""
    if callable(handler):
        handler(signum, None)
    elif handler == signal.SIG_DFL:
        os.kill(os.getpid(), signum)


def _make_folder(folder: Path) -> list[Path]:
    """Create a folder and its missing parents; give the ones created, deepest first."""
    missing = [p for p in (folder, *folder.parents) if not p.exists()]
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise LaneFinderError(f"cannot create the folder {folder}: a file is in the way") from None
    except OSError as e:
        raise LaneFinderError(f"cannot create the folder {folder}: {e.strerror or e}") from None
    return missing


class OutputSet:
    """All the outputs of one command, put in place together only when everything succeeded.

    Each output is written to a hidden temporary file beside it (:meth:`add`); :meth:`commit`
    moves them all into place, :meth:`discard` removes them and leaves whatever was at the
    destinations untouched.  As a context manager it commits on success and discards on any
    exception, Ctrl-C included; Ctrl-C and SIGTERM are held back while it does either, so a
    second Ctrl-C leaves no hidden file behind.

    Parameters
    ----------
    inputs : iterable of str or Path, optional
        The command's inputs: no output may name one of them.
    partial : bool, optional
        The outputs may be committed as partial (:meth:`commit`): no output's
        :func:`partial_name` may then name an input or another output, checked up front.

    Attributes
    ----------
    outputs : list of Path
        The destinations registered so far.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with OutputSet() as outs:
    ...     _ = outs.add(d / "a.txt").write_text("a")
    ...     _ = outs.add(d / "b.txt").write_text("b")
    ...     sorted(p.name for p in d.iterdir() if not p.name.startswith("."))
    []
    >>> sorted(p.name for p in d.iterdir())
    ['a.txt', 'b.txt']
    >>> OutputSet(inputs=[d / "a.txt"]).add(d / "a.txt")
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: refusing to overwrite the input .../a.txt; choose another output path
    """

    def __init__(self, inputs: Iterable[str | Path] = (), partial: bool = False):
        self._inputs = {Path(p).resolve(): Path(p) for p in inputs}
        self.partial = partial
        self._pending: list[tuple[Path, Path]] = []
        self._made: list[Path] = []
        self.outputs: list[Path] = []

    def check(self, path: str | Path) -> Path:
        """Check that a path may be one of this set's outputs, without creating anything.

        Parameters
        ----------
        path : str or Path
            The destination.

        Returns
        -------
        Path
            The destination.

        Raises
        ------
        LaneFinderError
            When ``path`` names an input, another output, a folder, or lies under a file.
        """
        dest = Path(path)
        real = dest.resolve()
        if real in self._inputs:
            raise LaneFinderError(f"refusing to overwrite the input {self._inputs[real]}; choose another output path")
        if any(real == o.resolve() for o in self.outputs):
            raise LaneFinderError(f"two outputs would be written to the same file: {dest}")
        if self.partial:
            part = partial_name(dest).resolve()
            if part in self._inputs:
                raise LaneFinderError(f"refusing {dest}: a stopped run would keep it as {partial_name(dest)}, "
                                      "which is an input; choose another output path")
            kept_as = {partial_name(o).resolve() for o in self.outputs}
            if part in kept_as or part in {o.resolve() for o in self.outputs} or real in kept_as:
                raise LaneFinderError(f"refusing {dest}: it and another output would share a name when a stopped "
                                      "run keeps them as .partial files; choose other output paths")
        if dest.is_dir():
            raise LaneFinderError(f"the output {dest} is a folder; give a file name")
        for parent in dest.parents:
            if parent.exists():
                if not parent.is_dir():
                    raise LaneFinderError(f"cannot create the folder {dest.parent}: {parent} is a file")
                break
        return dest

    def add(self, path: str | Path, suffix: str | None = None) -> Path:
        """Register an output and give the hidden temporary file to write it to.

        Parameters
        ----------
        path : str or Path
            The destination; its folder is created if needed.
        suffix : str, optional
            The temporary file's suffix (writers that pick a format by suffix need the right
            one); default the suffix of ``path``.

        Returns
        -------
        Path
            The temporary file (created empty), beside ``path``.

        Raises
        ------
        LaneFinderError
            When ``path`` names an input, another output or a folder, or its folder cannot be
            made or written.
        """
        dest = self.check(path)
        self._made += _make_folder(dest.parent)
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{dest.stem}.", suffix=suffix or dest.suffix, dir=dest.parent)
        except OSError as e:
            raise LaneFinderError(f"cannot write in {dest.parent}: {e.strerror or e}") from None
        os.close(fd)
        self._pending.append((Path(tmp), dest))
        self.outputs.append(dest)
        return Path(tmp)

    def commit(self, partial: bool = False) -> dict[Path, Path]:
        """Move every finished output into place, with ordinary permissions.

        Parameters
        ----------
        partial : bool, optional
            The outputs are incomplete (a run stopped early): each goes under
            :func:`partial_name` of its destination instead, and whatever is at the
            destination stays as it was.

        Returns
        -------
        dict of Path to Path
            Where each destination's file went.

        Raises
        ------
        LaneFinderError
            When a file cannot be moved, or ``partial`` is asked of a set not made ``partial``.
        """
        if partial and not self.partial:
            self.discard()
            raise LaneFinderError("this set of outputs was not made to be kept as partial files")
        placed: dict[Path, Path] = {}
        with signals_held():
            try:
                for tmp, dest in self._pending:
                    where = partial_name(dest) if partial else dest
                    publish(tmp, where)
                    placed[dest] = where
            except OSError as e:
                raise LaneFinderError(f"cannot put {dest} in place: {e.strerror or e}") from None
            finally:
                self.discard()
        return placed

    def discard(self) -> None:
        """Remove the temporary files that are left, and the folders made for them if empty."""
        with signals_held():
            for tmp, _ in self._pending:
                tmp.unlink(missing_ok=True)
            self._pending = []
            self._remove_folders()

    def _remove_folders(self) -> None:
        """Remove the folders this set created, where they are still empty."""
        for folder in sorted(set(self._made), key=lambda p: -len(p.parts)):
            with contextlib.suppress(OSError):
                folder.rmdir()
        self._made = []

    def __enter__(self) -> OutputSet:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.discard()


def partial_name(path: str | Path) -> Path:
    """Give the name an incomplete output is kept under: ``<stem>.partial<suffix>`` beside it.

    Parameters
    ----------
    path : str or Path
        The output's destination.

    Returns
    -------
    Path
        The partial output's path.

    Examples
    --------
    >>> partial_name("out/drive.mp4").as_posix()
    'out/drive.partial.mp4'
    """
    p = Path(path)
    return p.with_name(f"{p.stem}.partial{p.suffix}")


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
    with OutputSet() as outs:
        yield outs.add(path, suffix)


def atomic_write_text(path: str | Path, text: str, outputs: OutputSet | None = None) -> None:
    """Write a text file atomically: readers see the old file or the whole new one.

    Parameters
    ----------
    path : str or Path
        The file to write.
    text : str
        Its content.
    outputs : OutputSet, optional
        Write it as part of this set (put in place when the set commits).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "b.txt"
    >>> atomic_write_text(out, "hello")
    >>> out.read_text()
    'hello'
    """
    if outputs is not None:
        _write_text(outputs.add(path), text, path)
        return
    with atomic_path(path) as tmp:
        _write_text(tmp, text, path)


def _write_text(tmp: Path, text: str, dest: str | Path) -> None:
    try:
        tmp.write_text(text)
    except OSError as e:
        raise LaneFinderError(f"cannot write {dest}: {e.strerror or e}") from None


def write_image(path: str | Path, image: np.ndarray, outputs: OutputSet | None = None) -> None:
    """Write an image atomically; the format follows the suffix.

    Parameters
    ----------
    path : str or Path
        The file to write (``.png`` when it has no suffix).
    image : ndarray
        The image, BGR or grey.
    outputs : OutputSet, optional
        Write it as part of this set (put in place when the set commits).

    Raises
    ------
    LaneFinderError
        When OpenCV cannot encode the image in that format, or the file cannot be written.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "grey.png"
    >>> write_image(out, np.zeros((4, 6), np.uint8))
    >>> read_image(out).shape
    (4, 6, 3)
    """
    dest = Path(path)
    buf = encode_image(dest, image)
    if outputs is not None:
        _write_bytes(outputs.add(dest), buf, dest)
        return
    with atomic_path(dest) as tmp:
        _write_bytes(tmp, buf, dest)


def encode_image(path: str | Path, image: np.ndarray) -> np.ndarray:
    """Encode an image in the format its path's suffix names.

    Parameters
    ----------
    path : str or Path
        Only its suffix is used (``.png`` when it has none).
    image : ndarray
        The image, BGR or grey.

    Returns
    -------
    (N,) uint8 ndarray
        The encoded bytes.

    Raises
    ------
    LaneFinderError
        When the suffix is not an image format OpenCV writes.

    Examples
    --------
    >>> encode_image("a.png", np.zeros((4, 6), np.uint8))[1:4].tobytes()
    b'PNG'
    >>> encode_image("a.mp4", np.zeros((4, 6), np.uint8))
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: cannot write an image as .mp4: a.mp4 (use .png or .jpg)
    """
    dest = Path(path)
    suffix = dest.suffix.lower() or ".png"
    ok, buf = False, None
    if suffix in IMAGE_SUFFIXES:
        with contextlib.suppress(cv2.error):
            ok, buf = cv2.imencode(suffix, image)
    if not ok or buf is None:
        raise LaneFinderError(f"cannot write an image as {dest.suffix or 'a file without a suffix'}: {dest} "
                              "(use .png or .jpg)")
    return buf


def _write_bytes(tmp: Path, buf: np.ndarray, dest: Path) -> None:
    try:
        tmp.write_bytes(buf.tobytes())  # (ndarray.tofile hides the OS's reason for a short write)
    except OSError as e:
        raise LaneFinderError(f"cannot write {dest}: {e.strerror or e}") from None


def check_outputs(outputs: Iterable[str | Path], inputs: Iterable[str | Path]) -> None:
    """Check a command's output paths before any work: none names an input or another output.

    Parameters
    ----------
    outputs : iterable of str or Path
        The paths the command will write.
    inputs : iterable of str or Path
        The paths it reads.

    Raises
    ------
    LaneFinderError
        When an output names an input, another output or a folder, or lies under a file.

    Examples
    --------
    >>> check_outputs(["out.toml", "out_preview.png"], ["frame.jpg"])
    >>> check_outputs(["a.png", "./a.png"], [])
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: two outputs would be written to the same file: a.png
    """
    probe = OutputSet(inputs)
    for out in outputs:
        probe.outputs.append(probe.check(out))


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
