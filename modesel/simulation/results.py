"""What `simulate` returns."""
from __future__ import annotations

from dataclasses import dataclass, field

import pandas as pd


@dataclass(frozen=True)
class SimulationResult:
    """Outputs ('Time' [s] + OpenFAST channels, units in `outputs.attrs["units"]`),
    DOF count and cost: wall-clock time [s], simulated time [s], the
    integrator, the stiffness ratio it chose by, right-hand-side evaluations."""

    outputs: pd.DataFrame
    n_dofs: int
    wall_time_s: float
    simulated_time_s: float
    dof_names: list = field(default_factory=list)
    method: str = ""
    stiffness_ratio: float = float("nan")
    n_rhs: int = 0

    @property
    def speed(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.simulated_time_s / max(self.wall_time_s, 1e-12)
