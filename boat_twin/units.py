"""Unit conversions used at the edges only (inside, everything is SI), and the physical constants, each once."""

KNOT_MPS = 1852.0 / 3600.0
"""One international knot in m/s (exact: 1852 m per hour)."""

STANDARD_GRAVITY_MPS2 = 9.80665
"""Standard acceleration of gravity g0 in m/s^2 (CGPM 1901): the twin's one gravity."""

KGF_N = STANDARD_GRAVITY_MPS2 * 1.0
"""One kilogram-force in N: 1 kg under standard gravity (exact by definition)."""

SEAWATER_DENSITY_KGPM3 = 1025.0
"""Sea water density, kg/m^3: 15 °C, 35 PSU (ITTC 7.5-02-01-03; UNESCO EOS-80 gives 1025.9 at the surface): the
twin's one water density (hull coefficients, towed cable)."""

AIR_DENSITY_KGPM3 = 1.225
"""Air density at 15 °C, sea level, kg/m^3 (ISA)."""
