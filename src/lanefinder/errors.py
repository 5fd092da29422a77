"""Exceptions that the CLI turns into one-line messages."""

__all__ = ["LaneFinderError", "NoFramesError"]


class LaneFinderError(Exception):
    """A problem with the user's input: reported as one line, never as a traceback.

    Examples
    --------
    >>> try:
    ...     raise LaneFinderError("image not found: a.jpg")
    ... except LaneFinderError as e:
    ...     print(f"error: {e}")
    error: image not found: a.jpg
    """


class NoFramesError(LaneFinderError):
    """No frame could be decoded from (a span of) a video.

    Examples
    --------
    >>> isinstance(NoFramesError("no frames"), LaneFinderError)
    True
    """
