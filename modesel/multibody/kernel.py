"""Compiled (numba) Kane equations M(q) qdd = F(q, qd, t) and the explicit
DOP853 loop that integrates them without returning to Python.

Same mathematics as the numpy reference in `kane.py` (first paper
eq. 4-22, Appendix A and D1/D4), reorganised for speed only:

- the system is packed once into flat arrays (`packing.pack`; the array
  layout is defined here, next to the code that reads it, so that numba's
  on-disk cache is invalidated whenever either changes);
- Jacobian work is restricted to the columns that can be non-zero for a body
  (the coordinates of its ancestors' joints, intersected with the coordinates
  whose equations are needed), so a fixed-base tower costs no Jacobian work;
- a flexible body without elastic coordinates is a rigid body (its node sums
  A2-A7 formed at pack time, eq. 6-7 about its centre of mass), and rigid
  bodies on constant joints are lumped into their rigid parent at pack time
  (rigid blades into the hub, `lumping.py`): same mass, centre of mass and
  inertia, exact to round-off;
  node polar inertia keeps the flexible form of eq. A with t = [0, e_g]
  (no gyroscopic term, like the reference);
- flexible-body sums are formed in the body frame and the 6+ne blocks
  rotated once (p = R s, B = R B_loc; B^T B is invariant): over the N
  nodes (O(N ne^2), two matrix products), or, where cheaper, from the
  body's invariants formed at pack time (`body_integrals`; the cfunc
  `invariant_sums`, called through a pointer in the packed data, outside
  this file: compiled apart, it does not lengthen the compile of every loop
  that calls `_flexible`);
- the mass matrix of the free coordinates is solved by Cholesky (with a
  lossy gearbox, whose row makes it unsymmetric, by Gaussian elimination in
  the cfunc `gearbox_loss`, called through a pointer in the packed data).

Kernels take the packed arrays `data` and reusable `work` arrays (tuples).
All compiled code of the engine's equations is in this one file, but for the
functions it receives as pointers (the invariant route, the effects' loads),
whose code it does not hold. The right-hand side `free_system` is compiled
once, as a cfunc (`system_function`), which the loops (`runge_kutta`,
`reaction_loads`, `implicit.radau5`) take as their first argument: numba
would otherwise compile the whole right-hand side again into each loop that
calls it. `assemble` is inlined into it (numba IR), for the same reason:
each separately compiled layer re-optimises all it calls (the right-hand
side's compile alone, empty cache: 24.0 s with `assemble` apart, 19.7-20.4 s
inlined). The Python front is `compiled.CompiledRHS`; `engine_cache`
drops numba's cache when any engine source changes.
"""
from __future__ import annotations

import warnings

import numpy as np
from numba import njit, types
from numba.core.errors import NumbaExperimentalFeatureWarning

from modesel.multibody.blas import load_scipy_blas

# scipy's BLAS module loaded alone before numba's target first compiles or loads
# (`view2` below compiles at import): else numba imports the package scipy.linalg
load_scipy_blas()

# the loads function is a first-class function argument (one compiled loop for
# every scene, cached on disk); numba calls the feature experimental
warnings.filterwarnings("ignore", category=NumbaExperimentalFeatureWarning)

# reassociation and FMA for the node sums; no finite-math assumption, so NaN
# and inf still propagate to the divergence checks
_FAST = {"reassoc", "contract", "nsz"}

# body_int columns
(PARENT, KIND, ROT0, NROT, SH0, NSH, COL0, NCOL, NODE0, NNODE, NE, E0, HAS_S, HAS_JP, HAS_ETA, HAS_A,
 PHI0, S0, ETA0, KD0, INV0, NS, SIX0, LOAD0, NLOAD, LOSS) = range(26)
N_INT = 26
# INV0: offset of a flexible body's invariants in the float pool (0: it
# takes the node sums), NS its number of shortening modes, SIX0 the offset of
# its header for the invariant route in the int pool (`invariant_sums`:
# ne, ns, first load row, load row count, INV0, Phi of the load rows,
# shortening modes, position of each elastic coordinate among them).
# LOAD0, NLOAD: a flexible body's rows of the node loads (fnodes): its nodes
# (LOAD0 = NODE0), or its load points (`packing.with_load_points`)
# LOSS: 1 + the coordinate whose equation the body reaches through a lossy
# gearbox (`gearbox_loss.py`; 0: none), with its efficiency in body_float LOSS_ETA
# body kinds
SKIP, RIGID, FLEX, LUMPED = 0, 1, 2, 3
# body_float columns: offset(3) R0(9) mass cm(3) inertia_cm(9) axis(3) polar tensor(9) shortening axis(3)
# gearbox efficiency, its loss factor last decided (`gearbox_loss.py`)
OFF, R0, MASS, CM, INERTIA, AXIS, POLAR, SH_E, LOSS_ETA, LOSS_K = 0, 3, 12, 13, 16, 25, 28, 37, 40, 41
N_FLOAT = 42


# signature of a loads function (the effects' loads inside the compiled loop):
# (t, q_all, qd_all, R, vec, gen, fnodes, fflag, ints, floats, state, held) -> status;
# R, vec: the body frames of `kinematics` at (q_all, qd_all); it adds
# generalised forces to gen (n_all,) [N, N m] and inertial node loads to
# fnodes (rows of the packed node layout, or of a body's load points:
# `packing.with_load_points`; columns 0-2 the force [N], 3-5 the moment
# [N m]: `_add_node_forces`, `_flexible`), setting fflag[b] = 1 for each
# body it loads (fnodes and fflag are zero on entry); ints, floats: its packed
# parameters; state: its scratch and latched state; held (0 or 1): 1 keeps
# the loads of the effects that are costly and not stiff (the BEM loads, the
# tower drag) as the previous call left them (fnodes and fflag are then not
# cleared), for the columns of Radau's Jacobian (`SOLVE_HELD`). Status OK or
# NON_FINITE_ACC.
# It must be a numba cfunc (typed as a first-class function, so the loop that
# calls it is compiled once for every scene and cached); a problem without
# loads passes `no_loads.no_loads`, which adds none.
_F1, _F2, _F3, _I1 = types.float64[::1], types.float64[:, ::1], types.float64[:, :, ::1], types.int64[::1]
_I2 = types.int64[:, ::1]
LOADS_SIG = types.int64(types.float64, _F1, _F1, _F3, _F3, _F1, _F2, _I1, _I1, _F1, _F1, types.int64)

# signature of the invariant route of a flexible body (`invariant_sums.py`,
# called by `_flexible` through the pointer in data[13]): (offset of the
# body's header in the int pool, loaded, int pool, float pool, scratch with
# its inputs and outputs, node forces) -> mass
INVARIANT_SIG = types.float64(types.int64, types.int64, _I1, _F1, _F1, _F2)

# signature of a lossy gearbox's row and solve (`gearbox_loss.gearbox_loss`, called by
# `free_system` through the pointer in data[14] where a body has LOSS > 0): (body,
# solve mode, free, prescribed, qdd_p, gen, body_int, body_float, int pool, the body's
# R (3,3), vec (5,3) and Jw (3,n), scratch (3,3), M, F, Mf, Ff, out, offset of the
# accelerations in out) -> 1, or 0 if the mass matrix is singular
LOSS_SIG = types.int64(types.int64, types.int64, _I1, _I1, _F1, _F1, _I2, _F2, _I1, _F2, _F2, _F2,
                       _F2, _F2, _F1, _F2, _F1, _F1, types.int64)

# numba types of the kernel's arguments: prob and rwork (`compiled.CompiledRHS`),
# data and work (`packing.pack`; the layouts above and in `_work_arrays`)
_B1 = types.boolean[::1]
PROB_T = types.Tuple((_I1, _I1, _F2, _F1, _F1, _I2, _F2, _F2, _I1,
                      types.Tuple((types.FunctionType(LOADS_SIG), _I1, _F1, _F1))))
RWORK_T = types.Tuple((_F2, _F2, _F1, _F2, _F1))
DATA_T = types.Tuple((_I2, _F2, _I1, _I1, _F2, _F1, _F3, _F3, _F2, _F1, _F1, _F1, _B1,
                      types.FunctionType(INVARIANT_SIG), types.FunctionType(LOSS_SIG)))
WORK_T = types.Tuple((_F3, _F3, _F3, _F3, _F3, _F3, _F2, _F3, _F2, _F1, _F2, _F3, _F2, _F1, _F1, _F2))

# signature of `free_system`, the right-hand side, which the loops below and in
# `implicit.py` call through a pointer (`system_function.FREE_SYSTEM`, a cfunc):
# (t, x, out, solve, bounds, prob, rwork, data, work) -> (status, index);
# solve: NO_SOLVE, SOLVE or SOLVE_HELD (`free_system`)
SYSTEM_SIG = types.UniTuple(types.int64, 2)(types.float64, _F1, _F1, types.int64, _F1, PROB_T, RWORK_T, DATA_T,
                                            WORK_T)


# ------------------------------------------------------------------ small helpers
@njit(["float64[:, ::1](float64[::1], int64, int64, int64)",
       "int64[:, ::1](int64[::1], int64, int64, int64)"], cache=True)
def view2(a, offset, n0, n1):
    """a[offset:offset + n0 n1] as an (n0, n1) array: one compiled reshape that
    the many views of the kernel and of the effects' records
    (`model.effects.compiled`) call, instead of numba's reshape and its
    shape-error path compiled at each of them (`view3` likewise; about 40 ms
    of compile each); its signatures, given, keep literal sizes from
    compiling copies of it."""
    return a[offset:offset + n0 * n1].reshape((n0, n1))


@njit(["float64[:, :, ::1](float64[::1], int64, int64, int64, int64)"], cache=True)
def view3(a, offset, n0, n1, n2):
    """a[offset:offset + n0 n1 n2] as an (n0, n1, n2) array (`view2`)."""
    return a[offset:offset + n0 * n1 * n2].reshape((n0, n1, n2))


@njit(["float64[:, :, :, ::1](float64[::1], int64, int64, int64, int64, int64)"], cache=True)
def view4(a, offset, n0, n1, n2, n3):
    """a[offset:offset + n0 n1 n2 n3] as an (n0, n1, n2, n3) array (`view2`)."""
    return a[offset:offset + n0 * n1 * n2 * n3].reshape((n0, n1, n2, n3))


@njit(cache=True)
def cross3(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True)
def _right_rotate(Q, axis, angle):
    """Q <- Q Rot(axis, angle), Rot the elementary rotation body -> parent."""
    c, s = np.cos(angle), np.sin(angle)
    if axis == 0:
        i1, i2 = 1, 2
    elif axis == 1:
        i1, i2 = 2, 0
    else:
        i1, i2 = 0, 1
    for r in range(3):
        x, y = Q[r, i1], Q[r, i2]
        Q[r, i1] = c * x + s * y
        Q[r, i2] = -s * x + c * y


@njit(cache=True)
def _mv(A, x, out):
    """out = A x for 3x3 A."""
    for i in range(3):
        out[i] = A[i, 0] * x[0] + A[i, 1] * x[1] + A[i, 2] * x[2]


@njit(cache=True)
def _mtv(A, x, out):
    """out = A^T x for 3x3 A."""
    for i in range(3):
        out[i] = A[0, i] * x[0] + A[1, i] * x[1] + A[2, i] * x[2]


# --------------------------------------------------------------------- kinematics
@njit(cache=True)
def kinematics(q, qd, data, work):
    """Recursive kinematics (parents first) of every body frame, as
    `KaneEquations.kinematics`: rotation R, position r, velocity v, angular
    velocity w, bias accelerations a, alpha (qdd = 0) and the Jacobians
    Jv = dv/dqd, Jw = dw/dqd (partial velocities, eq. 8 and 20) on the
    body's columns. Results in work (R, vec = [r, v, w, a, alpha], Jv, Jw)."""
    bi, bf, ipool, rot_axis, rot_c, rot_off, A, shG, active = (data[0], data[1], data[2], data[3], data[4],
                                                                data[5], data[6], data[7], data[12])
    R, vec, Jv, Jw, m3n = work[0], work[1], work[2], work[3], work[4]
    nb = bi.shape[0]
    n = q.shape[0]
    Jwrel = m3n[0]
    Jrho = m3n[1]
    P = np.empty((3, 3))
    Q = np.empty((3, 3))
    t3 = np.empty((9, 3))   # w_rel, alpha_rel, rho_loc, acc_loc, rhod_loc, rho, rhod, P w_rel, Rp acc
    wrel, alrel, rho_loc, acc_loc, rhod_loc, rho, rhod, Pw, Racc = (t3[0], t3[1], t3[2], t3[3], t3[4], t3[5],
                                                                    t3[6], t3[7], t3[8])
    for b in range(nb):
        p = bi[b, PARENT]
        if p < 0:
            p = nb
        c0, nc = bi[b, COL0], bi[b, NCOL]
        Rp = R[p]
        for i in range(3):
            for j in range(3):
                P[i, j] = (Rp[i, 0] * bf[b, R0 + j] + Rp[i, 1] * bf[b, R0 + 3 + j]
                           + Rp[i, 2] * bf[b, R0 + 6 + j])
                Q[i, j] = 1.0 if i == j else 0.0
            wrel[i] = 0.0
            alrel[i] = 0.0
            rho_loc[i] = bf[b, OFF + i]
            acc_loc[i] = 0.0
        for cc in range(nc):
            col = ipool[c0 + cc]
            for i in range(3):
                Jwrel[i, col] = 0.0
                Jrho[i, col] = A[b, i, col]
        # elementary rotations: omega_rel = sum_k u_k thetadot_k in the P frame
        for k in range(bi[b, ROT0], bi[b, ROT0] + bi[b, NROT]):
            ax = rot_axis[k]
            th = rot_off[k]
            thd = 0.0
            for col in range(n):
                th += rot_c[k, col] * q[col]
                thd += rot_c[k, col] * qd[col]
            u0, u1, u2 = Q[0, ax], Q[1, ax], Q[2, ax]
            x0, x1, x2 = cross3(wrel[0], wrel[1], wrel[2], u0, u1, u2)
            alrel[0] += x0 * thd
            alrel[1] += x1 * thd
            alrel[2] += x2 * thd
            wrel[0] += u0 * thd
            wrel[1] += u1 * thd
            wrel[2] += u2 * thd
            for cc in range(nc):
                col = ipool[c0 + cc]
                ck = rot_c[k, col]
                Jwrel[0, col] += u0 * ck
                Jwrel[1, col] += u1 * ck
                Jwrel[2, col] += u2 * ck
            _right_rotate(Q, ax, th)
        # translation in the parent frame: linear in q, minus the axial shortening (D4)
        if bi[b, HAS_A]:
            for i in range(3):
                for col in range(n):
                    rho_loc[i] += A[b, i, col] * q[col]
        ns = bi[b, NSH]
        if ns > 0:
            sh = bi[b, SH0]
            qGq = 0.0
            qdGqd = 0.0
            for i_ in range(ns):
                ia = ipool[sh + i_]
                Gq = 0.0
                Gqd = 0.0
                for j_ in range(ns):
                    Gq += shG[b, i_, j_] * q[ipool[sh + j_]]
                    Gqd += shG[b, i_, j_] * qd[ipool[sh + j_]]
                qGq += q[ia] * Gq
                qdGqd += qd[ia] * Gqd
                if active[ia]:
                    for i in range(3):
                        Jrho[i, ia] -= bf[b, SH_E + i] * Gq
            for i in range(3):
                rho_loc[i] -= 0.5 * qGq * bf[b, SH_E + i]
                acc_loc[i] -= qdGqd * bf[b, SH_E + i]
        for i in range(3):
            s = 0.0
            for cc in range(nc):
                col = ipool[c0 + cc]
                s += Jrho[i, col] * qd[col]
            rhod_loc[i] = s
        _mv(Rp, rho_loc, rho)
        _mv(Rp, rhod_loc, rhod)
        _mv(Rp, acc_loc, Racc)
        _mv(P, wrel, Pw)
        for i in range(3):
            for j in range(3):
                R[b, i, j] = P[i, 0] * Q[0, j] + P[i, 1] * Q[1, j] + P[i, 2] * Q[2, j]
        rp, vp, wp, ap, alp = vec[p, 0], vec[p, 1], vec[p, 2], vec[p, 3], vec[p, 4]
        x = cross3(wp[0], wp[1], wp[2], rho[0], rho[1], rho[2])
        wwr = cross3(wp[0], wp[1], wp[2], x[0], x[1], x[2])
        arho = cross3(alp[0], alp[1], alp[2], rho[0], rho[1], rho[2])
        wrd = cross3(wp[0], wp[1], wp[2], rhod[0], rhod[1], rhod[2])
        wPw = cross3(wp[0], wp[1], wp[2], Pw[0], Pw[1], Pw[2])
        for i in range(3):
            Pal = P[i, 0] * alrel[0] + P[i, 1] * alrel[1] + P[i, 2] * alrel[2]
            vec[b, 0, i] = rp[i] + rho[i]
            vec[b, 1, i] = vp[i] + x[i] + rhod[i]
            vec[b, 2, i] = wp[i] + Pw[i]
            vec[b, 3, i] = ap[i] + arho[i] + wwr[i] + 2.0 * wrd[i] + Racc[i]
            vec[b, 4, i] = alp[i] + wPw[i] + Pal
        for cc in range(nc):
            col = ipool[c0 + cc]
            cr = cross3(rho[0], rho[1], rho[2], Jw[p, 0, col], Jw[p, 1, col], Jw[p, 2, col])
            for i in range(3):
                Jw[b, i, col] = Jw[p, i, col] + (P[i, 0] * Jwrel[0, col] + P[i, 1] * Jwrel[1, col]
                                                 + P[i, 2] * Jwrel[2, col])
                Jv[b, i, col] = (Jv[p, i, col] - cr[i] + Rp[i, 0] * Jrho[0, col] + Rp[i, 1] * Jrho[1, col]
                                 + Rp[i, 2] * Jrho[2, col])


@njit(cache=True)
def kinematics_along(Q, QD, data, work, R_out, vec_out):
    """`kinematics` at each state (rows of Q, QD: a history): the frames
    R_out[k], vec_out[k] of state k, in one call (the outputs' pass over the
    output times, `FrameKinematics.along`)."""
    for k in range(Q.shape[0]):
        kinematics(Q[k], QD[k], data, work)
        R_out[k] = work[0]
        vec_out[k] = work[1]


# ------------------------------------------------------------- body contributions
@njit(cache=True)
def rotate_tensor(R, body_frame, out):
    """out = R T R^T for the 3x3 tensor T stored row by row in `body_frame`
    (9 floats): a body-frame inertia expressed in the ground frame."""
    for i in range(3):
        for j in range(3):
            s = 0.0
            for k in range(3):
                for l in range(3):
                    s += R[i, k] * body_frame[3 * k + l] * R[j, l]
            out[i, j] = s


@njit(cache=True, inline="always")
def _rigid(b, gvec, fnodes, fflag, data, work, Mb, fy):
    """Generalised mass Mb and force fy of a rigid body in y = [v; w] of its
    origin (inertial axes): eq. 6-7 with J_vG = J_v - [p~] J_w expanded."""
    bi, bf = data[0], data[1]
    R, vec = work[0][b], work[1][b]
    w, a, al = vec[2], vec[3], vec[4]
    m = bf[b, MASS]
    v_scr = work[10]
    p, fG, Iw, Ial = v_scr[0], v_scr[1], v_scr[2], v_scr[3]
    Ig = work[11][0]
    _mv(R, bf[b, CM:CM + 3], p)
    rotate_tensor(R, bf[b, INERTIA:INERTIA + 9], Ig)
    x = cross3(w[0], w[1], w[2], p[0], p[1], p[2])
    wwp = cross3(w[0], w[1], w[2], x[0], x[1], x[2])
    alp = cross3(al[0], al[1], al[2], p[0], p[1], p[2])
    for i in range(3):
        fG[i] = m * (gvec[i] - (a[i] + alp[i] + wwp[i]))
    _mv(Ig, w, Iw)
    _mv(Ig, al, Ial)
    gyr = cross3(w[0], w[1], w[2], Iw[0], Iw[1], Iw[2])
    mom = cross3(p[0], p[1], p[2], fG[0], fG[1], fG[2])
    pp = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
    for i in range(3):
        for j in range(3):
            Mb[i, j] = m if i == j else 0.0
            Mb[3 + i, 3 + j] = Ig[i, j] + m * ((pp if i == j else 0.0) - p[i] * p[j])
        fy[i] = fG[i]
        fy[3 + i] = mom[i] - (Ial[i] + gyr[i])
    # m [p~] blocks
    Mb[3, 0], Mb[3, 1], Mb[3, 2] = 0.0, -m * p[2], m * p[1]
    Mb[4, 0], Mb[4, 1], Mb[4, 2] = m * p[2], 0.0, -m * p[0]
    Mb[5, 0], Mb[5, 1], Mb[5, 2] = -m * p[1], m * p[0], 0.0
    for i in range(3):
        for j in range(3):
            Mb[j, 3 + i] = Mb[3 + i, j]
    if bi[b, HAS_JP]:
        # node polar inertia of flexible bodies without elastic DOFs,
        # sum J_p e_g e_g^T, with t = [0, e_g] (eq. A): no gyroscopic term
        rotate_tensor(R, bf[b, POLAR:POLAR + 9], Ig)
        for i in range(3):
            for j in range(3):
                Mb[3 + i, 3 + j] += Ig[i, j]
                fy[3 + i] -= Ig[i, j] * al[j]
    if fflag[b]:
        _add_node_forces(b, fnodes, data, work, fy)


@njit(cache=True, inline="always")
def _add_node_forces(b, fnodes, data, work, fy):
    """fy += [sum f_k; sum (p_k x f_k + m_k)] for the nodes of a body without
    elastic DOFs (node forces f_k and moments m_k, inertial: fnodes[k, 0:3],
    fnodes[k, 3:6]; a moment does work through the body's angular velocity)."""
    bi, s0 = data[0], data[8]
    R = work[0][b]
    pk = work[10][5]
    a0 = bi[b, NODE0]
    for k in range(a0, a0 + bi[b, NNODE]):
        _mv(R, s0[k], pk)
        f = fnodes[k]
        mk = cross3(pk[0], pk[1], pk[2], f[0], f[1], f[2])
        for i in range(3):
            fy[i] += f[i]
            fy[3 + i] += mk[i] + f[3 + i]


@njit(cache=True, fastmath=_FAST)
def _flexible(b, q, qd, gvec, fnodes, fflag, data, work, Mb, fy):
    """Generalised mass Mb and force fy of a flexible body in y = [v; w; qd_e]
    (Wallrapp form, eq. 11-19 and A2-A19) at the deformed configuration, with
    axial shortening (D4), node polar inertia and torsion. The sums are
    formed in the body frame (s, B_loc), over the nodes (`_node_sums`) or
    from the body's invariants (`invariant_sums`, `body_integrals`; the
    packer picks the cheaper), then rotated once (p = R s, B = R B_loc)."""
    bi, bf, ipool, fpool = data[0], data[1], data[2], data[11]
    R, vec = work[0][b], work[1][b]
    e_scr, B3 = work[6], work[7]
    ne, e0 = bi[b, NE], bi[b, E0]
    has_eta = bi[b, HAS_ETA]
    qe, qde, fe = e_scr[0, :ne], e_scr[1, :ne], e_scr[2, :ne]
    Ct, Cr = B3[0], B3[1]
    for l in range(ne):
        qe[l] = q[ipool[e0 + l]]
        qde[l] = qd[ipool[e0 + l]]
    loc = work[10]    # w, alpha, a, g (body frame), m p, f_t, f_r, -, -, -, -, axis, f_k, R m p
    wb, alb, ab, gb, mp, ft, fr, ax, fk, mpi = (loc[0], loc[1], loc[2], loc[3], loc[4], loc[5], loc[6],
                                                loc[11], loc[12], loc[13])
    _mtv(R, vec[2], wb)
    _mtv(R, vec[4], alb)
    _mtv(R, vec[3], ab)
    _mtv(R, gvec, gb)
    for i in range(3):
        ax[i] = bf[b, AXIS + i]
    Irr = work[11][1]
    Mee = work[15][:ne, :ne]
    if bi[b, INV0] > 0:
        # the invariant route, compiled apart and called through its pointer
        # (invariant_sums.py); inputs and outputs through the start of its scratch
        scr = work[14]
        for i in range(3):
            for j in range(3):
                scr[3 * i + j] = R[i, j]
            scr[9 + i], scr[12 + i], scr[15 + i], scr[18 + i], scr[21 + i] = wb[i], alb[i], ab[i], gb[i], ax[i]
        for l in range(ne):
            scr[24 + l] = qe[l]
            scr[24 + ne + l] = qde[l]
        mass = data[13](bi[b, SIX0], fflag[b], ipool, fpool, scr, fnodes)
        o = 24 + 2 * ne
        for i in range(3):
            mp[i], ft[i], fr[i] = scr[o + i], scr[o + 3 + i], scr[o + 6 + i]
            for j in range(3):
                Irr[i, j] = scr[o + 9 + 3 * i + j]
            for l in range(ne):
                Ct[i, l] = scr[o + 18 + i * ne + l]
                Cr[i, l] = scr[o + 18 + 3 * ne + i * ne + l]
        o += 18 + 6 * ne
        for l in range(ne):
            fe[l] = scr[o + l]
            for m_ in range(ne):
                Mee[l, m_] = scr[o + ne + l * ne + m_]
    else:
        mass = _node_sums(b, fnodes, fflag, data, work, Mee)
    if fflag[b]:
        # node moments m_k (on its load rows, the nodes or load points): work
        # through the body's angular velocity and, about the beam axis, through
        # the torsion shapes eta (t = [0, e_g, eta], one row per load row: at
        # load points, their T-weighted mean); the bodies carry no bending slopes, so the
        # bending part of a node moment (m_k . (e_axis x dPhi_k/ds)) is the
        # loading effect's own generalised force (effects/aero.py `node_moments`)
        r0, nl = bi[b, LOAD0], bi[b, NLOAD]
        for k in range(nl):
            _mtv(R, fnodes[r0 + k, 3:6], fk)
            for i in range(3):
                fr[i] += fk[i]
            if has_eta:
                eta = view2(fpool, bi[b, ETA0], nl, ne)
                ma = fk[0] * ax[0] + fk[1] * ax[1] + fk[2] * ax[2]
                for l in range(ne):
                    fe[l] += ma * eta[k, l]
    # elastic forces (A16-A19)
    KD = view3(fpool, bi[b, KD0], 2, ne, ne)
    for l in range(ne):
        x = 0.0
        for m_ in range(ne):
            x += KD[0, l, m_] * qe[m_] + KD[1, l, m_] * qde[m_]
        fe[l] -= x
    # rotate to inertial axes: p = R s, B = R B_loc
    _mv(R, mp, mpi)
    for i in range(3):
        for j in range(3):
            Mb[i, j] = mass if i == j else 0.0
            x = 0.0
            for k in range(3):
                for l in range(3):
                    x += R[i, k] * Irr[k, l] * R[j, l]
            Mb[3 + i, 3 + j] = x
    Mb[3, 0], Mb[3, 1], Mb[3, 2] = 0.0, -mpi[2], mpi[1]
    Mb[4, 0], Mb[4, 1], Mb[4, 2] = mpi[2], 0.0, -mpi[0]
    Mb[5, 0], Mb[5, 1], Mb[5, 2] = -mpi[1], mpi[0], 0.0
    for i in range(3):
        for j in range(3):
            Mb[j, 3 + i] = Mb[3 + i, j]
    for l in range(ne):
        for i in range(3):
            ct = R[i, 0] * Ct[0, l] + R[i, 1] * Ct[1, l] + R[i, 2] * Ct[2, l]
            cr = R[i, 0] * Cr[0, l] + R[i, 1] * Cr[1, l] + R[i, 2] * Cr[2, l]
            Mb[i, 6 + l] = ct
            Mb[6 + l, i] = ct
            Mb[3 + i, 6 + l] = cr
            Mb[6 + l, 3 + i] = cr
        for m_ in range(l, ne):
            Mb[6 + l, 6 + m_] = Mee[l, m_]
            Mb[6 + m_, 6 + l] = Mee[l, m_]
        fy[6 + l] = fe[l]
    for i in range(3):
        fy[i] = R[i, 0] * ft[0] + R[i, 1] * ft[1] + R[i, 2] * ft[2]
        fy[3 + i] = R[i, 0] * fr[0] + R[i, 1] * fr[1] + R[i, 2] * fr[2]


@njit(cache=True, fastmath=_FAST, inline="always")
def _node_sums(b, fnodes, fflag, data, work, Mee):
    """The body-frame sums of `_flexible` over the N nodes at the deformed
    configuration (O(N ne^2), two matrix products): writes m p, I_rr, C_t,
    C_r, f_t, f_r, M_ee and f_e (before the node moments and the elastic
    forces) into `work`; returns the body's mass."""
    bi = data[0]
    s0, nm, Jp, fpool = data[8], data[9], data[10], data[11]
    R = work[0][b]
    e_scr, B3, nodes = work[6], work[7], work[12]
    ne, a0, N = bi[b, NE], bi[b, NODE0], bi[b, NNODE]
    has_S, has_jp, has_eta = bi[b, HAS_S], bi[b, HAS_JP], bi[b, HAS_ETA]
    qe, qde, fe = e_scr[0, :ne], e_scr[1, :ne], e_scr[2, :ne]
    Ct, Cr = B3[0], B3[1]
    N3 = 3 * N
    Phi = view2(fpool, bi[b, PHI0], N3, ne)       # row 3k+i: node k, axis i
    B = view2(nodes[0], 0, N3, ne)                               # B_loc (body frame)
    W = view2(nodes[1], 0, N3, ne + 1)                     # [m_k B_loc, load_k]
    Sq = nodes[2, :N * ne]
    s, pdv, load = nodes[3, :N3], nodes[4, :N3], nodes[5, :N3]
    loc = work[10]
    wb, alb, ab, gb, mp, ft, fr, ax, fk = (loc[0], loc[1], loc[2], loc[3], loc[4], loc[5], loc[6],
                                           loc[11], loc[12])
    Irr = work[11][1]
    # deformed positions s = s0 + Phi q_e - 1/2 (q_e^T S_k q_e) e_axis and
    # B_loc = Phi - e_axis (S_k q_e)^T (first paper D4; second paper eq. 3)
    if has_S:
        Sk = view2(fpool, bi[b, S0], N * ne, ne)
    else:
        Sk = view2(fpool, 0, 0, ne)
    for k in range(N):
        qSq = 0.0
        qdSqd = 0.0
        if has_S:
            for l in range(ne):
                x = 0.0
                y = 0.0
                for m_ in range(ne):
                    x += Sk[k * ne + l, m_] * qe[m_]
                    y += Sk[k * ne + l, m_] * qde[m_]
                Sq[k * ne + l] = x
                qSq += qe[l] * x
                qdSqd += qde[l] * y
        for i in range(3):
            r = 3 * k + i
            x = s0[a0 + k, i] - 0.5 * qSq * ax[i]
            y = 0.0
            for l in range(ne):
                x += Phi[r, l] * qe[l]
                bl = Phi[r, l] - (ax[i] * Sq[k * ne + l] if has_S else 0.0)
                B[r, l] = bl
                y += bl * qde[l]
            s[r] = x
            pdv[r] = y
        load[3 * k] = -qdSqd          # axial acceleration, kept here until the load is formed
    # loads m (g - a_node) + f_node and the node rows of G = [I ...; [s_k~] ...]
    G = view2(work[13], 0, 6, N3)
    mass = mp0 = mp1 = mp2 = 0.0
    J00 = J11 = J22 = J01 = J02 = J12 = 0.0          # sum m s s^T
    for k in range(N):
        mk = nm[a0 + k]
        sk0, sk1, sk2 = s[3 * k], s[3 * k + 1], s[3 * k + 2]
        acc = load[3 * k]
        c1 = cross3(alb[0], alb[1], alb[2], sk0, sk1, sk2)
        c2 = cross3(wb[0], wb[1], wb[2], sk0, sk1, sk2)
        c3 = cross3(wb[0], wb[1], wb[2], c2[0], c2[1], c2[2])
        c4 = cross3(wb[0], wb[1], wb[2], pdv[3 * k], pdv[3 * k + 1], pdv[3 * k + 2])
        if fflag[b]:
            _mtv(R, fnodes[a0 + k, 0:3], fk)
        else:
            fk[0] = fk[1] = fk[2] = 0.0
        for i in range(3):
            an = ab[i] + c1[i] + c3[i] + 2.0 * c4[i] + acc * ax[i]
            load[3 * k + i] = mk * (gb[i] - an) + fk[i]
            W[3 * k + i, ne] = load[3 * k + i]
            for l in range(ne):
                W[3 * k + i, l] = mk * B[3 * k + i, l]
            for j in range(3):
                G[i, 3 * k + j] = 1.0 if i == j else 0.0
        G[3, 3 * k], G[3, 3 * k + 1], G[3, 3 * k + 2] = 0.0, -sk2, sk1
        G[4, 3 * k], G[4, 3 * k + 1], G[4, 3 * k + 2] = sk2, 0.0, -sk0
        G[5, 3 * k], G[5, 3 * k + 1], G[5, 3 * k + 2] = -sk1, sk0, 0.0
        mass += mk
        mp0 += mk * sk0
        mp1 += mk * sk1
        mp2 += mk * sk2
        J00 += mk * sk0 * sk0
        J11 += mk * sk1 * sk1
        J22 += mk * sk2 * sk2
        J01 += mk * sk0 * sk1
        J02 += mk * sk0 * sk2
        J12 += mk * sk1 * sk2
    mp[0], mp[1], mp[2] = mp0, mp1, mp2
    tr = J00 + J11 + J22
    Irr[0, 0], Irr[1, 1], Irr[2, 2] = tr - J00, tr - J11, tr - J22       # sum m (s.s E - s s^T)  (A5)
    Irr[0, 1] = Irr[1, 0] = -J01
    Irr[0, 2] = Irr[2, 0] = -J02
    Irr[1, 2] = Irr[2, 1] = -J12
    # [C_t^T; C_r^T] = sum_k [m B_k; s_k x m B_k] (A3-A4), with [sum load_k; sum s_k x load_k]
    GW = np.dot(G, W)
    for i in range(3):
        ft[i] = GW[i, ne]
        fr[i] = GW[3 + i, ne]
        for l in range(ne):
            Ct[i, l] = GW[i, l]
            Cr[i, l] = GW[3 + i, l]
    # sum_k m_k B_k^T B_k (A7), with sum_k B_k^T load_k (A16)
    BW = np.dot(B.T, W)
    for l in range(ne):
        fe[l] = BW[l, ne]
        for m_ in range(ne):
            Mee[l, m_] = BW[l, m_]
    if has_jp:
        # node polar inertia with t = [0, e_g, eta] (torsion), eq. A
        eal = ax[0] * alb[0] + ax[1] * alb[1] + ax[2] * alb[2]
        for k in range(N):
            jp = Jp[a0 + k]
            for i in range(3):
                for j in range(3):
                    Irr[i, j] += jp * ax[i] * ax[j]
                fr[i] -= jp * eal * ax[i]
        if has_eta:
            eta = view2(fpool, bi[b, ETA0], N, ne)
            for k in range(N):
                jp = Jp[a0 + k]
                for l in range(ne):
                    el = eta[k, l]
                    for i in range(3):
                        Cr[i, l] += jp * ax[i] * el
                    fe[l] -= jp * eal * el
                    for m_ in range(ne):
                        Mee[l, m_] += jp * el * eta[k, m_]
    return mass


@njit(cache=True, inline="always")
def _project(b, ne, data, work, Mb, fy, M, F):
    """M += Jb^T Mb Jb and F += Jb^T fy with Jb = [Jv; Jw; E_e] (eq. 7, 18-19),
    on the body's Jacobian columns and its own elastic coordinates."""
    bi, ipool = data[0], data[2]
    Jv, Jw, m6n = work[2][b], work[3][b], work[5]
    c0, nc, e0 = bi[b, COL0], bi[b, NCOL], bi[b, E0]
    J6, T = m6n[0], m6n[1]
    for cc in range(nc):
        col = ipool[c0 + cc]
        for i in range(3):
            J6[i, cc] = Jv[i, col]
            J6[3 + i, cc] = Jw[i, col]
    for cc in range(nc):
        for r in range(6 + ne):
            x = 0.0
            for k in range(6):
                x += Mb[r, k] * J6[k, cc]
            T[r, cc] = x                         # (Mb [J6; 0])[:, cc]
    for ci in range(nc):
        i = ipool[c0 + ci]
        x = 0.0
        for k in range(6):
            x += J6[k, ci] * fy[k]
        F[i] += x
        for cj in range(ci, nc):
            j = ipool[c0 + cj]
            x = 0.0
            for k in range(6):
                x += J6[k, ci] * T[k, cj]
            M[i, j] += x
            if cj != ci:
                M[j, i] += x
    for l in range(ne):
        il = ipool[e0 + l]
        F[il] += fy[6 + l]
        for cj in range(nc):
            j = ipool[c0 + cj]
            M[il, j] += T[6 + l, cj]
            M[j, il] += T[6 + l, cj]
        for m_ in range(ne):
            M[il, ipool[e0 + m_]] += Mb[6 + l, 6 + m_]


@njit(cache=True, inline="always")
def assemble(q, qd, gvec, fnodes, fflag, gen, data, work, M, F, with_kinematics=True):
    """M (n x n) and F (n) over all coordinates (eq. 22 before restriction);
    rows/columns of inactive coordinates are left zero. with_kinematics=False:
    the frames in `work` are already those of (q, qd)."""
    bi = data[0]
    Mb, fy = work[8], work[9]
    if with_kinematics:
        kinematics(q, qd, data, work)
    n = q.shape[0]
    for i in range(n):
        F[i] = gen[i]
        for j in range(n):
            M[i, j] = 0.0
    for b in range(bi.shape[0]):
        kind = bi[b, KIND]
        if kind == SKIP or (kind == LUMPED and not fflag[b]):
            continue
        if kind == RIGID:
            _rigid(b, gvec, fnodes, fflag, data, work, Mb, fy)
        elif kind == FLEX:
            _flexible(b, q, qd, gvec, fnodes, fflag, data, work, Mb, fy)
        else:   # lumped into an ancestor: only its node forces
            for i in range(6):
                fy[i] = 0.0
                for j in range(6):
                    Mb[i, j] = 0.0
            _add_node_forces(b, fnodes, data, work, fy)
        _project(b, bi[b, NE] if kind == FLEX else 0, data, work, Mb, fy, M, F)


# ------------------------------------------------------------- free coordinates
# status codes shared with integrate.py
OK, NON_FINITE_STATE, BEYOND_BOUND, SINGULAR, NON_FINITE_ACC, STEP_COLLAPSE = 0, 1, 2, 3, 4, 5
#: status of an integration loop stopped on request (its `control`, `watch.run_watched`)
INTERRUPTED = 6
#: the slots of an integration loop's `control` array: a stop request (non-zero:
#: stop after the current step) and the time [s] of the last accepted step
STOP_REQUEST, TIME_REACHED = 0, 1


@njit(cache=True, fastmath=_FAST)
def cholesky_solve(A, x):
    """Solve A y = x in place (x <- y, A <- its Cholesky factor) for a
    symmetric positive definite A (the mass matrix); False if A is not."""
    n = A.shape[0]
    for j in range(n):
        d = A[j, j]
        for k in range(j):
            d -= A[j, k] * A[j, k]
        if not d > 0.0:
            return False
        d = np.sqrt(d)
        A[j, j] = d
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= A[i, k] * A[j, k]
            A[i, j] = s / d
    for i in range(n):
        s = x[i]
        for k in range(i):
            s -= A[i, k] * x[k]
        x[i] = s / A[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, n):
            s -= A[k, i] * x[k]
        x[i] = s / A[i, i]
    return True


@njit(cache=True)
def lu_factor(A, piv):
    """LU with partial pivoting in place (as LAPACK getrf; real or complex A),
    row interchanges in piv; False if a pivot is exactly zero."""
    n = A.shape[0]
    for k in range(n):
        p = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                p = i
        piv[k] = p
        if big == 0.0:
            return False
        if p != k:
            for j in range(n):
                A[k, j], A[p, j] = A[p, j], A[k, j]
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            A[i, k] *= inv
            l = A[i, k]
            if l != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= l * A[k, j]
    return True


@njit(cache=True)
def lu_solve_factored(LU, piv, b):
    """Solve with `lu_factor`'s result in place (b <- solution; as getrs)."""
    n = LU.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= LU[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= LU[i, j] * b[j]
        b[i] = s / LU[i, i]


@njit(cache=True)
def lu_solve(A, x):
    """Solve A y = x in place (x <- y) by Gaussian elimination with partial
    pivoting (A overwritten by its factors); False if a pivot is exactly zero."""
    piv = np.empty(A.shape[0], np.int64)
    if not lu_factor(A, piv):
        return False
    lu_solve_factored(A, piv, x)
    return True


@njit(cache=True)
def free_rows(free, presc, qddp, M, F, Mf, Ff):
    """Mf = M_ff and Ff = F_f - M_fp qdd_p (eq. 21-22) from M and F over all
    coordinates."""
    nf = free.shape[0]
    for a in range(nf):
        v = F[free[a]]
        for k in range(presc.shape[0]):
            v -= M[free[a], presc[k]] * qddp[presc[k]]
        Ff[a] = v
        for b in range(nf):
            Mf[a, b] = M[free[a], free[b]]


@njit(cache=True)
def solve_free(free, presc, qddp, M, F, Mf, Ff, acc, symmetric):
    """acc = M_ff^-1 F_f from Mf and Ff as `free_rows` left them (Mf
    overwritten): by Cholesky where `symmetric`, by Gaussian elimination
    otherwise or where M_ff is not positive definite (Mf then formed again
    from M). False if singular (an exact zero pivot)."""
    nf = free.shape[0]
    for a in range(nf):
        acc[a] = Ff[a]
    if symmetric:
        if cholesky_solve(Mf, acc):
            return True
        free_rows(free, presc, qddp, M, F, Mf, Ff)
        for a in range(nf):
            acc[a] = Ff[a]
    return lu_solve(Mf, acc)


#: the `solve` argument of `free_system` (numpy int64s, typed int64 as in
#: SYSTEM_SIG; numba types a literal int as Literal[int]): M_ff and F_f only;
#: also the accelerations; also the accelerations, with the effects' costly
#: non-stiff loads held from the previous call (LOADS_SIG `held`)
NO_SOLVE, SOLVE, SOLVE_HELD = np.int64(0), np.int64(1), np.int64(2)


def free_system(t, x, out, solve, bounds, prob, rwork, data, work):
    """Compiled once, as the cfunc `system_function.FREE_SYSTEM` of
    SYSTEM_SIG, which the compiled loops take as their first argument
    (`system`) and Python calls through `call_system`; not jitted here.
    Equations of the free coordinates at time t and state x = [q, qd]:
    M_ff and F_f - M_fp qdd_p (eq. 21-22) into rwork (Mf, Ff); with `solve`,
    also out = [qd, qdd], qdd = M_ff^-1 (F_f - M_fp qdd_p) (Cholesky, which
    overwrites Mf; Gaussian elimination if M_ff is not positive definite),
    checking the state (finite, |q| <= bounds) and the accelerations as
    integrate.py does. solve = SOLVE_HELD: as SOLVE, with the BEM loads and
    the tower drag those of the previous call (the columns of Radau's
    Jacobian: `implicit.jacobian`); NO_SOLVE: M_ff and F_f only. A body
    with a lossy gearbox (body_int LOSS) has its equation's row and the
    solve done by data[14] (`gearbox_loss.gearbox_loss`).
    Returns (status, index of an offending coordinate or -1).

    prob = (free, prescribed, prescribed (value, rate, accel), fixed values,
    gravity, linear (row, col) and (stiffness, damping, k times the neutral
    position) of generalised spring-dampers gen_row -= k (q_col - neutral) +
    c qd_col, node forces, node-force
    flag per body, loads = (cfunc of LOADS_SIG, ints, floats, state): the
    effects' loads, `no_loads` without effects);
    rwork = (rows q_all, qd_all, qdd_p, gen; M; F; Mf; Ff)."""
    free, presc, pcoef, fixed, gvec, lin_idx, lin_kc, fnodes, fflag, loads = prob
    st, M, F, Mf, Ff = rwork[0], rwork[1], rwork[2], rwork[3], rwork[4]
    q_all, qd_all, qddp, gen = st[0], st[1], st[2], st[3]
    nf = free.shape[0]
    if solve != NO_SOLVE:
        for i in range(2 * nf):
            if not np.isfinite(x[i]):
                return NON_FINITE_STATE, i
        for i in range(nf):
            if abs(x[i]) > bounds[i]:
                return BEYOND_BOUND, i
    n = q_all.shape[0]
    for i in range(n):
        q_all[i] = fixed[i]
        qd_all[i] = 0.0
        qddp[i] = 0.0
        gen[i] = 0.0
    for k in range(nf):
        q_all[free[k]] = x[k]
        qd_all[free[k]] = x[nf + k]
    for k in range(presc.shape[0]):
        i = presc[k]
        q_all[i] = pcoef[k, 0] + pcoef[k, 1] * t + 0.5 * pcoef[k, 2] * t * t
        qd_all[i] = pcoef[k, 1] + pcoef[k, 2] * t
        qddp[i] = pcoef[k, 2]
    for k in range(lin_idx.shape[0]):
        gen[lin_idx[k, 0]] -= (lin_kc[k, 0] * q_all[lin_idx[k, 1]] + lin_kc[k, 1] * qd_all[lin_idx[k, 1]]
                               - lin_kc[k, 2])
    # the effects' loads (cfunc of LOADS_SIG: `no_loads` for a problem without
    # effects, so that one compiled specialisation of the loops serves every
    # problem; held: the BEM loads and the tower drag of the previous call),
    # then M and F. Written out here rather than in an inlined helper: numba
    # copies an inlined function's IR block by block with its whole scope, 1.2 s
    # of the first run's compile for that helper alone
    fn, l_int, l_flt, l_state = loads
    held = 1 if solve == SOLVE_HELD else 0
    kinematics(q_all, qd_all, data, work)
    if held == 0:
        fnodes[:, :] = 0.0
        fflag[:] = 0
    code = fn(t, q_all, qd_all, work[0], work[1], gen, fnodes, fflag, l_int, l_flt, l_state, held)
    if code != OK:
        return code, -1
    assemble(q_all, qd_all, gvec, fnodes, fflag, gen, data, work, M, F, False)
    free_rows(free, presc, qddp, M, F, Mf, Ff)
    for a in range(nf):
        out[a] = x[nf + a]
    bi = data[0]
    for b in range(bi.shape[0]):
        if bi[b, LOSS] > 0:
            # a lossy gearbox: its row and the accelerations (solved) by `gearbox_loss.gearbox_loss`
            if data[14](b, solve, free, presc, qddp, gen, bi, data[1], data[2], work[0][b], work[1][b],
                        work[3][b], work[11][0], M, F, Mf, Ff, out, nf) == 0:
                return SINGULAR, -1
            if solve == NO_SOLVE:
                return OK, -1
            for a in range(nf):
                if not np.isfinite(out[nf + a]):
                    return NON_FINITE_ACC, -1
            return OK, -1
    if solve == NO_SOLVE:
        return OK, -1
    if not solve_free(free, presc, qddp, M, F, Mf, Ff, out[nf:], True):
        return SINGULAR, -1
    for a in range(nf):
        if not np.isfinite(out[nf + a]):
            return NON_FINITE_ACC, -1
    return OK, -1


@njit(cache=True)
def call_system(system, t, x, out, solve, bounds, prob, rwork, data, work):
    """`free_system` through its cfunc `system` (SYSTEM_SIG), for Python."""
    return system(t, x, out, solve, bounds, prob, rwork, data, work)


@njit(cache=True)
def reaction_loads(system, solve, ts, X, rows, slots, prob, rwork, data, work, out):
    """Generalised reaction forces F_r - M_r qdd of the (fixed) coordinates
    `rows` at the states X[k] = [q, qd] and times ts[k] (a constraint
    coordinate's equation gives the load that holds it, first paper eq. 22)
    into out[k, :len(rows)], and the effects' state at `slots` after the same
    evaluation (their output channels) into the columns after; needs arrays
    packed with all rows. solve: SOLVE; NO_SOLVE leaves the free
    accelerations out (qdd = the prescribed ones), which gives the free rows'
    F_f of `free_system` at each state (the linear model's differences,
    `CompiledRHS.linear_model`, with any packing). A negative entry r of
    `rows` asks for the acceleration of coordinate -1 - r instead (free:
    solved; prescribed: its own; fixed: 0). Returns a status code."""
    nf = X.shape[1] // 2
    n = rwork[1].shape[0]
    nr = rows.shape[0]
    acc = np.empty(2 * nf)
    inf = np.full(nf, np.inf)
    qdd = np.empty(n)
    for k in range(ts.shape[0]):
        code, _ = system(ts[k], X[k], acc, solve, inf, prob, rwork, data, work)
        if code != OK:
            return code
        state = prob[9][3]
        for j in range(slots.shape[0]):
            out[k, nr + j] = state[slots[j]]
        M, F, qddp = rwork[1], rwork[2], rwork[0][2]
        for i in range(n):
            qdd[i] = qddp[i]
        for a in range(nf):
            qdd[prob[0][a]] = acc[nf + a] if solve != NO_SOLVE else 0.0
        for j in range(rows.shape[0]):
            r = rows[j]
            if r < 0:
                out[k, j] = qdd[-1 - r]
                continue
            v = F[r]
            for i in range(n):
                v -= M[r, i] * qdd[i]
            out[k, j] = v
    return OK


@njit(cache=True)
def _rms(x):
    s = 0.0
    for v in x:
        s += v * v
    return np.sqrt(s / x.shape[0])


@njit(cache=True, inline="always")
def initial_step(system, t, y, f, tmax, max_step, rtol, atol, order, bounds, prob, rwork, data, work):
    """scipy's select_initial_step for an error estimator of `order` from
    (t, y), f = f(t, y), with one right-hand side: (status, index, step), or
    (status, index, time of the failure) when that right-hand side fails."""
    nx = y.shape[0]
    scale = np.empty(nx)
    e = np.empty(nx)
    ys = np.empty(nx)
    f1 = np.empty(nx)
    for i in range(nx):
        scale[i] = atol[i] + abs(y[i]) * rtol
        e[i] = y[i] / scale[i]
    d0 = _rms(e)
    for i in range(nx):
        e[i] = f[i] / scale[i]
    d1 = _rms(e)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, tmax)
    for i in range(nx):
        ys[i] = y[i] + h0 * f[i]
    code, idx = system(t + h0, ys, f1, SOLVE, bounds, prob, rwork, data, work)
    if code != OK:
        return code, idx, t + h0
    for i in range(nx):
        e[i] = (f1[i] - f[i]) / scale[i]
    d2 = _rms(e) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return OK, -1, min(100 * h0, h1, tmax, max_step)


@njit(cache=True, inline="always")
def start(system, y, f, tmax, max_step, rtol, atol, order, bounds, prob, rwork, data, work):
    """The start of an integration from (0, y): f = f(0, y) and scipy's
    initial step for an error estimator of `order` (`initial_step`):
    (status, index, step, n_rhs), or (status, index, time of the failure,
    n_rhs) when a right-hand side fails."""
    code, idx = system(0.0, y, f, SOLVE, bounds, prob, rwork, data, work)
    if code != OK:
        return code, idx, 0.0, 1
    code, idx, h_abs = initial_step(system, 0.0, y, f, tmax, max_step, rtol, atol, order, bounds, prob, rwork, data,
                                    work)
    return code, idx, h_abs, 2


@njit(cache=True, inline="always")
def _stage(system, s, t, h, y, K, ys, A, C, bounds, prob, rwork, data, work):
    """Runge-Kutta stage s from step start (t, y): ys = y + h sum_j A[s,j] K[j],
    K[s] = f(t + C[s] h, ys). Returns free_system's (code, index)."""
    for i in range(len(y)):
        acc = 0.0
        for j in range(s):
            acc += K[j, i] * A[s, j]
        ys[i] = y[i] + acc * h
    return system(t + C[s] * h, ys, K[s], SOLVE, bounds, prob, rwork, data, work)


#: the explicit Runge-Kutta pairs of `runge_kutta` (its `kind`)
DOP853_KIND, RK45_KIND = 0, 1


@njit(cache=True, nogil=True)
def runge_kutta(system, x0, t_eval, tmax, rtol, atol, max_step, bounds, tab, kind, prob, rwork, data, work, Y,
                control):
    """An explicit Runge-Kutta pair with the step control and initial step of
    scipy.integrate's RungeKutta, evaluated at t_eval (increasing, within
    [0, tmax]) into Y. One loop for both pairs, so that one compiled
    specialisation serves them (the first run compiles it once):

    - kind DOP853_KIND: Dormand-Prince 8(5,3), scipy's DOP853 (Hairer,
      Norsett & Wanner I, II.10): its combined 5th/3rd-order error norm and
      7th-order dense output with 3 extra stages; tab = (A, B, C, E3, E5, D)
      of `dop853_tableau`;
    - kind RK45_KIND: Dormand-Prince 5(4), scipy's RK45 (Dormand & Prince
      1980; HNW I, II.4-5): 4th-order error estimate h K^T E and quartic
      dense output y + h sum_k (K^T P)_k x^(k+1); tab = (A, B, C, E, E, P) of
      `rk45_tableau`.

    control (2,): after each accepted step the loop writes its time into
    control[TIME_REACHED] and stops (INTERRUPTED) where control[STOP_REQUEST]
    is non-zero; it runs without the GIL, so that another thread can watch
    it (`watch.run_watched`: progress, Ctrl-C).

    Returns (status, time, n_rhs, n_out, index): status OK, a divergence code
    of `free_system` (time = where it occurred), STEP_COLLAPSE or INTERRUPTED
    (time = the last accepted step)."""
    A, B, C, E3, E5, D = tab
    dop = kind == DOP853_KIND
    nx = x0.shape[0]
    n_stages = B.shape[0]
    K = np.zeros((max(A.shape[0], n_stages + 1), nx))
    y = x0.copy()
    y_new = np.empty(nx)
    f = np.empty(nx)
    f_new = np.empty(nx)
    ys = np.empty(nx)
    scale = np.empty(nx)
    e5 = np.empty(nx)
    e3 = np.empty(nx)
    Fd = np.empty((3 + D.shape[0] if dop else D.shape[1], nx))     # dense output coefficients
    order = 7 if dop else 4                  # of the error estimator
    err_exp = -1.0 / (order + 1)
    SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0
    t = 0.0
    code, idx, h_abs, nfev = start(system, y, f, tmax, max_step, rtol, atol, order, bounds, prob, rwork, data, work)
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
            # Runge-Kutta stages
            for i in range(nx):
                K[0, i] = f[i]
            for s in range(1, n_stages):
                code, idx = _stage(system, s, t, h, y, K, ys, A, C, bounds, prob, rwork, data, work)
                nfev += 1
                if code != OK:
                    return code, t + C[s] * h, nfev, n_out, idx
            for i in range(nx):
                acc = 0.0
                for j in range(n_stages):
                    acc += K[j, i] * B[j]
                y_new[i] = y[i] + h * acc
            code, idx = system(t + h, y_new, f_new, SOLVE, bounds, prob, rwork, data, work)
            nfev += 1
            if code != OK:
                return code, t + h, nfev, n_out, idx
            for i in range(nx):
                K[n_stages, i] = f_new[i]
            # error estimate (scipy DOP853._estimate_error_norm / RungeKutta._estimate_error_norm)
            for i in range(nx):
                scale[i] = atol[i] + max(abs(y[i]), abs(y_new[i])) * rtol
                a5 = 0.0
                a3 = 0.0
                for j in range(n_stages + 1):
                    a5 += K[j, i] * E5[j]
                    a3 += K[j, i] * E3[j]
                e5[i] = a5 / scale[i]
                e3[i] = a3 / scale[i]
            n5 = 0.0
            n3 = 0.0
            for i in range(nx):
                n5 += e5[i] * e5[i]
                n3 += e3[i] * e3[i]
            if not dop:
                error_norm = abs(h) * np.sqrt(n5 / nx)
            elif n5 == 0.0 and n3 == 0.0:
                error_norm = 0.0
            else:
                error_norm = abs(h) * n5 / np.sqrt((n5 + 0.01 * n3) * nx)
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
            if dop:
                for s in range(n_stages + 1, A.shape[0]):
                    code, idx = _stage(system, s, t_old, h, y, K, ys, A, C, bounds, prob, rwork, data, work)
                    nfev += 1
                    if code != OK:
                        return code, t_old + C[s] * h, nfev, n_out, idx
                for i in range(nx):
                    dy = y_new[i] - y[i]
                    Fd[0, i] = dy
                    Fd[1, i] = h * K[0, i] - dy
                    Fd[2, i] = 2 * dy - h * (f_new[i] + K[0, i])
                    for r in range(D.shape[0]):
                        acc = 0.0
                        for j in range(A.shape[0]):
                            acc += D[r, j] * K[j, i]
                        Fd[3 + r, i] = h * acc
            else:
                for i in range(nx):
                    for r in range(D.shape[1]):
                        acc = 0.0
                        for j in range(n_stages + 1):
                            acc += K[j, i] * D[j, r]
                        Fd[r, i] = acc
            while n_out < nt and (t_eval[n_out] <= t or t >= tmax):
                xx = (t_eval[n_out] - t_old) / h
                for i in range(nx):
                    v = 0.0
                    if dop:
                        for r in range(Fd.shape[0] - 1, -1, -1):
                            v += Fd[r, i]
                            if (Fd.shape[0] - 1 - r) % 2 == 0:
                                v *= xx
                            else:
                                v *= 1 - xx
                        Y[n_out, i] = v + y[i]
                    else:
                        p = 1.0
                        for r in range(Fd.shape[0]):
                            p *= xx
                            v += Fd[r, i] * p
                        Y[n_out, i] = y[i] + h * v
                n_out += 1
        for i in range(nx):
            y[i] = y_new[i]
            f[i] = f_new[i]
        control[TIME_REACHED] = t
        if control[STOP_REQUEST] != 0.0 and t < tmax:
            return INTERRUPTED, t, nfev, n_out, -1
    return OK, t, nfev, n_out, -1
