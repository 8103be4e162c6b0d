"""The one exception type for bad user input (the CLI turns it into one line and exit code 2), and the hook that
keeps a stopping signal's exception from being printed by a C extension as a crash."""

from __future__ import annotations

import sys
from types import TracebackType


class InputError(Exception):
    """Bad input from the user (a file, a field, a flag); the message names it and says what is wrong."""


class PrintedStops:
    """``sys.excepthook`` for a run that a signal may stop by raising one of ``kinds``: a C extension whose import
    fails prints the error with ``PyErr_Print`` (which calls this hook) and raises its own instead. numba's
    ``_dispatcher``, Ctrl-C landing while it loaded, printed "Traceback ... KeyboardInterrupt" and raised
    "ImportError: numba._devicearray failed to import". A stop is noted in :attr:`stops` instead of printed, for
    the run to end as the stop it was; anything else is printed as Python does."""

    def __init__(self, kinds: tuple[type[BaseException], ...]) -> None:
        self.kinds = kinds
        self.stops: list[BaseException] = []

    def __call__(self, kind: type[BaseException], value: BaseException,
                 traceback: TracebackType | None) -> None:
        if issubclass(kind, self.kinds):
            self.stops.append(value)
        else:
            sys.__excepthook__(kind, value, traceback)
