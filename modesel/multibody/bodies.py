"""Data objects describing a multibody system: joints, rigid and flexible bodies.

Like `sympy.physics.mechanics`, these only *describe* the system; the method
object `modesel.multibody.kane.KaneEquations` produces M(q) and F(q, qd, t).

Coordinates: every body has a frame (origin O, rotation R from body to
inertial axes). A `Joint` places a child frame in its parent frame:

    r_child = r_parent + R_parent (offset + A q - 1/2 sum_j axis_j q^T G_j q)
    R_child = R_parent R0 Rot(a_1, theta_1) Rot(a_2, theta_2) ...
    theta_k = c_k . q + theta0_k

i.e. translations linear in q with an optional quadratic axial-shortening
term (first paper Appendix D4, second paper eq. 3), and any sequence of
elementary rotations whose angles are linear in q. This covers fixed
offsets/rotations, revolute joints, prismatic joints (platform surge),
drivetrain angles that are sums of DOFs (rotor azimuth = GeAz + DrTr), and
the elastic rotation of a flexible body's end from its tip slopes
(first paper Appendix D2).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Rotation:
    """Elementary rotation about body axis `axis` (0=x, 1=y, 2=z) of angle
    sum_dof coeffs[dof] * q[dof] + offset [rad]. A DOF may be free, fixed or
    prescribed in time (see `System`)."""

    axis: int
    coeffs: dict = field(default_factory=dict)
    offset: float = 0.0


@dataclass
class Shortening:
    """Axial shortening -1/2 q^T G q along `axis` (3-vector, parent frame)
    of a joint; G is (n_dof x n_dof) over `dofs`."""

    axis: np.ndarray
    dofs: tuple
    matrix: np.ndarray


@dataclass
class Joint:
    """Places a body in its parent (None = inertial ground).

    offset [m] in the parent frame, pre_rotation (3x3) constant, translation
    {dof: 3-vector [m per unit q]} in the parent frame, optional Shortening,
    rotations (sequence of `Rotation`, applied after pre_rotation)."""

    parent: str | None = None
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    pre_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    translation: dict = field(default_factory=dict)
    shortening: Shortening | None = None
    rotations: list = field(default_factory=list)


@dataclass
class RigidBody:
    """Rigid body: mass [kg], centre of mass `cm` [m] and inertia tensor about
    the CM `inertia` [kg m^2], both in the body frame (first paper eq. 6-9)."""

    name: str
    joint: Joint
    mass: float = 0.0
    cm: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))


@dataclass
class FlexibleBody:
    """Flexible beam-like body represented by quadrature nodes (first paper
    section 2.4 and Appendix A: the shape integrals are sums over these nodes
    evaluated at the deformed configuration).

    nodes : (N, 3) undeformed node positions s_P0 in the body frame [m].
    node_mass : (N,) quadrature mass of each node [kg].
    node_polar_inertia : (N,) rotary inertia of each node about `axis` [kg m^2].
    axis : unit vector of the beam axis in the body frame.
    dofs : names of the elastic coordinates q_e (length ne).
    shapes : (N, 3, ne) displacement of each node per unit q_e [m/m], body frame.
    shortening : (N, ne, ne) axial shortening matrices S_k with displacement
        -1/2 q_e^T S_k q_e along `axis` (None = zeroth-order field).
    torsion : (N, ne) elastic twist of each node per unit q_e [rad/unit].
    stiffness, damping : (ne, ne) elastic K_e [N/m] and D_e [N s/m] (eq. A16).
    field_mass : (ne, ne) generalised mass of each field's shapes alone
        (block-diagonal, untwisted shapes: ElastoDyn's MBF/MBE/MTFA), which
        defines the field frequencies of the modal damping; None: from `shapes`.
    """

    name: str
    joint: Joint
    nodes: np.ndarray
    node_mass: np.ndarray
    axis: np.ndarray
    dofs: tuple = ()
    shapes: np.ndarray | None = None
    shortening: np.ndarray | None = None
    torsion: np.ndarray | None = None
    node_polar_inertia: np.ndarray | None = None
    stiffness: np.ndarray | None = None
    damping: np.ndarray | None = None
    field_mass: np.ndarray | None = None

    @property
    def n_elastic(self) -> int:
        return len(self.dofs)
