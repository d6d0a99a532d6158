"""Mechanical energy of a built scene: kinetic 1/2 qd^T M(q) qd plus
gravitational potential sum m g z (rigid CMs and flexible nodes at their
deformed positions) plus elastic strain 1/2 q_e^T K_e q_e. Conserved when
damping and external forces are off and no coordinate is prescribed, so it
checks the equations and the integrator against each other."""
from __future__ import annotations

import numpy as np

from modesel.multibody.bodies import FlexibleBody


def total_energy(built, q, qd) -> float:
    """Energy [J] of `built` (api.Built) at free coordinates q, rates qd."""
    eq = built.eq
    M, _ = eq.evaluate(q, qd, 0.0)
    kinetic = 0.5 * qd @ M @ qd
    q_all, qd_all, _ = eq.full_state(q, qd, 0.0)
    states = eq.kinematics(q_all, qd_all)
    g = eq.system.gravity
    potential = 0.0
    for (b, _, f), st in zip(eq.bodies, states):
        if isinstance(b, FlexibleBody):
            pos, _, _ = eq.node_kinematics(b.name, st, q_all, qd_all)
            potential += g * f.m @ pos[:, 2]
            qe = q_all[f.idx]
            potential += 0.5 * qe @ f.K @ qe
        else:
            potential += g * b.mass * (st.r + st.R @ np.asarray(b.cm, float))[2]
    return float(kinetic + potential)
