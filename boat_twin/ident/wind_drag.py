"""The wind drag coefficient the surge identification fits where trials measured the true wind (an anemometer):
the wind is a known, time-varying input (:func:`~boat_twin.ident.trial_record.wind_record`), its drag coefficient
k = ½ρ_a·C_a·A_F (N·s²/m²) the parameter, in the output-error fit's place for a further force's scale (its
cluster-robust interval), for the selected resistance model and the baseline beside it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from boat_twin.ident.output_error import OutputErrorResult, SurgeFit
from boat_twin.units import AIR_DENSITY_KGPM3
from boat_twin.vessel.params import WINDAGE_DRAG_COEFFICIENT


@dataclass(frozen=True)
class WindDrag:
    """One fit's wind drag coefficient along the hull and its 95 % interval, N·s²/m²."""

    model: str
    """The resistance model it was fitted with (``baseline``, ``spline-K``)."""
    coefficient_Ns2pm2: float
    ci95_Ns2pm2: tuple[float, float]

    @property
    def frontal_area_m2(self) -> float:
        """The frontal windage area A_F = k / (½ρ_a·C_a) with the twin's drag coefficient C_a, m²."""
        return self.coefficient_Ns2pm2 / (0.5 * AIR_DENSITY_KGPM3 * WINDAGE_DRAG_COEFFICIENT)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (SI)."""
        return {"model": self.model, "coefficient_Ns2pm2": self.coefficient_Ns2pm2,
                "ci95_Ns2pm2": list(self.ci95_Ns2pm2), "frontal_windage_area_m2": self.frontal_area_m2}


def wind_drag(fit: SurgeFit) -> WindDrag:
    """The wind drag coefficient of a fit whose records carried the measured wind's force per unit coefficient."""
    half = fit.t_quantile() * fit.coupling_scale_sd
    return WindDrag(fit.basis.name, fit.coupling_scale, (fit.coupling_scale - half, fit.coupling_scale + half))


@dataclass(frozen=True)
class WindDragResult:
    """The wind drag of the selected fit and of the baseline (the simplest model) beside it."""

    selected: WindDrag
    baseline: WindDrag
    trials: int
    """Pooled trials that measured the wind, -."""

    def to_dict(self) -> dict[str, Any]:
        """The ``wind_drag`` entry of ``identify --json``."""
        return {"selected": self.selected.to_dict(), "baseline": self.baseline.to_dict(), "trials": self.trials,
                "note": "the measured true wind is a known input; the coefficient k = 0.5*rho_air*C_a*A_F of the "
                        "surge wind force k*(|V_a|*u_a + |V|*u) is fitted (A_F with the twin's C_a = "
                        f"{WINDAGE_DRAG_COEFFICIENT:g})"}


def wind_drag_result(oe: OutputErrorResult, trials: int) -> WindDragResult | None:
    """The wind drag of an output-error identification whose records carried the measured wind of ``trials``
    trials (None: none did, so no coefficient was fitted)."""
    if trials == 0 or not oe.selected.coupling_fitted:
        return None
    return WindDragResult(wind_drag(oe.selected), wind_drag(oe.baseline), trials)
