"""Helpers of the hostile-input tests (test_robustness.py's sweep, test_campaign.py's campaign): the generator of
command lines over every verb, from a table of each verb's flags and the hostile values they get."""

from __future__ import annotations

from collections.abc import Callable

from hypothesis import strategies as st

VerbFlags = dict[tuple[str, ...], dict[str, st.SearchStrategy[str] | None]]
"""Verb (with its fixed words) → flag → the values it is given ("" is the positional argument; None: a switch)."""


def command_lines(verb_flags: VerbFlags, finish: Callable[[tuple[str, ...], list[str]], list[str]],
                  twice: frozenset[str] = frozenset()) -> st.SearchStrategy[list[str]]:
    """Command lines of one verb drawn from ``verb_flags`` with one to four of its flags, each with a drawn value
    (given twice for the flags in ``twice``, which take two numbers); ``finish(verb, argv)`` appends what keeps a
    run cheap (a short duration, an option refused before the long work)."""

    @st.composite
    def draw_line(draw: st.DrawFn) -> list[str]:
        verb = draw(st.sampled_from(sorted(verb_flags)))
        flags = verb_flags[verb]
        argv = list(verb)
        for flag in draw(st.lists(st.sampled_from(sorted(flags)), min_size=1, max_size=4, unique=True)):
            values = flags[flag]
            value = [] if values is None else [draw(values)] * (2 if flag in twice else 1)
            argv += ([flag] if flag else []) + value
        return finish(verb, argv)

    return draw_line()
