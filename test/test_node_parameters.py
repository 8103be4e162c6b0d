"""A misspelt node parameter (``-p sead:=5``) is refused in one line naming it and the declared ones, exit 2,
instead of being ignored (issue 24)."""

from __future__ import annotations

import pytest
import rosnodes


@pytest.mark.parametrize(("node", "params", "named", "declared"), [
    ("identifier", {"ordr": 3}, "parameter ordr", "order"),
    ("simulator", {"sead": 5}, "parameter sead", "seed"),
    ("simulator", {"scenaro": "zigzag"}, "parameter scenaro", "real_time_factor"),
])
def test_a_misspelt_parameter_is_refused_listing_the_declared_ones(tmp_path, node, params, named, declared) -> None:
    proc = rosnodes.NodeProcess(node, params, tmp_path)
    assert proc.wait(rosnodes.START_TIMEOUT_S) == 2
    errors = [line for line in proc.stderr.strip().splitlines() if "error" in line]  # (start-up [WARN]s aside)
    assert len(errors) == 1 and errors[0].startswith(f"{node}: error: {named}: not a parameter"), errors
    assert declared in errors[0] and "Traceback" not in proc.stderr, errors
