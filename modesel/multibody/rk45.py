"""Compiled Dormand-Prince 5(4) ("compiled-RK45" of `integrate.py`), run
entirely in numba on the kernel's `free_system`.

The method, step control, initial step and dense output are those of
scipy.integrate.RK45 (Dormand & Prince 1980; Hairer, Norsett & Wanner,
Solving ODEs I, II.4-5): six stages and the first stage of the next step
(FSAL), fourth-order error estimate (error exponent -1/5), quartic dense
output. The tableau is held here as numbers, so a compiled run does not
import scipy.integrate; `tests/test_kernel.py` holds it equal to scipy's
class attributes bit for bit and the loop equal to scipy's steps.

Why a fifth-order method beside DOP853: a turbine with BEM has a
right-hand side with kinks (AeroDyn's polars are interpolated linearly in
the angle of attack, so every element crossing a table angle bends the
loads). An eighth-order step is no more accurate across a kink than a
fifth-order one, and it costs twice the stages; at the loose tolerances of
an OpenFAST case it spends most of its right-hand sides on rejected steps
(`integrate.LOW_ORDER_RTOL`).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from modesel.multibody.kernel import OK, SOLVE, STEP_COLLAPSE, free_system, rk_stage, start

#: stage nodes, coefficients and weights (scipy RK45.C, A, B)
C = np.array([0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1])
A = np.array([
    [0, 0, 0, 0, 0],
    [1 / 5, 0, 0, 0, 0],
    [3 / 40, 9 / 40, 0, 0, 0],
    [44 / 45, -56 / 15, 32 / 9, 0, 0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
])
B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
#: error estimator (difference of the fifth- and fourth-order weights, with the FSAL stage)
E = np.array([-71 / 57600, 0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
#: dense output: y(t + x h) = y + h sum_k (K^T P)[:, k] x^(k+1)
P = np.array([
    [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0, 0, 0, 0],
    [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
    [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
])
TABLE = (A.astype(float), B.astype(float), C.astype(float), E.astype(float), P.astype(float))


@njit(cache=True)
def rk45(x0, t_eval, tmax, rtol, atol, max_step, bounds, tab, prob, rwork, data, work, Y):
    """Dormand-Prince 5(4) with the step control, initial step and dense
    output of scipy.integrate.RK45, evaluated at t_eval (increasing, within
    [0, tmax]) into Y.

    Returns (status, time, n_rhs, n_out, index) as `kernel.dop853`."""
    A, B, C, E, P = tab
    nx = x0.shape[0]
    n_stages = B.shape[0]
    K = np.zeros((n_stages + 1, nx))
    y = x0.copy()
    y_new = np.empty(nx)
    f = np.empty(nx)
    f_new = np.empty(nx)
    ys = np.empty(nx)
    Q = np.empty((nx, P.shape[1]))
    err_exp = -1.0 / 5.0                     # error estimator order 4
    SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0
    t = 0.0
    code, idx, h_abs, nfev = start(y, f, tmax, max_step, rtol, atol, 4, bounds, prob, rwork, data, work)
    if code != OK:
        return code, h_abs, nfev, 0, idx
    n_out = 0
    nt = t_eval.shape[0]
    while t < tmax:
        min_step = 10 * abs(np.nextafter(t, np.inf) - t)
        if h_abs > max_step:
            h_abs = max_step
        elif h_abs < min_step:
            h_abs = min_step
        accepted = False
        rejected = False
        h = 0.0
        t_new = t
        while not accepted:
            if h_abs < min_step:
                return STEP_COLLAPSE, t, nfev, n_out, -1
            h = h_abs
            t_new = t + h
            if t_new > tmax:
                t_new = tmax
            h = t_new - t
            h_abs = abs(h)
            for i in range(nx):
                K[0, i] = f[i]
            for s in range(1, n_stages):
                code, idx = rk_stage(s, t, h, y, K, ys, A, C, bounds, prob, rwork, data, work)
                nfev += 1
                if code != OK:
                    return code, t + C[s] * h, nfev, n_out, idx
            for i in range(nx):
                acc = 0.0
                for j in range(n_stages):
                    acc += K[j, i] * B[j]
                y_new[i] = y[i] + h * acc
            code, idx = free_system(t + h, y_new, f_new, SOLVE, bounds, prob, rwork, data, work)
            nfev += 1
            if code != OK:
                return code, t + h, nfev, n_out, idx
            for i in range(nx):
                K[n_stages, i] = f_new[i]
            # error estimate (scipy RK45._estimate_error_norm: rms of h K^T E / scale)
            s2 = 0.0
            for i in range(nx):
                scale = atol[i] + max(abs(y[i]), abs(y_new[i])) * rtol
                acc = 0.0
                for j in range(n_stages + 1):
                    acc += K[j, i] * E[j]
                v = acc * h / scale
                s2 += v * v
            error_norm = np.sqrt(s2 / nx)
            if error_norm < 1:
                if error_norm == 0:
                    factor = MAX_FACTOR
                else:
                    factor = min(MAX_FACTOR, SAFETY * error_norm ** err_exp)
                if rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                accepted = True
            else:
                h_abs *= max(MIN_FACTOR, SAFETY * error_norm ** err_exp)
                rejected = True
        t_old = t
        t = t_new
        # dense output on the outputs in (t_old, t] (all remaining at the end)
        if n_out < nt and (t_eval[n_out] <= t or t >= tmax):
            for i in range(nx):
                for k in range(P.shape[1]):
                    acc = 0.0
                    for j in range(n_stages + 1):
                        acc += K[j, i] * P[j, k]
                    Q[i, k] = acc
            while n_out < nt and (t_eval[n_out] <= t or t >= tmax):
                xx = (t_eval[n_out] - t_old) / h
                for i in range(nx):
                    v = 0.0
                    p = 1.0
                    for k in range(P.shape[1]):
                        p *= xx
                        v += Q[i, k] * p
                    Y[n_out, i] = y[i] + h * v
                n_out += 1
        for i in range(nx):
            y[i] = y_new[i]
            f[i] = f_new[i]
    return OK, t, nfev, n_out, -1
