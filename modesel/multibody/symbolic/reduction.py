"""Exact reduction of a `System` before the symbolic derivation.

A flexible body without elastic coordinates is a rigid body (blades of a
model without blade DOFs); a rigid body attached to a rigid parent by a
joint that no free or prescribed coordinate moves is rigidly part of that
parent, so the two are lumped into one rigid body (hub + blades = rotor R
of the first paper, section 4.4). Lumping adds masses, first moments and
inertia tensors (parallel-axis theorem), which is exact: the equations of
motion are unchanged. The System itself is not modified.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from modesel.errors import ModeselError
from modesel.multibody.bodies import FlexibleBody, Joint, RigidBody
from modesel.multibody.kane import elementary_rotation


def rigid_properties(body: FlexibleBody):
    """(mass, cm, inertia about the cm) of a flexible body with no elastic
    coordinate: sums over its quadrature nodes (eq. A2-A4 with u = 0)."""
    if body.node_polar_inertia is not None and np.any(body.node_polar_inertia):
        raise ModeselError(f"body '{body.name}': node rotary inertia without torsion DOFs is not supported "
                           "by the symbolic layer", field=body.name)
    m = np.asarray(body.node_mass, float)
    s0 = np.asarray(body.nodes, float)
    mass = float(m.sum())
    cm = m @ s0 / mass if mass > 0 else np.zeros(3)
    d = s0 - cm
    inertia = np.einsum("k,kj,kj->", m, d, d) * np.eye(3) - (d * m[:, None]).T @ d
    return mass, cm, inertia


def combine(parts):
    """Lump rigid parts [(mass, cm, inertia_about_cm)] given in one frame."""
    mass = sum(p[0] for p in parts)
    if mass == 0.0:
        return 0.0, np.zeros(3), sum(p[2] for p in parts)
    cm = sum(p[0] * np.asarray(p[1]) for p in parts) / mass
    inertia = np.zeros((3, 3))
    for m, c, J in parts:
        d = np.asarray(c) - cm
        inertia += J + m * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, cm, inertia


def moving_coordinates(joint: Joint) -> set:
    """Coordinates a joint depends on."""
    used = set(joint.translation)
    for r in joint.rotations:
        used |= set(r.coeffs)
    if joint.shortening is not None:
        used |= set(joint.shortening.dofs)
    return used


def constant_placement(joint: Joint, fixed: dict):
    """(R, o): rotation and origin of a constant joint's child in its parent
    frame, with fixed coordinates at their values (bodies.py conventions)."""
    o = np.asarray(joint.offset, float).copy()
    for d, vec in joint.translation.items():
        o += np.asarray(vec, float) * fixed.get(d, 0.0)
    if joint.shortening is not None:
        sh = joint.shortening
        qs = np.array([fixed.get(d, 0.0) for d in sh.dofs])
        o -= 0.5 * (qs @ np.asarray(sh.matrix) @ qs) * np.asarray(sh.axis, float)
    R = np.asarray(joint.pre_rotation, float).copy()
    for r in joint.rotations:
        angle = r.offset + sum(k * fixed.get(d, 0.0) for d, k in r.coeffs.items())
        R = R @ elementary_rotation(r.axis, angle)
    return R, o


@dataclass
class ReducedSystem:
    """Bodies after reduction (parents first) and what was lumped where."""

    bodies: list
    lumped: dict = field(default_factory=dict)      # body name -> names lumped into it

    def body(self, name):
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(name)


def reduce_system(system) -> ReducedSystem:
    """Rigid-ify flexible bodies without DOFs and lump constant-jointed
    rigid leaves into their rigid parents (repeated until nothing changes)."""
    moving = set(system.free) | set(system.prescribed)
    fixed = dict(system.fixed)
    bodies = []
    for b in system.bodies:
        if isinstance(b, FlexibleBody) and b.n_elastic == 0:
            mass, cm, J = rigid_properties(b)
            b = RigidBody(b.name, b.joint, mass, cm, J)
        elif isinstance(b, RigidBody):
            b = RigidBody(b.name, b.joint, float(b.mass), np.asarray(b.cm, float),
                          np.asarray(b.inertia, float))
        bodies.append(b)
    lumped = {b.name: [] for b in bodies}
    changed = True
    while changed:
        changed = False
        parents = {b.joint.parent for b in bodies}
        for child in reversed(bodies):
            j = child.joint
            if (not isinstance(child, RigidBody) or child.name in parents or j.parent is None
                    or moving_coordinates(j) & moving):
                continue
            parent = next(b for b in bodies if b.name == j.parent)
            if not isinstance(parent, RigidBody):
                continue
            R, o = constant_placement(j, fixed)
            mass, cm, J = combine([(parent.mass, parent.cm, parent.inertia),
                                   (child.mass, o + R @ child.cm, R @ child.inertia @ R.T)])
            merged = RigidBody(parent.name, parent.joint, mass, cm, J)
            bodies = [merged if b is parent else b for b in bodies if b is not child]
            lumped[parent.name] += [child.name] + lumped.pop(child.name)
            changed = True
            break
    return ReducedSystem(bodies, {k: v for k, v in lumped.items() if v})
