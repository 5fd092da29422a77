"""The video job: a dashcam video in, an annotated video and per-frame telemetry out.

Decoding, processing and encoding overlap in three threads (PyAV and OpenCV release the
GIL in their C code), joined by small bounded queues.  The job counts what it shows from the
results themselves (:class:`RunCounts`), so it needs nothing of the tracker's insides.
"""

from __future__ import annotations

import contextlib
import math
import numbers
import queue
import signal
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from .birdseye import BirdsEye
from .config import Config, config_arg
from .errors import LaneFinderError, NoFramesError
from .events import EVENT_KINDS, EVENT_SUFFIXES, detect_events, write_events
from .io import OutputSet, encode_image, signals_held
from .lane import LOST, REDETECT, LaneResult
from .limits import check_memory
from .pipeline import LaneFinder
from .render import annotate, contact_sheet, draw_debug
from .selfcal import SetupState
from .selfcal import wanted as selfcal_wanted
from .telemetry import TELEMETRY_SUFFIXES, BlownOut, TelemetryWriter, h_samples, make_row
from .tracking import at_fps
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
    output : str or None
        The annotated video (None when no video was written).
    telemetry : str or None
        The telemetry file.
    padded : tuple of int or None
        The size the video was encoded at when the frames' odd size was padded by a pixel.
    events : dict of str to int or None
        Lane events found, by kind, when they were asked for.
    events_path : str or None
        The events file.
    setup : SetupState or None
        The self-calibration's last word, when the run self-calibrated.
    contact_sheet : str or None
        The contact sheet, when one was written.
    sheet_frames : tuple of int
        The frames on the contact sheet, by their place in the run (0: the first frame
        processed, as in the annotated video); empty without a sheet.

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
    output: str | None
    telemetry: str | None
    padded: tuple[int, int] | None = None
    events: dict[str, int] | None = None
    events_path: str | None = None
    setup: SetupState | None = None
    contact_sheet: str | None = None
    sheet_frames: tuple[int, ...] = ()

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
            ", ".join(f"{k}: {v}" for k, v in (("video", self.output), ("telemetry", self.telemetry),
                                               ("contact sheet", self.contact_sheet)) if v),
        ]
        if self.events is not None:
            out.append("events: " + ", ".join(f"{k} {v}" for k, v in self.events.items()) + f" -> {self.events_path}")
        if self.setup is not None:
            out += _setup_lines(self.setup)
        if self.truncated:
            out.append("the input ended early (truncated file): the output holds the frames that could be read")
        if self.interrupted:
            out.append("interrupted: the outputs above hold the frames processed so far, under .partial names "
                       "(any earlier outputs of the same names are left as they were)")
        if self.padded:
            out.append(f"note: the frames have an odd size, which H.264 cannot hold: the video is padded by one "
                       f"pixel to {self.padded[0]}x{self.padded[1]} (the last row/column repeated)")
        return out


def _setup_lines(st: SetupState) -> list[str]:
    """Say what the self-calibration found and how sure it is."""
    if st.source == "default":
        return ["set-up: self-calibration found too few straight-road frames; the default set-up was used "
                "(run `lanefinder setup` for this camera)"]
    if st.source == "first-frame":
        return ["set-up: self-calibration found too few straight-road frames; the set-up the first frame gave "
                f"alone (or two early frames agreed on) was used: horizon row {st.horizon_px:.0f} px, "
                f"camera {st.height_m:.2f} m over the road "
                "(run `lanefinder setup` for this camera)"]
    if st.source == "lines":
        return ["set-up: self-calibration found too few straight-road frames; the starting set-up was used, "
                f"pitched to where the lane lines measured meet: horizon row {st.horizon_px:.0f} px, camera "
                f"{st.height_m:.2f} m over the road (run `lanefinder setup` for this camera)"]
    q = st.quality
    of = (f" ({q.frames_offered} offered, {q.frames_offered - st.frames} refused as outliers or curving)"
          if q is not None and q.frames_offered > st.frames else "")
    where = (f"horizon row {st.horizon_px:.0f} px, camera {st.height_m:.2f} m over the road, focal length "
             f"{st.focal_px:.0f} px")
    refused = (f"{st.refused} sure estimate(s) refused, the frame each came with showing the lane surer with the "
               "set-up in use (selfcal.estimate_check)")
    if st.refused and not st.updates:
        out = [f"set-up: the set-up the run started with was kept: {where}; {refused}; "
               f"the last estimate rests on {st.frames} straight-road frames{of}"]
    else:
        out = [f"set-up: self-calibrated from {st.frames} straight-road frames{of}, {st.updates} change(s) of the "
               f"set-up in use: {where}"]
        if st.refused:
            out.append(f"set-up: {refused}")
    if st.quality is not None:
        out.append("last estimate's " + st.quality.lines()[2])
    return out


def _stop_on_signals(stop: threading.Event) -> Callable[[], None]:
    """Make Ctrl-C (SIGINT) and SIGTERM set ``stop``; returns the undo.

    The job then ends at a frame boundary with the video and the telemetry in step; a second
    signal acts as usual.  Main thread only.
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


def _check_args(dst: Path | None, telemetry: str | Path | None, sheet: str | Path | None, start_s: float,
                end_s: float | None, events: str | Path | None, collecting: bool = False) -> None:
    """Refuse bad names, times that are not numbers and impossible spans before any work."""
    if dst is None and telemetry is None and events is None and not collecting:
        raise LaneFinderError("nothing to write: give an output video, telemetry, events, or several")
    if events is not None and Path(events).suffix.lower() not in EVENT_SUFFIXES:
        raise LaneFinderError(f"events file must end in .csv, .jsonl or .parquet: {events}")
    if dst is not None and dst.suffix.lower() != ".mp4":
        raise LaneFinderError(f"the output video must be an .mp4 file: {dst}")
    if telemetry is not None and Path(telemetry).suffix.lower() not in TELEMETRY_SUFFIXES:
        raise LaneFinderError(f"telemetry file must end in .csv, .jsonl or .parquet: {telemetry}")
    if sheet is not None:
        encode_image(sheet, np.zeros((2, 2, 3), np.uint8))  # refuses a suffix that is not an image format
    for name, value in (("start_s", start_s), ("end_s", end_s)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, numbers.Real)):
            raise LaneFinderError(f"{name} must be a number of seconds (got {value!r})")
    if not (start_s >= 0 and (end_s is None or end_s > start_s)) or math.isinf(start_s):  # also refuses NaN
        raise LaneFinderError(f"--start/--end must satisfy 0 <= start < end (got {start_s}, {end_s})")


class _Threads:
    """The decoder and encoder threads around the main (processing) loop."""

    def __init__(self, source: Iterator[Frame], sink: VideoSink | None, max_frames: int | None):
        self.in_q: queue.Queue = queue.Queue(maxsize=_QUEUE_FRAMES)
        self.out_q: queue.Queue = queue.Queue(maxsize=_QUEUE_FRAMES)
        self.stop = threading.Event()
        self.errors: list[BaseException] = []
        self._source, self._sink, self._max = source, sink, max_frames
        self._dec = threading.Thread(target=self._decode, name="lanefinder-decode", daemon=True)
        self._enc = threading.Thread(target=self._encode, name="lanefinder-encode", daemon=True)
        self._dec.start()
        if sink is not None:
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
        assert self._sink is not None
        try:
            while (img := self.out_q.get()) is not _END:
                self._sink.write(img)
        except BaseException as e:
            self.errors.append(e)
            self.stop.set()
            while self.out_q.get() is not _END:  # drain so the producer never blocks
                pass

    def frames(self) -> Iterator[Frame]:
        """Yield the decoded frames, until the end or a stop."""
        while (f := self.in_q.get()) is not _END and not self.stop.is_set():
            yield f

    def join(self) -> None:
        """Stop both threads: the encoder after the frames queued, the decoder at once."""
        self.stop.set()
        if self._enc.is_alive():
            self.out_q.put(_END)
            self._enc.join()
        while self._dec.is_alive():
            with contextlib.suppress(queue.Empty):
                self.in_q.get(timeout=0.05)


def _stop(sink: VideoSink | None, writer: TelemetryWriter | None) -> None:
    """Drop the video and the telemetry of a failed run (their set removes the files)."""
    if sink is not None:
        sink.discard()
    if writer is not None:
        writer.discard()


def _thumb(image: np.ndarray) -> np.ndarray:
    return cv2.resize(image, (_THUMB_WIDTH_PX, int(_THUMB_WIDTH_PX * image.shape[0] / image.shape[1])),
                      interpolation=cv2.INTER_AREA)


def _expected_frames(info: VideoInfo, start_s: float, end_s: float | None, max_frames: int | None) -> int:
    span_end = min(end_s, info.duration_s) if end_s is not None else info.duration_s
    expected = max(1, round((span_end - start_s) * float(info.fps)))
    return min(expected, max_frames) if max_frames else expected


class _Run:
    """The processing loop of one video: each frame found, drawn, written and counted."""

    def __init__(self, finder: LaneFinder, be: BirdsEye, expected: int, sheet_frames: int, debug: bool,
                 on_result: Callable[[int, LaneResult], None] | None, events_fps: float | None = None):
        self.finder, self.be, self.expected, self.debug, self.on_result = finder, be, expected, debug, on_result
        # What the lane events need of each frame (a few numbers: about 20 MB an hour of 25 fps video).
        self.events_fps = events_fps
        self.event_rows: list[dict] = []
        self.sheet_at = set(np.linspace(0, expected - 1, min(sheet_frames, expected)).round().astype(int).tolist()) \
            if sheet_frames else set()
        self.thumbs: list[tuple[float, np.ndarray]] = []
        self.sheet_frames: list[int] = []  # their places in the run
        self.counts = RunCounts()

    def frame(self, f: Frame, draw: bool) -> tuple[LaneResult, np.ndarray | None]:
        """Find one frame's lane; returns the result and, when ``draw`` asks for it, the annotated image."""
        result = self.finder.process(f.image)
        self.be = self.finder.last_birdseye  # the set-up this frame was seen with (self-calibration changes it)
        out = None
        on_sheet = self.counts.frames in self.sheet_at
        if draw or on_sheet:
            out = annotate(f.image, result, self.be, self.finder.config.render, inplace=True)
            if self.debug:
                draw_debug(out, result)
            if on_sheet:
                self.thumbs.append((f.time_s, _thumb(out)))
                self.sheet_frames.append(self.counts.frames)
        return result, (out if draw else None)

    def emit(self, f: Frame, result: LaneResult, out: np.ndarray | None, writer: TelemetryWriter | None,
             threads: _Threads, blown: BlownOut | None = None) -> None:
        """Write one frame's telemetry row and queue its image, as one step that no signal splits."""
        row = make_row(f.index, f.time_s, result, self.be, self.finder.config.far.confidence_decay_m, blown) \
            if writer else None
        with signals_held():
            if row is not None and writer is not None:
                writer.write(row)
            if out is not None:
                threads.out_q.put(out)
            self.counts.add(result)
            if self.events_fps is not None:
                self.event_rows.append({"frame": f.index, "time_s": f.time_s, "state": result.state,
                                        "offset_m": result.offset_m, "width_m": result.width_m,
                                        "misses": result.misses})
        if self.on_result:
            self.on_result(f.index, result)

    def events(self, path: str | Path, cfg: Config, outs: OutputSet) -> dict[str, int]:
        """Find the lane events of the frames done and write them into the output set; count them by kind."""
        assert self.events_fps is not None
        found = detect_events(self.event_rows, self.events_fps, cfg.events)
        write_events(path, found, outputs=outs)
        return {k: sum(e.kind == k for e in found) for k in EVENT_KINDS}

    def loop(self, threads: _Threads, writer: TelemetryWriter | None, encoding: bool, progress: bool,
             name: str) -> bool:
        """Process frames until the end, a failure or a stop signal; returns True if interrupted."""
        from tqdm import tqdm

        interrupt = threading.Event()
        undo_signal = _stop_on_signals(interrupt)
        bar = tqdm(total=self.expected, unit="frame", disable=None if progress else True, dynamic_ncols=True, desc=name)
        try:
            for f in threads.frames():
                if interrupt.is_set():
                    break
                # Where the frame is blown out (glare), looked at before anything is drawn on it.
                blown = BlownOut.of(f.image, h_samples(f.image.shape[0])) if writer else None
                result, out = self.frame(f, draw=encoding)
                self.emit(f, result, out, writer, threads, blown)
                bar.update(1)
        except KeyboardInterrupt:
            interrupt.set()
        finally:
            bar.close()
            undo_signal()
            threads.join()
        return interrupt.is_set()


def process_video(
    src: str | Path,
    dst: str | Path | None,
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
    events: str | Path | None = None,
) -> VideoSummary:
    """Find the lane in every frame of a video; write the annotated video and the telemetry.

    See the README's "Videos" section.  Ctrl-C or SIGTERM stop at a frame boundary: the video
    and the telemetry then hold the frames done so far.  If processing fails, the telemetry
    is not put in place.

    Parameters
    ----------
    src : str or Path
        The input video (anything PyAV decodes).
    dst : str or Path or None
        The annotated H.264 MP4 to write; None writes no video (then nothing is drawn or
        encoded, and ``telemetry`` or ``on_result`` must be given).
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
        Frames on the contact sheet (0 or more).
    progress : bool
        Show a progress bar.
    max_frames : int, optional
        Stop after this many frames.
    on_result : callable, optional
        ``on_result(frame_index, result)``, called for every frame, in order.
    events : str or Path, optional
        Lane events file (``.csv``, ``.jsonl`` or ``.parquet``; see :mod:`lanefinder.events`),
        written with the other outputs.

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
    cfg = config_arg(config)
    src, dst = Path(src), (Path(dst) if dst is not None else None)
    _check_args(dst, telemetry, contact_sheet_path, start_s, end_s, events, collecting=on_result is not None)
    if not (isinstance(sheet_frames, int) and sheet_frames >= 0):
        raise LaneFinderError(f"a contact sheet needs a whole number of frames, 0 or more (got {sheet_frames!r})")
    if max_frames is not None and (isinstance(max_frames, bool) or not isinstance(max_frames, numbers.Integral)
                                   or max_frames < 1):
        raise LaneFinderError(f"max_frames must be a whole number, 1 or more, or None for all (got {max_frames!r})")
    info = VideoInfo.from_path(src)
    if start_s >= info.duration_s > 0:
        raise LaneFinderError(f"--start {start_s} s is past the end of the video ({info.duration_s:.2f} s)")
    # Tracking's frame counts and gains, set for tracking.reference_fps, are scaled to this video's rate.
    finder = LaneFinder(cfg.model_copy(update={"tracking": at_fps(cfg.tracking, float(info.fps))}),
                        keep_debug=debug, self_calibrate=selfcal_wanted(cfg))
    be = finder.birdseye(info.size)  # fails early on a size the camera cannot serve
    check_memory(cfg, info.size, frames_held=4 * _QUEUE_FRAMES)
    expected = _expected_frames(info, start_s, end_s, max_frames)
    decode_stats = DecodeStats()
    run = _Run(finder, be, expected, sheet_frames if contact_sheet_path else 0, debug, on_result,
               float(info.fps) if events is not None else None)
    # Every output is written beside its destination and put in place together, only at the end.
    with OutputSet(inputs=[src], partial=True) as outs:
        sink = VideoSink(dst, info, cfg.video.preset, cfg.video.crf, cfg.video.threads, outputs=outs) \
            if dst is not None else None
        writer = TelemetryWriter(telemetry, outputs=outs) if telemetry is not None else None
        sheet_tmp = outs.add(contact_sheet_path) if contact_sheet_path else None
        if events is not None:
            outs.check(events)  # refuses an input or another output's name before any work
        threads = _Threads(frames(src, start_s, end_s, cfg.video.threads, decode_stats), sink, max_frames)
        t0 = time.perf_counter()
        try:
            interrupted = run.loop(threads, writer, sink is not None, progress, src.name)
        finally:
            threads.join()
        done = run.counts.frames
        if threads.errors and not interrupted:
            _stop(sink, writer)
            e = threads.errors[0]
            if isinstance(e, LaneFinderError):
                raise e
            raise LaneFinderError(f"video processing failed after {done} frames: {e}") from e
        if done == 0:
            _stop(sink, writer)
            if interrupted:
                raise KeyboardInterrupt  # before the first frame: nothing to keep
            span = f" from {start_s} s" if start_s else ""
            span += f" to {end_s} s" if end_s is not None else (" to the end" if span else "")
            raise NoFramesError(f"no frames could be decoded from {src}{span}")
        try:
            if writer:
                writer.close()
            if sink is not None:
                sink.close()
        except BaseException:
            _stop(sink, writer)
            raise
        found = run.events(events, cfg, outs) if events is not None else None
        if sheet_tmp is not None and run.thumbs:
            buf = encode_image(contact_sheet_path, contact_sheet(run.thumbs))
            try:
                sheet_tmp.write_bytes(buf.tobytes())
            except OSError as e:
                raise LaneFinderError(f"cannot write {contact_sheet_path}: {e.strerror or e}") from None
        elapsed = time.perf_counter() - t0
        # Stopped early: what was done is kept, under partial names (whatever was at the
        # destinations, a complete earlier run say, stays as it was).
        placed = outs.commit(partial=True) if interrupted else {}
    if placed:
        dst, telemetry, events = (placed.get(Path(p), Path(p)) if p is not None else None
                                  for p in (dst, telemetry, events))
        contact_sheet_path = placed.get(Path(contact_sheet_path)) if contact_sheet_path else None
    # A file cut short may just end (its index said more): fewer frames than it announced.
    ended_early = decode_stats.truncated or (not interrupted and done < expected - _EARLY_END_FRAMES)
    c = run.counts
    return VideoSummary(
        frames=done, seconds=elapsed, fps=done / elapsed if elapsed else 0.0, tracked=c.with_lane,
        both_found=c.both_found, redetections=c.redetections, lost=c.lost, damaged=decode_stats.damaged,
        truncated=ended_early, interrupted=interrupted, output=str(dst) if dst is not None else None,
        telemetry=str(telemetry) if telemetry else None, padded=sink.size if sink is not None and sink.padded else None,
        events=found, events_path=str(events) if events is not None else None,
        setup=finder.selfcal.state if finder.selfcal is not None else None,
        contact_sheet=str(contact_sheet_path) if contact_sheet_path else None,
        sheet_frames=tuple(run.sheet_frames) if contact_sheet_path and run.thumbs else (),
    )
