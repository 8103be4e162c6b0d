"""The one progress line a command keeps redrawing on stderr (``\\r`` and the text), ended before any other line:
a stop, an error or a warning starts on a line of its own, not after the progress text."""

from __future__ import annotations

import sys

_pending = False
"""A progress line is on stderr, not yet ended."""


def show(text: str) -> None:
    """Redraw the progress line as ``text``."""
    global _pending
    sys.stderr.write(f"\r{text}")
    sys.stderr.flush()
    _pending = True


def clear(width: int) -> None:
    """Blank the progress line (``width`` characters) and return to its start: the next line takes its place."""
    global _pending
    if _pending:
        sys.stderr.write("\r" + " " * width + "\r")
        sys.stderr.flush()
    _pending = False


def end() -> None:
    """End the progress line where it stands (a newline), if one is drawn."""
    global _pending
    if _pending:
        sys.stderr.write("\n")
        sys.stderr.flush()
    _pending = False
