"""The video job: a dashcam video in, an annotated video and per-frame telemetry out.

Decoding, processing and encoding overlap in three threads (PyAV and OpenCV release the
GIL in their C code), joined by small bounded queues.  The job counts what it shows from the
results themselves (:class:`RunCounts`), so it needs nothing of the tracker's insides.
"""

from __future__ import annotations

import contextlib
import queue
import signal
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from .config import Config
from .errors import LaneFinderError
from .io import check_not_input, write_image
from .lane import LOST, REDETECT, LaneResult
from .pipeline import LaneFinder
from .render import annotate, contact_sheet, draw_debug
from .telemetry import TelemetryWriter, make_row
from .video import DecodeStats, Frame, VideoInfo, VideoSink, frames

__all__ = ["RunCounts", "VideoSummary", "process_video"]

_END = object()
# Frames waiting between the threads: enough to smooth out the stages' jitter, little memory.
_QUEUE_FRAMES = 8
# A run that ends more frames than this short of what the container announced ended early.
_EARLY_END_FRAMES = 2
# Width of a contact-sheet thumbnail, pixels.
_THUMB_WIDTH_PX = 320


@dataclass
class RunCounts:
    """Frame counts of a run, from its results.

    Attributes
    ----------
    frames : int
        Frames processed.
    with_lane : int
        Frames that show a lane (state not ``lost``).
    both_found : int
        Frames with both lines measured and accepted.
    redetections : int
        Frames searched blind that show a lane (state ``re-detect``).
    lost : int
        Frames without a lane (state ``lost``).

    Examples
    --------
    >>> import numpy as np
    >>> from lanefinder import LaneFinder
    >>> counts = RunCounts()
    >>> counts.add(LaneFinder().process(np.zeros((720, 1280, 3), np.uint8)))
    >>> counts.frames, counts.lost
    (1, 1)
    """

    frames: int = 0
    with_lane: int = 0
    both_found: int = 0
    redetections: int = 0
    lost: int = 0

    def add(self, result: LaneResult) -> None:
        """Count one frame's result.

        Parameters
        ----------
        result : LaneResult
            The frame's result.
        """
        self.frames += 1
        self.lost += result.state == LOST
        self.with_lane += result.state != LOST
        self.redetections += result.state == REDETECT
        self.both_found += result.left.found and result.right.found


@dataclass(frozen=True)
class VideoSummary:
    """What a video run did.

    Attributes
    ----------
    frames : int
        Frames processed.
    seconds : float
        Wall time of the run, seconds.
    fps : float
        Frames per second end to end.
    tracked : int
        Frames that show a lane.
    both_found : int
        Frames with both lines measured.
    redetections : int
        Frames searched blind that show a lane.
    lost : int
        Frames marked lost.
    damaged : int
        Damaged packets skipped.
    truncated : bool
        The input ended early.
    interrupted : bool
        The run was stopped by Ctrl-C or SIGTERM.
    output : str
        The annotated video.
    telemetry : str or None
        The telemetry file.

    Examples
    --------
    >>> s = VideoSummary(frames=10, seconds=0.5, fps=20.0, tracked=9, both_found=8, redetections=1, lost=1,
    ...                  damaged=0, truncated=False, interrupted=False, output="out.mp4", telemetry=None)
    >>> s.lines()[1]
    'frames with a lane: 9 (90.0%), both lines seen: 8'
    """

    frames: int
    seconds: float
    fps: float
    tracked: int
    both_found: int
    redetections: int
    lost: int
    damaged: int
    truncated: bool
    interrupted: bool
    output: str
    telemetry: str | None

    def lines(self) -> list[str]:
        """Return the end-of-run summary as printed lines.

        Returns
        -------
        list of str
            Frames and fps, lane shares, re-detections and losses, outputs, and notes.
        """
        pct = 100 * self.tracked / self.frames if self.frames else 0.0
        out = [
            f"frames: {self.frames} in {self.seconds:.1f} s ({self.fps:.1f} fps)",
            f"frames with a lane: {self.tracked} ({pct:.1f}%), both lines seen: {self.both_found}",
            f"re-detections: {self.redetections}, frames marked lost: {self.lost}, damaged packets: {self.damaged}",
            f"video: {self.output}" + (f", telemetry: {self.telemetry}" if self.telemetry else ""),
        ]
        if self.truncated:
            out.append("the input ended early (truncated file): the output holds the frames that could be read")
        if self.interrupted:
            out.append("interrupted: the output holds the frames processed so far")
        return out


def _stop_on_signals(stop: threading.Event) -> Callable[[], None]:
    """Ctrl-C (SIGINT) or SIGTERM set ``stop``, so the job ends at a frame boundary with the video and the
    telemetry in step; a second signal acts as usual.  Main thread only; returns the undo.
    """
    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    old = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}

    def restore() -> None:
        for sig, handler in old.items():
            signal.signal(sig, handler)

    def handler(signum, frame) -> None:
        stop.set()
        restore()

    for sig in old:
        signal.signal(sig, handler)
    return restore


def _check_args(src: Path, dst: Path, telemetry: str | Path | None, sheet: str | Path | None, start_s: float,
                end_s: float | None) -> None:
    """Refuse outputs over inputs and impossible spans before any work."""
    check_not_input(dst, [src])
    for extra in (telemetry, sheet):
        if extra is not None:
            check_not_input(extra, [src, dst])
    if not (start_s >= 0 and (end_s is None or end_s > start_s)):  # also refuses NaN
        raise LaneFinderError(f"--start/--end must satisfy 0 <= start < end (got {start_s}, {end_s})")


class _Threads:
    """The decoder and encoder threads around the main (processing) loop."""

    def __init__(self, source: Iterator[Frame], sink: VideoSink, max_frames: int | None):
        self.in_q: queue.Queue = queue.Queue(maxsize=_QUEUE_FRAMES)
        self.out_q: queue.Queue = queue.Queue(maxsize=_QUEUE_FRAMES)
        self.stop = threading.Event()
        self.errors: list[BaseException] = []
        self._source, self._sink, self._max = source, sink, max_frames
        self._dec = threading.Thread(target=self._decode, name="lanefinder-decode", daemon=True)
        self._enc = threading.Thread(target=self._encode, name="lanefinder-encode", daemon=True)
        self._dec.start()
        self._enc.start()

    def _decode(self) -> None:
        try:
            for i, f in enumerate(self._source):
                if self.stop.is_set() or (self._max and i >= self._max):
                    break
                self.in_q.put(f)
        except BaseException as e:  # reported by the main thread
            self.errors.append(e)
        finally:
            self.in_q.put(_END)

    def _encode(self) -> None:
        try:
            while (img := self.out_q.get()) is not _END:
                self._sink.write(img)
        except BaseException as e:
            self.errors.append(e)
            self.stop.set()
            while self.out_q.get() is not _END:  # drain so the producer never blocks
                pass

    def frames(self) -> Iterator[Frame]:
        """The decoded frames, until the end or a stop."""
        while (f := self.in_q.get()) is not _END and not self.stop.is_set():
            yield f

    def join(self) -> None:
        """Stop both threads: the encoder after the frames queued, the decoder at once."""
        self.stop.set()
        self.out_q.put(_END)
        self._enc.join()
        while self._dec.is_alive():
            with contextlib.suppress(queue.Empty):
                self.in_q.get(timeout=0.05)


def _thumb(image: np.ndarray) -> np.ndarray:
    return cv2.resize(image, (_THUMB_WIDTH_PX, int(_THUMB_WIDTH_PX * image.shape[0] / image.shape[1])),
                      interpolation=cv2.INTER_AREA)


def _expected_frames(info: VideoInfo, start_s: float, end_s: float | None, max_frames: int | None) -> int:
    span_end = min(end_s, info.duration_s) if end_s is not None else info.duration_s
    expected = max(1, round((span_end - start_s) * float(info.fps)))
    return min(expected, max_frames) if max_frames else expected


def process_video(
    src: str | Path,
    dst: str | Path,
    config: Config | None = None,
    start_s: float = 0.0,
    end_s: float | None = None,
    telemetry: str | Path | None = None,
    debug: bool = False,
    contact_sheet_path: str | Path | None = None,
    sheet_frames: int = 20,
    progress: bool = True,
    max_frames: int | None = None,
    on_result: Callable[[int, LaneResult], None] | None = None,
) -> VideoSummary:
    """Find the lane in every frame of a video; write the annotated video and the telemetry.

    See the README's "Videos" section.  Ctrl-C or SIGTERM stop at a frame boundary: the video
    and the telemetry then hold the frames done so far.  If processing fails, the telemetry
    is not put in place.

    Parameters
    ----------
    src : str or Path
        The input video (anything PyAV decodes).
    dst : str or Path
        The annotated H.264 MP4 to write.
    config : Config, optional
        The configuration (defaults when omitted).
    start_s, end_s : float
        The span to process, seconds from the start (``end_s`` None: to the end).
    telemetry : str or Path, optional
        Per-frame telemetry file, ``.csv`` or ``.jsonl``.
    debug : bool
        Draw the bird's-eye search picture-in-picture on every frame.
    contact_sheet_path : str or Path, optional
        A PNG grid of ``sheet_frames`` frames spread over the run.
    sheet_frames : int
        Frames on the contact sheet.
    progress : bool
        Show a progress bar.
    max_frames : int, optional
        Stop after this many frames.
    on_result : callable, optional
        ``on_result(frame_index, result)``, called for every frame, in order.

    Returns
    -------
    VideoSummary
        Frames, speed, lane shares and the outputs.

    Raises
    ------
    LaneFinderError
        For an unreadable input, an output that names an input, a bad span, or a failure while
        processing.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     s = process_video("data/clips/project_37-47s.mp4", f"{d}/o.mp4", max_frames=5, progress=False)
    >>> s.frames, s.tracked
    (5, 5)
    """
    from tqdm import tqdm

    cfg = config or Config()
    src, dst = Path(src), Path(dst)
    _check_args(src, dst, telemetry, contact_sheet_path, start_s, end_s)
    info = VideoInfo.from_path(src)
    if start_s >= info.duration_s > 0:
        raise LaneFinderError(f"--start {start_s} s is past the end of the video ({info.duration_s:.2f} s)")
    finder = LaneFinder(cfg, keep_debug=debug)
    be = finder.birdseye(info.size)  # fails early on a size the camera cannot serve
    expected = _expected_frames(info, start_s, end_s, max_frames)
    sheet_at = set(np.linspace(0, expected - 1, min(sheet_frames, expected)).round().astype(int).tolist())

    decode_stats = DecodeStats()
    sink = VideoSink(dst, info, cfg.video.preset, cfg.video.crf, cfg.video.threads)
    writer = TelemetryWriter(telemetry) if telemetry is not None else None
    threads = _Threads(frames(src, start_s, end_s, cfg.video.threads, decode_stats), sink, max_frames)
    interrupt = threading.Event()
    undo_signal = _stop_on_signals(interrupt)
    thumbs: list[tuple[float, np.ndarray]] = []
    counts = RunCounts()
    t0 = time.perf_counter()
    bar = tqdm(total=expected, unit="frame", disable=not progress, dynamic_ncols=True, desc=src.name)
    try:
        for f in threads.frames():
            if interrupt.is_set():
                break
            result = finder.process(f.image)
            out = annotate(f.image, result, be, cfg.render, inplace=True)
            if debug:
                draw_debug(out, result)
            threads.out_q.put(out)
            if writer:
                writer.write(make_row(f.index, f.time_s, result, be))
            if on_result:
                on_result(f.index, result)
            if counts.frames in sheet_at:
                thumbs.append((f.time_s, _thumb(out)))
            counts.add(result)
            bar.update(1)
    except KeyboardInterrupt:
        interrupt.set()
    finally:
        bar.close()
        undo_signal()
        threads.join()
    interrupted = interrupt.is_set()
    failed = bool(threads.errors) and not interrupted
    if writer:
        (writer.discard if failed or not counts.frames else writer.close)()
    (sink.close if counts.frames and not failed else sink.discard)()
    elapsed = time.perf_counter() - t0
    # A file cut short may just end (its index said more): fewer frames than it announced.
    ended_early = decode_stats.truncated or (not interrupted and counts.frames < expected - _EARLY_END_FRAMES)
    if failed:
        e = threads.errors[0]
        if isinstance(e, LaneFinderError):
            raise e
        raise LaneFinderError(f"video processing failed after {counts.frames} frames: {e}") from e
    if counts.frames == 0:
        raise LaneFinderError(f"no frames could be decoded from {src}" +
                              (f" between {start_s} s and {end_s} s" if start_s or end_s else ""))
    if contact_sheet_path and thumbs:
        write_image(contact_sheet_path, contact_sheet(thumbs))
    return VideoSummary(
        frames=counts.frames, seconds=elapsed, fps=counts.frames / elapsed if elapsed else 0.0,
        tracked=counts.with_lane, both_found=counts.both_found, redetections=counts.redetections, lost=counts.lost,
        damaged=decode_stats.damaged, truncated=ended_early, interrupted=interrupted,
        output=str(dst), telemetry=str(telemetry) if telemetry else None,
    )
