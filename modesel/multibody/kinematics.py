"""Kinematics of body frames and of points on flexible bodies, for the
Kane equations and for loads that depend on the motion (aerodynamics, tower
drag).

Node kinematics of a flexible body (first paper Appendix D4, second paper
eq. 3), body frame (s, B_loc) and inertial axes (p, v_p):

    s      = s0 + Phi q_e - 1/2 (q_e^T S_k q_e) e_axis
    B_loc  = ds/dq_e = Phi - e_axis (S_k q_e)^T
    p      = r + R s
    v_p    = v + w x (R s) + R B_loc qd_e

`deformed_nodes` and `node_kinematics` are the numpy reference (used by
`KaneEquations`, and by `PointSet.along` for many states at once: they take
a leading axis of states); `points` is their compiled twin (numba), used
through `PointSet` on the quadrature nodes or other stations such as the
AeroDyn nodes. tests/test_turbine.py holds the two equal.

`FrameKinematics(eq)(q_all, qd_all)` returns every body frame's rotation R
and origin position r, velocity v, angular velocity w (inertial axes),
computed by the compiled recursive kinematics (`kernel.kinematics`, the
twin of `KaneEquations.kinematics`) on its own packed arrays.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from modesel.multibody import kernel
from modesel.multibody.packing import pack
from modesel.multibody.rotations import cross


def deformed_nodes(s0, Phi, S, axis, qe, qde):
    """Body-frame node positions s (N,3) [m], partial velocities
    B_loc = ds/dq_e (N,3,ne) and the acceleration at qdd_e = 0,
    -(qd_e^T S_k qd_e) e_axis (N,3), of a flexible body with nodes s0 (N,3),
    shapes Phi (N,3,ne), shortening matrices S (N,ne,ne) (None: none) along
    `axis`, at elastic state (qe, qde) (first paper D4). For n states at
    once, qe and qde (n, ne): every result then has the leading axis n."""
    s = s0 + np.einsum("mil,...l->...mi", Phi, qe)
    B_loc = np.broadcast_to(Phi, s.shape[:-2] + Phi.shape).copy()
    acc_loc = np.zeros_like(s)
    if S is not None:
        Sq = np.einsum("mlj,...j->...ml", S, qe)                   # (..., N, ne)
        s = s - 0.5 * np.einsum("...ml,...l->...m", Sq, qe)[..., None] * axis
        B_loc = B_loc - axis[:, None] * Sq[..., None, :]
        acc_loc = -np.einsum("mij,...i,...j->...m", S, qde, qde)[..., None] * axis
    return s, B_loc, acc_loc


def node_kinematics(R, r, v, w, s0, Phi, S, axis, qe, qde):
    """Inertial positions (N,3) [m] and velocities (N,3) [m/s] of a
    flexible body's nodes, and their body-frame positions s (N,3), for a
    body frame with rotation R, origin r, velocity v and angular velocity w
    (see `deformed_nodes` for the rest). For n states at once, R (n,3,3),
    r, v, w (n,3) and qe, qde (n,ne): every result then has the leading axis n."""
    s, B_loc, _ = deformed_nodes(s0, Phi, S, axis, qe, qde)
    p = np.einsum("...ij,...mj->...mi", R, s)
    sd = np.einsum("...mil,...l->...mi", B_loc, qde)              # ds/dt in the body frame
    vel = v[..., None, :] + cross(w[..., None, :], p) + np.einsum("...ij,...mj->...mi", R, sd)
    return r[..., None, :] + p, vel, s


class FrameKinematics:
    """Body frames of a `KaneEquations` at any state (compiled)."""

    def __init__(self, eq):
        active = np.zeros(eq.n_all, bool)
        active[eq.free_idx] = True
        active[eq.presc_idx] = True
        self.packed = pack(eq, active, invariants=False)      # frames only: no body sums
        self.index = dict(eq.body_index)

    def __call__(self, q_all, qd_all):
        """(R (n_bodies+1, 3, 3), vec (n_bodies+1, 5, 3)) with vec[b] = [r, v, w, a_bias,
        alpha_bias] of body b (index `self.index[name]`)."""
        p = self.packed
        kernel.kinematics(np.asarray(q_all, float), np.asarray(qd_all, float), p.data, p.work)
        return p.work[0], p.work[1]

    def along(self, Q, QD):
        """The frames at each state (rows of Q, QD (n, n_all)) in one compiled
        call: (R (n, n_bodies+1, 3, 3), vec (n, n_bodies+1, 5, 3)), row k as
        `__call__` gives it for state k (not a buffer: kept)."""
        p = self.packed
        Q, QD = np.ascontiguousarray(Q, float), np.ascontiguousarray(QD, float)
        R = np.empty((len(Q),) + p.work[0].shape)
        vec = np.empty((len(Q),) + p.work[1].shape)
        kernel.kinematics_along(Q, QD, p.data, p.work, R, vec)
        return R, vec


@dataclass
class PointSet:
    """Points of a flexible body: s0 (M,3) [m], Phi (M,3,ne), S (M,ne,ne) or
    zeros, axis (3,), idx (ne,) indices of the body's elastic coordinates,
    body (index into the frame arrays)."""

    body: int
    s0: np.ndarray
    Phi: np.ndarray
    S: np.ndarray
    axis: np.ndarray
    idx: np.ndarray

    @classmethod
    def of_body(cls, eq, name):
        """The quadrature nodes of flexible body `name`."""
        b = eq.system.body(name)
        return cls.of_points(eq, name, b.nodes, b.shapes, b.shortening)

    @classmethod
    def of_points(cls, eq, name, s0, Phi, S):
        """Points of flexible body `name` with their own s0, Phi, S (S None: no shortening)."""
        b = eq.system.body(name)
        ne = b.n_elastic
        s0 = np.asarray(s0, float)
        M = len(s0)
        Phi = np.asarray(Phi, float) if (ne and Phi is not None) else np.zeros((M, 3, ne))
        S = np.zeros((M, ne, ne)) if (S is None or not ne) else np.asarray(S, float)
        idx = np.array([eq.index[d] for d in b.dofs], dtype=np.int64)
        return cls(eq.body_index[name], np.ascontiguousarray(s0), np.ascontiguousarray(Phi),
                   np.ascontiguousarray(S), np.asarray(b.axis, float), idx)

    def kinematics(self, frames, q_all, qd_all, pos=None, vel=None):
        """Inertial positions and velocities (M,3) of the points."""
        R, vec = frames
        M = len(self.s0)
        pos = np.empty((M, 3)) if pos is None else pos
        vel = np.empty((M, 3)) if vel is None else vel
        points(R[self.body], vec[self.body], self.s0, self.Phi, self.S, self.axis,
               q_all[self.idx], qd_all[self.idx], pos, vel)
        return pos, vel

    def along(self, frames, Q, QD):
        """Inertial positions and velocities (n, M, 3) of the points at each of
        n states (rows of Q, QD (n, n_all)), for the frames `FrameKinematics.along`
        gives at them: the numpy reference (`node_kinematics`) at every state at once."""
        R, vec = frames
        b = self.body
        pos, vel, _ = node_kinematics(R[:, b], vec[:, b, 0], vec[:, b, 1], vec[:, b, 2], self.s0, self.Phi, self.S,
                                      self.axis, Q[:, self.idx], QD[:, self.idx])
        return pos, vel


@njit(cache=True)
def points(R, vec, s0, Phi, S, axis, qe, qde, pos, vel):
    """Positions `pos` and velocities `vel` (M,3) of points on a flexible
    body with frame (R, vec = [r, v, w, ...]) at elastic state (qe, qde):
    the compiled twin of `node_kinematics` (S zeros: no shortening)."""
    ne = qe.shape[0]
    r, v, w = vec[0], vec[1], vec[2]
    s = np.empty(3)
    sd = np.empty(3)
    Sq = np.empty(ne)
    for k in range(s0.shape[0]):
        qSq = 0.0
        qdSq = 0.0
        for l in range(ne):
            x = 0.0
            for m in range(ne):
                x += S[k, l, m] * qe[m]
            Sq[l] = x
            qSq += qe[l] * x
            qdSq += qde[l] * x
        for i in range(3):
            si = s0[k, i] - 0.5 * qSq * axis[i]
            di = -qdSq * axis[i]
            for l in range(ne):
                si += Phi[k, i, l] * qe[l]
                di += Phi[k, i, l] * qde[l]
            s[i] = si
            sd[i] = di
        for i in range(3):
            p = R[i, 0] * s[0] + R[i, 1] * s[1] + R[i, 2] * s[2]
            pd = R[i, 0] * sd[0] + R[i, 1] * sd[1] + R[i, 2] * sd[2]
            pos[k, i] = r[i] + p
            vel[k, i] = v[i] + pd
        # w x (R s)
        p0 = pos[k, 0] - r[0]
        p1 = pos[k, 1] - r[1]
        p2 = pos[k, 2] - r[2]
        vel[k, 0] += w[1] * p2 - w[2] * p1
        vel[k, 1] += w[2] * p0 - w[0] * p2
        vel[k, 2] += w[0] * p1 - w[1] * p0
