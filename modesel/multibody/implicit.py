"""Compiled Radau IIA (order 5) for M(q) qdd = F(q, qd, t), run entirely in
numba on the kernel's `free_system` (its cfunc, the loops' `system`
argument; method "compiled-Radau" of `integrate.py`).

The algorithm, step control, Newton iteration, error estimate and dense
output are those of scipy.integrate.Radau (Hairer & Wanner, Solving ODEs II,
sec. IV.8): three-stage collocation, simplified Newton with the real and
complex eigen-decomposition of the Radau matrix, third-order embedded error
estimate, Gustafsson's predictive step control, cubic collocation
polynomial as dense output. Three differences, none in what a step
computes once its Newton iteration has converged:

- The Jacobian of x = [q, qd], f = [qd, qdd(t, q, qd)] is
  J = [[0, I], [dqdd/dq, dqdd/dqd]]: the upper half is exact; the lower half
  is formed by forward differences of the compiled accelerations (one
  right-hand side per column, 2 n per Jacobian), with the BEM loads and the
  tower drag held at their values at x (`kernel.SOLVE_HELD`): a column then
  costs the structure and the generator alone, about half a full right-hand
  side on the 38-DOF turbine. The stiff part of J is the structure's
  (elastic stiffness, geometric stiffening, gyroscopic terms), which the
  held columns keep; what they leave out, the aerodynamic damping and
  stiffness (the flap-rate diagonal of the 11-DOF turbine at 11.4 m/s is
  -6.6 1/s with the BEM, under 0.2 1/s held: h |dJ| of about 0.3 at the
  38-DOF turbine's 40-ms steps), slows Newton's convergence a little (5374
  against 4974 right-hand sides of the iteration, 20 s of the 38-DOF turbine)
  and changes nothing it converges to. The generator's law is evaluated in
  every column (an induction generator's torque slope can be stiff).
- The Newton systems (c I - J) [u; v] = [r1; r2] (c = mu / h, real or
  complex) are solved through their n x n Schur complement
  (c^2 I - c B - A) u = r2 + (c I - B) r1, v = c u - r1 (A = dqdd/dq,
  B = dqdd/dqd), an LU of n instead of 2 n unknowns.
- A new Jacobian after slowly converging Newton iterations is taken less
  eagerly (JAC_AFTER_ITERATIONS, JAC_AFTER_RATE): on a turning rotor the
  Jacobian changes at every step and scipy's rule spent most right-hand
  sides on Jacobians.

Radau IIA is L-stable: modes far faster than the step are damped (that is
what lets the step follow the slow response); modes the step resolves keep
their damping to the error tolerance (order 5; the damping error of a mode
of angular frequency w with step h is O((w h)^5) per step).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from modesel.multibody.kernel import (BEYOND_BOUND, INTERRUPTED, NON_FINITE_ACC, NON_FINITE_STATE, OK, SOLVE,
                                      SOLVE_HELD, STEP_COLLAPSE, STOP_REQUEST, TIME_REACHED, lu_factor,
                                      lu_solve_factored, start)

S6 = 6 ** 0.5
C = np.array([(4 - S6) / 10, (4 + S6) / 10, 1.0])
E = np.array([-13 - 7 * S6, -13 + 7 * S6, -1.0]) / 3
MU_REAL = 3 + 3 ** (2 / 3) - 3 ** (1 / 3)
MU_COMPLEX = (3 + 0.5 * (3 ** (1 / 3) - 3 ** (2 / 3)) - 0.5j * (3 ** (5 / 6) + 3 ** (7 / 6)))
T = np.array([[0.09443876248897524, -0.14125529502095421, 0.03002919410514742],
              [0.25021312296533332, 0.20412935229379994, -0.38294211275726192],
              [1.0, 1.0, 0.0]])
TI = np.array([[4.17871859155190428, 0.32768282076106237, 0.52337644549944951],
               [-4.17871859155190428, -0.32768282076106237, 0.47662355450055044],
               [0.50287263494578682, -2.57192694985560522, 0.59603920482822492]])
P = np.array([[13 / 3 + 7 * S6 / 3, -23 / 3 - 22 * S6 / 3, 10 / 3 + 5 * S6],
              [13 / 3 - 7 * S6 / 3, -23 / 3 + 22 * S6 / 3, 10 / 3 - 5 * S6],
              [1 / 3, -8 / 3, 10 / 3]])
NEWTON_MAXITER = 6
MIN_FACTOR, MAX_FACTOR = 0.2, 10.0
#: relative forward-difference step of the Jacobian columns, and its floor (the
#: scale on which the equations are nonlinear: a metre, a radian, per second)
JAC_REL_STEP = np.sqrt(np.finfo(float).eps)
JAC_FLOOR = 1.0
#: a new Jacobian after a step whose Newton iteration took more than this many
#: iterations with a convergence rate above this (scipy: 2 and 1e-3; a Newton
#: failure always takes a new one). Measured on the 38-DOF turbine with BEM at
#: rtol 1e-5, 20 s: scipy's values 97 Jacobians, 11484 right-hand sides;
#: these 40 and 7918, the same steps (478 against 504) and tolerance. With the
#: held loads (cheaper columns): 3 iterations 72 Jacobians, 10776 right-hand
#: sides, 1.43 s; 4: 43, 8685, 1.20-1.22 s; 5: 38, 8520, 1.21 s.
JAC_AFTER_ITERATIONS = 4
JAC_AFTER_RATE = 0.1
TABLE = (C, E, T, TI, P)


@njit(cache=True)
def _factor(c, Ja, Jb, S, piv):
    """S = c^2 I - c B - A, factorised; False if singular."""
    n = Ja.shape[0]
    for i in range(n):
        for j in range(n):
            S[i, j] = -c * Jb[i, j] - Ja[i, j]
        S[i, i] += c * c
    return lu_factor(S, piv)


@njit(cache=True)
def _solve(c, Jb, S, piv, r, u, out):
    """(c I - J) out = r with J = [[0, I], [A, B]], through the factorised
    Schur complement S; r, out (2 n), u scratch (n), all of S's dtype."""
    n = Jb.shape[0]
    for i in range(n):
        v = r[n + i] + c * r[i]
        for j in range(n):
            v -= Jb[i, j] * r[j]
        u[i] = v
    lu_solve_factored(S, piv, u)
    for i in range(n):
        out[i] = u[i]
        out[n + i] = c * u[i] - r[i]


@njit(cache=True)
def jacobian(system, held, t, x, f, Ja, Jb, base, scratch, out, inf_bounds, prob, rwork, data, work, counts):
    """Lower half of the Jacobian at (t, x), f = f(t, x): Ja = dqdd/dq,
    Jb = dqdd/dqd by forward differences. held (bool): the columns hold the
    BEM loads and the tower drag at their values at x (`kernel.SOLVE_HELD`),
    differenced against a new evaluation at x into `base` (one more
    right-hand side, which also sets the held loads); f is then not read.
    counts[0] (right-hand sides) and counts[1] (Jacobians) are incremented.
    Returns a status code."""
    counts[1] += 1
    n = Ja.shape[0]
    mode = SOLVE
    ref = f
    if held:
        code, _ = system(t, x, base, SOLVE, inf_bounds, prob, rwork, data, work)
        counts[0] += 1
        if code != OK:
            return code
        mode = SOLVE_HELD
        ref = base
    for i in range(2 * n):
        scratch[i] = x[i]
    for j in range(2 * n):
        h = JAC_REL_STEP * max(abs(x[j]), JAC_FLOOR)
        scratch[j] = x[j] + h
        h = scratch[j] - x[j]
        code, _ = system(t, scratch, out, mode, inf_bounds, prob, rwork, data, work)
        counts[0] += 1
        scratch[j] = x[j]
        if code != OK:
            return code
        for i in range(n):
            d = (out[n + i] - ref[n + i]) / h
            if j < n:
                Ja[i, j] = d
            else:
                Jb[i, j - n] = d
    return OK


@njit(cache=True)
def _norm(e, scale):
    s = 0.0
    for i in range(e.shape[0]):
        v = e[i] / scale[i]
        s += v * v
    return np.sqrt(s / e.shape[0])


@njit(cache=True, nogil=True)
def radau5(system, x0, t_eval, tmax, rtol, atol, max_step, bounds, tab, prob, rwork, data, work, Y, control):
    """Radau IIA order 5 from x0 = [q, qd] over [0, tmax], outputs at t_eval
    (increasing, within [0, tmax]) into Y.

    control (2,): as `kernel.runge_kutta`'s (the time of each accepted step
    out, a stop request in); it runs without the GIL.

    Returns (status, time, n_rhs, n_out, index, n_jac, n_lu, n_steps):
    status OK, a divergence code of `free_system` (time = where it occurred),
    STEP_COLLAPSE or INTERRUPTED (time = the last accepted step)."""
    Cc, Ee, Tt, TIt, Pp = tab
    nx = x0.shape[0]
    n = nx // 2
    eps = np.finfo(np.float64).eps
    newton_tol = max(10 * eps / rtol, min(0.03, rtol ** 0.5))
    mu_r = MU_REAL
    mu_c = MU_COMPLEX
    inf_bounds = np.full(n, np.inf)
    y = x0.copy()
    f = np.empty(nx)
    f_new = np.empty(nx)
    f_held = np.empty(nx)
    y_new = np.empty(nx)
    scratch = np.empty(nx)
    tmp = np.empty(nx)
    scale = np.empty(nx)
    Ja = np.zeros((n, n))
    Jb = np.zeros((n, n))
    S_r = np.empty((n, n))
    S_c = np.empty((n, n), np.complex128)
    piv_r = np.empty(n, np.int64)
    piv_c = np.empty(n, np.int64)
    u_r = np.empty(n)
    u_c = np.empty(n, np.complex128)
    r_c = np.empty(nx, np.complex128)
    o_c = np.empty(nx, np.complex128)
    Z = np.zeros((3, nx))
    Z0 = np.zeros((3, nx))
    W = np.zeros((3, nx))
    dW = np.zeros((3, nx))
    F = np.zeros((3, nx))
    Q = np.zeros((nx, 3))
    y_old = x0.copy()
    ZE = np.empty(nx)
    err = np.empty(nx)
    counts = np.zeros(2, np.int64)          # right-hand sides and Jacobians of `jacobian`
    n_lu = 0
    n_steps = 0
    t = 0.0
    code, idx, h_abs, nfev = start(system, y, f, tmax, max_step, rtol, atol, 3, bounds, prob, rwork, data, work)
    if code != OK:
        return code, h_abs, nfev, 0, idx, 0, n_lu, n_steps
    h_abs_old = -1.0            # -1: none (scipy None)
    error_norm_old = -1.0
    code = jacobian(system, True, t, y, f, Ja, Jb, f_held, scratch, tmp, inf_bounds, prob, rwork, data,
                    work, counts)
    if code != OK:
        return code, t, nfev + counts[0], 0, -1, counts[1], n_lu, n_steps
    current_jac = True
    have_lu = False
    have_sol = False
    sol_t_old = 0.0
    sol_h = 1.0
    n_out = 0
    nt = t_eval.shape[0]
    # outputs at t = 0
    while n_out < nt and t_eval[n_out] <= 0.0:
        for i in range(nx):
            Y[n_out, i] = y[i]
        n_out += 1
    while t < tmax:
        min_step = 10 * abs(np.nextafter(t, np.inf) - t)
        h_abs_start = h_abs                 # scipy's self.h_abs: the next step's h_abs_old
        if h_abs > max_step:
            h_abs = max_step
            h_abs_old = -1.0
            error_norm_old = -1.0
        elif h_abs < min_step:
            h_abs = min_step
            h_abs_old = -1.0
            error_norm_old = -1.0
        rejected = False
        accepted = False
        h = 0.0
        m_r = 0.0
        m_c = 0.0j
        t_new = t
        n_iter = 0
        rate = -1.0
        error_norm = 0.0
        safety = 0.9
        while not accepted:
            if h_abs < min_step:
                return STEP_COLLAPSE, t, nfev + counts[0], n_out, -1, counts[1], n_lu, n_steps
            h = h_abs
            t_new = t + h
            if t_new > tmax:
                t_new = tmax
            h = t_new - t
            h_abs = abs(h)
            m_r = mu_r / h
            m_c = mu_c / h
            # initial guess: the previous step's collocation polynomial
            for s in range(3):
                if have_sol:
                    xx = (t + h * Cc[s] - sol_t_old) / sol_h
                    for i in range(nx):
                        Z0[s, i] = y_old[i] + Q[i, 0] * xx + Q[i, 1] * xx * xx + Q[i, 2] * xx * xx * xx - y[i]
                else:
                    for i in range(nx):
                        Z0[s, i] = 0.0
            for i in range(nx):
                scale[i] = atol[i] + abs(y[i]) * rtol
            converged = False
            while not converged:
                if not have_lu:
                    ok_r = _factor(m_r, Ja, Jb, S_r, piv_r)
                    ok_c = _factor(m_c, Ja, Jb, S_c, piv_c)
                    n_lu += 2
                    have_lu = ok_r and ok_c
                    if not have_lu:
                        break
                # simplified Newton iteration (scipy solve_collocation_system)
                for s in range(3):
                    for i in range(nx):
                        W[s, i] = TIt[s, 0] * Z0[0, i] + TIt[s, 1] * Z0[1, i] + TIt[s, 2] * Z0[2, i]
                        Z[s, i] = Z0[s, i]
                dW_norm_old = -1.0
                rate = -1.0
                converged = False
                n_iter = 0
                for kk in range(NEWTON_MAXITER):
                    n_iter = kk + 1
                    bad = False
                    for s in range(3):
                        for i in range(nx):
                            scratch[i] = y[i] + Z[s, i]
                        code, idx = system(t + Cc[s] * h, scratch, tmp, SOLVE, bounds, prob, rwork, data,
                                                work)
                        nfev += 1
                        if code != OK:
                            # a trial state outside the model (non-finite, beyond a bound): retry
                            # with a smaller step, as scipy does on a non-finite right-hand side
                            if code == NON_FINITE_STATE or code == BEYOND_BOUND or code == NON_FINITE_ACC:
                                bad = True
                                break
                            return code, t + Cc[s] * h, nfev + counts[0], n_out, idx, counts[1], n_lu, n_steps
                        for i in range(nx):
                            F[s, i] = tmp[i]
                    if bad:
                        break
                    for i in range(nx):
                        fr = F[0, i] * TIt[0, 0] + F[1, i] * TIt[0, 1] + F[2, i] * TIt[0, 2]
                        tmp[i] = fr - m_r * W[0, i]
                        fc = (F[0, i] * (TIt[1, 0] + 1j * TIt[2, 0]) + F[1, i] * (TIt[1, 1] + 1j * TIt[2, 1])
                              + F[2, i] * (TIt[1, 2] + 1j * TIt[2, 2]))
                        r_c[i] = fc - m_c * (W[1, i] + 1j * W[2, i])
                    _solve(m_r, Jb, S_r, piv_r, tmp, u_r, scratch)
                    _solve(m_c, Jb, S_c, piv_c, r_c, u_c, o_c)
                    dn = 0.0
                    for i in range(nx):
                        dW[0, i] = scratch[i]
                        dW[1, i] = o_c[i].real
                        dW[2, i] = o_c[i].imag
                        for s in range(3):
                            v = dW[s, i] / scale[i]
                            dn += v * v
                    dW_norm = np.sqrt(dn / (3 * nx))
                    if not np.isfinite(dW_norm):
                        break
                    if dW_norm_old >= 0.0:
                        rate = dW_norm / dW_norm_old
                    if rate >= 0.0 and (rate >= 1 or rate ** (NEWTON_MAXITER - kk) / (1 - rate) * dW_norm
                                        > newton_tol):
                        break
                    for s in range(3):
                        for i in range(nx):
                            W[s, i] += dW[s, i]
                    for s in range(3):
                        for i in range(nx):
                            Z[s, i] = Tt[s, 0] * W[0, i] + Tt[s, 1] * W[1, i] + Tt[s, 2] * W[2, i]
                    if dW_norm == 0 or (rate >= 0.0 and rate / (1 - rate) * dW_norm < newton_tol):
                        converged = True
                        break
                    dW_norm_old = dW_norm
                if not converged:
                    if current_jac:
                        break
                    code = jacobian(system, True, t, y, f, Ja, Jb, f_held, scratch, tmp, inf_bounds, prob, rwork,
                                    data, work, counts)
                    if code != OK:
                        return code, t, nfev + counts[0], n_out, -1, counts[1], n_lu, n_steps
                    current_jac = True
                    have_lu = False
            if not converged:
                h_abs *= 0.5
                have_lu = False
                continue
            for i in range(nx):
                y_new[i] = y[i] + Z[2, i]
                ZE[i] = (Z[0, i] * Ee[0] + Z[1, i] * Ee[1] + Z[2, i] * Ee[2]) / h
                tmp[i] = f[i] + ZE[i]
            _solve(m_r, Jb, S_r, piv_r, tmp, u_r, err)
            for i in range(nx):
                scale[i] = atol[i] + max(abs(y[i]), abs(y_new[i])) * rtol
            error_norm = _norm(err, scale)
            safety = 0.9 * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + n_iter)
            if rejected and error_norm > 1:
                for i in range(nx):
                    scratch[i] = y[i] + err[i]
                code, idx = system(t, scratch, tmp, SOLVE, inf_bounds, prob, rwork, data, work)
                nfev += 1
                if code == OK:
                    for i in range(nx):
                        tmp[i] += ZE[i]
                    _solve(m_r, Jb, S_r, piv_r, tmp, u_r, err)
                    error_norm = _norm(err, scale)
            if error_norm > 1:
                h_abs *= max(MIN_FACTOR, safety * _predict(h_abs, h_abs_old, error_norm, error_norm_old))
                have_lu = False
                rejected = True
            else:
                accepted = True
        n_steps += 1
        recompute_jac = n_iter > JAC_AFTER_ITERATIONS and rate > JAC_AFTER_RATE
        factor = min(MAX_FACTOR, safety * _predict(h_abs, h_abs_old, error_norm, error_norm_old))
        if not recompute_jac and factor < 1.2:
            factor = 1.0
        else:
            have_lu = False
        code, idx = system(t_new, y_new, f_new, SOLVE, bounds, prob, rwork, data, work)
        nfev += 1
        if code != OK:
            return code, t_new, nfev + counts[0], n_out, idx, counts[1], n_lu, n_steps
        if recompute_jac:
            code = jacobian(system, True, t_new, y_new, f_new, Ja, Jb, f_held, scratch, tmp, inf_bounds, prob,
                            rwork, data, work, counts)
            if code != OK:
                return code, t_new, nfev + counts[0], n_out, -1, counts[1], n_lu, n_steps
            current_jac = True
        else:
            current_jac = False
        h_abs_old = h_abs_start
        error_norm_old = error_norm
        h_abs = h_abs * factor
        # dense output Q = Z^T P on (t, t_new]
        for i in range(nx):
            y_old[i] = y[i]
            for c in range(3):
                Q[i, c] = Z[0, i] * Pp[0, c] + Z[1, i] * Pp[1, c] + Z[2, i] * Pp[2, c]
        have_sol = True
        sol_t_old = t
        sol_h = h
        t = t_new
        for i in range(nx):
            y[i] = y_new[i]
            f[i] = f_new[i]
        while n_out < nt and (t_eval[n_out] <= t or t >= tmax):
            xx = (t_eval[n_out] - sol_t_old) / sol_h
            for i in range(nx):
                Y[n_out, i] = y_old[i] + Q[i, 0] * xx + Q[i, 1] * xx * xx + Q[i, 2] * xx * xx * xx
            n_out += 1
        control[TIME_REACHED] = t
        if control[STOP_REQUEST] != 0.0 and t < tmax:
            return INTERRUPTED, t, nfev + counts[0], n_out, -1, counts[1], n_lu, n_steps
    return OK, t, nfev + counts[0], n_out, -1, counts[1], n_lu, n_steps


@njit(cache=True)
def _predict(h_abs, h_abs_old, error_norm, error_norm_old):
    """scipy radau predict_factor (Hairer & Wanner IV.8); negative old values mean none."""
    if error_norm_old < 0.0 or h_abs_old < 0.0 or error_norm == 0:
        multiplier = 1.0
    else:
        multiplier = h_abs / h_abs_old * (error_norm_old / error_norm) ** 0.25
    if error_norm == 0:
        return np.inf
    return min(1.0, multiplier) * error_norm ** -0.25
