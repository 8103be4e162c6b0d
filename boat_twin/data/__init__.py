"""Data sets shipped with boat_twin (published tables, read with their units stated)."""

from importlib import resources

import numpy as np

from boat_twin.units import KGF_N, KNOT_MPS


def dyda2021_table1() -> tuple[np.ndarray, np.ndarray]:
    """Table 1 of Dyda & Chumakova (2021) as printed: (speed in knots, thrust in kgf), 37 rows.

    The paper prints no units; boat_twin reads speed in knots and thrust in kilogram-force (docs/model.md explains why).
    """
    text = resources.files(__package__).joinpath("dyda2021_table1.csv").read_text()
    table = np.loadtxt(text.splitlines(), delimiter=",", comments="#", skiprows=3)
    return table[:, 0], table[:, 1]


def dyda2021_table1_si() -> tuple[np.ndarray, np.ndarray]:
    """Table 1 of Dyda & Chumakova (2021) in SI: (speed in m/s, thrust in N)."""
    speed_kn, thrust_kgf = dyda2021_table1()
    return speed_kn * KNOT_MPS, thrust_kgf * KGF_N
