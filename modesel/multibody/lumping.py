"""Exact lumping of rigid parts that move together.

A flexible body without elastic coordinates is a rigid body (its node sums,
first paper eq. A2-A4 with u = 0); a rigid body attached to a rigid parent
by a joint that does not move is rigidly part of that parent, so the two are
one rigid body (hub + blades = rotor R of the first paper, section 4.4).
Lumping adds masses, first moments and inertia tensors (parallel-axis
theorem), which is exact: the equations of motion are unchanged.

Used by the compiled kernel's packing (`packing.pack`: a lumped body keeps
its frame, for its children and its node forces) and by the symbolic
reduction (`symbolic.reduction`: lumped bodies disappear, so only whole
subtrees are lumped).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modesel.multibody.rotations import elementary_rotation


@dataclass(frozen=True)
class RigidPart:
    """Mass [kg], centre of mass `cm` (3,) [m] and inertia tensor about the
    centre of mass `inertia` (3, 3) [kg m^2], in one frame."""

    mass: float
    cm: np.ndarray
    inertia: np.ndarray

    def placed(self, R: np.ndarray, o: np.ndarray) -> "RigidPart":
        """The part in the frame where its own frame has rotation R and origin o."""
        return RigidPart(self.mass, o + R @ self.cm, R @ self.inertia @ R.T)


def rigid_equivalent(nodes, node_mass) -> RigidPart:
    """Rigid body of point masses `node_mass` (N,) [kg] at `nodes` (N, 3) [m]
    (a flexible body's node sums without deformation, eq. A2-A4)."""
    m = np.asarray(node_mass, float)
    s0 = np.asarray(nodes, float)
    mass = float(m.sum())
    cm = m @ s0 / mass if mass > 0 else np.zeros(3)
    d = s0 - cm
    return RigidPart(mass, cm, (m @ np.einsum("ki,ki->k", d, d)) * np.eye(3) - (d * m[:, None]).T @ d)


def combine(parts) -> RigidPart:
    """One rigid part from parts given in one frame (parallel-axis theorem)."""
    mass = sum(p.mass for p in parts)
    if mass == 0.0:
        return RigidPart(0.0, np.zeros(3), sum(p.inertia for p in parts))
    cm = sum(p.mass * np.asarray(p.cm) for p in parts) / mass
    inertia = np.zeros((3, 3))
    for p in parts:
        d = np.asarray(p.cm) - cm
        inertia += p.inertia + p.mass * (d @ d * np.eye(3) - np.outer(d, d))
    return RigidPart(float(mass), cm, inertia)


def joint_coordinates(joint) -> set:
    """Names of the coordinates a `Joint` names (translation, rotations, shortening)."""
    used = set(joint.translation)
    for r in joint.rotations:
        used |= set(r.coeffs)
    if joint.shortening is not None:
        used |= set(joint.shortening.dofs)
    return used


def constant_placement(joint, values: dict | None = None):
    """(R, o): rotation and origin of a joint's child in its parent frame
    with its coordinates held at `values` {name: value} (absent: 0), by the
    conventions of `bodies.Joint`."""
    values = {} if values is None else values
    o = np.asarray(joint.offset, float).copy()
    for d, vec in joint.translation.items():
        o += np.asarray(vec, float) * values.get(d, 0.0)
    if joint.shortening is not None:
        sh = joint.shortening
        qs = np.array([values.get(d, 0.0) for d in sh.dofs])
        o -= 0.5 * (qs @ np.asarray(sh.matrix) @ qs) * np.asarray(sh.axis, float)
    R = np.asarray(joint.pre_rotation, float).copy()
    for r in joint.rotations:
        angle = r.offset + sum(k * values.get(d, 0.0) for d, k in r.coeffs.items())
        R = R @ elementary_rotation(r.axis, angle)
    return R, o


@dataclass(frozen=True)
class Lumping:
    """Result of `lump`: `target[k]` the body that body k is lumped into
    (k itself if not lumped), `pose[k]` = (R, o) of body k in its target's
    frame, `parts` {target: combined RigidPart} for every target that received
    a body."""

    target: list
    pose: list
    parts: dict

    def lumped_into(self, t: int) -> list:
        """Bodies lumped into body t (parents first)."""
        return [k for k, tk in enumerate(self.target) if tk == t and k != t]


def lump(parents, parts, placements, joins, *, whole_subtrees: bool) -> Lumping:
    """Lump rigid bodies into their rigid ancestors.

    Bodies are listed parents first: parents[k] the parent index (-1 for
    the ground), parts[k] the body's RigidPart in its own frame,
    placements[k] = (R, o) of its frame in its parent's, joins[k] whether
    body k may be lumped into its parent (rigid, on a constant joint, parent
    rigid: the caller decides). With `whole_subtrees`, a body is lumped only
    if all its children are (lumped bodies then carry no frame); otherwise
    each joining body is lumped and keeps its frame for its children."""
    nb = len(parents)
    lumped = list(joins)
    if whole_subtrees:
        for k in reversed(range(nb)):
            if lumped[k] and any(not lumped[c] for c in range(k + 1, nb) if parents[c] == k):
                lumped[k] = False
    target = list(range(nb))
    pose = [(np.eye(3), np.zeros(3)) for _ in range(nb)]
    members = {}
    for k in range(nb):
        if not lumped[k]:
            continue
        p = parents[k]
        Rp, op = pose[p]
        R, o = placements[k]
        target[k], pose[k] = target[p], (Rp @ R, op + Rp @ o)
        members.setdefault(target[k], []).append(k)
    combined = {t: combine([parts[t]] + [parts[k].placed(*pose[k]) for k in ks]) for t, ks in members.items()}
    return Lumping(target, pose, combined)
