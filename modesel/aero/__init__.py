"""Aerodynamics of the reduced turbine model (second paper, section 3, eqs. 51-52).

- `read_aerodyn(path)` -> `AeroDynDeck`: blades (`AeroBlade`, airfoil
  `PolarSet`), air density, BEM switches (`BemOptions`), tower table (`TowerDrag`).
- `BemSolver(...).solve(r, V_n, V_t, pitch, skew, skew_azimuth)` ->
  `ElementLoads`: vectorised quasi-steady BEM for all blade elements
  (Prandtl tip/hub loss, Buhl/Glauert, Pitt/Peters); f_n, f_t [N/m].
  `allocate(shape)` + `solve_into(buffers, ...)`: the same without allocation.
- `steady_rotor(U, Omega, pitch, deck, ...)`: thrust, torque, power, C_P, C_T, C_Q.
- `Wind`: InflowWind's uniform wind, steady or tabulated in time
  (`Wind.vector`, compiled twin `wind.wind_velocity`).
- `TowerDrag.load(z, v_wind, v_tower)`: tower drag per unit length (eq. 51)
  (compiled twin `tower_drag.drag_forces`).
"""
from modesel.aero.airfoils import Polar, PolarSet, read_polars
from modesel.aero.bem import (BemOptions, BemSolver, ElementLoads, axial_induction,
                                            pitt_peters, prandtl_loss, skew_angles,
                                            thrust_coefficient)
from modesel.aero.blade import AeroBlade
from modesel.turbine.aerodyn import AeroDynDeck, read_aerodyn, read_aerodyn_blade
from modesel.aero.rotor import steady_rotor
from modesel.aero.tower_drag import TowerDrag
from modesel.aero.wind import Wind

__all__ = ["AeroBlade", "AeroDynDeck", "BemOptions", "BemSolver", "ElementLoads", "Polar",
           "PolarSet", "TowerDrag", "Wind", "axial_induction", "pitt_peters", "prandtl_loss",
           "read_aerodyn", "read_aerodyn_blade", "read_polars", "skew_angles", "steady_rotor",
           "thrust_coefficient"]
