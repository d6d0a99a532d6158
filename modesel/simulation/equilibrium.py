"""Static equilibrium of a built scene: the starting point that removes most
of the start-up transient (scene `[initial] equilibrium = true`)."""
from __future__ import annotations

import numpy as np

from modesel.errors import ModeselError
from modesel.vocabulary import RIGID_BODY_DOFS


def static_equilibrium(built, t: float = 0.0) -> np.ndarray:
    """Free coordinates at which the elastic and drivetrain coordinates of
    `built` (assembly.Built) have no acceleration (rigid-body DOFs and all
    rates as in the initial state): the deflection [m, rad] under gravity,
    centrifugal and aerodynamic loads at t [s]."""
    import scipy.optimize
    names = built.model.system.free
    sel = np.array([i for i, n in enumerate(names) if n not in RIGID_BODY_DOFS], dtype=int)
    if not len(sel):
        return built.q0.copy()

    accelerations = _accelerations(built)

    def residual(x):
        q = built.q0.copy()
        q[sel] = x
        return accelerations(t, q, built.qd0)[sel]

    sol = scipy.optimize.root(residual, built.q0[sel], method="hybr", options={"xtol": 1e-10})
    if not sol.success or not np.all(np.isfinite(sol.x)):
        raise ModeselError(f"no static equilibrium found ({sol.message})", file=built.scene.path,
                           field="initial.equilibrium")
    q = built.q0.copy()
    q[sel] = sol.x
    return q


def _accelerations(built):
    """(t, q, qd) -> accelerations of the free coordinates [m/s^2, rad/s^2]:
    the compiled right-hand side with the effects' loads (`Built.rhs`) where
    it exists, the one the simulation integrates, with the first run's
    compile in parallel (`first_run.compile_in_parallel`) before its first
    call; else M^-1 F of `Built.M_F`. NaN where the compiled right-hand
    side fails (the root finder then reports no equilibrium)."""
    from modesel.simulation import first_run
    first_run.compile_in_parallel(built)
    rhs = built.rhs()
    if not hasattr(rhs, "accelerations"):
        def solved(t, q, qd):
            M, F = rhs(t, q, qd)
            return np.linalg.solve(M, F)
        return solved

    from modesel.multibody.kernel import OK

    def compiled(t, q, qd):
        qdd, code = rhs.accelerations(t, q, qd)
        return qdd if code == OK else np.full_like(qdd, np.nan)
    return compiled
