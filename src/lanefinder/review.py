"""``lanefinder review``: a local web page over a batch folder or a video with its telemetry.

The server (FastAPI on uvicorn) reads what lies under PATH and the source videos named by
its manifest, decodes frames with PyAV on request, draws the lane from the telemetry, and
re-runs a single frame with a changed configuration for the inspector.  The page is plain
HTML, CSS and JavaScript shipped in this package (``review_static/``); the plots use the
plotly.js that the ``plotly`` Python package installs.  There is no JavaScript build step.

Safe by default: it binds 127.0.0.1; files are served only from under PATH (no traversal,
no absolute paths, no symlinks that leave it); request bodies and frame indices are
bounded; the one thing it writes is the config that "Save config" asks for.
"""

from __future__ import annotations

import base64
import contextlib
import json
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from pydantic import BaseModel, ValidationError

from .config import BirdseyeConfig, Config, config_from_dict, dump_config
from .errors import LaneFinderError
from .io import atomic_write_text
from .stats import lane_shares
from .telemetry import MAX_ABS_VALUE, TELEMETRY_SUFFIXES, is_number_list, read_telemetry

__all__ = ["LOCAL_HOSTS", "MAX_BODY_BYTES", "TUNABLE_SECTIONS", "FrameReader", "Review", "VideoSource", "config_form",
           "create_app", "draw_row", "load_review", "serve"]

#: Largest request body accepted, bytes.
MAX_BODY_BYTES = 64 * 1024
#: Host names the server answers to by default (this machine; ``testserver`` is FastAPI's TestClient).
LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1", "[::1]", "testserver")
#: The config sections the inspector's form offers.
TUNABLE_SECTIONS = ("threshold", "search", "tracking", "render")
_STATIC = Path(__file__).with_name("review_static")
_STATIC_FILES = {"index.html": "text/html", "app.js": "text/javascript", "style.css": "text/css"}
# Decoded frames kept per video (for stepping back and re-rendering the same frame).
_CACHE_FRAMES = 16
# Seeking is to a keyframe; a frame this few ahead of the last one decoded is reached by decoding on.
_DECODE_ON_FRAMES = 90
_JPEG_QUALITY = 85
# Per-frame telemetry the page gets for a video (``checks``: None in files written before that column).
_SERIES = ("time_s", "state", "offset_m", "radius_m", "width_m", "left_conf", "right_conf", "checks")


class FrameReader:
    """Random access to a video's frames: PyAV, seeking to keyframes, a small cache.

    Parameters
    ----------
    path : str or Path
        The video.

    Attributes
    ----------
    fps : float
        Frame rate, frames/s.
    frames : int
        Frame count (from the container).
    size : tuple of int
        (width, height), pixels.

    Examples
    --------
    >>> r = FrameReader("data/clips/project_37-47s.mp4")
    >>> r.get(30).shape, r.frames
    ((720, 1280, 3), 250)
    >>> r.close()
    """

    def __init__(self, path: str | Path):
        import av

        from .video import VideoInfo, main_stream

        info = VideoInfo.from_path(path)
        self.path = str(path)
        self.fps, self.frames, self.size = float(info.fps), info.total_frames, info.size
        self._av = av
        self._c = av.open(self.path)
        self._s = main_stream(self._c)
        self._s.thread_type = "AUTO"
        self._tb = self._s.time_base
        self._t0 = self._s.start_time or 0
        self._it = None
        self._last = -1
        self._cache: OrderedDict[int, np.ndarray] = OrderedDict()
        self._lock = threading.Lock()

    def _index(self, f) -> int:
        return round(float((f.pts - self._t0) * self._tb) * self.fps) if f.pts is not None else self._last + 1

    def get(self, n: int) -> np.ndarray:
        """Return frame ``n`` (BGR).

        Parameters
        ----------
        n : int
            Frame index, 0 <= n < frames.

        Returns
        -------
        (H, W, 3) uint8 ndarray
            The frame.

        Raises
        ------
        LaneFinderError
            When ``n`` is out of range or cannot be decoded.
        """
        from .video import frame_image

        if not 0 <= n < self.frames:
            raise LaneFinderError(f"frame {n} is out of range 0..{self.frames - 1}")
        with self._lock:
            if n in self._cache:
                self._cache.move_to_end(n)
                return self._cache[n]
            if self._it is None or not (self._last < n <= self._last + _DECODE_ON_FRAMES):
                self._c.seek(int((n / self.fps) / self._tb) + self._t0, stream=self._s, backward=True,
                             any_frame=False)
                self._it = self._c.decode(self._s)
                self._last = -1
            try:
                for f in self._it:
                    i = self._index(f)
                    self._last = i
                    if i >= n:
                        img = frame_image(f)
                        self._cache[n] = img
                        if len(self._cache) > _CACHE_FRAMES:
                            self._cache.popitem(last=False)
                        return img
            except self._av.error.FFmpegError as e:
                self._it = None
                raise LaneFinderError(f"cannot decode frame {n} of {self.path}: {e}") from None
            self._it = None
            raise LaneFinderError(f"frame {n} could not be decoded from {self.path}")

    def close(self) -> None:
        """Close the video."""
        with contextlib.suppress(Exception):
            self._c.close()


@dataclass
class VideoSource:
    """One video of a review: its source, telemetry and events.

    Attributes
    ----------
    video_id : str
        Its name (the batch partition value, or the file's stem).
    source : Path or None
        The video file (None when it is not readable here).
    telemetry : list of Path
        Its telemetry files (a batch partition's parts, or one file).
    events : list of dict
        Its lane events.
    summary : dict
        Its summary row (a batch's ``summary.parquet`` row, or figures computed from the telemetry).
    changed : bool
        The video file was modified after its telemetry was written and its content hash is not
        the one the batch recorded (a batch's video replaced since): its frames may not be the
        ones the telemetry describes.

    Examples
    --------
    >>> VideoSource(video_id="a", source=None, telemetry=[]).rows()
    []
    """

    video_id: str
    source: Path | None
    telemetry: list[Path]
    events: list[dict] = field(default_factory=list)
    summary: dict = field(default_factory=dict)
    changed: bool = False
    _rows: list[dict] | None = None
    _by_frame: dict[int, dict] | None = None
    _reader: FrameReader | None = None

    def rows(self) -> list[dict]:
        """Return the telemetry rows, in frame order (read once).

        Returns
        -------
        list of dict
            The rows.
        """
        if self._rows is None:
            rows: list[dict] = []
            for p in self.telemetry:
                rows += read_telemetry(p)
            by_frame: dict[int, dict] = {}
            for i, r in enumerate(rows, 1):
                r.pop("video", None)
                where = f"telemetry of {self.video_id}: row {i}"
                frame = r.get("frame")
                if frame is None:
                    raise LaneFinderError(f"{where} has no frame number")
                if not isinstance(frame, int) or isinstance(frame, bool) or frame < 0:
                    raise LaneFinderError(f"{where}: frame must be a whole number, 0 or more ({frame!r})")
                if frame in by_frame:
                    raise LaneFinderError(f"{where}: frame {frame} is given twice")
                for k in ("left_x", "right_x", "h_samples"):  # what the page draws: a bad one was an HTTP 500
                    if r.get(k) is not None and not is_number_list(r[k]):
                        raise LaneFinderError(f"{where}: {k} must be a list of numbers within +-{MAX_ABS_VALUE:g}")
                by_frame[frame] = r
            self._rows = sorted(rows, key=lambda r: r["frame"])
            self._by_frame = by_frame
        return self._rows

    def row_at(self, frame: int) -> dict | None:
        """Return the telemetry row of a frame.

        Parameters
        ----------
        frame : int
            Frame index.

        Returns
        -------
        dict or None
            Its row, or None when the telemetry has none.
        """
        self.rows()
        assert self._by_frame is not None
        return self._by_frame.get(frame)

    def frame_count(self) -> int:
        """Return the number of frames: the container's count, else one past the telemetry's last frame.

        Returns
        -------
        int
            Frames.
        """
        n = self.reader().frames if self.source is not None else 0
        rows = self.rows()
        return n if n > 0 else (rows[-1]["frame"] + 1 if rows else 0)

    def fps(self) -> float:
        """Return the frame rate: the container's, else from the telemetry's times.

        Returns
        -------
        float
            Frames per second (25 when nothing says).
        """
        if self.source is not None and self.reader().fps > 0:
            return self.reader().fps
        rows = [r for r in self.rows() if r.get("time_s") is not None]
        if len(rows) >= 2 and rows[-1]["time_s"] > rows[0]["time_s"]:
            return (rows[-1]["frame"] - rows[0]["frame"]) / (rows[-1]["time_s"] - rows[0]["time_s"])
        return 25.0

    def reader(self) -> FrameReader:
        """Return the frame reader of the source video (opened once).

        Returns
        -------
        FrameReader
            Its frames.

        Raises
        ------
        LaneFinderError
            When the source video is not available.
        """
        if self.source is None:
            raise LaneFinderError(f"the source video of {self.video_id} is not available here")
        if self._reader is None:
            self._reader = FrameReader(self.source)
        return self._reader


class Review:
    """What a review serves: the videos under PATH, the base config and where a saved config goes.

    Parameters
    ----------
    path : str or Path
        A ``lanefinder batch`` output folder, or a video with its telemetry beside it
        (``<stem>.parquet``, ``.csv`` or ``.jsonl``, or given by ``telemetry``).
    config : Config, optional
        The configuration the inspector starts from (default: the defaults).
    config_path : str or Path, optional
        The file it came from (an input: never written over).
    telemetry : str or Path, optional
        The video's telemetry, when PATH is a video.

    Attributes
    ----------
    path : Path
        PATH, resolved (the folder, or the video).
    root : Path
        The folder whose files may be served.
    out_dir : Path
        Where a saved config goes: the batch output folder, or the folder of the video's
        telemetry (its outputs; the video's own folder may be an input folder).
    mode : str
        ``fleet`` or ``video``.
    videos : dict of str to VideoSource
        The videos, by id.

    Raises
    ------
    LaneFinderError
        When PATH is neither, or a video has no telemetry.

    Examples
    --------
    >>> import tempfile, shutil
    >>> from lanefinder.videojob import process_video
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = shutil.copy("data/clips/harder_challenge_0-4s.mp4", d / "h.mp4")
    >>> _ = process_video(d / "h.mp4", None, telemetry=d / "h.csv", progress=False, max_frames=20)
    >>> rv = Review(d / "h.mp4")
    >>> rv.mode, list(rv.videos), len(rv.videos["h"].rows())
    ('video', ['h'], 20)
    """

    def __init__(self, path: str | Path, config: Config | None = None, config_path: str | Path | None = None,
                 telemetry: str | Path | None = None):
        p = Path(path)
        self.config = config or Config()
        self.config_path = Path(config_path).resolve() if config_path else None
        if p.is_dir():
            self.root, self.mode = p.resolve(), "fleet"
            self.videos = _fleet_videos(self.root)
        elif p.is_file():
            self.root, self.mode = p.resolve().parent, "video"
            self.videos = {p.stem: _single_video(p.resolve(), telemetry, self.config)}
        else:
            raise LaneFinderError(f"not found: {p}")
        self.path = p.resolve()
        tele = [t for v in self.videos.values() for t in v.telemetry]
        self.out_dir = tele[0].parent if self.mode == "video" and tele else self.root
        self.inputs = {v.source for v in self.videos.values() if v.source} | \
            {t for v in self.videos.values() for t in v.telemetry} | ({self.config_path} if self.config_path else set())

    def video(self, video_id: str) -> VideoSource:
        """Return a video by id.

        Parameters
        ----------
        video_id : str
            Its id.

        Returns
        -------
        VideoSource
            The video.

        Raises
        ------
        KeyError
            When there is no such video.
        """
        return self.videos[video_id]

    def save_config(self, cfg: Config) -> Path:
        """Write ``cfg`` as TOML next to the outputs (``out_dir``), atomically, never over an input.

        Parameters
        ----------
        cfg : Config
            The configuration to save.

        Returns
        -------
        Path
            The file written (``review-config.toml``, or ``review-config-2.toml`` ... when that
            name is an input).
        """
        for i in range(1, 100):
            path = self.out_dir / ("review-config.toml" if i == 1 else f"review-config-{i}.toml")
            if path.resolve() not in self.inputs and not path.is_symlink():
                break
        atomic_write_text(path, dump_config(cfg, "toml"))
        return path

    def safe_path(self, rel: str) -> Path:
        """Resolve a path relative to the root, refusing anything that leaves it.

        Parameters
        ----------
        rel : str
            A relative path (as in a URL).

        Returns
        -------
        Path
            The file, under the root.

        Raises
        ------
        FileNotFoundError
            For an absolute path, ``..``, a symlink that leaves the root, a missing file, or (when
            PATH is a video) any file but the video and its telemetry.
        """
        if not rel or rel.startswith(("/", "\\")) or "\x00" in rel or Path(rel).is_absolute():
            raise FileNotFoundError(rel)
        p = (self.root / rel).resolve()
        if not p.is_relative_to(self.root) or not p.is_file():
            raise FileNotFoundError(rel)
        if self.mode == "video" and p not in self.inputs:  # PATH is the video: its siblings are not served
            raise FileNotFoundError(rel)
        return p


def _fleet_videos(root: Path) -> dict[str, VideoSource]:
    """Give the videos of a batch folder, from its manifest, summary and events."""
    manifest = root / "manifest.json"
    if not manifest.is_file():
        raise LaneFinderError(f"{root} is not a lanefinder batch folder (no manifest.json); "
                              "give a batch output folder or a video with its telemetry")
    try:
        entries = json.loads(manifest.read_text())["videos"]
        if not isinstance(entries, dict) or not all(isinstance(e, dict) and isinstance(e.get("video_id"), str)
                                                    for e in entries.values()):
            raise ValueError("an entry has no video_id")
    except (ValueError, KeyError, TypeError, OSError) as e:
        raise LaneFinderError(f"{manifest} cannot be read: {e}") from None
    events: dict[str, list[dict]] = {}
    for e in _table_rows(root / "events.parquet"):
        events.setdefault(e.pop("video", None), []).append(e)
    summary = {r.get("video"): r for r in _table_rows(root / "summary.parquet")}
    out = {}
    for url, e in entries.items():
        vid = e["video_id"]
        part = root / "telemetry" / f"video={vid}"
        local = url[len("file://"):] if url.startswith("file://") else (None if "://" in url else url)
        src = Path(local) if local and Path(local).is_file() else None  # remote sources are not decoded here
        row = summary.get(vid) or {"video": vid, "input": url, "status": e.get("status"), "error": e.get("error")}
        parts = sorted(part.glob("*.parquet")) if part.is_dir() else []
        # A second of slack: file systems keep modification times to a second or two.
        changed = src is not None and bool(parts) and src.stat().st_mtime > max(q.stat().st_mtime for q in parts) + 1
        if changed and e.get("content_hash"):  # newer, as a copy of the folder may be: is it another video?
            from .batch import content_hash

            changed = content_hash(str(src)) != e["content_hash"]
        out[vid] = VideoSource(video_id=vid, source=src, telemetry=parts, events=events.get(vid, []), summary=row,
                               changed=changed)
    return out


def _table_rows(path: Path) -> list[dict]:
    """Give the rows of a batch's Parquet table (none when it is not there)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    if not path.is_file():
        return []
    try:
        return pq.read_table(path).to_pylist()
    except (OSError, pa.ArrowException) as e:
        raise LaneFinderError(f"{path} cannot be read: {e}".splitlines()[0]) from None


def _single_video(video: Path, telemetry: str | Path | None, cfg: Config) -> VideoSource:
    """Give a video with its telemetry beside it (or given)."""
    from .events import detect_events, event_row

    if telemetry is None:
        found = [video.with_suffix(s) for s in TELEMETRY_SUFFIXES if video.with_suffix(s).is_file()]
        if not found:
            raise LaneFinderError(f"no telemetry beside {video} ({video.stem}.parquet, .csv or .jsonl): run "
                                  f"`lanefinder video {video} --telemetry {video.with_suffix('.parquet')}` first, "
                                  "or give --telemetry")
        telemetry = found[0]
    v = VideoSource(video_id=video.stem, source=video, telemetry=[Path(telemetry).resolve()])
    rows = v.rows()
    if not rows:
        raise LaneFinderError(f"{telemetry} has no rows: not the telemetry of a run on {video.name}")
    n = v.reader().frames
    if n > 0 and rows[-1]["frame"] > n * 1.02 + 5:  # the container's count may be an estimate
        raise LaneFinderError(f"{telemetry} runs to frame {rows[-1]['frame']}, but {video.name} has about {n} frames: "
                              "is it the telemetry of another video? (telemetry of a run with --start counts frames "
                              "from the source video's start: review it with the source video)")
    fps = v.reader().fps
    v.events = [event_row(e) for e in detect_events(rows, fps, cfg.events)]
    v.summary = {"video": v.video_id, "input": str(video), "status": "done", "error": None,
                 **lane_shares([r.get("state") for r in rows], [r.get("width_m") for r in rows]),
                 "events": len(v.events)}
    return v


# -- pictures -------------------------------------------------------------------------------------
def _jpeg(img: np.ndarray, width: int | None = None) -> bytes:
    if width and img.shape[1] > width:
        img = cv2.resize(img, (width, round(img.shape[0] * width / img.shape[1])), interpolation=cv2.INTER_AREA)
    ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, _JPEG_QUALITY])
    if not ok:
        raise LaneFinderError("cannot encode the image")
    return buf.tobytes()


def draw_row(frame: np.ndarray, row: dict | None) -> np.ndarray:
    """Draw a telemetry row's lane on its frame: the lines at the TuSimple rows, the lane filled.

    Parameters
    ----------
    frame : (H, W, 3) uint8 ndarray
        The frame, BGR (not changed).
    row : dict or None
        Its telemetry row (``h_samples``, ``left_x``, ``right_x``, ``state``, ``offset_m``, ...).

    Returns
    -------
    (H, W, 3) uint8 ndarray
        A copy with the lane drawn and a one-line label.

    Examples
    --------
    >>> img = np.zeros((720, 1280, 3), np.uint8)
    >>> row = {"h_samples": [600, 700], "left_x": [400.0, 300.0], "right_x": [800.0, 900.0], "state": "tracking"}
    >>> int(draw_row(img, row)[650, 600, 1]) > 0
    True
    """
    out = frame.copy()
    if not row:
        return out
    ys = row.get("h_samples") or []
    lines = []
    for key, color in (("left_x", (0, 0, 255)), ("right_x", (255, 80, 0))):
        pts = [(x, y) for x, y in zip(row.get(key) or [], ys, strict=False) if x is not None and x >= 0]
        lines.append(np.array(pts, np.float32).reshape(-1, 2))
        if len(pts) >= 2:
            cv2.polylines(out, [np.round(lines[-1]).astype(np.int32)], False, color, 4, cv2.LINE_AA)
    left, right = lines
    if len(left) >= 2 and len(right) >= 2:
        poly = np.round(np.vstack([left, right[::-1]])).astype(np.int32)
        fill = out.copy()
        cv2.fillPoly(fill, [poly], (0, 200, 0))
        out = cv2.addWeighted(fill, 0.3, out, 0.7, 0)
    label = f"{row.get('state', '')}  offset {_fmt(row.get('offset_m'), '+.2f')} m  width {_fmt(row.get('width_m'))} m"
    cv2.putText(out, label, (20, 40), cv2.FONT_HERSHEY_SIMPLEX, 1.0, (0, 0, 0), 5, cv2.LINE_AA)
    cv2.putText(out, label, (20, 40), cv2.FONT_HERSHEY_SIMPLEX, 1.0, (255, 255, 255), 2, cv2.LINE_AA)
    return out


def _clean(obj: Any) -> Any:
    """Give ``obj`` with NaN and infinities as None (JSON has neither)."""
    if isinstance(obj, float):
        return obj if np.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    return obj


def _fmt(v: Any, spec: str = ".2f") -> str:
    return "-" if v is None else format(v, spec)


# -- the config form ------------------------------------------------------------------------------
def config_form(cfg: Config) -> list[dict]:
    """Describe the tunable fields of the inspector's form, from the config's schema.

    Parameters
    ----------
    cfg : Config
        Gives the current values.

    Returns
    -------
    list of dict
        One per field of :data:`TUNABLE_SECTIONS` (nested sections flattened, ``a.b.c``):
        ``key``, ``type`` (``number``, ``integer``, ``boolean`` or ``choice``), ``value``,
        ``min``, ``max``, ``choices`` and ``help``.  Tuple-valued fields (colours) are left out.

    Examples
    --------
    >>> form = config_form(Config())
    >>> [f for f in form if f["key"] == "threshold.ridge.rel_contrast"][0]["type"]
    'number'
    """
    out: list[dict] = []
    for section in TUNABLE_SECTIONS:
        _fields(getattr(cfg, section), section, out)
    return out


def _fields(model: BaseModel, prefix: str, out: list[dict]) -> None:
    import typing

    for name, info in type(model).model_fields.items():
        value = getattr(model, name)
        key = f"{prefix}.{name}"
        if isinstance(value, BaseModel):
            _fields(value, key, out)
            continue
        lo = hi = None
        for m in info.metadata:
            lo = getattr(m, "ge", None) if getattr(m, "ge", None) is not None else (getattr(m, "gt", None)
                                                                                    if lo is None else lo)
            hi = getattr(m, "le", None) if getattr(m, "le", None) is not None else (getattr(m, "lt", None)
                                                                                    if hi is None else hi)
        ann = info.annotation
        entry = {"key": key, "value": value, "min": lo, "max": hi, "choices": None, "help": info.description or ""}
        if typing.get_origin(ann) is typing.Literal:
            entry.update(type="choice", choices=list(typing.get_args(ann)))
        elif ann is bool:
            entry["type"] = "boolean"
        elif ann is int:
            entry["type"] = "integer"
        elif ann is float:
            entry["type"] = "number"
        else:
            continue
        out.append(entry)


def _merged(base: Config, changes: dict[str, Any], src: list | None,
            reference_size: tuple[int, int] | None = None, frame_size: tuple[int, int] | None = None) -> Config:
    """Give the base config with the form's changes (``a.b.c`` keys) and the trapezoid applied.

    A dragged trapezoid (``src``, for frames of ``reference_size``) replaces the corners of the
    set-up in use for frames of ``frame_size`` (:func:`_used_birdseye`): for another lens with no
    set-up of its own, the lens's nominal set-up, with its scales.
    """
    if reference_size is not None and src is None:
        raise LaneFinderError("reference_size goes with src: the frame size the trapezoid is given for")
    data = base.model_dump(mode="json")
    for key, value in changes.items():
        parts = key.split(".")
        if parts[0] not in TUNABLE_SECTIONS:
            raise LaneFinderError(f"{key}: only {', '.join(TUNABLE_SECTIONS)} can be changed here")
        node = data
        for p in parts[:-1]:
            if not isinstance(node.get(p), dict):
                raise LaneFinderError(f"{key}: no such setting")
            node = node[p]
        if parts[-1] not in node:
            raise LaneFinderError(f"{key}: no such setting")
        node[parts[-1]] = value
    if src is not None:
        if frame_size is not None:
            data["birdseye"] = _used_birdseye(base, frame_size).model_dump(mode="json")
        data["birdseye"]["src"] = src
        if reference_size is not None:
            data["birdseye"]["reference_size"] = list(reference_size)
    return config_from_dict(data, "the form")


def _used_birdseye(cfg: Config, frame_size: tuple[int, int] | None) -> BirdseyeConfig:
    """Give the set-up a config puts in use for frames of a size (the config's own when the size is unknown)."""
    from .pipeline import birdseye_config_used

    return cfg.birdseye if frame_size is None else birdseye_config_used(cfg, None, frame_size)


# -- the app --------------------------------------------------------------------------------------
class _BoundedBody:
    """ASGI middleware: a request body over ``limit`` bytes gets a 413, whether it says its size or not.

    The body (at most ``limit`` bytes) is read first, then handed to the app.
    """

    def __init__(self, app, limit: int):
        self.app, self.limit = app, limit

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        size = dict(scope.get("headers") or []).get(b"content-length")
        if size is not None and (not size.isdigit() or int(size) > self.limit):
            await self._refuse(send)
            return
        body, more = b"", True
        while more:
            message = await receive()
            if message["type"] != "http.request":  # the client went away
                return
            body += message.get("body", b"")
            more = message.get("more_body", False)
            if len(body) > self.limit:
                await self._refuse(send)
                return
        sent = False

        async def replay():
            nonlocal sent
            if sent:
                return await receive()
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}

        await self.app(scope, replay, send)

    async def _refuse(self, send) -> None:
        body = json.dumps({"detail": f"request body over {self.limit} bytes"}).encode()
        await send({"type": "http.response.start", "status": 413,
                    "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]})
        await send({"type": "http.response.body", "body": body})


class _Inspect(BaseModel):
    config: dict[str, Any] = {}
    src: list[list[float]] | None = None
    reference_size: tuple[int, int] | None = None  # the frame size ``src`` is given for
    video: str | None = None  # (to save) the video whose frames the trapezoid was drawn on


def create_app(review: Review, allowed_hosts: tuple[str, ...] | None = None):
    """Build the web app (FastAPI) for a review.

    Parameters
    ----------
    review : Review
        What to serve.
    allowed_hosts : tuple of str, optional
        The host names requests may be addressed to (default :data:`LOCAL_HOSTS`; ``("*",)``
        for any).

    Returns
    -------
    fastapi.FastAPI
        The app; run it with uvicorn (see :func:`serve`).

    Examples
    --------
    >>> import tempfile, shutil
    >>> from fastapi.testclient import TestClient
    >>> from lanefinder.videojob import process_video
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = shutil.copy("data/clips/harder_challenge_0-4s.mp4", d / "h.mp4")
    >>> _ = process_video(d / "h.mp4", None, telemetry=d / "h.csv", progress=False, max_frames=10)
    >>> client = TestClient(create_app(Review(d / "h.mp4")))
    >>> client.get("/api/videos").json()[0]["video"], client.get("/files/../etc/passwd").status_code
    ('h', 404)
    """
    from fastapi import FastAPI, HTTPException, Request
    from fastapi.exceptions import RequestValidationError
    from fastapi.responses import FileResponse, JSONResponse, Response
    from starlette.middleware.trustedhost import TrustedHostMiddleware

    app = FastAPI(title="lanefinder review", docs_url=None, redoc_url=None, openapi_url=None)
    # Only requests addressed to this machine's names: a page elsewhere cannot reach the server
    # through a name of its own that resolves here (DNS rebinding).
    app.add_middleware(TrustedHostMiddleware, allowed_hosts=list(allowed_hosts or LOCAL_HOSTS))
    app.add_middleware(_BoundedBody, limit=MAX_BODY_BYTES)

    @app.exception_handler(LaneFinderError)
    async def lanefinder_error(_request: Request, exc: LaneFinderError):
        return JSONResponse({"detail": str(exc)}, status_code=422)

    def video(video_id: str) -> VideoSource:
        try:
            return review.video(video_id)
        except KeyError:
            raise HTTPException(404, f"no video {video_id!r}") from None

    def frame_index(v: VideoSource, n: int) -> int:
        count = v.frame_count()
        if not 0 <= n < count:
            raise HTTPException(404, f"frame {n} is out of range 0..{count - 1}")
        return n

    @app.get("/")
    def index():
        return FileResponse(_STATIC / "index.html", media_type="text/html")

    @app.get("/static/{name}")
    def static(name: str):
        if name not in _STATIC_FILES:
            raise HTTPException(404, "not found")
        return FileResponse(_STATIC / name, media_type=_STATIC_FILES[name])

    @app.get("/vendor/plotly.min.js")
    def plotly_js():
        import plotly

        return FileResponse(Path(plotly.__file__).parent / "package_data" / "plotly.min.js",
                            media_type="text/javascript")

    @app.get("/api/info")
    def info():
        return {"mode": review.mode, "root": review.root.name, "videos": len(review.videos),
                "config": json.loads(review.config.model_dump_json()), "form": config_form(review.config),
                "config_path": str(review.config_path) if review.config_path else None}

    @app.get("/api/videos")
    def videos():
        rows = []
        for v in review.videos.values():
            s = dict(v.summary)
            s["events"] = len(v.events) if s.get("status", "done") == "done" else None
            s["video"] = v.video_id
            s["source_available"] = v.source is not None
            rows.append(s)
        return _clean(rows)

    @app.get("/api/videos/{video_id}")
    def video_info(video_id: str):
        v = video(video_id)
        rows = v.rows()
        series = {k: [row.get(k) for row in rows] for k in _SERIES}
        series["frame"] = [row["frame"] for row in rows]
        used = _used_birdseye(review.config, frame_size_of(v))
        return _clean({"video": v.video_id, "frames": v.frame_count(), "fps": v.fps(), "source": v.source is not None,
                       "series": series, "events": v.events, "summary": v.summary,
                       "src": used.src, "reference_size": used.reference_size})

    def frame_size_of(v: VideoSource) -> tuple[int, int] | None:
        return tuple(v.reader().size) if v.source is not None else None

    def with_source(video_id: str) -> VideoSource:
        v = video(video_id)
        if v.source is None:
            raise HTTPException(404, f"the source video of {video_id} is not readable here")
        return v

    @app.get("/api/videos/{video_id}/frames/{n}.jpg")
    def frame(video_id: str, n: int, overlay: bool = True, width: int = 960):
        v = with_source(video_id)
        n = frame_index(v, n)
        img = v.reader().get(n)
        if overlay:
            img = draw_row(img, v.row_at(n))
        return Response(_jpeg(img, max(160, min(width, 3840))), media_type="image/jpeg")

    @app.post("/api/videos/{video_id}/frames/{n}/inspect")
    def inspect(video_id: str, n: int, body: _Inspect):
        from .pipeline import LaneFinder
        from .stages import inspect_frame

        v = with_source(video_id)
        n = frame_index(v, n)
        t0 = time.perf_counter()
        size = frame_size_of(v)
        cfg = _merged(review.config, body.config, body.src, body.reference_size, size)
        img = v.reader().get(n)
        images, result = inspect_frame(img, LaneFinder(cfg))
        used = _used_birdseye(cfg, size)
        encoded = {k: "data:image/jpeg;base64," + base64.b64encode(_jpeg(im, 800)).decode() for k, im in images.items()}
        return _clean({"ms": round((time.perf_counter() - t0) * 1000, 1), "images": encoded,
                       "result": {"state": result.state, "offset_m": result.offset_m, "width_m": result.width_m,
                                  "radius_m": result.radius_m, "left_conf": result.left.confidence,
                                  "right_conf": result.right.confidence, "checks": list(result.checks)},
                       "src": used.src, "reference_size": used.reference_size})

    @app.post("/api/config/save")
    def save(body: _Inspect):
        from .pipeline import LaneFinder

        size = frame_size_of(video(body.video)) if body.video is not None else None
        if body.src is not None and size is None:
            raise LaneFinderError("a trapezoid is saved with the video it was drawn on: give 'video', one whose "
                                  "source is readable here")
        cfg = _merged(review.config, body.config, body.src, body.reference_size, size)
        if size is not None:
            LaneFinder(cfg).birdseye(size)  # a config that cannot serve this video is refused, not saved
        path = review.save_config(cfg)
        return {"path": str(path), "name": path.name}

    @app.get("/files/{rel:path}")
    def files(rel: str):
        try:
            return FileResponse(review.safe_path(rel))
        except (FileNotFoundError, OSError, ValueError):
            raise HTTPException(404, "not found") from None

    @app.exception_handler(ValidationError)
    async def bad_body(_request: Request, exc: ValidationError):
        return JSONResponse({"detail": str(exc).splitlines()[0]}, status_code=422)

    @app.exception_handler(RequestValidationError)
    async def bad_request(_request: Request, exc: RequestValidationError):
        errors = exc.errors()
        first = errors[0] if errors else {}
        where = ".".join(str(p) for p in first.get("loc", ())[1:]) or "request"
        return JSONResponse({"detail": f"{where}: {first.get('msg', 'invalid')}"}, status_code=422)

    return app


def serve(review: Review, host: str = "127.0.0.1", port: int = 8765, echo=print) -> None:
    r"""Serve a review until Ctrl-C.

    Parameters
    ----------
    review : Review
        What to serve.
    host : str
        The address to bind (127.0.0.1 by default: this machine only).
    port : int
        The port (0: any free port).
    echo : callable
        Where the address (and a warning for a non-local host) is printed, and ``review
        stopped`` when Ctrl-C stops it (a normal end: ``lanefinder review`` then exits 0).

    Raises
    ------
    LaneFinderError
        When the address cannot be bound.

    Examples
    --------
    >>> import tempfile, shutil
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = shutil.copy("data/clips/harder_challenge_0-4s.mp4", d / "h.mp4")
    >>> _ = (d / "h.csv").write_text("frame,time_s,state\n0,0.0,lost\n")
    >>> serve(Review(d / "h.mp4"), port=-1)
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: cannot listen on 127.0.0.1:-1: ...
    """
    import socket

    import uvicorn

    if host not in ("127.0.0.1", "localhost", "::1"):
        echo(f"warning: serving on {host}: anyone who can reach this address can see the videos and frames")
    if changed := [v.video_id for v in review.videos.values() if v.changed]:
        echo(f"warning: {len(changed)} video(s) were modified after their telemetry was written (replaced since the "
             f"batch?): their frames may not match their lanes: {', '.join(changed[:5])}"
             f"{' ...' if len(changed) > 5 else ''}")
    try:
        sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((host, port))
    except (OSError, OverflowError) as e:
        raise LaneFinderError(f"cannot listen on {host}:{port}: {getattr(e, 'strerror', None) or e}") from None
    shown = sock.getsockname()[1]
    n = len(review.videos)
    echo(f"lanefinder review of {review.path} ({review.mode}, {n} video{'s' if n != 1 else ''}): "
         f"http://{'[' + host + ']' if ':' in host else host}:{shown}/  (Ctrl-C to stop)")
    hosts = None if host in ("127.0.0.1", "localhost", "::1") else ("*",)
    try:
        uvicorn.Server(uvicorn.Config(create_app(review, hosts), log_level="warning")).run(sockets=[sock])
    except KeyboardInterrupt:  # Ctrl-C is how a review is stopped: uvicorn shuts down, then passes it on
        echo("review stopped")


def load_review(path: str | Path, config_path: str | Path | None = None,
                telemetry: str | Path | None = None) -> Review:
    """Open a review with the config from a file (or the defaults).

    Parameters
    ----------
    path : str or Path
        A batch folder or a video.
    config_path : str or Path, optional
        A config file.
    telemetry : str or Path, optional
        The video's telemetry.

    Returns
    -------
    Review
        Ready to serve.

    Examples
    --------
    >>> load_review("no/such/folder")
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: not found: no/such/folder
    """
    from .pipeline import load_checked_config

    cfg = load_checked_config(config_path or None)  # a missing camera file: else every inspection would fail
    return Review(path, cfg, config_path, telemetry)
