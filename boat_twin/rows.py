"""Rows of floats gathered one at a time (a log's messages, a live twin's innovations) at 8 bytes a number."""

from __future__ import annotations

from array import array

import numpy as np

__all__ = ["Rows"]


class Rows:
    """Rows of numbers appended to one flat ``array('d')``: bounded memory, no message objects kept (a row as a
    Python tuple of floats costs about 17 times its 8 bytes a number)."""

    __slots__ = ("data", "width")

    def __init__(self, width: int) -> None:
        self.width = width
        self.data = array("d")

    def add(self, row: tuple[float, ...]) -> None:
        self.data.extend(row)

    def array(self) -> np.ndarray:
        """The rows as an (n, width) view of the buffer (no copy; append nothing after this)."""
        return np.frombuffer(self.data, dtype=float).reshape(-1, self.width)
