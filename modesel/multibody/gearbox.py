"""Gearbox losses in the equations of motion (ElastoDyn's GBoxEff < 100 %;
numpy reference, compiled twin `gearbox_loss.gearbox_loss`).

ElastoDyn (ElastoDyn.f90: FillAugMat's "GBFric" terms, SignLSSTrq, and
CalcOutput's HSShftTq) lets the friction of the gearbox act only on the
generator azimuth's equation. With g that equation, r the generator body's
row of the mass matrix on it (r_j = J_g^T M_b J_j: its partial velocities J
and generalised mass M_b, first paper eq. 6-7), b its part of F_g at
qdd = 0 (its bias, the inertial terms in the rates) and Q the generalised
force given on g (the generator torque on the high-speed shaft, -N_g T; a
brake there would be one more), the equation keeps the rotor's terms and
takes the generator's k times:

    M_gj += (k - 1) r_j,        F_g += (k - 1) (b + Q)

where the low-speed shaft torque sigma = r qdd - b - Q = N_g (T + I_g a_g)
(the torque the gearbox passes to the generator, referred to the low-speed
shaft) decides k: k = 1/eta while sigma >= 0 (the shaft drives the
generator: the rotor supplies the losses too), k = eta while sigma < 0
(the generator or the inertia of the high-speed side drives the rotor). The
mass matrix is then not symmetric, and is solved by Gaussian elimination.

ElastoDyn takes the sign of sigma from the previous time step
(SgnPrvLSTQ). Here it is the sign that the accelerations solved with it
reproduce: the equations are solved without losses, k taken from that
sign, solved again, and with the other k where the result contradicts it.
With ElastoDyn's drivetrain spring (DrTr free), sigma is the spring-damper
torque k_DT DrTr + c_DT DrTr', a function of the state, so the first k
holds; with a rigid drivetrain (DrTr fixed), sigma is proportional to
N_g T J_rotor + J_gen Q_aero whatever k is. Outputs: HSShftTq =
LSShftTq eta^sign(LSShftTq) / N_g (`model.outputs`).
"""
from __future__ import annotations

import numpy as np


def factor(sigma: float, efficiency: float) -> float:
    """k of the module doc: 1/eta for a shaft torque sigma >= 0, else eta."""
    return 1.0 / efficiency if sigma >= 0.0 else efficiency


def with_losses(M, F, free_idx, presc_idx, qdd_p, g, r, bias, given, efficiency):
    """M and F (all coordinates, without losses) with the losses on row g
    (module doc): r, bias the gearbox body's row and bias on g (its
    `kane.rigid_terms` there), `given` the
    generalised force given on g [N m], qdd_p (all coordinates) the
    prescribed accelerations. New arrays."""
    qdd = np.zeros(len(F))
    qdd[presc_idx] = qdd_p[presc_idx]

    def solved(M_, F_):
        Mf = M_[np.ix_(free_idx, free_idx)]
        Ff = F_[free_idx] - M_[np.ix_(free_idx, presc_idx)] @ qdd_p[presc_idx]
        qdd[free_idx] = np.linalg.solve(Mf, Ff)
        return float(r @ qdd) - bias - given

    def scaled(k):
        M_, F_ = M.copy(), F.copy()
        M_[g] += (k - 1.0) * r
        F_[g] += (k - 1.0) * (bias + given)
        return M_, F_

    k = factor(solved(M, F), efficiency)
    out = scaled(k)
    other = factor(solved(*out), efficiency)
    if other != k:
        out = scaled(other)
    return out
