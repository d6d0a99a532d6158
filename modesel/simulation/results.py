"""What `simulate` returns."""
from __future__ import annotations

import functools
from dataclasses import dataclass, field


@dataclass(frozen=True)
class SimulationResult:
    """Output columns {'Time' [s] and OpenFAST channels: 1-D arrays, one per
    output time}, their units {channel: unit}, DOF count and cost:
    wall-clock time [s], simulated time [s], the integrator, the stiffness
    ratio it chose by, right-hand-side evaluations. `outputs` is the same
    table as a pandas DataFrame (units in `outputs.attrs["units"]`), made on
    first use, so that a caller that only writes the columns never imports
    pandas."""

    columns: dict
    n_dofs: int
    wall_time_s: float
    simulated_time_s: float
    dof_names: list = field(default_factory=list)
    method: str = ""
    stiffness_ratio: float = float("nan")
    n_rhs: int = 0
    units: dict = field(default_factory=dict)

    @functools.cached_property
    def outputs(self):
        """The columns as a pandas DataFrame, units in ``attrs["units"]``."""
        import pandas as pd
        df = pd.DataFrame(self.columns)
        df.attrs["units"] = dict(self.units)
        return df

    @property
    def speed(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.simulated_time_s / max(self.wall_time_s, 1e-12)
