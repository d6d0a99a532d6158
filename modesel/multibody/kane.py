"""Kane's method with velocity-transformation matrices (first paper section 2,
eq. 4-22, Appendix A and D1): the method object that turns a `System` into

    M(q) qdd = F(q, qd, t)

in minimal coordinates, for any number of bodies and elastic modes.

The kinematics are recursive over the tree (parents first): for each body
the position r, rotation R, velocity v and angular velocity w of its origin,
their Jacobians J_v = dv/dqd and J_w = dw/dqd (the partial velocities,
eq. 8 and 20) and the "bias" accelerations a_b, alpha_b (accelerations with
qdd = 0). Then each body adds J^T M_body J to M and J^T (f - M_body*bias)
to F (eq. 7, 9, 18, 19). Rigid bodies use eq. 6; flexible bodies use the
Wallrapp equations (eq. 11, Appendix A) with the shape integrals summed over
the body's quadrature nodes at the current deformation, including the
second-order axial shortening (Appendix D4), which yields the geometric
stiffening of Appendix C (tower top mass and self weight, blade centrifugal
and gravity stiffening) from the kinematics themselves.

Cost is O(bodies * n^2) per evaluation, with no symbolic expression growth,
so a 40-DOF model is as easy as a 3-DOF one.

Two implementations of the same equations: this module's numpy code is the
readable reference (`evaluate_full_reference`, `evaluate_reference`); the
numba kernel of `kernel.py` (packed once, on first use, by `packing.pack`)
serves `evaluate`, `evaluate_full` and `compiled_rhs` (`compiled.CompiledRHS`),
and tests hold the two equal to 1e-10. The system must not be modified
after the first evaluation.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from modesel.multibody.bodies import FlexibleBody
from modesel.multibody.compiled import CompiledRHS
from modesel.multibody.kinematics import deformed_nodes, node_kinematics
from modesel.multibody.packing import Packed, pack
from modesel.multibody.rotations import cross, elementary_rotation, skew
from modesel.multibody.system import System

_E = np.eye(3)


@dataclass
class BodyState:
    """Kinematics of one body frame at the current state (inertial axes)."""

    r: np.ndarray
    R: np.ndarray
    v: np.ndarray
    w: np.ndarray
    Jv: np.ndarray
    Jw: np.ndarray
    a_bias: np.ndarray
    alpha_bias: np.ndarray


class JointArrays:
    """A `Joint` over the coordinate vector (n coordinates, `index` name ->
    position): offset (3,), R0 (3,3), translation matrix A (3, n) [m per
    unit q], rotations [(axis, coefficients (n,), offset)], shortening
    (axis (3,), coordinate indices, G) or None."""

    def __init__(self, joint, index, n):
        self.parent = joint.parent
        self.offset = np.asarray(joint.offset, float)
        self.R0 = np.asarray(joint.pre_rotation, float)
        self.A = np.zeros((3, n))
        for d, vec in joint.translation.items():
            self.A[:, index[d]] += np.asarray(vec, float)
        self.has_A = bool(np.any(self.A))
        self.rotations = []
        for rot in joint.rotations:
            c = np.zeros(n)
            for d, k in rot.coeffs.items():
                c[index[d]] += k
            self.rotations.append((rot.axis, c, float(rot.offset)))
        self.short = None
        if joint.shortening is not None:
            sh = joint.shortening
            idx = np.array([index[d] for d in sh.dofs], dtype=int)
            self.short = (np.asarray(sh.axis, float), idx, np.asarray(sh.matrix, float))


class FlexibleArrays:
    """A `FlexibleBody`'s node data as arrays: idx (ne,) positions of its
    elastic coordinates, s0 (N,3), m (N,), axis, Phi (N,3,ne), S (N,ne,ne)
    or None, eta (N,ne) or None, Jp (N,) or None, K and D (ne,ne), mass."""

    def __init__(self, body: FlexibleBody, index):
        self.idx = np.array([index[d] for d in body.dofs], dtype=int)
        ne = len(self.idx)
        N = len(body.node_mass)
        self.s0 = np.asarray(body.nodes, float)
        self.m = np.asarray(body.node_mass, float)
        self.axis = np.asarray(body.axis, float)
        self.Phi = np.zeros((N, 3, ne)) if body.shapes is None else np.asarray(body.shapes, float)
        self.S = None if (body.shortening is None or ne == 0) else np.asarray(body.shortening, float)
        self.eta = None if body.torsion is None else np.asarray(body.torsion, float)
        self.Jp = None if body.node_polar_inertia is None else np.asarray(body.node_polar_inertia, float)
        self.K = np.zeros((ne, ne)) if body.stiffness is None else np.asarray(body.stiffness, float)
        self.D = np.zeros((ne, ne)) if body.damping is None else np.asarray(body.damping, float)
        self.mass = float(self.m.sum())


class BodyArrays(NamedTuple):
    """One body of `KaneEquations.bodies`: its description and its arrays
    (flexible None for a rigid body)."""

    body: object
    joint: JointArrays
    flexible: FlexibleArrays | None


def rigid_terms(body, st: BodyState, gravity) -> tuple:
    """A rigid body's terms of M (n_all x n_all) and F (n_all) (first paper
    eq. 6-7, numpy reference) from its kinematics `st`: mass, centre of mass
    and inertia about it of `body` (body frame), `gravity` (3,) [m/s^2]."""
    p = st.R @ np.asarray(body.cm, float)
    Ig = st.R @ np.asarray(body.inertia, float) @ st.R.T
    JvG = st.Jv - skew(p) @ st.Jw
    aG = st.a_bias + cross(st.alpha_bias, p) + cross(st.w, cross(st.w, p))
    M = body.mass * JvG.T @ JvG + st.Jw.T @ Ig @ st.Jw
    F = JvG.T @ (body.mass * (gravity - aG)) - st.Jw.T @ (Ig @ st.alpha_bias + cross(st.w, Ig @ st.w))
    return M, F


class KaneEquations:
    """Produces M(q) and F(q, qd, t) of a `System` (first paper eq. 22).

    `evaluate(q, qd, t)` takes the *free* coordinates and returns (M, F)
    restricted to them; `evaluate_full` works on all coordinates.
    External loads: `node_forces` {body name: (N, 3) inertial-frame forces
    on the flexible body's nodes [N], or (N, 6): forces and node moments
    [N m], which do work through the body's angular velocity and, about its
    axis, its torsion shapes; the bodies carry no bending slopes, so the
    bending part of a node moment is the loading effect's generalised
    force} and `generalized` (n_all,) forces [N or N m]
    added to the right-hand side (eq. 9-10, 19).

    Public attributes: `names`, `index` (coordinate name -> position),
    `n_all`, `free_idx`, `presc_idx`, `fixed_values` (n_all,), `gravity`
    (3,) [m/s^2], `bodies` (list of `BodyArrays`, parents first),
    `body_index` (body name -> position), `n_bodies`.
    """

    def __init__(self, system: System):
        self.system = system
        self.names = system.coordinate_names()
        self.index = {n: i for i, n in enumerate(self.names)}
        self.n_all = len(self.names)
        self.free_idx = np.array([self.index[n] for n in system.free], dtype=int)
        self.presc_idx = np.array([self.index[n] for n in system.prescribed], dtype=int)
        self._prescribed = list(system.prescribed.values())
        self.fixed_values = np.zeros(self.n_all)
        for n, v in system.fixed.items():
            self.fixed_values[self.index[n]] = v
        self.gravity = np.array([0.0, 0.0, -system.gravity])
        self.bodies = []
        for b in system.bodies:
            joint = JointArrays(b.joint, self.index, self.n_all)
            flex = FlexibleArrays(b, self.index) if isinstance(b, FlexibleBody) else None
            self.bodies.append(BodyArrays(b, joint, flex))
        self.body_index = {b.name: i for i, b in enumerate(system.bodies)}
        self.n_bodies = len(self.bodies)
        #: (body position, coordinate position, efficiency) of a lossy gearbox
        #: (`System.gearbox_loss`) acting on a free coordinate, else None
        loss = system.gearbox_loss
        self.loss = None
        if loss is not None and loss.efficiency < 1.0 and loss.coordinate in system.free:
            self.loss = (self.body_index[loss.body], self.index[loss.coordinate], float(loss.efficiency))

    # ------------------------------------------------------------------ state
    def full_state(self, q, qd, t):
        """All coordinates, rates and prescribed accelerations at time t."""
        q_all = self.fixed_values.copy()
        qd_all = np.zeros(self.n_all)
        qdd_presc = np.zeros(self.n_all)
        q_all[self.free_idx] = q
        qd_all[self.free_idx] = qd
        for i, (qp, qdp, qddp) in zip(self.presc_idx, self.prescribed_state(t)):
            q_all[i], qd_all[i], qdd_presc[i] = qp, qdp, qddp
        return q_all, qd_all, qdd_presc

    def prescribed_state(self, t) -> np.ndarray:
        """(n_prescribed, 3): q, qd, qdd of the prescribed coordinates
        (order of `presc_idx`) at time t [s]."""
        return np.array([p(t) for p in self._prescribed], float).reshape(-1, 3)

    @property
    def prescribed_polynomials(self) -> np.ndarray | None:
        """(n_prescribed, 3): (value, rate, accel) of the prescribed
        coordinates, q(t) = value + rate t + 1/2 accel t^2; None when one is
        a Python function of time."""
        if any(p.function is not None for p in self._prescribed):
            return None
        return np.array([[p.value, p.rate, p.accel] for p in self._prescribed], float).reshape(-1, 3)

    # ------------------------------------------------------------- kinematics
    def kinematics(self, q, qd):
        """Recursive kinematics of every body frame (all coordinates)."""
        n = self.n_all
        states = []
        for b, j, _ in self.bodies:
            if j.parent is None:
                Rp = np.eye(3); rp = np.zeros(3); vp = np.zeros(3); wp = np.zeros(3)
                Jvp = np.zeros((3, n)); Jwp = np.zeros((3, n)); ap = np.zeros(3); alp = np.zeros(3)
            else:
                ps = states[self.body_index[j.parent]]
                Rp, rp, vp, wp, Jvp, Jwp, ap, alp = ps.R, ps.r, ps.v, ps.w, ps.Jv, ps.Jw, ps.a_bias, ps.alpha_bias
            P = Rp @ j.R0
            # rotations: omega_rel = sum_k u_k thetadot_k (in the P frame)
            Q = np.eye(3)
            w_rel = np.zeros(3)
            al_rel = np.zeros(3)
            Jw_rel = np.zeros((3, n))
            for axis, c, off in j.rotations:
                th = c @ q + off
                thd = c @ qd
                u = Q[:, axis]
                al_rel += cross(w_rel, u) * thd
                w_rel = w_rel + u * thd
                Jw_rel += np.outer(u, c)
                Q = Q @ elementary_rotation(axis, th)
            # translation in the parent frame
            rho_loc = j.offset.copy()
            Jrho = j.A.copy() if j.has_A else np.zeros((3, n))
            if j.has_A:
                rho_loc += j.A @ q
            acc_loc = np.zeros(3)
            if j.short is not None:
                e, idx, G = j.short
                qs, qds = q[idx], qd[idx]
                Gq = G @ qs
                rho_loc -= 0.5 * (qs @ Gq) * e
                Jrho[:, idx] -= np.outer(e, Gq)
                acc_loc -= (qds @ G @ qds) * e
            rhod_loc = Jrho @ qd
            rho = Rp @ rho_loc
            rhod = Rp @ rhod_loc
            R = P @ Q
            r = rp + rho
            w = wp + P @ w_rel
            Jw = Jwp + P @ Jw_rel
            v = vp + cross(wp, rho) + rhod
            Jv = Jvp - skew(rho) @ Jwp + Rp @ Jrho
            a = ap + cross(alp, rho) + cross(wp, cross(wp, rho)) + 2.0 * cross(wp, rhod) + Rp @ acc_loc
            al = alp + cross(wp, P @ w_rel) + P @ al_rel
            states.append(BodyState(r, R, v, w, Jv, Jw, a, al))
        return states

    def node_kinematics(self, name, state: BodyState, q, qd):
        """Inertial positions (N,3), velocities (N,3) and local-frame
        deformation of a flexible body's nodes (`kinematics.node_kinematics`)."""
        f = self.bodies[self.body_index[name]].flexible
        return node_kinematics(state.R, state.r, state.v, state.w, f.s0, f.Phi, f.S, f.axis,
                               q[f.idx], qd[f.idx])

    # -------------------------------------------------------- compiled kernel
    @cached_property
    def packed_full(self) -> Packed:
        """Kernel arrays computing every row of M and F."""
        return pack(self)

    @cached_property
    def packed_free(self) -> Packed:
        """Kernel arrays computing the rows of free and prescribed coordinates."""
        return self.pack_free()

    def pack_free(self, invariants=None) -> Packed:
        """`packed_free`, anew; invariants: as `packing.pack` (None: each
        flexible body's cheaper route)."""
        active = np.zeros(self.n_all, bool)
        active[self.free_idx] = True
        active[self.presc_idx] = True
        return pack(self, active, invariants)

    @cached_property
    def _kernel_all_rows(self) -> CompiledRHS:
        return CompiledRHS(self, all_rows=True)

    @cached_property
    def _kernel_free_rows(self) -> CompiledRHS:
        # `evaluate` (scipy's integrators, `Built.M_F`: no hot loop) takes
        # the node sums, so that it loads no invariant route (a first run
        # compiles its cfunc beside the loads)
        return CompiledRHS(self, packed=self.pack_free(invariants=False))

    def compiled_rhs(self, linear=(), *, all_rows=False) -> CompiledRHS:
        """Compiled right-hand side of the free coordinates for `integrate`
        (see `compiled.CompiledRHS`; `linear` adds generalised spring-dampers;
        all_rows for `reactions` of fixed coordinates)."""
        return CompiledRHS(self, linear, all_rows=all_rows)

    # -------------------------------------------------------------- equations
    def evaluate_full(self, q, qd, node_forces=None, generalized=None, states=None):
        """M (n_all x n_all) and F (n_all) over all coordinates (compiled
        kernel; with precomputed `states` the numpy reference)."""
        if states is not None:
            return self.evaluate_full_reference(q, qd, node_forces, generalized, states)
        return self._kernel_all_rows.full(q, qd, generalized, node_forces)

    def evaluate_full_reference(self, q, qd, node_forces=None, generalized=None, states=None):
        """M (n_all x n_all) and F (n_all) over all coordinates (numpy reference)."""
        n = self.n_all
        M = np.zeros((n, n))
        F = np.zeros(n) if generalized is None else np.array(generalized, float)
        g = self.gravity
        states = self.kinematics(q, qd) if states is None else states
        for (b, j, f), st in zip(self.bodies, states):
            if f is None:
                if b.mass == 0.0 and not np.any(b.inertia):
                    continue
                Mb, Fb = rigid_terms(b, st, g)
                M += Mb
                F += Fb
                continue
            self._flexible(b, f, st, q, qd, M, F, g, None if node_forces is None else node_forces.get(b.name))
        return M, F

    def _flexible(self, b, f, st, q, qd, M, F, g, fnodes):
        """Flexible body contribution, eq. 11-19 with Appendix A integrals
        summed over the nodes at the deformed configuration."""
        ne = len(f.idx)
        s, B_loc, acc_loc = deformed_nodes(f.s0, f.Phi, f.S, f.axis, q[f.idx], qd[f.idx])
        R = st.R
        p = s @ R.T                                          # (N,3) inertial axes
        B = np.einsum("ij,kjl->kil", R, B_loc)               # (N,3,ne)
        qde = qd[f.idx]
        pd = B @ qde if ne else np.zeros_like(p)             # elastic velocity (N,3)
        w, al = st.w, st.alpha_bias
        a_nodes = (st.a_bias + cross(al, p) + cross(w, cross(w, p)) + 2.0 * cross(w, pd)
                   + acc_loc @ R.T)
        m = f.m
        load = m[:, None] * (g - a_nodes)
        moments = None
        if fnodes is not None:
            fnodes = np.asarray(fnodes, float)
            load = load + fnodes[:, 0:3]
            if fnodes.shape[1] == 6:
                moments = fnodes[:, 3:6]
        # generalised body mass matrix (A2-A7) in y = [v; w; qd_e]
        mp = m @ p
        Mb = np.zeros((6 + ne, 6 + ne))
        Mb[0:3, 0:3] = f.mass * _E
        Mb[0:3, 3:6] = -skew(mp)
        Mb[3:6, 0:3] = skew(mp)
        Mb[3:6, 3:6] = (m @ np.einsum("ki,ki->k", p, p)) * _E - (p * m[:, None]).T @ p
        fy = np.zeros(6 + ne)
        fy[0:3] = load.sum(axis=0)
        fy[3:6] = cross(p, load).sum(axis=0)
        if moments is not None:                      # node moments: work through w (and torsion)
            fy[3:6] += moments.sum(axis=0)
        if ne:
            mB = m[:, None, None] * B
            Ct = mB.sum(axis=0)                                             # (3,ne)  C_t^T
            Cr = cross(p[:, :, None].transpose(0, 2, 1), mB.transpose(0, 2, 1)).sum(axis=0).T  # C_r^T
            Mb[0:3, 6:] = Ct
            Mb[6:, 0:3] = Ct.T
            Mb[3:6, 6:] = Cr
            Mb[6:, 3:6] = Cr.T
            Mb[6:, 6:] = np.einsum("kil,kim->lm", mB, B)
            fy[6:] = np.einsum("kil,ki->l", B, load) - f.K @ q[f.idx] - f.D @ qde      # eq. A16-A19
            if moments is not None and f.eta is not None:
                fy[6:] += (moments @ (R @ f.axis)) @ f.eta
        if f.Jp is not None and np.any(f.Jp):
            eg = R @ f.axis
            t = np.zeros((len(m), 6 + ne))
            t[:, 3:6] = eg
            if f.eta is not None and ne:
                t[:, 6:] = f.eta
            Mb += np.einsum("k,ki,kj->ij", f.Jp, t, t)
            fy -= (f.Jp * (eg @ al)) @ t
        Jb = np.vstack([st.Jv, st.Jw, np.zeros((ne, self.n_all))])
        if ne:
            Jb[6 + np.arange(ne), f.idx] = 1.0
        M += Jb.T @ Mb @ Jb
        # subtract the bias part of the generalised body force already in `load`
        F += Jb.T @ fy

    def evaluate(self, q, qd, t=0.0, node_forces=None, generalized=None):
        """(M, F) for the free coordinates: M qdd = F (eq. 22), with a lossy
        gearbox's row (`gearbox.with_losses`; M then not symmetric)."""
        q_all, qd_all, qdd_p = self.full_state(q, qd, t)
        M, F = self._kernel_free_rows.full(q_all, qd_all, generalized, node_forces)
        if self.loss is not None:
            M, F = self._with_losses(M, F, q_all, qd_all, qdd_p, generalized)
        return self._restrict(M, F, qdd_p)

    def evaluate_reference(self, q, qd, t=0.0, node_forces=None, generalized=None):
        """`evaluate` with the numpy reference."""
        q_all, qd_all, qdd_p = self.full_state(q, qd, t)
        states = self.kinematics(q_all, qd_all)
        M, F = self.evaluate_full_reference(q_all, qd_all, node_forces, generalized, states)
        if self.loss is not None:
            M, F = self._with_losses(M, F, q_all, qd_all, qdd_p, generalized, states)
        return self._restrict(M, F, qdd_p)

    def _with_losses(self, M, F, q_all, qd_all, qdd_p, generalized, states=None):
        """M and F (all coordinates) with the lossy gearbox's row (numpy
        reference): the gearbox body's row and bias on its coordinate are
        its `rigid_terms` there."""
        from modesel.multibody.gearbox import with_losses
        k, g, eta = self.loss
        states = self.kinematics(q_all, qd_all) if states is None else states
        Mb, Fb = rigid_terms(self.bodies[k][0], states[k], self.gravity)
        given = 0.0 if generalized is None else float(generalized[g])
        return with_losses(M, F, self.free_idx, self.presc_idx, qdd_p, g, Mb[g], float(Fb[g]), given, eta)

    def _restrict(self, M, F, qdd_p):
        """Free rows and columns; prescribed accelerations to the right (eq. 21-22)."""
        fi = self.free_idx
        if len(self.presc_idx):
            F = F - M[:, self.presc_idx] @ qdd_p[self.presc_idx]
        return M[np.ix_(fi, fi)], F[fi]
