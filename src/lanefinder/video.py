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

__all__ = ["DecodeStats", "Frame", "VideoInfo", "VideoSink", "frames"]


@dataclass(frozen=True)
class VideoInfo:
    """What a video is: size, frame rate, length and codec.

    Attributes
    ----------
    width, height : int
        Frame size, pixels.
    fps : Fraction
        Frame rate, frames per second, exact.
    total_frames : int
        Frame count (from the container, or estimated from duration and rate).
    duration_s : float
        Duration, seconds (0.0 when the container does not say).
    codec : str
        The video codec's name, e.g. ``h264``.

    Examples
    --------
    >>> info = VideoInfo.from_path("data/clips/project_37-47s.mp4")
    >>> info.size, info.fps, info.codec
    ((1280, 720), Fraction(25, 1), 'h264')
    """

    width: int
    height: int
    fps: Fraction
    total_frames: int
    duration_s: float
    codec: str

    @property
    def size(self) -> tuple[int, int]:
        """(width, height), pixels."""
        return self.width, self.height

    @classmethod
    def from_path(cls, path: str | Path) -> VideoInfo:
        """Read the facts of the first video stream of a file.

        Parameters
        ----------
        path : str or Path
            Any container and codec FFmpeg reads.

        Returns
        -------
        VideoInfo
            Its size, rate, frame count, duration and codec.

        Raises
        ------
        LaneFinderError
            When the file is missing, unreadable, or has no video stream.
        """
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
    """A decoded frame.

    Attributes
    ----------
    index : int
        Frame number from the start of the video (time times rate, rounded).
    time_s : float
        Presentation time from the start of the video, seconds.
    image : (H, W, 3) uint8 ndarray
        The pixels, BGR.

    Examples
    --------
    >>> f = Frame(index=0, time_s=0.0, image=np.zeros((720, 1280, 3), np.uint8))
    >>> f.image.shape
    (720, 1280, 3)
    """

    index: int
    time_s: float
    image: np.ndarray


@dataclass
class DecodeStats:
    """What went wrong while decoding, filled in by :func:`frames` as it goes.

    Attributes
    ----------
    damaged : int
        Packets that did not decode and were skipped.
    decoded : int
        Frames decoded and yielded.
    truncated : bool
        True when the file ended early (cut short or unreadable past some point).

    Examples
    --------
    >>> stats = DecodeStats()
    >>> n = sum(1 for _ in frames("data/clips/project_37-47s.mp4", end_s=1.0, stats=stats))
    >>> n, stats.decoded, stats.damaged, stats.truncated
    (25, 25, 0, False)
    """

    damaged: int = 0
    decoded: int = 0
    truncated: bool = False


def frames(path: str | Path, start_s: float = 0.0, end_s: float | None = None, threads: int = 0,
           stats: DecodeStats | None = None) -> Iterator[Frame]:
    """Decode a video as BGR frames, from ``start_s`` to ``end_s``.

    Damaged packets are skipped and counted in ``stats.damaged``; a file cut short ends the
    generator early with ``stats.truncated`` set, after the frames that could be read.

    Parameters
    ----------
    path : str or Path
        The video.
    start_s : float, optional
        Where to start, seconds (seeks to the keyframe before, then skips to it).
    end_s : float, optional
        Where to stop, seconds (exclusive); default the end.
    threads : int, optional
        Decoder threads; 0 lets FFmpeg choose.
    stats : DecodeStats, optional
        Filled in while decoding.

    Yields
    ------
    Frame
        In presentation order.  Memory stays flat: one frame at a time.

    Raises
    ------
    LaneFinderError
        When the file is missing, unreadable, or has no video stream.

    Examples
    --------
    >>> clip = frames("data/clips/project_37-47s.mp4", start_s=2.0, end_s=3.0)
    >>> first = next(clip)
    >>> first.index, first.time_s, first.image.shape
    (50, 2.0, (720, 1280, 3))
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
    """Write an H.264 MP4 that is never half-written.

    Frames go to a hidden temporary file beside ``path``; :meth:`close` finishes the file and
    moves it into place.  Used as a context manager, an exception or Ctrl-C still finishes the
    frames written so far into a playable ``path``; :meth:`discard` drops the output instead.

    Parameters
    ----------
    path : str or Path
        The MP4 to write; its folder is created if needed.
    info : VideoInfo
        Gives the size and frame rate.
    preset : str, optional
        The x264 speed preset.
    crf : int, optional
        The x264 constant rate factor (lower is better and larger).
    threads : int, optional
        Encoder threads; 0 lets FFmpeg choose.

    Attributes
    ----------
    path : Path
        The final file.
    frames_written : int
        Frames written so far.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "black.mp4"
    >>> info = VideoInfo(width=64, height=48, fps=Fraction(25), total_frames=5, duration_s=0.2, codec="h264")
    >>> with VideoSink(out, info) as sink:
    ...     for _ in range(5):
    ...         sink.write(np.zeros((48, 64, 3), np.uint8))
    >>> VideoInfo.from_path(out).total_frames
    5
    """

    def __init__(self, path: str | Path, info: VideoInfo, preset: str = "veryfast", crf: int = 23,
                 threads: int = 0):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{self.path.stem}.", suffix=".partial.mp4", dir=self.path.parent)
        os.close(fd)
        self.tmp = Path(tmp)
        self.frames_written = 0
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
        """Encode one frame.

        Parameters
        ----------
        image : (height, width, 3) uint8 ndarray
            The frame, BGR, at the size given by ``info``.
        """
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
        self.close()
