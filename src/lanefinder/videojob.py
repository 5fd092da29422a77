"""The main job: a dashcam video in, an annotated video and per-frame telemetry out.

Decoding, processing and encoding overlap in three threads (PyAV and OpenCV release the
GIL in their C code), joined by small bounded queues.
"""

from __future__ import annotations

import contextlib
import queue
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from .config import Config
from .errors import LaneFinderError
from .io import check_not_input, write_image
from .pipeline import LaneFinder, LaneResult
from .render import annotate, search_view
from .telemetry import TelemetryWriter, make_row
from .video import DecodeStats, VideoInfo, VideoSink, frames

_END = object()


@dataclass(frozen=True)
class VideoSummary:
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


def debug_overlay(out: np.ndarray, result: LaneResult) -> np.ndarray:
    """Picture-in-picture: bird's-eye binary with windows/band and fits, plus confidences (in place)."""
    if result.binary is None:
        return out
    _h, w = out.shape[:2]
    view = search_view(result.binary, result.search, result, show_histogram=True)
    pw = w // 3
    ph = round(view.shape[0] * pw / view.shape[1])
    pip = cv2.resize(view, (pw, ph), interpolation=cv2.INTER_AREA)
    text = [f"{result.state}  misses {result.misses}",
            f"L conf {result.left_conf:.2f} px {result.left_pixels}",
            f"R conf {result.right_conf:.2f} px {result.right_pixels}"]
    if result.checks:
        text.append("failed: " + ",".join(result.checks))
    for i, s in enumerate(text):
        cv2.putText(pip, s, (8, 20 + 20 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 255, 255), 1, cv2.LINE_AA)
    out[10:10 + ph, w - pw - 10:w - 10] = pip
    return out


def contact_sheet(thumbs: list[tuple[float, np.ndarray]], cols: int = 5) -> np.ndarray:
    """A grid of labelled thumbnails (time in seconds on each)."""
    if not thumbs:
        raise LaneFinderError("no frames for a contact sheet")
    th, tw = thumbs[0][1].shape[:2]
    rows = (len(thumbs) + cols - 1) // cols
    sheet = np.full((rows * (th + 4) + 4, cols * (tw + 4) + 4, 3), 32, np.uint8)
    for i, (t, img) in enumerate(thumbs):
        r, c = divmod(i, cols)
        y, x = 4 + r * (th + 4), 4 + c * (tw + 4)
        tile = img.copy()
        label = f"{int(t // 60)}:{t % 60:05.2f}"
        cv2.rectangle(tile, (0, th - 24), (len(label) * 11 + 10, th), (0, 0, 0), -1)
        cv2.putText(tile, label, (5, th - 7), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1, cv2.LINE_AA)
        sheet[y:y + th, x:x + tw] = tile
    return sheet


def _stop_on_signals(stop: threading.Event) -> Callable[[], None]:
    """Ctrl-C (SIGINT) or SIGTERM set ``stop``, so the job ends at a frame boundary with the video and the
    telemetry in step; a second signal acts as usual.  Main thread only; returns the undo."""
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
    """Annotate a video; returns the run's summary.  See the README's "Videos" section.

    ``on_result(frame_index, result)`` is called for every frame, in order.
    """
    from tqdm import tqdm

    cfg = config or Config()
    src, dst = Path(src), Path(dst)
    check_not_input(dst, [src])
    if telemetry is not None:
        check_not_input(telemetry, [src, dst])
    if start_s < 0 or (end_s is not None and end_s <= start_s):
        raise LaneFinderError(f"--start/--end must satisfy 0 <= start < end (got {start_s}, {end_s})")
    info = VideoInfo.from_path(src)
    if start_s >= info.duration_s > 0:
        raise LaneFinderError(f"--start {start_s} s is past the end of the video ({info.duration_s:.2f} s)")
    finder = LaneFinder(cfg, keep_debug=debug)
    be = finder.birdseye(info.size)  # fails early on a size the camera cannot serve
    span_end = min(end_s, info.duration_s) if end_s is not None else info.duration_s
    expected = max(1, round((span_end - start_s) * float(info.fps)))
    if max_frames:
        expected = min(expected, max_frames)
    sheet_at = set(np.linspace(0, expected - 1, min(sheet_frames, expected)).round().astype(int).tolist())

    stats = DecodeStats()
    in_q: queue.Queue = queue.Queue(maxsize=8)
    out_q: queue.Queue = queue.Queue(maxsize=8)
    stop = threading.Event()
    errors: list[BaseException] = []

    def decode() -> None:
        try:
            for i, f in enumerate(frames(src, start_s, end_s, cfg.video.threads, stats)):
                if stop.is_set() or (max_frames and i >= max_frames):
                    break
                in_q.put(f)
        except BaseException as e:  # reported by the main thread
            errors.append(e)
        finally:
            in_q.put(_END)

    sink = VideoSink(dst, info, cfg.video.preset, cfg.video.crf, cfg.video.threads)
    writer = TelemetryWriter(telemetry) if telemetry is not None else None

    def encode() -> None:
        try:
            while (img := out_q.get()) is not _END:
                sink.write(img)
        except BaseException as e:
            errors.append(e)
            stop.set()
            while out_q.get() is not _END:  # drain so the producer never blocks
                pass

    dec = threading.Thread(target=decode, name="lanefinder-decode", daemon=True)
    enc = threading.Thread(target=encode, name="lanefinder-encode", daemon=True)
    dec.start()
    enc.start()
    interrupt = threading.Event()
    undo_signal = _stop_on_signals(interrupt)
    thumbs: list[tuple[float, np.ndarray]] = []
    n = both = 0
    interrupted = False
    t0 = time.perf_counter()
    bar = tqdm(total=expected, unit="frame", disable=not progress, dynamic_ncols=True, desc=src.name)
    try:
        while (f := in_q.get()) is not _END:
            if interrupt.is_set():
                interrupted = True
                break
            if stop.is_set():
                break
            result = finder.process(f.image)
            out = annotate(f.image, result, be, cfg.render, inplace=True)
            if debug:
                debug_overlay(out, result)
            out_q.put(out)
            if writer:
                writer.write(make_row(f.index, f.time_s, result, be))
            if on_result:
                on_result(f.index, result)
            if n in sheet_at:
                thumbs.append((f.time_s, cv2.resize(out, (320, int(320 * out.shape[0] / out.shape[1])),
                                                    interpolation=cv2.INTER_AREA)))
            n += 1
            both += result.left_found and result.right_found
            bar.update(1)
        interrupted = interrupted or interrupt.is_set()
    except KeyboardInterrupt:
        interrupted = True
    finally:
        stop.set()
        bar.close()
        undo_signal()
        out_q.put(_END)
        enc.join()
        # Unblock and end the decoder.
        while dec.is_alive():
            with contextlib.suppress(queue.Empty):
                in_q.get(timeout=0.05)
        if writer:
            writer.close()
        if n:
            sink.close()
        else:
            sink.discard()
    elapsed = time.perf_counter() - t0
    if errors and not interrupted:
        e = errors[0]
        if isinstance(e, LaneFinderError):
            raise e
        raise LaneFinderError(f"video processing failed after {n} frames: {e}") from e
    if n == 0:
        raise LaneFinderError(f"no frames could be decoded from {src}" +
                              (f" between {start_s} s and {end_s} s" if start_s or end_s else ""))
    if contact_sheet_path and thumbs:
        write_image(contact_sheet_path, contact_sheet(thumbs))
    st = finder.tracker.stats if finder.tracker else {}
    return VideoSummary(
        frames=n, seconds=elapsed, fps=n / elapsed if elapsed else 0.0,
        tracked=st.get("tracked", 0) + max(0, n - st.get("tracked", 0) - st.get("lost", 0)),
        both_found=both, redetections=st.get("redetect", 0), lost=st.get("lost", 0),
        damaged=stats.damaged, truncated=stats.truncated, interrupted=interrupted,
        output=str(dst), telemetry=str(telemetry) if telemetry else None,
    )
