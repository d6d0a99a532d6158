"""Packing a `KaneEquations` into the flat arrays of the compiled kernel
(`kernel.py`, which defines the layout constants used here).

`pack(eq, active)` returns `Packed`: `data`, a tuple of arrays

    (body_int (nb, N_INT), body_float (nb, N_FLOAT), int pool, rotation axes,
     rotation coefficients (n_rot, n), rotation offsets, translation matrices
     A (nb, 3, n), shortening matrices G (nb, ns, ns), node positions s0
     (N_nodes, 3), node masses, node polar inertias, float pool, active mask,
     invariant route: `invariant_sums` or a stand-in, `invariant_function`;
     gearbox losses: `gearbox_loss` or a stand-in, `loss_function`)

(the int pool holds each body's Jacobian columns, elastic coordinates and
shortening coordinates, and for a body on the invariant route its
shortening modes; the float pool each flexible body's Phi (N,3,ne),
S (N,ne,ne), eta (N,ne), K and D, and its invariants, contiguous), and
`work`, the arrays the kernels write (body frames: R (nb+1,3,3) and vec
(nb+1,5,3) = [r, v, w, a_bias, alpha_bias] with slot nb the ground;
Jacobians; scratch, the last the flexible bodies' M_ee and the invariant
route's intermediate sums). Each flexible body takes the node sums or its
invariants, whichever is the cheaper (`body_integrals.choose_invariants`).
Rigid bodies on constant joints are lumped here (`lumping.lump`).
`with_load_points` gives a packing whose bodies take their loads at load
points (`LoadPoints`) instead of their nodes.
"""
from __future__ import annotations

import ctypes
from dataclasses import dataclass, field, replace

import numba.experimental.function_type  # noqa: F401  (numba's typeof of `_Unused`)
import numpy as np
from numba import types

from modesel.multibody.kernel import (AXIS, CM, COL0, E0, ETA0, FLEX, HAS_A, HAS_ETA, HAS_JP, HAS_S, INERTIA,
                                      INV0, INVARIANT_SIG, KD0, KIND, LOAD0, LOSS, LOSS_ETA, LOSS_K, LOSS_SIG,
                                      LUMPED, MASS, N_FLOAT, N_INT, NCOL, NE, NLOAD, NNODE, NODE0, NROT, NS, NSH,
                                      OFF, PARENT, PHI0, POLAR, R0, RIGID, ROT0, S0, SH0, SH_E, SIX0, SKIP)
from modesel.multibody import body_integrals
from modesel.multibody.lumping import RigidPart, constant_placement, lump, rigid_equivalent


@dataclass
class Packed:
    """Flat arrays of a compiled system (`data`) and reusable work arrays."""

    data: tuple
    work: tuple
    n_all: int
    n_bodies: int
    node_start: dict      # flexible body name -> (first node, node count)
    #: flexible body name -> `LoadPoints` of a body whose node loads come at
    #: load points (`with_load_points`); the others take them at their nodes
    load_points: dict = field(default_factory=dict)

    def node_rows(self, name) -> tuple:
        """(first row, count) of flexible body `name`'s node loads in fnodes.
        A body that takes its loads at load points has no node rows the
        kernel reads: ValueError, so that no effect's node loads are lost."""
        if name in self.load_points:
            raise ValueError(f"{name} takes its loads at load points, not at its nodes")
        return self.node_start[name]

    def _rows_used(self) -> int:
        """Node rows of every flexible body, then the rows of the load points."""
        return (sum(c for _, c in self.node_start.values())
                + sum(len(p.weights) for p in self.load_points.values()))

    @property
    def n_rows(self) -> int:
        """Rows of the node loads (fnodes): every node, then the load points
        (at least one row)."""
        return max(self._rows_used(), 1)


def _joint_columns(joint, n):
    cols = set(np.flatnonzero(np.any(joint.A != 0.0, axis=0))) if joint.has_A else set()
    for _, c, _ in joint.rotations:
        cols |= set(np.flatnonzero(c != 0.0))
    if joint.short is not None:
        cols |= set(int(i) for i in joint.short[1])
    return cols


def pack(eq, active=None, invariants=None) -> Packed:
    """Pack `eq` (a `KaneEquations`) for the kernels. `active` (n_all bool):
    coordinates whose rows/columns of M and F are needed (default all);
    the others must have zero rate (fixed coordinates). `invariants`: True
    or False forces every flexible body onto the invariant route or the
    node sums (`body_integrals`); None takes the cheaper per body."""
    n = eq.n_all
    active = np.ones(n, bool) if active is None else np.asarray(active, bool)
    nb = len(eq.bodies)
    slot = {b.name: i for i, (b, _, _) in enumerate(eq.bodies)}
    bi = np.zeros((nb, N_INT), np.int64)
    bf = np.zeros((nb, N_FLOAT))
    A = np.zeros((nb, 3, n))
    rot_axis, rot_c, rot_off = [], [], []
    ipool = []
    cols_of = []
    flex_nodes = []
    nsh_max = max([len(j.short[1]) for _, j, _ in eq.bodies if j.short is not None] + [1])
    ne_max = max([len(f.idx) for _, _, f in eq.bodies if f is not None] + [1])
    shG = np.zeros((nb, nsh_max, nsh_max))
    node_start = {}
    n_nodes = 0
    for k, (b, j, f) in enumerate(eq.bodies):
        parent = -1 if j.parent is None else slot[j.parent]
        bi[k, PARENT] = parent
        bf[k, OFF:OFF + 3] = j.offset
        bf[k, R0:R0 + 9] = j.R0.ravel()
        if j.has_A:
            A[k] = j.A
            bi[k, HAS_A] = 1
        bi[k, ROT0], bi[k, NROT] = len(rot_axis), len(j.rotations)
        for axis, c, off in j.rotations:
            rot_axis.append(axis)
            rot_c.append(c)
            rot_off.append(off)
        if j.short is not None:
            e, idx, G = j.short
            bi[k, SH0], bi[k, NSH] = len(ipool), len(idx)
            ipool.extend(int(i) for i in idx)
            shG[k, :len(idx), :len(idx)] = G
            bf[k, SH_E:SH_E + 3] = e
        cols = (set() if parent < 0 else set(cols_of[parent])) | _joint_columns(j, n)
        cols = sorted(c for c in cols if active[c])
        cols_of.append(cols)
        bi[k, COL0], bi[k, NCOL] = len(ipool), len(cols)
        ipool.extend(cols)
        if f is None:
            has_inertia = b.mass != 0.0 or np.any(b.inertia)
            bi[k, KIND] = RIGID if (has_inertia and cols) else SKIP
            bf[k, MASS] = b.mass
            bf[k, CM:CM + 3] = np.asarray(b.cm, float)
            bf[k, INERTIA:INERTIA + 9] = np.asarray(b.inertia, float).ravel()
            continue
        ne = len(f.idx)
        N = len(f.m)
        bi[k, NODE0], bi[k, NNODE], bi[k, NE] = n_nodes, N, ne
        bi[k, LOAD0], bi[k, NLOAD] = n_nodes, N
        node_start[b.name] = (n_nodes, N)
        n_nodes += N
        flex_nodes.append((k, f))
        bf[k, AXIS:AXIS + 3] = f.axis
        bi[k, E0] = len(ipool)
        ipool.extend(int(i) for i in f.idx)
        has_jp = f.Jp is not None and bool(np.any(f.Jp))
        bi[k, HAS_JP] = has_jp
        if ne == 0:
            # rigid equivalent of the node sums (A2-A7 at q_e = 0): exact
            part = rigid_equivalent(f.s0, f.m)
            bf[k, MASS] = part.mass
            bf[k, CM:CM + 3] = part.cm
            bf[k, INERTIA:INERTIA + 9] = part.inertia.ravel()
            if has_jp:
                bf[k, POLAR:POLAR + 9] = (float(f.Jp.sum()) * np.outer(f.axis, f.axis)).ravel()
            bi[k, KIND] = RIGID if cols else SKIP
        else:
            bi[k, KIND] = FLEX
            bi[k, HAS_S] = f.S is not None
            bi[k, HAS_ETA] = f.eta is not None
    s0 = np.zeros((max(n_nodes, 1), 3))
    nm = np.zeros(max(n_nodes, 1))
    Jp = np.zeros(max(n_nodes, 1))
    fpool = [np.zeros(1)]          # per flexible body, contiguous: Phi (N,3,ne), S (N,ne,ne), eta (N,ne), K, D,
    size = 1                       # [invariants (body_integrals.BLOCKS)]
    scratch = 1
    for k, f in flex_nodes:
        a, N, ne = bi[k, NODE0], bi[k, NNODE], bi[k, NE]
        s0[a:a + N] = f.s0
        nm[a:a + N] = f.m
        if f.Jp is not None:
            Jp[a:a + N] = f.Jp
        if ne == 0:
            continue
        blocks = [(PHI0, f.Phi), (S0, f.S), (ETA0, f.eta), (KD0, np.stack([f.K, f.D]))]
        use = body_integrals.choose_invariants(f) if invariants is None else bool(invariants)
        if use:
            flat, sidx = body_integrals.invariants(f)
            blocks.append((INV0, flat))
            pos = np.full(ne, -1, np.int64)
            pos[sidx] = np.arange(len(sidx))
            # header of invariant_sums: ne, ns, first node, node count, offsets of
            # the invariants and of Phi in the float pool (set below), modes, positions
            head = bi[k, SIX0] = len(ipool)
            bi[k, NS] = len(sidx)
            ipool.extend([ne, len(sidx), int(a), N, 0, 0])
            ipool.extend(int(i) for i in sidx)
            ipool.extend(int(i) for i in pos)
            scratch = max(scratch, body_integrals.scratch_size(ne, len(sidx)))
        for col, arr in blocks:
            if arr is None:
                continue
            bi[k, col] = size
            fpool.append(np.ascontiguousarray(arr, float).ravel())
            size += fpool[-1].size
        if use:
            ipool[head + 4], ipool[head + 5] = bi[k, INV0], bi[k, PHI0]
    _lump_rigid_subtrees(eq, bi, bf)
    if eq.loss is not None and active[eq.loss[1]]:
        k, g, eta = eq.loss
        body = eq.bodies[k][0]
        if bi[k, KIND] not in (RIGID, SKIP) or body.mass != 0.0:
            raise ValueError(f"the gearbox's body {body.name} must be a massless rigid body (an inertia) turning "
                             f"with its coordinate")
        # the loss factor held until a solve decides it: the shaft driving the generator (as ElastoDyn starts)
        bi[k, LOSS], bf[k, LOSS_ETA], bf[k, LOSS_K] = g + 1, eta, 1.0 / eta
    n_max = max([bi[k, NNODE] for k, _ in flex_nodes] + [1])
    nrot = max(len(rot_axis), 1)
    rc = np.zeros((nrot, n))
    if rot_c:
        rc[:len(rot_c)] = np.array(rot_c)
    data = (bi, bf, np.array(ipool + [0], np.int64), np.array(rot_axis + [0], np.int64), rc,
            np.array(rot_off + [0.0]), A, shG, s0, nm, Jp, np.concatenate(fpool), active.copy(),
            invariant_function(bool(np.any(bi[:, INV0] > 0))), loss_function(bool(np.any(bi[:, LOSS] > 0))))
    work = _work_arrays(nb, n, ne_max, n_max) + (np.zeros(scratch), np.zeros((ne_max, ne_max)))
    return Packed(data, work, n, nb, node_start)


@dataclass(frozen=True)
class LoadPoints:
    """P load points of a flexible body, each standing for the node loads of
    one column of a fixed transfer T (N, P): node loads f_k = sum_a T_ka g_a
    of point intensities g_a (e.g. a line load [N/m] at the blade's
    aerodynamic stations, `effects/aero.py`). Every node sum a load enters
    (f_t, f_r, f_e of A16, with s_k and B_k = Phi_k - a (S_k q)^T) is linear
    in the node's s0_k, Phi_k and S_k, so a point with the T-weighted mean
    geometry (s0, Phi, S below) loaded by F_a = w_a g_a gives exactly the
    generalised forces of those node loads, and its moment M_a the work of
    node moments with the same transfer through the body's angular velocity
    and, about the beam axis, through its torsion shapes eta (their mean
    too: the work of a node moment is linear in eta_k). first: its first
    row of the node loads (fnodes); weights w_a = sum_k T_ka [m for a line
    load]."""

    first: int
    weights: np.ndarray     # (P,)
    s0: np.ndarray          # (P, 3) [m]
    Phi: np.ndarray         # (P, 3, ne)
    S: np.ndarray | None    # (P, ne, ne) [1/m] or None
    eta: np.ndarray | None = None   # (P, ne) [rad] or None: no torsion shapes


def with_load_points(packed: Packed, eq, transfers: dict) -> Packed:
    """`packed` with the loads of the bodies in `transfers` ({flexible body
    name: T (N, P)}, `LoadPoints`) taken at load points: their rows follow
    the nodes' in fnodes, and the body's loaded sums (`invariant_sums`, the
    node moments of `kernel._flexible`) run over its P points instead of its
    N nodes. Only a body on the invariant route with fewer points than
    nodes takes them; the others keep their nodes
    (`Packed.load_points` says which did). The arrays of `packed` are not
    changed."""
    bodies = {b.name: (k, f) for k, (b, _, f) in enumerate(eq.bodies) if f is not None}
    bi, ipool, fpool = packed.data[0].copy(), packed.data[2].copy(), packed.data[11]
    blocks = [fpool]
    size = fpool.size
    row = packed._rows_used()               # the next load point's row
    points = dict(packed.load_points)
    for name, T in transfers.items():
        k, f = bodies[name]
        if bi[k, KIND] != FLEX or bi[k, INV0] == 0 or name in points:
            continue
        T = np.asarray(T, float)
        if T.shape[1] >= T.shape[0]:
            continue                            # no fewer points than nodes
        w = T.sum(axis=0)
        W = T * np.divide(1.0, w, out=np.zeros_like(w), where=w != 0.0)            # columns: weighted means
        lp = LoadPoints(row, w, W.T @ f.s0, np.einsum("kp,kil->pil", W, f.Phi),
                        None if f.S is None else np.einsum("kp,kab->pab", W, f.S),
                        None if f.eta is None else W.T @ f.eta)
        ne, N, head = bi[k, NE], bi[k, NNODE], bi[k, SIX0]
        sidx = ipool[head + 6:head + 6 + ipool[head + 1]]
        inv = fpool[bi[k, INV0]:bi[k, INV0] + body_integrals.block_size(ne, len(sidx), N)]
        blocks.append(body_integrals.with_load_rows(inv, ne, sidx, N, lp.s0, lp.S))
        bi[k, INV0] = ipool[head + 4] = size
        size += blocks[-1].size
        blocks.append(np.ascontiguousarray(lp.Phi, float).ravel())
        ipool[head + 5] = size
        size += blocks[-1].size
        if lp.eta is not None:                # the points' torsion, read by the node-moment loop only
            blocks.append(np.ascontiguousarray(lp.eta, float).ravel())
            bi[k, ETA0] = size
            size += blocks[-1].size
        ipool[head + 2], ipool[head + 3] = row, len(w)
        bi[k, LOAD0], bi[k, NLOAD] = row, len(w)
        points[name] = lp
        row += len(w)
    if len(points) == len(packed.load_points):
        return packed
    d = packed.data
    data = (bi, d[1], ipool) + d[3:11] + (np.concatenate(blocks),) + d[12:]
    return replace(packed, data=data, work=tuple(a.copy() for a in packed.work), load_points=points)


class _Unused(types.WrapperAddressProtocol):
    """Stands in for `invariant_sums.invariant_sums` in a system where no
    body takes the invariant route, or for `gearbox_loss.gearbox_loss` in
    one without gearbox losses: the same numba type (so that one compiled
    kernel serves both), without loading the cfunc (about 35 ms). No body
    calls it; a call would return NaN (the invariant route: non-finite
    accelerations) or 0 (the gearbox: a singular mass matrix), which the
    kernel reports."""

    def __init__(self, signature, restype, value):
        self._signature = signature
        self._f = ctypes.CFUNCTYPE(restype)(lambda: value)

    def __wrapper_address__(self):
        return ctypes.cast(self._f, ctypes.c_void_p).value

    def signature(self):
        return self._signature


_UNUSED = _Unused(INVARIANT_SIG, ctypes.c_double, float("nan"))
_NO_LOSS = _Unused(LOSS_SIG, ctypes.c_int64, 0)


def invariant_function(needed: bool):
    """data[13] of a packed system: the invariant route's cfunc where a body
    takes it (imported, so compiled or loaded, on first use), else `_Unused`."""
    if needed:
        from modesel.multibody.invariant_sums import invariant_sums
        return invariant_sums
    return _UNUSED


def loss_function(needed: bool):
    """data[14] of a packed system: the gearbox losses' cfunc where a body has
    them (`gearbox_loss`, imported, so compiled or loaded, on first use), else
    a stand-in."""
    if needed:
        from modesel.multibody.gearbox_loss import gearbox_loss
        return gearbox_loss
    return _NO_LOSS


def _lump_rigid_subtrees(eq, bi, bf):
    """Lump every rigid body attached by a constant joint (one that depends
    on no coordinate) to a rigid ancestor (e.g. rigid blades on the hub) into
    that ancestor (`lumping.lump`): same total mass, centre of mass, inertia
    tensor and polar tensor (exact). The lumped body keeps its kinematics
    only for its node forces (kind LUMPED)."""
    n = eq.n_all
    parents = list(bi[:, PARENT])
    flexible = [bi[k, KIND] == FLEX for k in range(len(parents))]
    joins = [bi[k, KIND] == RIGID and parents[k] >= 0 and not flexible[parents[k]]
             and not _joint_columns(j, n) for k, (_, j, _) in enumerate(eq.bodies)]
    parts = [RigidPart(float(bf[k, MASS]), bf[k, CM:CM + 3].copy(), bf[k, INERTIA:INERTIA + 9].reshape(3, 3).copy())
             for k in range(len(parents))]
    placements = [constant_placement(b.joint) if joins[k] else None for k, (b, _, _) in enumerate(eq.bodies)]
    result = lump(parents, parts, placements, joins, whole_subtrees=False)
    for t, part in result.parts.items():
        for k in result.lumped_into(t):
            R = result.pose[k][0]
            P = bf[t, POLAR:POLAR + 9].reshape(3, 3) + R @ bf[k, POLAR:POLAR + 9].reshape(3, 3) @ R.T
            bf[t, POLAR:POLAR + 9] = P.ravel()
            bi[t, HAS_JP] = bi[t, HAS_JP] or bi[k, HAS_JP]
            bi[k, KIND] = LUMPED
        bi[t, KIND] = RIGID
        bf[t, MASS] = part.mass
        bf[t, CM:CM + 3] = part.cm
        bf[t, INERTIA:INERTIA + 9] = part.inertia.ravel()


def _work_arrays(nb, n, ne_max, n_max):
    """Arrays the kernels write: body frames (slot nb = ground) and scratch."""
    ne1 = max(ne_max, 1)
    R = np.zeros((nb + 1, 3, 3))
    R[nb] = np.eye(3)
    vec = np.zeros((nb + 1, 5, 3))                    # r, v, w, a_bias, alpha_bias
    Jv = np.zeros((nb + 1, 3, n))
    Jw = np.zeros((nb + 1, 3, n))
    m3n = np.zeros((2, 3, n))                         # J_w,rel, J_rho of a joint
    m6n = np.zeros((2, 6 + ne_max, n))                # [J_v; J_w] on a body's columns, Mb times it
    e_scr = np.zeros((3, ne1))                        # q_e, qd_e, elastic forces
    B3 = np.zeros((2, 3, ne1))                        # C_t^T, C_r^T (body frame)
    Mb = np.zeros((6 + ne_max, 6 + ne_max))           # generalised body mass
    fy = np.zeros(6 + ne_max)                         # generalised body force
    v_scr = np.zeros((16, 3))
    m_scr = np.zeros((2, 3, 3))
    nodes = np.zeros((6, 3 * n_max * (ne_max + 1)))   # B_loc, [m B_loc, load], S q, s, p_dot, load
    G = np.zeros(18 * n_max)                          # [I; [s_k~]] per node
    return (R, vec, Jv, Jw, m3n, m6n, e_scr, B3, Mb, fy, v_scr, m_scr, nodes, G)
