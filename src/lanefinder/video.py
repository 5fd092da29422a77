"""Video I/O with PyAV: VideoInfo, a frame generator, and an H.264 sink that is never half-written.

Modelled on supervision's VideoInfo / get_video_frames_generator / VideoSink.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np

from .errors import LaneFinderError
from .io import OutputSet, input_file

__all__ = ["DecodeStats", "Frame", "VideoInfo", "VideoSink", "frame_image", "frames", "main_stream", "upright"]


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
        """Read the facts of a file's main video stream (:func:`main_stream`), as it is shown (its rotation applied).

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
            s = main_stream(c)
            fps = Fraction(s.average_rate or s.guessed_rate or 25)
            if s.duration is not None and s.time_base is not None:
                duration = float(s.duration * s.time_base)
            elif c.duration is not None:
                duration = c.duration / av.time_base
            else:
                duration = 0.0
            frames = int(s.frames) or round(duration * fps)
            w, h = s.codec_context.width, s.codec_context.height
            if round(_first_rotation(c, s) / 90) % 2:  # shown turned a quarter: as wide as it is stored tall
                w, h = h, w
            return cls(w, h, fps, frames, duration, s.codec_context.name)


def main_stream(container: av.container.InputContainer) -> av.video.stream.VideoStream:
    """Give a container's main video stream: the one of most pixels a frame (the first of those).

    A file may hold a small preview or a second camera beside the road video; the largest is
    taken, the same one by every reader (``VideoInfo``, :func:`frames`, the review page).

    Parameters
    ----------
    container : av.container.InputContainer
        An open container with at least one video stream.

    Returns
    -------
    av.video.stream.VideoStream
        The stream.

    Examples
    --------
    >>> import av
    >>> with av.open("data/clips/project_37-47s.mp4") as c:
    ...     main_stream(c).index
    0
    """
    # (max gives the first of equals)
    return max(container.streams.video, key=lambda st: (st.codec_context.width or 0) * (st.codec_context.height or 0))


def _first_rotation(container: av.container.InputContainer, stream: av.video.stream.VideoStream) -> float:
    """Give the display rotation of a stream's first frame (0 when none decodes)."""
    with contextlib.suppress(av.error.FFmpegError, StopIteration, ValueError):
        return _rotation(next(container.decode(stream)))
    return 0.0


def _rotation(frame: av.VideoFrame) -> float:
    """Give a decoded frame's display rotation, degrees counter-clockwise (0 when the file says none)."""
    r = getattr(frame, "rotation", 0) or 0
    return float(r) if math.isfinite(r) else 0.0


def frame_image(frame: av.VideoFrame) -> np.ndarray:
    """Give a decoded PyAV frame as a BGR array, turned the way its file says it is shown.

    Parameters
    ----------
    frame : av.VideoFrame
        The decoded frame.

    Returns
    -------
    (H, W, 3) uint8 ndarray
        Its pixels, BGR, upright (:func:`upright`).

    Examples
    --------
    >>> import av
    >>> with av.open("data/clips/project_37-47s.mp4") as c:
    ...     frame_image(next(c.decode(video=0))).shape
    (720, 1280, 3)
    """
    return upright(frame.to_ndarray(format="bgr24"), _rotation(frame))


#: The turns ``cv2.rotate`` makes, by quarter turns clockwise.
_QUARTER_TURNS = (None, cv2.ROTATE_90_CLOCKWISE, cv2.ROTATE_180, cv2.ROTATE_90_COUNTERCLOCKWISE)


def upright(image: np.ndarray, rotation_deg: float) -> np.ndarray:
    """Turn a decoded frame the way its file says it is shown (a phone's rotation metadata).

    Parameters
    ----------
    image : (H, W, 3) ndarray
        The frame as stored.
    rotation_deg : float
        The display rotation (FFmpeg's display matrix): the frame is shown turned this many
        degrees counter-clockwise; rounded to quarter turns.

    Returns
    -------
    ndarray
        The frame as shown (the same array when there is nothing to turn).

    Examples
    --------
    >>> img = np.zeros((2, 3, 3), np.uint8)
    >>> upright(img, 0.0) is img, upright(img, -90.0).shape, upright(img, 180.0).shape
    (True, (3, 2, 3), (2, 3, 3))
    """
    turn = _QUARTER_TURNS[round(-rotation_deg / 90) % 4]
    return image if turn is None else cv2.rotate(image, turn)


# Containers that hold a still image, not a video.
_IMAGE_FORMATS = ("image2", "png_pipe", "jpeg_pipe", "bmp_pipe", "tiff_pipe", "webp_pipe", "gif", "apng")


def _open(path: str | Path):
    p = input_file(path, "video")
    try:
        c = av.open(str(p))
    except (av.error.FFmpegError, OSError, UnicodeDecodeError, ValueError) as e:
        hint = ""
        if p.suffix.lower() in (".mp4", ".mov", ".m4v") and _index_missing(p):
            hint = ("the file is cut short before its index (moov), which this file keeps at the end, "
                    "so no frame can be found; ")
        raise LaneFinderError(f"cannot open video {p}: {hint}{_reason(e)}") from None
    fmt = c.format.name if c.format else ""
    has_video = bool(c.streams.video)
    still = any(f in fmt.split(",") for f in _IMAGE_FORMATS) or fmt.endswith("_pipe")
    if not has_video or still:
        c.close()
        if has_video:
            raise LaneFinderError(f"{p} is a still image, not a video: use `lanefinder image`")
        raise LaneFinderError(f"{p} has no video stream")
    return c


def _index_missing(p: Path) -> bool:
    """Tell whether an MP4 lacks its index (no ``moov`` box in the first or last 16 MB)."""
    try:
        with p.open("rb") as f:
            head = f.read(16 << 20)
            f.seek(max(0, p.stat().st_size - (16 << 20)))
            tail = f.read()
    except OSError:
        return False
    return head[4:8] == b"ftyp" and b"mdat" in head and b"moov" not in head and b"moov" not in tail


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
        s = main_stream(c)
        s.thread_type = "AUTO"
        s.codec_context.thread_count = threads
        fps = Fraction(s.average_rate or s.guessed_rate or 25)
        tb = s.time_base
        if start_s > 0:
            c.seek(int(start_s / tb), stream=s, backward=True, any_frame=False)
        first_pts = s.start_time or 0
        last = -1
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
                # Frame numbers from the timestamps, strictly increasing even where a
                # variable-rate recording puts two frames in one slot.
                index = max(last + 1, round(t * fps))
                last = index
                yield Frame(index, t, frame_image(f))


class VideoSink:
    """Write an H.264 MP4 that is never half-written.

    Frames go to a hidden temporary file beside ``path``; :meth:`close` finishes the file and
    moves it into place.  Used as a context manager, an exception or Ctrl-C still finishes the
    frames written so far into a playable ``path``; :meth:`discard` drops the output instead.
    H.264 needs an even width and height: a frame of odd size is padded by one pixel
    (its last row or column repeated), and ``padded`` says so.

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
    outputs : OutputSet, optional
        Write the video as part of this set: :meth:`close` then finishes the file and the set
        puts it in place together with the command's other outputs.

    Attributes
    ----------
    path : Path
        The final file.
    frames_written : int
        Frames written so far.
    size : tuple of int
        (width, height) encoded, pixels: ``info.size`` rounded up to even numbers.
    padded : bool
        True when ``size`` differs from ``info.size``.

    Raises
    ------
    LaneFinderError
        When the encoder cannot be opened or the file cannot be written.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "black.mp4"
    >>> info = VideoInfo(width=65, height=48, fps=Fraction(25), total_frames=5, duration_s=0.2, codec="h264")
    >>> with VideoSink(out, info) as sink:
    ...     for _ in range(5):
    ...         sink.write(np.zeros((48, 65, 3), np.uint8))
    >>> sink.padded, VideoInfo.from_path(out).size, VideoInfo.from_path(out).total_frames
    (True, (66, 48), 5)
    """

    def __init__(self, path: str | Path, info: VideoInfo, preset: str = "veryfast", crf: int = 23,
                 threads: int = 0, outputs: OutputSet | None = None):
        self.path = Path(path)
        self._own = outputs is None
        self._outputs = outputs if outputs is not None else OutputSet()
        self.tmp = self._outputs.add(self.path, suffix=".mp4")
        self.frames_written = 0
        self.size = (info.width + info.width % 2, info.height + info.height % 2)
        self.padded = self.size != (info.width, info.height)
        self._closed = False
        try:
            self._container = av.open(str(self.tmp), "w", format="mp4")
            rate = info.fps.limit_denominator(100000)
            self._stream = self._container.add_stream("libx264", rate=rate)
            self._stream.width, self._stream.height = self.size
            self._stream.pix_fmt = "yuv420p"
            self._stream.time_base = 1 / rate
            self._stream.codec_context.thread_count = threads
            self._stream.options = {"crf": str(crf), "preset": preset}
        except (av.error.FFmpegError, OSError, ValueError) as e:
            self._closed = True
            self._drop()
            raise LaneFinderError(f"cannot write the video {self.path}: {e}") from None

    def write(self, image: np.ndarray) -> None:
        """Encode one frame.

        Parameters
        ----------
        image : (height, width, 3) uint8 ndarray
            The frame, BGR, at the size given by ``info``.

        Raises
        ------
        LaneFinderError
            When the frame cannot be encoded or written (a full disk, for one).
        """
        if self.padded:
            h, w = image.shape[:2]
            image = cv2.copyMakeBorder(image, 0, self.size[1] - h, 0, self.size[0] - w, cv2.BORDER_REPLICATE)
        try:
            frame = av.VideoFrame.from_ndarray(image, format="bgr24")
            frame.pts = self.frames_written
            self._container.mux(self._stream.encode(frame))
        except (av.error.FFmpegError, OSError, ValueError) as e:
            raise LaneFinderError(f"cannot write the video {self.path}: {_reason(e)}") from None
        self.frames_written += 1

    def close(self) -> None:
        """Flush the encoder and finish the MP4; move it to ``path`` unless it belongs to a set.

        Raises
        ------
        LaneFinderError
            When the file cannot be finished (a full disk, for one); nothing is put in place.
        """
        if self._closed:
            return
        self._closed = True
        try:
            self._container.mux(self._stream.encode(None))
            self._container.close()
        except (av.error.FFmpegError, OSError, ValueError) as e:
            with contextlib.suppress(av.error.FFmpegError, OSError, ValueError):
                self._container.close()
            self._drop()
            raise LaneFinderError(f"cannot finish the video {self.path}: {_reason(e)}") from None
        if self._own:
            (self._outputs.commit if self.frames_written else self._outputs.discard)()

    def discard(self) -> None:
        """Drop the output (nothing to keep)."""
        if not self._closed:
            self._closed = True
            with contextlib.suppress(av.error.FFmpegError, OSError, ValueError):
                self._container.close()
        self._drop()

    def _drop(self) -> None:
        if self._own:
            self._outputs.discard()
        else:
            self.tmp.unlink(missing_ok=True)

    def __enter__(self) -> VideoSink:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close()


def _reason(e: BaseException) -> str:
    """Give the OS's words for an I/O failure (``No space left on device``), else the message."""
    return getattr(e, "strerror", None) or str(e)
