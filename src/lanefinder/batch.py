"""The batch job: a fleet of videos on a Dask cluster, written as one queryable Parquet dataset.

``run_batch`` finds the inputs (files, folders searched recursively for videos, text files
that list paths; local paths or fsspec URLs), probes each one on the cluster, cuts the long
ones into segments (each after the first starting ``batch.warmup_s`` early so the tracker
is warm when its own span begins; the overlap is dropped), and runs the segments as Dask
tasks.  Each task writes its rows into ``OUTDIR/.staging/video=<id>/`` (one Parquet file per
segment, put in place only when complete) and sends back a few numbers per frame, from which
the client finds the lane events of the whole video and its summary; once all of a video's
segments are back, its parts move into ``OUTDIR/telemetry/video=<id>/`` together.

A manifest (``OUTDIR/manifest.json``, rewritten atomically after every video) keys each
input by its content hash and the config's hash: a re-run skips what is done, redoes what
failed or changed, and says how many of each.  One video's failure is recorded with its
reason and never stops the others.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
import math
import os
import posixpath
import re
import tempfile
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import fsspec
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from . import __version__
from .config import Config, config_arg, dump_config
from .errors import LaneFinderError, NoFramesError
from .stats import lane_shares
from .telemetry import FIELDS

__all__ = [
    "VIDEO_SUFFIXES",
    "BatchReport",
    "Segment",
    "VideoEntry",
    "config_hash",
    "content_hash",
    "find_inputs",
    "plan_segments",
    "run_batch",
    "run_segment",
]

#: File suffixes taken for videos when a folder is searched.
VIDEO_SUFFIXES = (".mp4", ".mov", ".m4v", ".mkv", ".avi", ".webm", ".ts", ".mts", ".mpg", ".mpeg", ".h264")
#: Suffixes of a text file that lists inputs, one a line.
LIST_SUFFIXES = (".txt", ".lst", ".list")
_MANIFEST = "manifest.json"
# Bytes read for the content hash: the head, the tail and evenly spaced blocks between.
_HASH_BLOCK = 1 << 20
_HASH_BLOCKS = 16
# Columns a task sends back per frame (enough for events and the summary).
_EVENT_COLUMNS = ("frame", "time_s", "state", "offset_m", "width_m", "misses")


@dataclass(frozen=True)
class Segment:
    """A span of one video, processed as one task.

    Attributes
    ----------
    video_id : str
        The video's name in the dataset (its partition value).
    url : str
        The input (a local path or an fsspec URL).
    index : int
        The segment's number in its video, from 0.
    start_s : float
        Where the segment's own span begins, s.
    end_s : float or None
        Where it ends (exclusive), s; None: the end of the video.
    warmup_s : float
        Processed before ``start_s`` to warm the tracker up, and dropped, s.
    fps : float
        The video's frame rate, frames/s.

    Examples
    --------
    >>> s = Segment(video_id="a", url="a.mp4", index=1, start_s=120.0, end_s=240.0, warmup_s=4.0, fps=25.0)
    >>> s.run_from_s
    116.0
    """

    video_id: str
    url: str
    index: int
    start_s: float
    end_s: float | None
    warmup_s: float
    fps: float

    @property
    def run_from_s(self) -> float:
        """Where decoding starts: the span's start less the warm-up, s."""
        return max(0.0, self.start_s - self.warmup_s)


@dataclass
class VideoEntry:
    """One input's record in the manifest.

    Attributes
    ----------
    url : str
        The input.
    video_id : str
        Its name in the dataset.
    content_hash, config_hash : str
        What the record was made from.
    status : str
        ``done`` or ``failed``.
    error : str or None
        Why it failed.
    summary : dict
        The video's row of ``summary.parquet`` (without ``video``, ``input``, ``status``, ``error``).
    events : list of dict
        Its lane events (rows of ``events.parquet`` without ``video``).

    Examples
    --------
    >>> VideoEntry(url="a.mp4", video_id="a", content_hash="x", config_hash="y", status="failed",
    ...            error="cannot open").status
    'failed'
    """

    url: str
    video_id: str
    content_hash: str
    config_hash: str
    status: str
    error: str | None = None
    summary: dict = field(default_factory=dict)
    events: list = field(default_factory=list)


@dataclass(frozen=True)
class BatchReport:
    """What a batch run did.

    Attributes
    ----------
    videos : int
        Inputs in all.
    done : int
        Processed (or redone) this run and succeeded.
    skipped : int
        Done before with the same content and config: not run again.
    redone_failed, redone_changed : int
        Of ``done`` and ``failed``: inputs that had failed before, or whose content or config
        changed (or whose rows were gone or damaged).
    failed : int
        Failed this run (recorded with their reason).
    frames : int
        Frames processed this run.
    seconds : float
        Wall time, s.
    outdir : str
        The output folder.
    dashboard : str or None
        The Dask dashboard's address, when there is one.

    Examples
    --------
    >>> r = BatchReport(videos=3, done=2, skipped=1, redone_failed=0, redone_changed=0, failed=0, frames=50,
    ...                 seconds=2.0, outdir="out", dashboard=None)
    >>> r.lines()[0]
    '3 videos: 2 processed, 1 skipped (done before, unchanged), 0 failed'
    """

    videos: int
    done: int
    skipped: int
    redone_failed: int
    redone_changed: int
    failed: int
    frames: int
    seconds: float
    outdir: str
    dashboard: str | None = None

    def lines(self) -> list[str]:
        """Return the end-of-run summary as printed lines.

        Returns
        -------
        list of str
            Counts, speed and where the outputs are.
        """
        fps = self.frames / self.seconds if self.seconds else 0.0
        return [
            f"{self.videos} video{'' if self.videos == 1 else 's'}: {self.done} processed, "
            f"{self.skipped} skipped (done before, unchanged), "
            f"{self.failed} failed",
            f"redone: {self.redone_failed} that had failed, {self.redone_changed} whose content or config changed "
            "(or whose rows were gone or damaged)",
            f"frames: {self.frames} in {self.seconds:.1f} s ({fps:.1f} fps over the fleet)",
            f"outputs: {self.outdir} (telemetry/, events.parquet, summary.parquet, summary.csv, manifest.json)",
        ]


# -- inputs ------------------------------------------------------------------------------------
def _fs(url: str):
    """Give the fsspec file system and path of a URL or local path; a bad or unsupported URL is one line."""
    try:
        return fsspec.core.url_to_fs(url)
    except ImportError as e:
        raise LaneFinderError(f"{url}: this kind of URL needs a package that is not installed ({e})") from None
    except (ValueError, TypeError, OSError) as e:
        raise LaneFinderError(f"{url}: not a usable path or URL ({e})") from None


def _is_url(s: str) -> bool:
    return bool(re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*://", s))


def _local(url: str) -> str | None:
    """Give the local path of an input, or None when it is remote."""
    if not _is_url(url):
        return url
    return url[len("file://"):] if url.startswith("file://") else None


def _norm(s: str) -> str:
    """Give a stable key for an input: absolute local paths, URLs as given."""
    local = _local(s)
    return os.path.abspath(local) if local is not None else s


def find_inputs(inputs: Sequence[str | Path], skip: str | Path | None = None) -> list[str]:
    """List the videos named by files, folders (searched recursively) and text files of paths.

    Parameters
    ----------
    inputs : sequence of str or Path
        Video files, folders, or ``.txt``/``.lst`` files with one path or URL a line (blank
        lines and lines starting with ``#`` are skipped); local paths or fsspec URLs.
    skip : str or Path, optional
        A local folder whose videos a folder's search leaves out (the batch's output, which
        ``--video`` writes videos into, when it lies in an input folder).

    Returns
    -------
    list of str
        The videos, each once, in the order given (a folder's in sorted order); local paths
        made absolute.

    Raises
    ------
    LaneFinderError
        When an input does not exist, or no video is found.

    Examples
    --------
    >>> [Path(p).name for p in find_inputs(["data/clips"])]
    ['challenge_3-7s.mp4', 'harder_challenge_0-4s.mp4', 'project_37-47s.mp4']
    """
    found: list[str] = []
    skipped = os.path.abspath(local) + os.sep if skip is not None and (local := _local(str(skip))) else None
    for raw in inputs:
        s = str(raw)
        fs, path = _fs(s)
        try:
            isdir = fs.isdir(path)
            exists = isdir or fs.isfile(path)
        except (OSError, ValueError) as e:
            raise LaneFinderError(f"cannot read {s}: {e}") from None
        if not exists:
            raise LaneFinderError(f"input not found: {s}")
        if isdir:
            # The output folder is left out only when it lies inside this one (an input folder inside
            # the output, or the output itself, is refused by the run, with its reason).
            inside = os.path.abspath(path) + os.sep
            leave = skipped if skipped and _local(s) is not None and skipped.startswith(inside) \
                and skipped != inside else None
            files = sorted(p for p in fs.find(path) if p.lower().endswith(VIDEO_SUFFIXES)
                           and not posixpath.basename(p).startswith(".")
                           and not (leave and os.path.abspath(p).startswith(leave)))
            found += [_rebuild(s, fs, p) for p in files]
        elif path.lower().endswith(LIST_SUFFIXES):
            found += _read_list(fs, path, s)
        else:
            found.append(s)
    keys = list(dict.fromkeys(_norm(f) for f in found))
    if not keys:
        raise LaneFinderError("no videos found in " + ", ".join(map(str, inputs)))
    return keys


def _rebuild(given: str, fs, path: str) -> str:
    """Give a path found under a folder in the form the folder was given (local path or URL)."""
    if _local(given) is not None:
        return path
    return fs.unstrip_protocol(path)


def _read_list(fs, path: str, given: str) -> list[str]:
    try:
        text = fs.cat_file(path).decode()
    except (OSError, UnicodeDecodeError) as e:
        raise LaneFinderError(f"cannot read the list of inputs {given}: {e}") from None
    base = posixpath.dirname(path)
    out = []
    for line in text.removeprefix("\ufeff").splitlines():  # a byte-order mark (Windows Notepad) is no path
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        local = _local(given)
        if not _is_url(line) and local is not None and not os.path.isabs(line):
            line = os.path.join(os.path.dirname(os.path.abspath(local)), line)
        elif not _is_url(line) and local is None:
            line = fs.unstrip_protocol(posixpath.join(base, line))
        out.append(line)
    return out


def content_hash(url: str) -> str:
    """Hash a video's content: its size, its first and last MB and 16 evenly spaced MB.

    Sampling keeps this cheap on hours of footage (at most 18 MB read a file); a change that
    keeps the size and touches none of the sampled blocks goes unnoticed.

    Parameters
    ----------
    url : str
        A local path or an fsspec URL.

    Returns
    -------
    str
        A BLAKE2b hex digest (32 characters).

    Raises
    ------
    LaneFinderError
        When the file cannot be read.

    Examples
    --------
    >>> len(content_hash("data/clips/project_37-47s.mp4"))
    32
    """
    try:
        fs, path = _fs(url)
        size = fs.size(path)
        h = hashlib.blake2b(str(size).encode(), digest_size=16)
        with fs.open(path, "rb") as f:
            if size <= (_HASH_BLOCKS + 2) * _HASH_BLOCK:
                h.update(f.read())
            else:
                for off in [0, *(round(size * (i + 1) / (_HASH_BLOCKS + 1)) for i in range(_HASH_BLOCKS)),
                            size - _HASH_BLOCK]:
                    f.seek(off)
                    h.update(f.read(_HASH_BLOCK))
        return h.hexdigest()
    except (OSError, ValueError) as e:
        raise LaneFinderError(f"cannot read {url}: {getattr(e, 'strerror', None) or e}") from None


def config_hash(cfg: Config) -> str:
    """Hash a configuration, the camera file it names, the lanefinder version and the telemetry's columns.

    (A batch re-run redoes what an earlier run wrote with other columns, so a dataset's parts
    always share one schema.)

    Parameters
    ----------
    cfg : Config
        The configuration.

    Returns
    -------
    str
        A hex digest (16 characters).

    Examples
    --------
    >>> config_hash(Config()) == config_hash(Config())
    True
    """
    h = hashlib.blake2b(f"{__version__}\n{','.join(FIELDS)}\n{dump_config(cfg, 'json')}".encode(), digest_size=8)
    camera = Path(cfg.camera.model)
    if cfg.camera.model not in ("udacity", "none") and camera.is_file():
        h.update(camera.read_bytes())  # a camera calibrated again is a changed config
    return h.hexdigest()


def plan_segments(video_id: str, url: str, duration_s: float, fps: float, segment_s: float,
                  warmup_s: float) -> list[Segment]:
    """Cut a video into segments of ``segment_s`` (the last one runs to the end).

    Parameters
    ----------
    video_id, url : str
        The video's name and input.
    duration_s : float
        Its duration, s (0 when unknown: one segment).
    fps : float
        Its frame rate, frames/s.
    segment_s : float
        Segment length, s (0: one segment).
    warmup_s : float
        Warm-up before each segment but the first, s.

    Returns
    -------
    list of Segment
        In order; together they cover every frame exactly once.

    Examples
    --------
    >>> [(s.start_s, s.end_s) for s in plan_segments("a", "a.mp4", 250.0, 25.0, 100.0, 4.0)]
    [(0.0, 100.0), (100.0, 200.0), (200.0, None)]
    """
    n = 1 if segment_s <= 0 or duration_s <= 0 else max(1, math.ceil(duration_s / segment_s - 0.25))
    return [Segment(video_id=video_id, url=url, index=i, start_s=i * segment_s if n > 1 else 0.0,
                    end_s=(i + 1) * segment_s if i < n - 1 else None, warmup_s=warmup_s if i else 0.0, fps=fps)
            for i in range(n)]


#: The longest name taken whole from a file's name for its video id (longer ones are cut and tagged).
_MAX_ID_CHARS = 120


def _video_ids(keys: Sequence[str], known: dict[str, str]) -> dict[str, str]:
    """Give every input a stable, unique, file-safe name (its partition value)."""
    ids = dict(known)
    used = set(ids.values())
    for k in keys:
        if k in ids:
            continue
        stem = re.sub(r"[^A-Za-z0-9._-]+", "_", posixpath.splitext(posixpath.basename(k.rstrip("/")))[0])
        tag = hashlib.blake2b(k.encode(), digest_size=3).hexdigest()
        if not re.search(r"[A-Za-z0-9]", stem):  # a name of other scripts only: nothing of it is left
            stem = f"video-{tag}"
        elif len(stem) > _MAX_ID_CHARS:  # a folder's name (.staging/video=<id>) must stay within 255 bytes
            stem = f"{stem[:_MAX_ID_CHARS]}-{tag}"
        name = stem
        if name in used:
            name = f"{stem}-{tag}"
        ids[k] = name
        used.add(name)
    return ids


# -- the work on a worker ----------------------------------------------------------------------
def _probe(url: str) -> dict:
    """On a worker: the video's facts and content hash, or the reason it cannot be read."""
    from .video import VideoInfo

    try:
        with _local_copy(url) as path:
            info = VideoInfo.from_path(path)
        return {"fps": float(info.fps), "duration_s": info.duration_s, "frames": info.total_frames,
                "size": list(info.size), "hash": content_hash(url)}
    except LaneFinderError as e:
        return {"error": str(e)}
    except Exception as e:  # a worker never dies of one input
        return {"error": f"{type(e).__name__}: {e}"}


@contextlib.contextmanager
def _local_copy(url: str):
    """Give a local path for an input: itself when local, else a temporary copy."""
    local = _local(url)
    if local is not None:
        yield local
        return
    suffix = posixpath.splitext(url)[1] or ".mp4"
    fd, tmp = tempfile.mkstemp(prefix="lanefinder-", suffix=suffix)
    os.close(fd)
    try:
        try:
            fs, path = _fs(url)
            fs.get_file(path, tmp)
        except (OSError, ValueError) as e:
            raise LaneFinderError(f"cannot read {url}: {e}") from None
        yield tmp
    finally:
        with contextlib.suppress(OSError):
            os.unlink(tmp)


def _put(fs, local: str, dest: str) -> None:
    """Copy a finished local file to ``dest`` on ``fs``: to a hidden name first, then moved into place."""
    folder, name = posixpath.split(dest)
    fs.makedirs(folder, exist_ok=True)
    hidden = posixpath.join(folder, f".{name}.{os.getpid()}.tmp")
    fs.put_file(local, hidden)
    fs.mv(hidden, dest)


def run_segment(seg: Segment, cfg: Config, outdir: str, write_video: bool = False) -> dict:
    """Process one segment (a Dask task): write its telemetry part, return its frames' numbers.

    Parameters
    ----------
    seg : Segment
        What to process.
    cfg : Config
        The configuration.
    outdir : str
        The batch's output folder (local path or fsspec URL).
    write_video : bool
        Also write the annotated video to ``OUTDIR/videos/<id>.mp4`` (for a one-segment video).

    Returns
    -------
    dict
        ``video_id``, ``index``, ``frames`` (rows kept), ``seconds`` (processing time),
        ``damaged``, ``truncated``, ``columns`` (``frame``, ``time_s``, ``state``, ``offset_m``,
        ``width_m`` of every kept frame), ``both_found``; or ``error`` with the reason.

    Examples
    --------
    >>> import tempfile
    >>> seg = Segment(video_id="p", url="data/clips/project_37-47s.mp4", index=0, start_s=0.0, end_s=0.4,
    ...               warmup_s=0.0, fps=25.0)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     r = run_segment(seg, Config(), d)
    >>> r["frames"], r["columns"]["state"][:2]
    (10, ['re-detect', 'tracking'])
    """
    from .videojob import process_video

    t0 = time.perf_counter()
    try:
        fs, root = _fs(outdir)
        with _local_copy(seg.url) as src, tempfile.TemporaryDirectory(prefix="lanefinder-seg-") as tmp:
            tele = Path(tmp, "t.parquet")
            video = Path(tmp, f"{seg.video_id}.mp4") if write_video else None
            try:
                s = process_video(src, video, cfg, start_s=seg.run_from_s, end_s=seg.end_s, telemetry=tele,
                                  progress=False)
            except NoFramesError as e:  # past the end of a file cut short: nothing here, not a failure
                return {"video_id": seg.video_id, "index": seg.index, "frames": 0, "empty": str(e),
                        "columns": {k: [] for k in _EVENT_COLUMNS}, "both_found": 0, "damaged": 0,
                        "truncated": True, "seconds": time.perf_counter() - t0}
            table = pq.read_table(tele)
            keep = pc.greater_equal(table["time_s"], seg.start_s - 0.5 / seg.fps) if seg.index else None
            if keep is not None:
                table = table.filter(keep)
            part = Path(tmp, "part.parquet")
            pq.write_table(table, part, compression="zstd")
            _put(fs, str(part), posixpath.join(_staging(root, seg.video_id), f"part-{seg.index:04d}.parquet"))
            if video is not None:
                _put(fs, str(video), _video_path(root, seg.video_id))
        cols = table.select(list(_EVENT_COLUMNS)).to_pydict()
        both = pc.sum(pc.and_(table["left_found"], table["right_found"])).as_py() or 0
        return {"video_id": seg.video_id, "index": seg.index, "frames": table.num_rows, "columns": cols,
                "both_found": int(both), "damaged": s.damaged, "truncated": s.truncated,
                "seconds": time.perf_counter() - t0}
    except LaneFinderError as e:
        return {"video_id": seg.video_id, "index": seg.index, "error": str(e)}
    except Exception as e:  # one segment's failure never takes the worker or the fleet down
        return {"video_id": seg.video_id, "index": seg.index, "error": f"{type(e).__name__}: {e}"}


# -- the manifest and the fleet tables ---------------------------------------------------------
def _load_manifest(fs, root: str) -> dict[str, VideoEntry]:
    path = posixpath.join(root, _MANIFEST)
    if not fs.exists(path):
        return {}
    try:
        data = json.loads(fs.cat_file(path))
        return {k: VideoEntry(**v) for k, v in data["videos"].items()}
    except (ValueError, KeyError, TypeError, OSError) as e:
        raise LaneFinderError(f"{path} is not a lanefinder batch manifest ({e}); move it away to start afresh") \
            from None


def _write_bytes(fs, dest: str, data: bytes) -> None:
    folder, name = posixpath.split(dest)
    fs.makedirs(folder, exist_ok=True)
    hidden = posixpath.join(folder, f".{name}.tmp")
    with fs.open(hidden, "wb") as f:
        f.write(data)
    fs.mv(hidden, dest)


def _save_manifest(fs, root: str, entries: dict[str, VideoEntry], cfg_hash: str) -> None:
    data = {"lanefinder": __version__, "config_hash": cfg_hash, "videos": {k: asdict(v) for k, v in entries.items()}}
    _write_bytes(fs, posixpath.join(root, _MANIFEST), json.dumps(data, indent=1).encode())


_SUMMARY_FIELDS = ("video", "input", "status", "error", "frames", "duration_s", "pct_lane", "pct_lost",
                   "pct_both_lines", "mean_width_m", "fps", "damaged_packets", "truncated", "setup", "config_hash",
                   "content_hash", "events_departure_left", "events_departure_right", "events_lane_change_left",
                   "events_lane_change_right", "events_lost")


def _summarise(results: list[dict], fps: float, cfg: Config,
               frame_size: tuple[int, int]) -> tuple[dict, list[dict]]:
    """Give a video's summary and events from its segments' results (in order)."""
    from .events import EVENT_KINDS, detect_events, event_row
    from .pipeline import birdseye_config_used

    cols: dict[str, list] = {k: [] for k in _EVENT_COLUMNS}
    for r in results:
        for k in _EVENT_COLUMNS:
            cols[k] += r["columns"][k]
    n = len(cols["frame"])
    rows = [dict(zip(_EVENT_COLUMNS, vals, strict=True)) for vals in zip(*cols.values(), strict=True)]
    events = [event_row(e) for e in detect_events(rows, fps, cfg.events)]
    seconds = sum(r["seconds"] for r in results)
    kinds = {k: sum(e["kind"] == k for e in events) for k in EVENT_KINDS}
    b = birdseye_config_used(cfg, None, frame_size)  # the set-up the run started from
    summary = {
        **lane_shares(cols["state"], cols["width_m"]), "duration_s": round(n / fps, 3) if fps else None,
        "pct_both_lines": round(100 * sum(r["both_found"] for r in results) / n, 2) if n else None,
        "fps": round(n / seconds, 2) if seconds else None,
        "damaged_packets": sum(r["damaged"] for r in results), "truncated": any(r["truncated"] for r in results),
        "setup": json.dumps({"camera": cfg.camera.model, "src": b.src, "reference_size": b.reference_size}),
        **{f"events_{k.replace('-', '_')}": v for k, v in kinds.items()},
    }
    return summary, events


def _fleet_tables(fs, root: str, entries: dict[str, VideoEntry]) -> None:
    """Write summary.parquet, summary.csv and events.parquet from the manifest's entries."""
    srows = []
    for e in entries.values():
        row = {k: None for k in _SUMMARY_FIELDS}
        row.update(e.summary if e.status == "done" else {})
        row.update({"video": e.video_id, "input": e.url, "status": e.status, "error": e.error,
                    "config_hash": e.config_hash, "content_hash": e.content_hash})
        srows.append(row)
    types = {"video": pa.string(), "input": pa.string(), "status": pa.string(), "error": pa.string(),
             "frames": pa.int64(), "damaged_packets": pa.int64(), "truncated": pa.bool_(), "setup": pa.string(),
             "config_hash": pa.string(), "content_hash": pa.string()}
    schema = pa.schema([pa.field(k, types.get(k, pa.int64() if k.startswith("events_") else pa.float64()))
                        for k in _SUMMARY_FIELDS])
    summary = pa.Table.from_pylist(srows, schema=schema)
    erows = [{"video": e.video_id, **ev} for e in entries.values() if e.status == "done" for ev in e.events]
    events = pa.Table.from_pylist(erows, schema=_events_schema())
    for name, table in (("summary.parquet", summary), ("events.parquet", events)):
        buf = pa.BufferOutputStream()
        pq.write_table(table, buf)
        _write_bytes(fs, posixpath.join(root, name), buf.getvalue().to_pybytes())
    text = io.StringIO()
    w = csv.DictWriter(text, fieldnames=list(_SUMMARY_FIELDS))
    w.writeheader()
    w.writerows({k: ("" if v is None else v) for k, v in r.items()} for r in srows)
    _write_bytes(fs, posixpath.join(root, "summary.csv"), text.getvalue().encode())


def _events_schema() -> pa.Schema:
    from .events import EVENT_FIELDS

    types = {"kind": pa.string(), "start_frame": pa.int64(), "end_frame": pa.int64()}
    return pa.schema([pa.field("video", pa.string())] + [pa.field(k, types.get(k, pa.float64())) for k in EVENT_FIELDS])


# -- the client --------------------------------------------------------------------------------
@contextlib.contextmanager
def _client(workers: int | None, scheduler: str | None, in_process: bool):
    """Give a Dask client: on a running scheduler, or on a local cluster that ends with the run."""
    import logging

    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError, ValueError) as e:
            raise LaneFinderError(f"cannot reach the Dask scheduler at {scheduler}: {e}") from None
        try:
            yield client
        finally:
            client.close()
        return
    n = workers or os.cpu_count() or 1
    # The scheduler's web server (and dashboard) on a free port of this machine only.
    # In-process workers (for memory:// URLs, which live in this process) talk over inproc://.
    where = {} if in_process else {"host": "127.0.0.1"}
    # Local worker processes ignore Ctrl-C once started (lanefinder.daskworker): this process stops
    # the run.  (A Ctrl-C in the second or so while they start still reaches them: they stop with
    # tracebacks.  Ignoring it here while they start, which they would inherit, would lose it.)
    preload = {} if in_process else {"preload": ["lanefinder.daskworker"]}
    # An interrupt during a client call can make distributed's own clean-up raise inside the event
    # loop (a NameError in distributed.utils.sync's cancel callback), which tornado logs with a
    # traceback after the run has already stopped cleanly.
    tornado_log = logging.getLogger("tornado.application")
    level = tornado_log.level
    tornado_log.setLevel(logging.CRITICAL)
    try:
        with LocalCluster(n_workers=n, threads_per_worker=1, processes=not in_process,
                          dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR, **where,
                          **preload) as cluster, Client(cluster) as client:
            yield client
    finally:
        tornado_log.setLevel(level)


def _dashboard(client) -> str | None:
    with contextlib.suppress(Exception):
        services = client.scheduler_info().get("services", {})
        if "dashboard" in services:
            return client.dashboard_link
    return None


def run_batch(inputs: Sequence[str | Path], outdir: str | Path, config: Config | None = None,
              workers: int | None = None, scheduler: str | None = None, write_video: bool = False,
              progress: bool = True, echo: Callable[[str], None] | None = None) -> BatchReport:
    """Find the lane in every frame of a fleet of videos, on a Dask cluster.

    See the README's "Fleets" section for the outputs.

    Parameters
    ----------
    inputs : sequence of str or Path
        Videos, folders and lists of paths (see :func:`find_inputs`); local paths or fsspec URLs.
    outdir : str or Path
        The output folder (local path or fsspec URL); a re-run into it resumes.
    config : Config, optional
        The configuration (defaults when omitted).
    workers : int, optional
        Local workers (default one per core); ignored with ``scheduler``.
    scheduler : str, optional
        The address of a running Dask scheduler (``tcp://HOST:PORT``).
    write_video : bool
        Also write annotated videos (``OUTDIR/videos/<id>.mp4``); videos are then not split.
    progress : bool
        Show a progress bar over the fleet.
    echo : callable, optional
        Where to print notes (the dashboard address); default nowhere.

    Returns
    -------
    BatchReport
        Counts of processed, skipped, redone and failed videos, frames and time.

    Raises
    ------
    LaneFinderError
        When no input is found, the output folder cannot be written, or the scheduler cannot be reached.
        A video that fails does not raise: it is recorded in the summary and the manifest.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     r = run_batch(["data/clips/challenge_3-7s.mp4"], d, workers=1, progress=False)
    ...     names = sorted(p.name for p in Path(d).iterdir())
    >>> r.done, r.failed, names
    (1, 0, ['events.parquet', 'manifest.json', 'summary.csv', 'summary.parquet', 'telemetry'])
    """
    cfg = config_arg(config)
    say = echo or (lambda _s: None)
    t0 = time.perf_counter()
    if isinstance(inputs, (str, Path)):  # one input (a string is a sequence of characters)
        inputs = [inputs]
    out = str(outdir)
    keys = find_inputs(inputs, skip=out)
    fs, root = _fs(out)
    _check_outdir(fs, root, out, keys)
    entries = _load_manifest(fs, root)
    fleet = _Fleet(fs, root, out, cfg, entries, _video_ids(keys, {k: e.video_id for k, e in entries.items()}),
                   write_video)
    in_process = any(k.startswith("memory://") for k in [*keys, out])
    try:
        with _client(workers, scheduler, in_process) as client:
            if (link := _dashboard(client)) is not None:
                say(f"Dask dashboard: {link}")
            probes = _gather_each(client, keys, [client.submit(_probe, k, pure=False) for k in keys],
                                  lambda k, e: {"error": f"the worker failed while probing {k}: {e}"})
            plan = fleet.plan(keys, probes)
            fleet.run(client, plan, probes, progress)
    except BaseException:
        # Stopped (Ctrl-C) or broken: once the local workers are gone, the parts of the videos not
        # finished go (a re-run redoes them; they lie outside telemetry/, where no query sees them).
        fleet.drop_unfinished()
        raise
    fleet.tidy()
    _fleet_tables(fs, root, entries)
    return BatchReport(videos=len(keys), outdir=out, seconds=time.perf_counter() - t0, dashboard=link, **fleet.counts)


def _gather_each(client, keys: Sequence, futures: Sequence, on_error: Callable[[Any, BaseException], dict]) -> dict:
    """Give each future's result by key; a future that raised (a worker that died) gives ``on_error``'s."""
    out = {}
    for k, fut in zip(keys, futures, strict=True):
        try:
            out[k] = fut.result()
        except Exception as e:
            out[k] = on_error(k, e)
    return out


class _Fleet:
    """The client's side of one batch run: what to do with each input, and what came back."""

    def __init__(self, fs, root: str, out: str, cfg: Config, entries: dict[str, VideoEntry], ids: dict[str, str],
                 write_video: bool):
        self.fs, self.root, self.out, self.cfg, self.entries, self.ids = fs, root, out, cfg, entries, ids
        self.write_video = write_video
        self.chash = config_hash(cfg)
        self.counts = {"done": 0, "skipped": 0, "redone_failed": 0, "redone_changed": 0, "failed": 0, "frames": 0}
        self.why: dict[str, str] = {}
        self.unfinished: list[str] = []  # the inputs planned but not finished when run() ended

    def _redone(self, key: str) -> None:
        if self.why.get(key):
            self.counts[f"redone_{self.why[key]}"] += 1

    def _unchanged(self, old: VideoEntry | None, probe: dict) -> bool:
        return bool(old and old.status == "done" and old.content_hash == probe["hash"]
                    and old.config_hash == self.chash
                    and _parts_complete(self.fs, self.root, old.video_id, (old.summary or {}).get("frames"))
                    and (not self.write_video or self.fs.exists(_video_path(self.root, old.video_id))))

    def plan(self, keys: Sequence[str], probes: dict[str, dict]) -> dict[str, list[Segment]]:
        """Skip what is done and unchanged, record what cannot be read, and cut the rest into segments."""
        plan: dict[str, list[Segment]] = {}
        seg_s = 0.0 if self.write_video else self.cfg.batch.segment_s
        with contextlib.suppress(Exception):  # parts staged inside telemetry/ by runs before 2026-11-27, killed
            for old_parts in self.fs.glob(_old_staging(self.root, "*")):
                _remove(self.fs, old_parts)
        for k in keys:
            p, old = probes[k], self.entries.get(k)
            self.why[k] = "" if old is None else ("failed" if old.status == "failed" else "changed")
            if "error" in p:
                self._fail(k, p["error"], "")
            elif self._unchanged(old, p):
                self.counts["skipped"] += 1
            else:
                _remove(self.fs, _staging(self.root, self.ids[k]))  # left by a run that was killed
                plan[k] = plan_segments(self.ids[k], k, p["duration_s"], p["fps"], seg_s, self.cfg.batch.warmup_s)
        _save_manifest(self.fs, self.root, self.entries, self.chash)
        return plan

    def _fail(self, key: str, error: str, content_hash: str) -> None:
        """Record a failed input; its rows from before (now stale) and any half-written ones go."""
        vid = self.ids[key]
        _remove(self.fs, _staging(self.root, vid))
        _remove(self.fs, _partition(self.root, vid))
        self.entries[key] = VideoEntry(url=key, video_id=vid, content_hash=content_hash, config_hash=self.chash,
                                       status="failed", error=error)
        self.counts["failed"] += 1
        self._redone(key)

    def run(self, client, plan: dict[str, list[Segment]], probes: dict[str, dict], progress: bool) -> None:
        """Run the segments on the cluster; finish each video as its last segment comes back."""
        from distributed import as_completed
        from tqdm import tqdm

        bar = tqdm(total=sum(max(1, probes[k]["frames"]) for k in plan), unit="frame",
                   disable=None if progress else True, dynamic_ncols=True, desc="fleet")
        self.unfinished = list(plan)  # until each is finished (an interrupt may come while submitting)
        futures = {client.submit(run_segment, s, self.cfg, self.out, self.write_video, pure=False): (k, s)
                   for k in plan for s in plan[k]}
        back: dict[str, list[dict]] = {k: [] for k in plan}
        finished: set[str] = set()
        try:
            for fut in as_completed(futures):
                k, seg = futures[fut]
                try:
                    r = fut.result()
                except Exception as e:  # the worker died (out of memory, a decoder crash): this video fails
                    r = {"video_id": seg.video_id, "index": seg.index, "error": f"the worker failed: {e}"}
                back[k].append(r)
                bar.update(r.get("frames", 0))
                if len(back[k]) == len(plan[k]):
                    self._finish(k, probes[k], sorted(back[k], key=lambda x: x["index"]))
                    finished.add(k)
                    bar.set_postfix(failed=self.counts["failed"])
        finally:
            self.unfinished = [k for k in plan if k not in finished]
            if self.unfinished:  # stopped: what has not started never will (a running task ends on its own)
                with contextlib.suppress(Exception):
                    client.cancel([f for f, (k, _) in futures.items() if k in self.unfinished])
            bar.close()

    def drop_unfinished(self) -> None:
        """Remove the parts of the videos a stopped run did not finish (call once no worker writes them)."""
        for k in self.unfinished:
            with contextlib.suppress(Exception):
                _remove(self.fs, _staging(self.root, self.ids[k]))
        self.tidy()

    def tidy(self) -> None:
        """Remove the staging folder once it is empty."""
        where = posixpath.join(self.root, ".staging")
        with contextlib.suppress(Exception):
            if self.fs.isdir(where) and not self.fs.ls(where, detail=False):
                self.fs.rmdir(where)

    def _finish(self, key: str, probe: dict, results: list[dict]) -> None:
        """Put a video's rows in place and record it, or record why it failed."""
        vid = self.ids[key]
        errors = [r["error"] for r in results if "error" in r]
        if not errors and all("empty" in r for r in results):
            errors = [results[0]["empty"]]
        try:
            if errors:
                raise LaneFinderError(errors[0])
            summary, events = _summarise([r for r in results if "empty" not in r], probe["fps"], self.cfg,
                                         tuple(probe["size"]))
            _remove(self.fs, _partition(self.root, vid))
            self.fs.makedirs(posixpath.join(self.root, "telemetry"), exist_ok=True)
            self.fs.mv(_staging(self.root, vid), _partition(self.root, vid), recursive=True)
        except Exception as e:
            self._fail(key, str(e) if isinstance(e, LaneFinderError) else f"{type(e).__name__}: {e}", probe["hash"])
        else:
            self.entries[key] = VideoEntry(url=key, video_id=vid, content_hash=probe["hash"], config_hash=self.chash,
                                           status="done", summary=summary, events=events)
            self.counts["done"] += 1
            self.counts["frames"] += summary["frames"]
            self._redone(key)
        _save_manifest(self.fs, self.root, self.entries, self.chash)


def _check_outdir(fs, root: str, out: str, keys: Iterable[str]) -> None:
    """Refuse an output folder that is a file, or that holds an input."""
    if fs.isfile(root):
        raise LaneFinderError(f"the output folder is a file: {out}")
    local = _local(out)
    if local is not None:
        base = os.path.abspath(local)
        for k in keys:
            if _local(k) is not None and os.path.abspath(k).startswith(base + os.sep):
                raise LaneFinderError(f"an input lies in the output folder (it could be written over): {k}")
    try:
        fs.makedirs(root, exist_ok=True)
    except OSError as e:
        raise LaneFinderError(f"cannot write in {out}: {getattr(e, 'strerror', None) or e}") from None


def _partition(root: str, video_id: str) -> str:
    return posixpath.join(root, "telemetry", f"video={video_id}")


def _staging(root: str, video_id: str) -> str:
    """Where a video's parts are written until all are done (outside ``telemetry/``: no query sees half a video)."""
    return posixpath.join(root, ".staging", f"video={video_id}")


def _old_staging(root: str, video_id: str) -> str:
    """Where runs before 2026-11-27 staged a video's parts (inside ``telemetry/``; a run removes any it finds)."""
    return posixpath.join(root, "telemetry", f".video={video_id}.new")


def _video_path(root: str, video_id: str) -> str:
    return posixpath.join(root, "videos", f"{video_id}.mp4")


def _parts_complete(fs, root: str, video_id: str, frames: int | None) -> bool:
    """Tell whether a video's partition holds readable parts of ``frames`` rows in all (their footers are read)."""
    try:
        parts = [p for p in fs.ls(_partition(root, video_id), detail=False) if p.endswith(".parquet")]
        rows = 0
        for p in parts:
            with fs.open(p, "rb") as f:
                rows += pq.read_metadata(f).num_rows
    except (OSError, pa.ArrowException):  # gone, or not Parquet (damaged)
        return False
    return bool(parts) and (frames is None or rows == frames)


def _remove(fs, path: str) -> None:
    """Remove a folder of parts, if it is there."""
    with contextlib.suppress(FileNotFoundError):
        if fs.exists(path):
            fs.rm(path, recursive=True)
