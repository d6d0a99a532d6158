"""Time integration of M(q) qdd = F(q, qd, t): one front function,
`integrate`, and named methods (`METHODS`), each reported by its name:

- "compiled-DOP853": Dormand-Prince 8(5,3) with scipy's DOP853 step
  control, initial step and dense output, run entirely in the numba kernel
  (`kernel.runge_kutta`) on a `CompiledRHS` whose prescribed coordinates are
  polynomial in t (`CompiledRHS.compilable`); its outputs equal scipy's
  DOP853 to round-off;
- "compiled-RK45": Dormand-Prince 5(4) with scipy's RK45 step control,
  initial step and dense output, run by the same compiled loop
  (`kernel.runge_kutta`) with its own tableau (`rk45_tableau`); its outputs
  equal scipy's RK45 to round-off;
- "compiled-Radau": Radau IIA of order 5 with scipy's algorithm (Newton
  iteration, step control, error estimate, dense output), run entirely in
  the numba kernel (`implicit.radau5`) with the Jacobian of the compiled
  right-hand side (velocity rows exact, acceleration rows by compiled
  forward differences); L-stable, so modes far faster than the step are
  damped while the step follows the slow response;
- scipy's methods by their own names ("DOP853", "Radau", "RK45", "BDF",
  "LSODA") through `solve_ivp`, on any callable (t, q, qd) -> (M, F), or on
  a `CompiledRHS`, whose accelerations are then solved in the kernel.

Method choice (`choose_method`, "auto"): the scene is linearised at its
initial state; with stiffness ratio r = omega_max / omega_min of the
non-zero natural frequencies and N = omega_max * tmax / (2 pi) cycles of the
fastest mode, an explicit Runge-Kutta method is used when r < STIFF_RATIO = 80
(`explicit_method`: Dormand-Prince 5(4) for a right-hand side with kinks,
the BEM loads, at a relative tolerance of LOW_ORDER_RTOL = 1e-6 or looser,
else DOP853; "compiled-" when the right-hand side runs compiled), else the implicit Radau IIA method, whose
step is not limited by the fastest mode ("compiled-Radau" when the
right-hand side runs compiled, else scipy's "Radau"). The choice and the
numbers behind it are returned with the result.

BLAS threads: the kernel's small matrix products (a few hundred rows) call
the BLAS of numpy/scipy, whose worker threads only add synchronisation at
these sizes (a 41-DOF right-hand side took 40-100 ms instead of 0.3 ms on
a loaded 2-core machine); `integrate` runs with one BLAS thread
(`blas.single_thread_blas`) and restores the previous count.

Divergence detection: non-finite accelerations, states beyond physical bounds
(elastic tip displacement above half the beam length, rigid rates above
1e3 rad/s) or a step-size collapse stop the run with `SimulationDiverged`
(reason, time).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from modesel.errors import ModeselError, SimulationDiverged
from modesel.multibody import dop853_tableau, kernel
from modesel.multibody.blas import single_thread_blas
from modesel.multibody.compiled import CompiledRHS

COMPILED_DOP853 = "compiled-DOP853"
COMPILED_RK45 = "compiled-RK45"
COMPILED_RADAU = "compiled-Radau"
SCIPY_METHODS = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
METHODS = (COMPILED_DOP853, COMPILED_RK45, COMPILED_RADAU) + SCIPY_METHODS
COMPILED_METHODS = (COMPILED_DOP853, COMPILED_RK45, COMPILED_RADAU)
#: relative tolerance from which "auto" integrates a right-hand side with
#: kinks explicitly with Dormand-Prince 5(4) instead of DOP853. With BEM it has
#: kinks (polars interpolated linearly in the angle of attack), across which
#: an eighth-order step is no more accurate than a fifth-order one at twice
#: the stages. Measured against compiled-DOP853 at rtol 1e-10 (largest error
#: of any coordinate or rate over the run, relative to its range):
#: steady_08, 100 s: DOP853 at rtol 1e-5 / atol 1e-6 15242 right-hand
#: sides, error 9.7e-4; RK45 at 3e-6 / 3e-7 11252, 9.9e-4. steady_11p4,
#: 20 s: 7316, 4.5e-4; 4226, 8.4e-4. turbine_wind_11p4, both at its own
#: 1e-5 / 1e-5, 20 s: 3458, 6.5e-2 (the drivetrain's rate); 1436, 1.9e-2
#: (`python3 benchmarks/bench_methods.py SCENE --tmax T`). A smooth one keeps
#: DOP853: the parked OpenFAST release (no aero), 20 s, DOP853 at 1e-5 / 1e-6
#: 4250 right-hand sides, error 1.4e-4; RK45 at 1e-5 / 1e-6 4646, 2.0e-4.
LOW_ORDER_RTOL = 1e-6
#: stiffness ratio omega_max / omega_min from which "auto" integrates implicitly:
#: where the two compiled methods cost the same. Measured (10 s each, the
#: scene's tolerances for both methods, idle 2-core machine; wall of the whole
#: `simulate`, DOP853 / Radau): NREL 5-MW at 11.4 m/s with BEM, ratio 12 (1 mode
#: per field) 0.31 / 0.37 s, 37 (cosine:2) 0.53 / 0.62 s, 51 (clamped:2) 0.69 /
#: 0.66 s, 57 (fem:2) 1.13 / 1.12 s, 69 (cosine:3) 0.97 / 0.96 s, 93 (clamped:3)
#: 1.20 / 0.98 s, 111 (fem:3) 2.23 / 1.39 s, 166 (fem:4) 3.31 / 1.69 s; parked
#: turbine fem:3, ratio 53, 1.55 / 1.70 s; steady_08, ratio 12, 0.44 / 0.63 s.
#: (It was 200, which left the 29- and 38-DOF turbines on the explicit method
#: at 1.6-2 times the cost.)
STIFF_RATIO = 80.0
IMPLICIT_METHODS = (COMPILED_RADAU, "Radau", "BDF")
#: default (rtol, atol [m, rad, m/s, rad/s]) where the scene sets none.
#: Explicit: 1e-8, 1e-10. Implicit: 1e-6, 1e-6: Radau's step control keeps
#: its global error far below the tolerance (3-DOF land model with cosine:6
#: per tower direction, 13 DOFs, 20 s of a 1-m free decay, against
#: compiled-DOP853 at rtol 1e-11: tower-top error 5e-12 m at 1e-8/1e-10,
#: 5.2e-8 m at 1e-6/1e-6, rotor azimuth 1.2e-8 rad; compiled-DOP853 at its
#: default 1.9e-10 m), and 1e-8/1e-10 would cost it 7 times the steps.
DEFAULT_TOLERANCES = {"explicit": (1e-8, 1e-10), "implicit": (1e-6, 1e-6)}


def default_tolerances(method: str) -> tuple[float, float]:
    """(rtol, atol) of `method` where the scene sets none (DEFAULT_TOLERANCES)."""
    return DEFAULT_TOLERANCES["implicit" if method in IMPLICIT_METHODS else "explicit"]


#: the Butcher tableau of compiled-DOP853: scipy's DOP853 with its extra
#: dense-output stages (A 16x16, B, C 16, E3, E5, D), held as numbers in
#: `dop853_tableau` (equal to scipy's class attributes, tests/test_kernel.py)
_DOP853_TABLE = dop853_tableau.TABLE
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
    """Whether `rhs_M_F` can be integrated by the compiled methods (`COMPILED_METHODS`)."""
    return isinstance(rhs_M_F, CompiledRHS) and rhs_M_F.compilable


def explicit_method(rtol: float | None = None, compiled: bool = True, kinked: bool = False) -> str:
    """The explicit method "auto" takes at relative tolerance `rtol` (None:
    the explicit default): Dormand-Prince 5(4) for a right-hand side with
    kinks (`kinked`: BEM loads on linearly interpolated polars) from
    LOW_ORDER_RTOL on, else DOP853; "compiled-" when `compiled`."""
    rtol = DEFAULT_TOLERANCES["explicit"][0] if rtol is None else float(rtol)
    if kinked and rtol >= LOW_ORDER_RTOL:
        return COMPILED_RK45 if compiled else "RK45"
    return COMPILED_DOP853 if compiled else "DOP853"


def choose_method(omegas: np.ndarray, requested: str = "auto", rhs=None, rtol=None,
                  kinked: bool = False) -> tuple[str, float]:
    """(method, stiffness ratio) from the natural frequencies [rad/s]:
    `requested` unless "auto"; "auto" gives the implicit Radau IIA for a
    ratio of STIFF_RATIO or more, else the explicit method of `rtol` (the
    scene's relative tolerance, None for the default) and `kinked`
    (`explicit_method`); each "compiled-" when `rhs` runs compiled."""
    w = np.abs(omegas[np.abs(omegas) > 1e-6])
    ratio = float(w.max() / w.min()) if len(w) else 1.0
    if requested != "auto":
        return requested, ratio
    compiled = runs_compiled(rhs)
    if ratio >= STIFF_RATIO:
        return (COMPILED_RADAU if compiled else "Radau"), ratio
    return explicit_method(rtol, compiled, kinked), ratio


def integrate(rhs_M_F, q0, qd0, tmax, dt, *, method="DOP853", rtol=1e-8, atol=None, max_step=np.inf,
              bounds=None, stiffness_ratio=float("nan"), progress=None) -> Integration:
    """Integrate from (q0, qd0) over [0, tmax] [s], output every dt [s],
    with the named `method` (one of `METHODS`).

    rhs_M_F(t, q, qd) -> (M, F), or a `CompiledRHS`. bounds: (n,) maximum
    |q| per coordinate (inf = unbounded) used for divergence detection.
    progress: optional progress(t, tmax) called every 64 right-hand-side
    evaluations of the scipy methods, about every quarter second of the
    compiled ones (which run in a watched thread, `watch.run_watched`)."""
    n = len(q0)
    t_eval = np.arange(0.0, tmax + 0.5 * dt, dt)
    t_eval = t_eval[t_eval <= tmax + 1e-12]
    qb = np.full(n, np.inf) if bounds is None else np.asarray(bounds, float)
    if atol is None:
        atol = 1e-10
    x0 = np.concatenate([q0, qd0]).astype(float)
    with single_thread_blas():
        if method in COMPILED_METHODS:
            if not runs_compiled(rhs_M_F):
                raise ModeselError(f"{method} needs a compiled right-hand side with prescribed motion "
                                   "polynomial in time (and every load effect in compiled form)",
                                   field="solver.method")
            return _integrate_compiled(rhs_M_F, x0, t_eval, float(tmax), rtol, atol, max_step, qb,
                                       stiffness_ratio, method, progress)
        return _integrate_scipy(rhs_M_F, x0, t_eval, tmax, method, rtol, atol, max_step, qb, stiffness_ratio,
                                progress)


def _integrate_scipy(rhs_M_F, x0, t_eval, tmax, method, rtol, atol, max_step, qb, stiffness_ratio, progress):
    """scipy's solve_ivp with the named method."""
    n = len(x0) // 2
    counter = [0]
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

    from scipy.integrate import solve_ivp          # here: compiled runs do not import scipy.integrate
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


def _integrate_compiled(rhs, x0, t_eval, tmax, rtol, atol, max_step, bounds, stiffness_ratio,
                        method=COMPILED_DOP853, progress=None) -> Integration:
    """compiled-DOP853, compiled-RK45 or compiled-Radau: the method entirely
    in the kernel (same algorithm and tolerances as solve_ivp's DOP853 /
    RK45 / Radau), in a thread that this one watches (`watch.run_watched`:
    progress about every quarter second, Ctrl-C stops it after its step)."""
    nx = len(x0)
    rtol = max(float(rtol), 100 * np.finfo(float).eps)     # as scipy validate_tol
    atol = np.broadcast_to(np.asarray(atol, float), (nx,)).copy()
    if np.any(atol < 0):
        raise ModeselError("atol must be non-negative", field="solver.atol")
    if not max_step > 0:
        raise ModeselError("max_step must be positive", field="solver.max_step")
    info = {}
    if method == COMPILED_RADAU:
        code, t_stop, nfev, idx, Y, info = rhs.radau(x0, t_eval, tmax, rtol, atol, float(max_step), bounds,
                                                     progress)
    elif method == COMPILED_RK45:
        code, t_stop, nfev, idx, Y = rhs.rk45(x0, t_eval, tmax, rtol, atol, float(max_step), bounds, progress)
    else:
        code, t_stop, nfev, idx, Y = rhs.dop853(x0, t_eval, tmax, rtol, atol, float(max_step), bounds,
                                                _DOP853_TABLE, progress)
    if code == kernel.INTERRUPTED:      # only on a stop request, whose exception is on its way
        raise KeyboardInterrupt
    if code == kernel.STEP_COLLAPSE:
        raise SimulationDiverged("integrator failed (Required step size is less than spacing between numbers.)",
                                 float(t_stop))
    if code == kernel.BEYOND_BOUND:
        raise SimulationDiverged(_beyond(idx), float(t_stop))
    if code != kernel.OK:
        raise SimulationDiverged(_REASONS[code], float(t_stop))
    n = nx // 2
    return Integration(t_eval[:len(Y)].copy(), Y[:, :n].copy(), Y[:, n:].copy(), method,
                       stiffness_ratio, int(nfev), info)
