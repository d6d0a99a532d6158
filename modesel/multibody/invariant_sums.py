"""The generalised mass and force sums of a flexible body from its
invariants (`body_integrals`), compiled once as a numba cfunc that the
kernel calls through a function pointer (`kernel._flexible`, the packed
`data`).

Its own module and a cfunc, not a function of `kernel.py`: numba links the
code of every function a compiled function calls into that function's own
module and optimises it again there, so this long function inside the
kernel's call chain (right-hand side, Runge-Kutta and Radau loops, reaction
loads) would be optimised once per level and doubled the first run's
compile time (30 s to 66 s on 2 cores). Called through a pointer, it is
compiled once, when this module is first imported (`packing` imports it
for a system that uses it; `simulation.first_run` compiles it beside the
kernel). It reads everything from its arguments (no layout constant of the
kernel) but for the array views `kernel.view2`/`view3`/`view4` (one compiled
reshape each, instead of numba's reshape and its shape-error path compiled at
each of 32 sites).
"""
from __future__ import annotations

from numba import cfunc, njit

from modesel.multibody.kernel import INVARIANT_SIG, view2, view3, view4


@njit(cache=True)
def _take(buf, off, n):
    """A slice of n entries of a flat array, and the next offset."""
    return buf[off:off + n], off + n


@njit(cache=True, inline="always")
def _cross3(a0, a1, a2, b0, b1, b2):
    """a x b of two vectors given by their components."""
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True, inline="always")
def _rotate_back(R, x, out):
    """out = R^T x (inertial to body axes)."""
    for i in range(3):
        out[i] = R[0, i] * x[0] + R[1, i] * x[1] + R[2, i] * x[2]


@cfunc(INVARIANT_SIG, cache=True, fastmath={"reassoc", "contract", "nsz"})
def invariant_sums(head, loaded, ipool, fpool, scr, fnodes):
    """The body-frame sums of `kernel._flexible` from the body's invariants
    (`body_integrals.BLOCKS`: the node sums expanded as polynomials in q_e,
    qd_e with s_k = s0_k + Phi_k q - 1/2 (q^T S_k q) a,
    B_k = Phi_k - a (S_k q)^T, first paper A2-A19 and D4), node forces
    (fnodes, when `loaded`) summed over the nodes; returns the body's mass.

    ipool[head:] = [ne, ns, first node, node count, offset of the
    invariants in fpool, offset of Phi in fpool, shortening modes (ns),
    position of each elastic coordinate among them or -1 (ne)]. scr starts
    with the inputs R (body to inertial, 3x3), w, alpha, a_o, g, axis (body
    frame), q_e, qd_e, then the outputs m p, f_t, f_r, I_rr (3x3), C_t,
    C_r (3 x ne), f_e (ne, before the node moments and the elastic forces),
    M_ee (ne x ne), what `kernel._node_sums` forms (`kernel._flexible`
    writes and reads them); the rest of scr is scratch. (Few arguments: the
    compile time of the kernel's pointer call grows with their number.)

    With gma = g - a_o and node acceleration
    a_k = a_o + alpha x s_k + w x (w x s_k) + 2 w x B_k qd - (qd^T S_k qd) a:
      f_t = M gma - alpha x m p - w x (w x m p) - 2 w x C_t qd + a sum m d,
      f_r = m p x gma - (tr J - J) alpha - J w x w - 2 (w tr H_q - H_q^T w)
            + (sum m d s) x a,
      f_e,l = C_t,l . gma - alpha . C_r,l - w^T H_l w + |w|^2 tr H_l
            - 2 sum_m qd_m w . sum m B_m x B_l + sum m d a . B_l,
    with J = sum m s s^T, H_l = sum m s B_l^T, H_q = sum_l H_l qd_l,
    d_k = qd^T S_k qd."""
    ne, ns, a0, N, inv0, phi0 = (ipool[head], ipool[head + 1], ipool[head + 2], ipool[head + 3],
                                 ipool[head + 4], ipool[head + 5])
    sidx = ipool[head + 6:head + 6 + ns]
    pos = ipool[head + 6 + ns:head + 6 + ns + ne]
    # inputs and outputs at the start of scr (IO_FLOATS, the kernel's layout)
    so = 0
    R = view2(scr, so, 3, 3)
    so += 9
    w, so = _take(scr, so, 3)
    al, so = _take(scr, so, 3)
    ab, so = _take(scr, so, 3)
    gb, so = _take(scr, so, 3)
    a, so = _take(scr, so, 3)
    qe, so = _take(scr, so, ne)
    qde, so = _take(scr, so, ne)
    mp, so = _take(scr, so, 3)
    ft, so = _take(scr, so, 3)
    fr, so = _take(scr, so, 3)
    Irr = view2(scr, so, 3, 3)
    so += 9
    Ct = view2(scr, so, 3, ne)
    so += 3 * ne
    Cr = view2(scr, so, 3, ne)
    so += 3 * ne
    fe, so = _take(scr, so, ne)
    Mee = view2(scr, so, ne, ne)
    so += ne * ne
    fk, so = _take(scr, so, 3)
    # the invariants (body_integrals.BLOCKS, in order)
    o = inv0
    mass = fpool[o]
    o += 1
    ms0, o = _take(fpool, o, 3)
    mPhi = view2(fpool, o, 3, ne)
    o += 3 * ne
    mS = view2(fpool, o, ns, ns)
    o += ns * ns
    Js0 = view2(fpool, o, 3, 3)
    o += 9
    Xs0P = view3(fpool, o, 3, 3, ne)
    o += 9 * ne
    XPP = view4(fpool, o, 3, ne, 3, ne)
    o += 9 * ne * ne
    P0 = view2(fpool, o, ne, ne)
    o += ne * ne
    K1 = view3(fpool, o, 3, ne, ne)
    o += 3 * ne * ne
    Ys0S = view3(fpool, o, 3, ns, ns)
    o += 3 * ns * ns
    YPS = view4(fpool, o, 3, ne, ns, ns)
    o += 3 * ne * ns * ns
    ZSS = view4(fpool, o, ns, ns, ns, ns)
    o += ns * ns * ns * ns
    Jsum = fpool[o]
    o += 1
    Jeta, o = _take(fpool, o, ne)
    Jee = view2(fpool, o, ne, ne)
    o += ne * ne
    # scratch after the inputs and outputs
    qs, so = _take(scr, so, ns)
    qds, so = _take(scr, so, ns)
    Zq = view3(scr, so, ns, ns, ns)
    so += ns * ns * ns
    ZV = view2(scr, so, ns, ns)
    so += ns * ns
    ZQ = view2(scr, so, ns, ns)
    so += ns * ns
    ZD, so = _take(scr, so, ns)
    cv, so = _take(scr, so, ns)
    vbar, so = _take(scr, so, ns)
    V0 = view2(scr, so, ns, 3)
    so += 3 * ns
    VP = view3(scr, so, 3, ne, ns)
    so += 3 * ne * ns
    VPq = view2(scr, so, 3, ns)
    so += 3 * ns
    sv = view2(scr, so, 3, ns)
    so += 3 * ns
    aVP = view2(scr, so, ne, ns)
    so += ne * ns
    uVP = view2(scr, so, ne, ns)
    so += ne * ns
    CPhi = view2(scr, so, 3, ne)
    so += 3 * ne
    DPhi = view2(scr, so, 3, ne)
    so += 3 * ne
    XPq = view3(scr, so, 3, ne, 3)
    so += 9 * ne
    H = view3(scr, so, 3, 3, ne)
    so += 9 * ne
    wK1 = view2(scr, so, ne, ne)
    so += ne * ne
    m33 = view3(scr, so, 5, 3, 3)
    so += 45
    J, A1, A2, Hq = m33[0], m33[1], m33[2], m33[3]
    v3 = view2(scr, so, 10, 3)
    so += 30
    c_s0, d_s0, cPq, dPq, gma, Ctq, Jw, u, t1 = v3[0], v3[1], v3[2], v3[3], v3[4], v3[5], v3[6], v3[7], v3[8]
    for x in range(ns):
        qs[x] = qe[sidx[x]]
        qds[x] = qde[sidx[x]]
    # S S terms (ns^4): Zq_abc = sum_d ZSS_abcd q_d; sum m v v^T = ZV;
    # sum m c S = ZQ; sum m c v = ZQ q; sum m d v = ZD; sum m c^2 = c2
    for x in range(ns):
        for y in range(ns):
            for z in range(ns):
                acc = 0.0
                for t in range(ns):
                    acc += ZSS[x, y, z, t] * qs[t]
                Zq[x, y, z] = acc
    c2 = 0.0
    for x in range(ns):
        for z in range(ns):
            acc = 0.0
            acc2 = 0.0
            for y in range(ns):
                acc += Zq[x, y, z] * qs[y]
                acc2 += Zq[x, z, y] * qs[y]
            ZV[x, z] = acc
            ZQ[x, z] = acc2
    for x in range(ns):
        acc = 0.0
        acc2 = 0.0
        acc3 = 0.0
        for y in range(ns):
            acc += ZQ[x, y] * qs[y]
            acc3 += mS[x, y] * qs[y]
            for z in range(ns):
                acc2 += Zq[y, z, x] * qds[y] * qds[z]
        cv[x] = acc
        ZD[x] = acc2
        vbar[x] = acc3
        c2 += qs[x] * acc
    csum = 0.0
    dsum = 0.0
    for x in range(ns):
        csum += qs[x] * vbar[x]
        for y in range(ns):
            dsum += qds[x] * mS[x, y] * qds[y]
    # s0 S terms: V0_ai = sum m v_a s0_i; c_s0 = sum m c s0; d_s0 = sum m d s0
    for i in range(3):
        c_s0[i] = 0.0
        d_s0[i] = 0.0
        for x in range(ns):
            acc = 0.0
            for y in range(ns):
                acc += Ys0S[i, x, y] * qs[y]
                d_s0[i] += Ys0S[i, x, y] * qds[x] * qds[y]
            V0[x, i] = acc
            c_s0[i] += acc * qs[x]
    # Phi S terms: VP_ila = sum m v_a Phi_il; CPhi = sum m c Phi; DPhi = sum m d Phi
    for i in range(3):
        for l in range(ne):
            cacc = 0.0
            dacc = 0.0
            for x in range(ns):
                acc = 0.0
                for y in range(ns):
                    acc += YPS[i, l, x, y] * qs[y]
                    dacc += YPS[i, l, x, y] * qds[x] * qds[y]
                VP[i, l, x] = acc
                cacc += acc * qs[x]
            CPhi[i, l] = cacc
            DPhi[i, l] = dacc
    # u = a x w: w . (x x a) = x . u
    c = _cross3(a[0], a[1], a[2], w[0], w[1], w[2])
    u[0], u[1], u[2] = c[0], c[1], c[2]
    for x in range(ns):
        for i in range(3):
            acc = 0.0
            for l in range(ne):
                acc += VP[i, l, x] * qe[l]
            VPq[i, x] = acc                                   # sum m v_a (Phi q)_i
        for l in range(ne):
            aVP[l, x] = a[0] * VP[0, l, x] + a[1] * VP[1, l, x] + a[2] * VP[2, l, x]
            uVP[l, x] = u[0] * VP[0, l, x] + u[1] * VP[1, l, x] + u[2] * VP[2, l, x]
    # Phi Phi terms: XPq_ilj = sum m Phi_il (Phi q)_j; A2 = sum m (Phi q)(Phi q)^T; A1 = sum m s0 (Phi q)^T
    for i in range(3):
        for l in range(ne):
            for j in range(3):
                acc = 0.0
                for m_ in range(ne):
                    acc += XPP[i, l, j, m_] * qe[m_]
                XPq[i, l, j] = acc
    for i in range(3):
        cPq[i] = 0.0
        dPq[i] = 0.0
        for l in range(ne):
            cPq[i] += CPhi[i, l] * qe[l]
            dPq[i] += DPhi[i, l] * qe[l]
        for j in range(3):
            x1 = 0.0
            x2 = 0.0
            for l in range(ne):
                x1 += Xs0P[i, j, l] * qe[l]
                x2 += XPq[i, l, j] * qe[l]
            A1[i, j] = x1
            A2[i, j] = x2
    # m p, J = sum m s s^T, I_rr (A5, with the node polar inertia)
    for i in range(3):
        x = ms0[i] - 0.5 * csum * a[i]
        for l in range(ne):
            x += mPhi[i, l] * qe[l]
        mp[i] = x
    for i in range(3):
        for j in range(3):
            J[i, j] = (Js0[i, j] + A1[i, j] + A1[j, i] + A2[i, j]
                       - 0.5 * (c_s0[i] * a[j] + a[i] * c_s0[j] + cPq[i] * a[j] + a[i] * cPq[j])
                       + 0.25 * c2 * a[i] * a[j])
    tr = J[0, 0] + J[1, 1] + J[2, 2]
    for i in range(3):
        for j in range(3):
            Irr[i, j] = (tr if i == j else 0.0) - J[i, j] + Jsum * a[i] * a[j]
    # C_t = sum m B; H_ijl = sum m s_i B_jl; C_r,l = sum m s x B_l (A3-A4)
    for i in range(3):
        for l in range(ne):
            Ct[i, l] = mPhi[i, l]
            for j in range(3):
                H[i, j, l] = Xs0P[i, j, l] + XPq[j, l, i] - 0.5 * a[i] * CPhi[j, l]
        for x in range(ns):
            Ct[i, sidx[x]] -= a[i] * vbar[x]
            sv[i, x] = V0[x, i] + VPq[i, x] - 0.5 * a[i] * cv[x]        # sum m s_i v_a
    for x in range(ns):
        for i in range(3):
            for j in range(3):
                H[i, j, sidx[x]] -= a[j] * sv[i, x]
    for l in range(ne):
        Cr[0, l] = H[1, 2, l] - H[2, 1, l]
        Cr[1, l] = H[2, 0, l] - H[0, 2, l]
        Cr[2, l] = H[0, 1, l] - H[1, 0, l]
    # M_ee = sum m B^T B (A7)
    for l in range(ne):
        for m_ in range(ne):
            Mee[l, m_] = P0[l, m_] + Jee[l, m_]
    for x in range(ns):
        mx = sidx[x]
        for l in range(ne):
            Mee[l, mx] -= aVP[l, x]
            Mee[mx, l] -= aVP[l, x]
        for y in range(ns):
            Mee[mx, sidx[y]] += ZV[x, y]
    # loads (A16): f_t, f_r, f_e of the inertial and gravity loads
    for i in range(3):
        gma[i] = gb[i] - ab[i]
        x = 0.0
        for l in range(ne):
            x += Ct[i, l] * qde[l]
        Ctq[i] = x
        for j in range(3):
            x = 0.0
            for l in range(ne):
                x += H[i, j, l] * qde[l]
            Hq[i, j] = x
        Jw[i] = J[i, 0] * w[0] + J[i, 1] * w[1] + J[i, 2] * w[2]
    c = _cross3(w[0], w[1], w[2], mp[0], mp[1], mp[2])
    c1 = _cross3(al[0], al[1], al[2], mp[0], mp[1], mp[2])
    c2v = _cross3(w[0], w[1], w[2], c[0], c[1], c[2])
    c3 = _cross3(w[0], w[1], w[2], Ctq[0], Ctq[1], Ctq[2])
    for i in range(3):
        ft[i] = mass * gma[i] - c1[i] - c2v[i] - 2.0 * c3[i] + a[i] * dsum
    trHq = Hq[0, 0] + Hq[1, 1] + Hq[2, 2]
    for i in range(3):
        t1[i] = d_s0[i] + dPq[i]
    c = _cross3(mp[0], mp[1], mp[2], gma[0], gma[1], gma[2])
    c1 = _cross3(Jw[0], Jw[1], Jw[2], w[0], w[1], w[2])
    c3 = _cross3(t1[0], t1[1], t1[2], a[0], a[1], a[2])
    eal = a[0] * al[0] + a[1] * al[1] + a[2] * al[2]
    for i in range(3):
        Ja = J[i, 0] * al[0] + J[i, 1] * al[1] + J[i, 2] * al[2]
        HTw = Hq[0, i] * w[0] + Hq[1, i] * w[1] + Hq[2, i] * w[2]
        fr[i] = (c[i] - (tr * al[i] - Ja) - c1[i] - 2.0 * (w[i] * trHq - HTw) + c3[i]
                 - Jsum * eal * a[i])
    ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
    for l in range(ne):
        for m_ in range(ne):
            wK1[m_, l] = w[0] * K1[0, m_, l] + w[1] * K1[1, m_, l] + w[2] * K1[2, m_, l]
    for x in range(ns):
        lx = sidx[x]
        for m_ in range(ne):
            wK1[m_, lx] -= uVP[m_, x]             # w . sum m B_m x B_l, l shortening
            wK1[lx, m_] += uVP[m_, x]             # m shortening
    for l in range(ne):
        x = 0.0
        for i in range(3):
            x += Ct[i, l] * gma[i] - al[i] * Cr[i, l] + a[i] * DPhi[i, l]
            for j in range(3):
                x -= w[i] * H[i, j, l] * w[j]
        x += ww * (H[0, 0, l] + H[1, 1, l] + H[2, 2, l])
        for m_ in range(ne):
            x -= 2.0 * qde[m_] * wK1[m_, l]
        if pos[l] >= 0:
            x -= ZD[pos[l]]
        fe[l] = x - eal * Jeta[l]
    # node polar inertia (eq. A with t = [0, e_g, eta]) in C_r
    for l in range(ne):
        for i in range(3):
            Cr[i, l] += a[i] * Jeta[l]
    # node forces of the loading effects, summed over the nodes: with
    # c_k = q^T S_k q = S_k : q q^T and sum_k (a . f_k) S_k q
    if loaded:
        Sn, o = _take(fpool, o, N * ns * ns)
        s0n, o = _take(fpool, o, 3 * N)
        Phi = fpool[phi0:phi0 + 3 * N * ne]
        Q, so = _take(scr, so, ns * ns)
        g, so = _take(scr, so, ns * ns)
        nss = ns * ns
        for x in range(ns):
            for y in range(ns):
                Q[x * ns + y] = qs[x] * qs[y]
        for x in range(nss):
            g[x] = 0.0
        for k in range(N):
            _rotate_back(R, fnodes[a0 + k, 0:3], fk)
            af = a[0] * fk[0] + a[1] * fk[1] + a[2] * fk[2]
            ck = 0.0
            base = k * nss
            for x in range(nss):
                sx = Sn[base + x]
                ck += sx * Q[x]
                g[x] += af * sx
            sk0 = s0n[3 * k] - 0.5 * ck * a[0]
            sk1 = s0n[3 * k + 1] - 0.5 * ck * a[1]
            sk2 = s0n[3 * k + 2] - 0.5 * ck * a[2]
            r0, r1, r2 = 3 * k * ne, (3 * k + 1) * ne, (3 * k + 2) * ne
            for l in range(ne):
                p0, p1, p2 = Phi[r0 + l], Phi[r1 + l], Phi[r2 + l]
                sk0 += p0 * qe[l]
                sk1 += p1 * qe[l]
                sk2 += p2 * qe[l]
                fe[l] += p0 * fk[0] + p1 * fk[1] + p2 * fk[2]
            c = _cross3(sk0, sk1, sk2, fk[0], fk[1], fk[2])
            for i in range(3):
                ft[i] += fk[i]
                fr[i] += c[i]
        for x in range(ns):
            acc = 0.0
            for y in range(ns):
                acc += g[x * ns + y] * qs[y]
            fe[sidx[x]] -= acc
    return mass


