"""Symbolic layer: the equations of motion of the small models derived with
SymPy (sympy.physics.mechanics kinematics + Kane's method, first paper
sections 2-4), from the same `System` data objects as the numeric engine.

Front functions:
    derive(system, small_angle=None)  -> SymbolicModel
    (scenes: `modesel.simulation.symbolic.derive_scene`, small models only)
    write_python(model, path), write_latex(model, path)

Modules: parameters (named constants and values), reduction (exact lumping
of rigid parts), shape_integrals (flexible-body integrals as symbols),
kane (kinematics and Kane assembly), approximations (small angles,
linearisation), model (SymbolicModel), export (Python and LaTeX).
"""
from modesel.multibody.symbolic.export import write_latex, write_python
from modesel.multibody.symbolic.model import SymbolicModel, derive

__all__ = ["SymbolicModel", "derive", "write_latex", "write_python"]
