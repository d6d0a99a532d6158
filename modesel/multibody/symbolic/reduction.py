"""Exact reduction of a `System` before the symbolic derivation.

A flexible body without elastic coordinates is a rigid body (blades of a
model without blade DOFs); a rigid body attached to a rigid parent by a
joint that no free or prescribed coordinate moves is rigidly part of that
parent, so the two are lumped into one rigid body (hub + blades = rotor R
of the first paper, section 4.4). Lumping adds masses, first moments and
inertia tensors (parallel-axis theorem, `lumping.py`, shared with the
compiled kernel), which is exact: the equations of motion are unchanged.
The System itself is not modified.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from modesel.errors import ModeselError
from modesel.multibody.bodies import FlexibleBody, RigidBody
from modesel.multibody.lumping import RigidPart, constant_placement, joint_coordinates, lump, rigid_equivalent


def rigid_properties(body: FlexibleBody) -> RigidPart:
    """Rigid body of a flexible body with no elastic coordinate: sums over
    its quadrature nodes (eq. A2-A4 with u = 0)."""
    if body.node_polar_inertia is not None and np.any(body.node_polar_inertia):
        raise ModeselError(f"body '{body.name}': node rotary inertia without torsion DOFs is not supported "
                           "by the symbolic layer", field=body.name)
    return rigid_equivalent(body.nodes, body.node_mass)


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
    """Rigid-ify flexible bodies without DOFs and lump rigid subtrees on
    joints that no free or prescribed coordinate moves into their rigid
    parents (`lumping.lump`, whole subtrees only)."""
    moving = set(system.free) | set(system.prescribed)
    parts = []
    for b in system.bodies:
        if isinstance(b, FlexibleBody) and b.n_elastic == 0:
            parts.append(rigid_properties(b))
        elif isinstance(b, RigidBody):
            parts.append(RigidPart(float(b.mass), np.asarray(b.cm, float), np.asarray(b.inertia, float)))
        else:
            parts.append(None)
    slot = {b.name: k for k, b in enumerate(system.bodies)}
    parents = [-1 if b.joint.parent is None else slot[b.joint.parent] for b in system.bodies]
    joins = [parts[k] is not None and parents[k] >= 0 and parts[parents[k]] is not None
             and not joint_coordinates(b.joint) & moving for k, b in enumerate(system.bodies)]
    placements = [constant_placement(b.joint, system.fixed) if joins[k] else None
                  for k, b in enumerate(system.bodies)]
    result = lump(parents, parts, placements, joins, whole_subtrees=True)
    bodies, lumped = [], {}
    for k, b in enumerate(system.bodies):
        if result.target[k] != k:
            continue
        if parts[k] is None:
            bodies.append(b)
            continue
        part = result.parts.get(k, parts[k])
        bodies.append(RigidBody(b.name, b.joint, part.mass, part.cm, part.inertia))
        if k in result.parts:
            lumped[b.name] = [system.bodies[i].name for i in result.lumped_into(k)]
    return ReducedSystem(bodies, lumped)
