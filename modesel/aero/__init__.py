"""Aerodynamics of the reduced turbine model (second paper, section 3, eqs. 51-52).

Physics only; the AeroDyn deck that feeds it (`AeroDynDeck`: blades,
airfoil `PolarSet`, air density, `BemOptions`, tower table) is read by
`modesel.turbine.aerodyn.read_aerodyn`.
- `BemSolver(...).solve(r, V_n, V_t, pitch, skew, skew_azimuth)` ->
  `ElementLoads`: vectorised quasi-steady BEM for all blade elements
  (Prandtl tip/hub loss, Buhl/Glauert, Pitt/Peters); f_n, f_t [N/m].
  `allocate(shape)` + `solve_into(buffers, ...)`: the same without allocation.
- `steady_rotor(U, Omega, pitch, deck, ...)`: thrust, torque, power, C_P, C_T, C_Q.
- `Wind`: InflowWind's uniform wind, steady or tabulated in time
  (`Wind.vector`, compiled twin `wind.wind_velocity`).
- `full_field.read_turbsim(path)` -> `FullField`: InflowWind's TurbSim full
  field (WindType 3; `FullField.velocity`, compiled twin
  `full_field.grid_velocity`, which `Wind(full_field=...)` feeds to
  `wind.wind_velocity`).
- `TowerDrag.load(z, v_wind, v_tower)`: tower drag per unit length (eq. 51)
  (compiled twin `tower_drag.drag_forces`).
- `TowerInfluence.velocity(points, ...)`: AeroDyn's tower potential flow and
  shadow on the blades' wind (TwrPotent, TwrShadow; compiled twin
  `tower_influence.tower_disturbance`).
"""
from modesel.aero.airfoils import Polar, PolarSet, read_polars
from modesel.aero.bem import (BemOptions, BemSolver, ElementLoads, axial_induction,
                                            pitt_peters, prandtl_loss, skew_angles,
                                            thrust_coefficient)
from modesel.aero.blade import AeroBlade
from modesel.aero.rotor import steady_rotor
from modesel.aero.tower_drag import TowerDrag
from modesel.aero.tower_influence import TowerInfluence
from modesel.aero.wind import Wind

__all__ = ["AeroBlade", "BemOptions", "BemSolver", "ElementLoads", "Polar",
           "PolarSet", "TowerDrag", "TowerInfluence", "Wind", "axial_induction", "pitt_peters", "prandtl_loss",
           "read_polars", "skew_angles", "steady_rotor",
           "thrust_coefficient"]
