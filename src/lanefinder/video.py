"""Video I/O with PyAV: VideoInfo, a frame generator, and an H.264 sink that is never half-written.

Modelled on supervision's VideoInfo / get_video_frames_generator / VideoSink.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import av
import numpy as np

from .errors import LaneFinderError
from .io import publish


@dataclass(frozen=True)
class VideoInfo:
    """Size (pixels), frame rate (frames/s, exact fraction), frame count (may be an estimate), duration (s)."""

    width: int
    height: int
    fps: Fraction
    total_frames: int
    duration_s: float
    codec: str

    @property
    def size(self) -> tuple[int, int]:
        return self.width, self.height

    @classmethod
    def from_path(cls, path: str | Path) -> VideoInfo:
        with _open(path) as c:
            s = c.streams.video[0]
            fps = Fraction(s.average_rate or s.guessed_rate or 25)
            if s.duration is not None and s.time_base is not None:
                duration = float(s.duration * s.time_base)
            elif c.duration is not None:
                duration = c.duration / av.time_base
            else:
                duration = 0.0
            frames = int(s.frames) or round(duration * fps)
            return cls(s.codec_context.width, s.codec_context.height, fps, frames, duration, s.codec_context.name)


def _open(path: str | Path):
    p = Path(path)
    if not p.is_file():
        raise LaneFinderError(f"video not found: {p}")
    try:
        c = av.open(str(p))
    except (av.error.FFmpegError, OSError, UnicodeDecodeError) as e:
        raise LaneFinderError(f"cannot open video {p}: {e}") from None
    if not c.streams.video:
        c.close()
        raise LaneFinderError(f"{p} has no video stream")
    return c


@dataclass(frozen=True)
class Frame:
    """A decoded frame: index from the start of the video, time in seconds, BGR uint8 pixels."""

    index: int
    time_s: float
    image: np.ndarray


@dataclass
class DecodeStats:
    damaged: int = 0
    decoded: int = 0
    truncated: bool = False


def frames(path: str | Path, start_s: float = 0.0, end_s: float | None = None, threads: int = 0,
           stats: DecodeStats | None = None) -> Iterator[Frame]:
    """Decode ``path`` from ``start_s`` to ``end_s`` (seconds) as BGR frames.

    Damaged packets are skipped and counted in ``stats.damaged``; a file cut short ends the
    generator early with ``stats.truncated`` set, after the frames that could be read.
    """
    stats = stats if stats is not None else DecodeStats()
    with _open(path) as c:
        s = c.streams.video[0]
        s.thread_type = "AUTO"
        s.codec_context.thread_count = threads
        fps = Fraction(s.average_rate or s.guessed_rate or 25)
        tb = s.time_base
        if start_s > 0:
            c.seek(int(start_s / tb), stream=s, backward=True, any_frame=False)
        first_pts = s.start_time or 0
        packets = c.demux(s)
        while True:
            try:
                packet = next(packets)
            except StopIteration:
                break
            except av.error.FFmpegError:
                stats.truncated = True
                break
            try:
                decoded = packet.decode()
            except av.error.FFmpegError:
                stats.damaged += 1
                continue
            for f in decoded:
                t = float((f.pts - first_pts) * tb) if f.pts is not None else stats.decoded / float(fps)
                if t < start_s - 0.5 / float(fps):
                    continue
                if end_s is not None and t >= end_s - 0.5 / float(fps):
                    return
                stats.decoded += 1
                yield Frame(round(t * fps), t, f.to_ndarray(format="bgr24"))


class VideoSink:
    """H.264 MP4 writer.  Frames go to a hidden temporary file beside ``path``; :meth:`close`
    finishes the file and moves it into place, so ``path`` is never a half-written video.

    Use as a context manager: on an exception or Ctrl-C the frames written so far are still
    finished into a playable ``path`` (``partial`` is then True).
    """

    def __init__(self, path: str | Path, info: VideoInfo, preset: str = "veryfast", crf: int = 23,
                 threads: int = 0):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{self.path.stem}.", suffix=".partial.mp4", dir=self.path.parent)
        os.close(fd)
        self.tmp = Path(tmp)
        self.frames_written = 0
        self.partial = False
        self._container = av.open(str(self.tmp), "w", format="mp4")
        rate = info.fps.limit_denominator(100000)
        self._stream = self._container.add_stream("libx264", rate=rate)
        self._stream.width, self._stream.height = info.width, info.height
        self._stream.pix_fmt = "yuv420p"
        self._stream.time_base = 1 / rate
        self._stream.codec_context.thread_count = threads
        self._stream.options = {"crf": str(crf), "preset": preset}
        self._closed = False

    def write(self, image: np.ndarray) -> None:
        frame = av.VideoFrame.from_ndarray(image, format="bgr24")
        frame.pts = self.frames_written
        self._container.mux(self._stream.encode(frame))
        self.frames_written += 1

    def close(self) -> None:
        """Flush the encoder, finish the MP4 and move it to ``path``."""
        if self._closed:
            return
        self._closed = True
        try:
            self._container.mux(self._stream.encode(None))
            self._container.close()
            if self.frames_written:
                publish(self.tmp, self.path)
        finally:
            self.tmp.unlink(missing_ok=True)

    def discard(self) -> None:
        """Drop the output (nothing to keep)."""
        self._closed = True
        with contextlib.suppress(av.error.FFmpegError):
            self._container.close()
        self.tmp.unlink(missing_ok=True)

    def __enter__(self) -> VideoSink:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            self.partial = True
        self.close()
