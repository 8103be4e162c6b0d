"""The package's Savitzky-Golay smoother is scipy.signal's, bit for bit (it is there so that the replay does not
import scipy.signal, and scipy.stats with it)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import savgol_filter as scipy_savgol

from boat_twin.signal_noise import savgol_filter


@pytest.mark.parametrize("seed", range(6))
def test_savgol_filter_is_scipys_bit_for_bit(seed) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(40):
        n = int(rng.integers(5, 300))
        window = 2 * int(rng.integers(1, min(25, (n - 1) // 2) + 1)) + 1
        order = int(rng.integers(0, min(3, window - 1) + 1))
        deriv = int(rng.integers(0, min(1, order) + 1))
        delta = float(rng.choice([1.0, 0.1, 0.05]))
        x = np.cumsum(rng.normal(size=n)) * 10 ** rng.uniform(-2, 2) + rng.uniform(-1e3, 1e3)
        expected = scipy_savgol(x, window, order, deriv=deriv, delta=delta, mode="interp")
        assert np.array_equal(savgol_filter(x, window, order, deriv, delta), expected)


def test_savgol_filter_refuses_what_it_does_not_do() -> None:
    with pytest.raises(ValueError, match="window"):
        savgol_filter(np.zeros(10), 4, 2)
    with pytest.raises(ValueError, match="window"):
        savgol_filter(np.zeros(5), 7, 2)
