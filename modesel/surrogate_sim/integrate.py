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
"""
from __future__ import annotations

import time as _time
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from modesel.errors import ModeselError, SimulationDiverged


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

    def f(t, x):
        counter[0] += 1
        q, qd = x[:n], x[n:]
        if not np.all(np.isfinite(x)):
            raise _Diverged("non-finite state", t)
        big = np.abs(q) > qb
        if np.any(big):
            raise _Diverged(f"coordinate {int(np.argmax(big))} beyond its physical bound", t)
        M, F = rhs_M_F(t, q, qd)
        try:
            qdd = np.linalg.solve(M, F)
        except np.linalg.LinAlgError:
            raise _Diverged("singular mass matrix", t) from None
        if not np.all(np.isfinite(qdd)):
            raise _Diverged("non-finite acceleration", t)
        return np.concatenate([qd, qdd])

    if atol is None:
        atol = 1e-10
    x0 = np.concatenate([q0, qd0])
    try:
        sol = solve_ivp(f, (0.0, tmax), x0, method=method, t_eval=t_eval, rtol=rtol, atol=atol,
                        max_step=max_step)
    except _Diverged as exc:
        raise SimulationDiverged(exc.reason, exc.t) from None
    if sol.status < 0:
        tfail = float(sol.t[-1]) if len(sol.t) else 0.0
        raise SimulationDiverged(f"integrator failed ({sol.message})", tfail)
    return Integration(sol.t, sol.y[:n].T, sol.y[n:].T, method, stiffness_ratio, counter[0])
