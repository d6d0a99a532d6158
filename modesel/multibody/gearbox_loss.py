"""Compiled twin of `gearbox.with_losses` (a lossy gearbox's row of the
equations and their solve; module doc of `gearbox`), a numba cfunc of
`kernel.LOSS_SIG` that the right-hand side `kernel.free_system` calls
through the pointer in the packed data (data[14]) where a body has a
gearbox loss.

Its own module and a cfunc, as `invariant_sums`: compiled inside the
kernel's right-hand side it lengthened every first run's compile by about
3 s (the right-hand side's cfunc alone, empty cache: 15.4-16.0 s -> 18.4-19.2
s); behind a pointer, only a scene with gearbox losses compiles it, on first
use (`packing.loss_function`).
"""
from __future__ import annotations

import numpy as np
from numba import cfunc, njit

from modesel.multibody.kernel import (COL0, INERTIA, KIND, LOSS, LOSS_ETA, LOSS_K, LOSS_SIG, NCOL, RIGID, SOLVE,
                                      SOLVE_HELD, cross3, free_rows, rotate_tensor, solve_free)


@njit(cache=True)
def _with_factor(factor, g, row, Fg, r, bias, given, M, F):
    """Row g of M and F with the generator's part taken `factor` times: the
    row without losses `row`, Fg plus (factor - 1) times r and bias + given."""
    for j in range(M.shape[0]):
        M[g, j] = row[j] + (factor - 1.0) * r[j]
    F[g] = Fg + (factor - 1.0) * (bias + given)


def _gearbox_loss(b, solve, free, presc, qddp, gen, bi, bf, ipool, R, vec, Jw, Ig, M, F, Mf, Ff, out, off):
    """Body b (a massless rigid body: an inertia about its origin; its frame
    R, vec = [r, v, w, a, alpha] and Jw) reaches the equation of coordinate
    g = bi[b, LOSS] - 1 through a gearbox of efficiency eta = bf[b, LOSS_ETA].
    Its row r of M on g (r_j = Jw_g^T I Jw_j) and its part of F_g (the bias
    -Jw_g^T (I alpha + w x I w)), with the generalised force given on g
    (gen[g]: the generator torque), are scaled by k = 1/eta while the shaft
    torque sigma = r qdd - bias - gen[g] >= 0, else by k = eta: the sign that
    the accelerations solved with it reproduce (solve = SOLVE; the factor is
    kept in bf[b, LOSS_K]). NO_SOLVE and SOLVE_HELD (the linear model's and
    Radau's differences) hold the factor last kept, as ElastoDyn holds the
    previous step's sign: sigma = 0 where the factor changes, so the
    solution is continuous there, but M and F each jump. Writes row g of M
    and F with the losses, then Mf, Ff from them; unless NO_SOLVE, the
    accelerations into out[off:]. Returns 0 if the mass matrix is singular."""
    g = bi[b, LOSS] - 1
    eta = bf[b, LOSS_ETA]
    n = M.shape[0]
    nf = free.shape[0]
    r = np.zeros(n)
    bias = 0.0
    if bi[b, KIND] == RIGID:
        rotate_tensor(R, bf[b, INERTIA:INERTIA + 9], Ig)
        w, al = vec[2], vec[4]
        u = np.zeros(3)
        Iw = np.zeros(3)
        for i in range(3):
            for k in range(3):
                u[i] += Ig[i, k] * Jw[k, g]
                Iw[i] += Ig[i, k] * w[k]
        gyr = cross3(w[0], w[1], w[2], Iw[0], Iw[1], Iw[2])
        for i in range(3):
            bias -= u[i] * al[i] + Jw[i, g] * gyr[i]
        c0, nc = bi[b, COL0], bi[b, NCOL]
        for cc in range(nc):
            col = ipool[c0 + cc]
            r[col] = u[0] * Jw[0, col] + u[1] * Jw[1, col] + u[2] * Jw[2, col]
    given = gen[g]
    row = M[g].copy()
    Fg = F[g]
    x = np.empty(nf)
    if solve != SOLVE:
        _with_factor(bf[b, LOSS_K], g, row, Fg, r, bias, given, M, F)
        if solve == SOLVE_HELD:
            free_rows(free, presc, qddp, M, F, Mf, Ff)
            if not solve_free(free, presc, qddp, M, F, Mf, Ff, x, False):
                return 0
            for a in range(nf):
                out[off + a] = x[a]
        free_rows(free, presc, qddp, M, F, Mf, Ff)
        return 1
    # the shaft torque's sign without losses, then with the factor it gives
    qdd = np.zeros(n)
    for k in range(presc.shape[0]):
        qdd[presc[k]] = qddp[presc[k]]
    if not solve_free(free, presc, qddp, M, F, Mf, Ff, x, True):     # Mf, Ff as `free_system` formed them
        return 0
    factor = 1.0
    for attempt in range(3):
        for a in range(nf):
            qdd[free[a]] = x[a]
        sigma = -bias - given
        for j in range(n):
            sigma += r[j] * qdd[j]
        wanted = 1.0 / eta if sigma >= 0.0 else eta
        if attempt > 0 and wanted == factor:
            break
        if attempt == 2:            # neither sign reproduces itself: keep the last
            break
        factor = wanted
        _with_factor(factor, g, row, Fg, r, bias, given, M, F)
        free_rows(free, presc, qddp, M, F, Mf, Ff)
        if not solve_free(free, presc, qddp, M, F, Mf, Ff, x, False):
            return 0
    bf[b, LOSS_K] = factor
    free_rows(free, presc, qddp, M, F, Mf, Ff)
    for a in range(nf):
        out[off + a] = x[a]
    return 1


gearbox_loss = cfunc(LOSS_SIG, cache=True)(_gearbox_loss)
