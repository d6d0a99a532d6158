"""Time integration of M(q) qdd = F(q, qd, t): one front function,
`integrate`, and named methods (`METHODS`), each reported by its name:

- "compiled-DOP853": Dormand-Prince 8(5,3) with scipy's DOP853 step
  control, initial step and dense output, run entirely in the numba kernel
  (`kernel.dop853`) on a `CompiledRHS` whose prescribed coordinates are
  polynomial in t (`CompiledRHS.compilable`); its outputs equal scipy's
  DOP853 to round-off;
- scipy's methods by their own names ("DOP853", "Radau", "RK45", "BDF",
  "LSODA") through `solve_ivp`, on any callable (t, q, qd) -> (M, F), or on
  a `CompiledRHS`, whose accelerations are then solved in the kernel.

Method choice (`choose_method`, "auto"): the scene is linearised at its
initial state; with stiffness ratio r = omega_max / omega_min of the
non-zero natural frequencies and N = omega_max * tmax / (2 pi) cycles of the
fastest mode, an explicit Runge-Kutta method is used when r < 200
("compiled-DOP853" when the right-hand side runs compiled, else "DOP853"),
else the implicit Radau IIA method, whose step is not limited by the fastest
mode. The choice and the numbers behind it are returned with the result.

Divergence detection: non-finite accelerations, states beyond physical bounds
(elastic tip displacement above half the beam length, rigid rates above
1e3 rad/s) or a step-size collapse stop the run with `SimulationDiverged`
(reason, time).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import DOP853, solve_ivp

from modesel.errors import ModeselError, SimulationDiverged
from modesel.multibody import kernel
from modesel.multibody.compiled import CompiledRHS

COMPILED_DOP853 = "compiled-DOP853"
SCIPY_METHODS = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
METHODS = (COMPILED_DOP853,) + SCIPY_METHODS


def _dop853_table():
    """Butcher tableau of scipy's DOP853 with its extra dense-output stages
    (A 16x16, B, C 16, E3, E5, D), from the public class attributes."""
    n = DOP853.n_stages
    A = np.zeros((n + 1 + len(DOP853.A_EXTRA), n + 1 + len(DOP853.A_EXTRA)))
    A[:n, :n] = DOP853.A
    A[n, :n] = DOP853.B                         # stage n: the first stage of the next step (FSAL)
    A[n + 1:, :] = DOP853.A_EXTRA
    C = np.concatenate([DOP853.C, [1.0], DOP853.C_EXTRA])
    return tuple(np.ascontiguousarray(a, float) for a in (A, DOP853.B, C, DOP853.E3, DOP853.E5, DOP853.D))


_DOP853_TABLE = _dop853_table()
_REASONS = {kernel.NON_FINITE_STATE: "non-finite state",
            kernel.SINGULAR: "singular mass matrix",
            kernel.NON_FINITE_ACC: "non-finite acceleration"}


class _Diverged(Exception):
    def __init__(self, reason, t):
        super().__init__(reason)
        self.reason, self.t = reason, t


@dataclass
class Integration:
    """Outputs at t (n_t,) [s]: q, qd (n_t, n); `method` the name of the
    method that ran (one of `METHODS`), the stiffness ratio it was chosen
    by, the number of right-hand-side evaluations."""

    t: np.ndarray
    q: np.ndarray          # (n_t, n)
    qd: np.ndarray
    method: str
    stiffness_ratio: float = float("nan")
    n_rhs: int = 0
    info: dict = field(default_factory=dict)


def runs_compiled(rhs_M_F) -> bool:
    """Whether `rhs_M_F` can be integrated by "compiled-DOP853"."""
    return isinstance(rhs_M_F, CompiledRHS) and rhs_M_F.compilable


def choose_method(omegas: np.ndarray, requested: str = "auto", rhs=None) -> tuple[str, float]:
    """(method, stiffness ratio) from the natural frequencies [rad/s]:
    `requested` unless "auto"; "auto" gives "Radau" for a ratio of 200 or
    more, else "compiled-DOP853" when `rhs` runs compiled, else "DOP853"."""
    w = np.abs(omegas[np.abs(omegas) > 1e-6])
    ratio = float(w.max() / w.min()) if len(w) else 1.0
    if requested != "auto":
        return requested, ratio
    if ratio >= 200.0:
        return "Radau", ratio
    return (COMPILED_DOP853 if runs_compiled(rhs) else "DOP853"), ratio


def integrate(rhs_M_F, q0, qd0, tmax, dt, *, method="DOP853", rtol=1e-8, atol=None, max_step=np.inf,
              bounds=None, stiffness_ratio=float("nan"), progress=None) -> Integration:
    """Integrate from (q0, qd0) over [0, tmax] [s], output every dt [s],
    with the named `method` (one of `METHODS`).

    rhs_M_F(t, q, qd) -> (M, F), or a `CompiledRHS`. bounds: (n,) maximum
    |q| per coordinate (inf = unbounded) used for divergence detection.
    progress: optional progress(t, tmax) called every 64 right-hand-side
    evaluations of the scipy methods (compiled-DOP853 runs in the kernel and
    reports nothing until it returns)."""
    n = len(q0)
    t_eval = np.arange(0.0, tmax + 0.5 * dt, dt)
    t_eval = t_eval[t_eval <= tmax + 1e-12]
    counter = [0]
    qb = np.full(n, np.inf) if bounds is None else np.asarray(bounds, float)
    if atol is None:
        atol = 1e-10
    x0 = np.concatenate([q0, qd0]).astype(float)
    if method == COMPILED_DOP853:
        if not runs_compiled(rhs_M_F):
            raise ModeselError(f"{COMPILED_DOP853} needs a compiled right-hand side with prescribed motion "
                               "polynomial in time (and every load effect in compiled form)",
                               field="solver.method")
        return _integrate_compiled(rhs_M_F, x0, t_eval, float(tmax), rtol, atol, max_step, qb, stiffness_ratio)
    compiled = isinstance(rhs_M_F, CompiledRHS)

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
        if progress is not None and counter[0] % 64 == 0:
            progress(t, tmax)
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
    """compiled-DOP853: DOP853 entirely in the kernel (same algorithm and
    tolerances as solve_ivp)."""
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
    return Integration(t_eval[:len(Y)].copy(), Y[:, :n].copy(), Y[:, n:].copy(), COMPILED_DOP853,
                       stiffness_ratio, int(nfev))
