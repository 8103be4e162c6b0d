"""What ``identify`` adds to the twin it writes: the twin's own model error on the recordings it was identified
from, each predicted by a twin identified without it (issue 42; docs/diagnosis.md, "Diagnosis against the twin's
own error"). Above both the identification and the diagnosis, which it joins."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from boat_twin.diagnose.model_error import measure_model_error
from boat_twin.errors import InputError
from boat_twin.ident.pipeline import identify_and_resimulate
from boat_twin.ident.report import identified_twin
from boat_twin.ident.results import TrialsIdentification
from boat_twin.io.trial import Trial
from boat_twin.model_error import ModelError
from boat_twin.twin.replay import cut_windows


def identified_model_error(trials: list[Trial], found: TrialsIdentification, options: dict[str, Any],
                           progress: Callable[[str], None] | None = None) -> tuple[ModelError | None, str]:
    """The model error of the twin ``found`` (identified from ``trials`` with ``identify_and_resimulate``'s
    ``options``) and a line saying how it was measured, or (None, why not). Each recording is predicted by the twin
    identified from the others (held out), so it takes two or more recordings the diagnosis' windows can cut (a
    twin's error on the very recording it was fitted to would understate what it normally gets wrong)."""
    say = progress or (lambda _line: None)
    usable = [t for t in trials if _windowed(t)]
    if found.vessel is None:
        return None, "no model error measured: no twin was built"
    if len(usable) < 2:
        return None, ("no model error measured (twin.yaml without one): it takes two or more recordings of at "
                      "least the diagnosis' 6 windows, each predicted by the twin identified from the others")
    twins = []
    for i, trial in enumerate(usable):
        say(f"model error: identifying without {trial.metadata.source} ({i + 1} of {len(usable)}) ...")
        others = identify_and_resimulate(usable[:i] + usable[i + 1:], **options)
        twins.append(identified_twin(others) or identified_twin(found))
    say("model error: replaying each recording through its twin ...")
    try:
        error = measure_model_error(usable, [t for t in twins if t is not None], heldout=True)
    except InputError as err:  # a recording the diagnosis' replay cannot read: the twin is written without
        return None, f"no model error measured: {err}"
    return error, (f"model error measured: each of {len(usable)} recordings predicted by the twin identified from "
                   "the others")


def _windowed(trial: Trial) -> bool:
    try:
        cut_windows(trial)
    except InputError:
        return False
    return True
