"""Exceptions that the CLI turns into one-line messages."""


class LaneFinderError(Exception):
    """A problem with the user's input: reported as one line, never as a traceback."""
