"""Time integration of M(q) qdd = F(q, qd, t) with SciPy (`solve_ivp`).

Method choice ("auto"): the scene is linearised at its initial state; with
stiffness ratio r = omega_max / omega_min of the non-zero natural
frequencies and N = omega_max * tmax / (2 pi) cycles of the fastest mode,
an explicit Runge-Kutta (DOP853) is used when r < 200, else the implicit
Radau IIA method, whose step is not limited by the fastest mode. The choice
and the numbers behind it are returned with the result.

Divergence detection: non-finite accelerations, states beyond physical bounds
(elastic tip displacement above half the beam length, rigid rates above
1e3 rad/s) or a step-size collapse stop the run with `SimulationDiverged`
(reason, time).

Speed: with a `kernel.CompiledRHS` (`KaneEquations.compiled_rhs`) and DOP853
the whole loop runs compiled (`kernel.dop853`: scipy's DOP853 step control,
initial step and dense output, so the outputs equal solve_ivp's to round-off);
other methods call scipy with the compiled accelerations. Any other
callable (t, q, qd) -> (M, F) goes through scipy unchanged.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp
from scipy.integrate._ivp import dop853_coefficients as _dop

from modesel.errors import ModeselError, SimulationDiverged
from modesel.multibody import kernel

_DOP853_TABLE = (np.ascontiguousarray(_dop.A), np.ascontiguousarray(_dop.B), np.ascontiguousarray(_dop.C),
                 np.ascontiguousarray(_dop.E3), np.ascontiguousarray(_dop.E5), np.ascontiguousarray(_dop.D))
_REASONS = {kernel.NON_FINITE_STATE: "non-finite state",
            kernel.SINGULAR: "singular mass matrix",
            kernel.NON_FINITE_ACC: "non-finite acceleration"}


class _Diverged(Exception):
    def __init__(self, reason, t):
        super().__init__(reason)
        self.reason, self.t = reason, t


@dataclass
class Integration:
    t: np.ndarray
    q: np.ndarray          # (n_t, n)
    qd: np.ndarray
    method: str
    stiffness_ratio: float = float("nan")
    n_rhs: int = 0
    info: dict = field(default_factory=dict)


def choose_method(omegas: np.ndarray, requested: str = "auto") -> tuple[str, float]:
    """(method, stiffness ratio) from the natural frequencies [rad/s]."""
    w = np.abs(omegas[np.abs(omegas) > 1e-6])
    ratio = float(w.max() / w.min()) if len(w) else 1.0
    if requested != "auto":
        return requested, ratio
    return ("DOP853" if ratio < 200.0 else "Radau"), ratio


def integrate(rhs_M_F, q0, qd0, tmax, dt, *, method="DOP853", rtol=1e-8, atol=None, max_step=np.inf,
              bounds=None, stiffness_ratio=float("nan")) -> Integration:
    """Integrate from (q0, qd0) over [0, tmax], output every dt.

    rhs_M_F(t, q, qd) -> (M, F). bounds: (n,) maximum |q| per coordinate
    (inf = unbounded) used for divergence detection."""
    n = len(q0)
    t_eval = np.arange(0.0, tmax + 0.5 * dt, dt)
    t_eval = t_eval[t_eval <= tmax + 1e-12]
    counter = [0]
    qb = np.full(n, np.inf) if bounds is None else np.asarray(bounds, float)
    if atol is None:
        atol = 1e-10
    x0 = np.concatenate([q0, qd0]).astype(float)
    compiled = isinstance(rhs_M_F, kernel.CompiledRHS)
    if compiled and method == "DOP853" and rhs_M_F.compilable:
        return _integrate_compiled(rhs_M_F, x0, t_eval, float(tmax), rtol, atol, max_step, qb, stiffness_ratio)

    def accelerations(t, q, qd):
        if compiled:
            qdd, code = rhs_M_F.accelerations(t, q, qd)
            if code != kernel.OK:
                raise _Diverged(_REASONS[code], t)
            return qdd
        M, F = rhs_M_F(t, q, qd)
        try:
            return np.linalg.solve(M, F)
        except np.linalg.LinAlgError:
            raise _Diverged("singular mass matrix", t) from None

    def f(t, x):
        counter[0] += 1
        q, qd = x[:n], x[n:]
        if not np.all(np.isfinite(x)):
            raise _Diverged("non-finite state", t)
        big = np.abs(q) > qb
        if np.any(big):
            raise _Diverged(_beyond(int(np.argmax(big))), t)
        qdd = accelerations(t, q, qd)
        if not np.all(np.isfinite(qdd)):
            raise _Diverged("non-finite acceleration", t)
        return np.concatenate([qd, qdd])

    try:
        sol = solve_ivp(f, (0.0, tmax), x0, method=method, t_eval=t_eval, rtol=rtol, atol=atol,
                        max_step=max_step)
    except _Diverged as exc:
        raise SimulationDiverged(exc.reason, exc.t) from None
    if sol.status < 0:
        tfail = float(sol.t[-1]) if len(sol.t) else 0.0
        raise SimulationDiverged(f"integrator failed ({sol.message})", tfail)
    return Integration(sol.t, sol.y[:n].T, sol.y[n:].T, method, stiffness_ratio, counter[0])


def _beyond(i):
    return f"coordinate {i} beyond its physical bound"


def _integrate_compiled(rhs, x0, t_eval, tmax, rtol, atol, max_step, bounds, stiffness_ratio) -> Integration:
    """DOP853 entirely in the kernel (same algorithm and tolerances as solve_ivp)."""
    nx = len(x0)
    rtol = max(float(rtol), 100 * np.finfo(float).eps)     # as scipy validate_tol
    atol = np.broadcast_to(np.asarray(atol, float), (nx,)).copy()
    if np.any(atol < 0):
        raise ModeselError("atol must be non-negative", field="solver.atol")
    if not max_step > 0:
        raise ModeselError("max_step must be positive", field="solver.max_step")
    code, t_stop, nfev, idx, Y = rhs.dop853(x0, t_eval, tmax, rtol, atol, float(max_step), bounds,
                                            _DOP853_TABLE)
    if code == kernel.STEP_COLLAPSE:
        raise SimulationDiverged("integrator failed (Required step size is less than spacing between numbers.)",
                                 float(t_stop))
    if code == kernel.BEYOND_BOUND:
        raise SimulationDiverged(_beyond(idx), float(t_stop))
    if code != kernel.OK:
        raise SimulationDiverged(_REASONS[code], float(t_stop))
    n = nx // 2
    return Integration(t_eval[:len(Y)].copy(), Y[:, :n].copy(), Y[:, n:].copy(), "DOP853",
                       stiffness_ratio, int(nfev))
