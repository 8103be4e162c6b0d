"""A stretch of a trial: ``--start`` / ``--end`` (seconds since the trial's start) of identify, diagnose and follow,
e.g. to leave out idling at either end of a recording."""

from __future__ import annotations

import math
from dataclasses import fields, replace

import numpy as np

from boat_twin.errors import InputError
from boat_twin.io.trial import Trial

MIN_SAMPLES = 20
"""A stretch must keep at least this many grid samples."""


def trial_between(trial: Trial, start_s: float | None = None, end_s: float | None = None) -> Trial:
    """The samples of ``trial`` from ``start_s`` to ``end_s`` (s since its start, inclusive; None: its start or
    end), on the same grid, its time again from 0 (``metadata.start_time_s`` moved by the cut, the gaps kept
    where they overlap, the cut stated in ``metadata.stream_choices``). Refuses a stretch outside the trial or of
    fewer than :data:`MIN_SAMPLES` samples, naming the trial's span."""
    if start_s is None and end_s is None:
        return trial
    t = trial.t_s
    span = f"the trial spans 0 to {float(t[-1]):.1f} s"
    low = 0.0 if start_s is None else float(start_s)
    high = float(t[-1]) if end_s is None else float(end_s)
    if not (math.isfinite(low) and math.isfinite(high)) or low < 0.0:
        raise InputError(f"--start/--end: {low:g} to {high:g} s is not a stretch of the trial ({span})")
    keep = (t >= low - 1e-9) & (t <= high + 1e-9)
    if np.count_nonzero(keep) < MIN_SAMPLES:
        raise InputError(f"--start {low:g} s to --end {high:g} s keeps {np.count_nonzero(keep)} sample(s), fewer "
                         f"than {MIN_SAMPLES}: {span}")
    first = int(np.argmax(keep))
    last = int(len(t) - np.argmax(keep[::-1]))
    t0 = float(t[first])
    cut = {f.name: getattr(trial, f.name)[first:last] for f in fields(trial)
           if isinstance(getattr(trial, f.name), np.ndarray) and getattr(trial, f.name).shape[:1] == t.shape}
    cut["t_s"] = cut["t_s"] - t0
    meta = replace(trial.metadata, start_time_s=trial.metadata.start_time_s + t0,
                   gaps=[(role, max(a, t0) - t0, min(b, float(t[last - 1])) - t0)
                         for role, a, b in trial.metadata.gaps if b > t0 and a < float(t[last - 1])],
                   stream_choices=[*trial.metadata.stream_choices,
                                   f"cut to {t0:.1f}-{float(t[last - 1]):.1f} s of the recording (--start/--end)"])
    return replace(trial, **cut, metadata=meta)
