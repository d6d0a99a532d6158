"""Gearbox losses (ElastoDyn's GBoxEff < 100 %, `multibody.gearbox`) against
the closed form of a rigid two-inertia drivetrain.

A rotor of inertia J_r about the shaft (angle GeAz) drives, through a gearbox
of ratio N and efficiency eta, a generator of inertia I_g (angle N GeAz) that
resists with a torque T (on the high-speed shaft). ElastoDyn's equation of
GeAz, with k = 1/eta while the low-speed shaft drives the generator and
k = eta while it is driven:

    (J_r + k N^2 I_g) GeAz'' = -k N T

The shaft torque N (T + I_g N GeAz'') = N T J_r / (J_r + k N^2 I_g) has the
sign of T: a braking generator (T > 0) takes k = 1/eta, a motoring one
(T < 0) k = eta. The torque is given as a damper on GeAz at the rate w, -c w
= -N T, so T = c w / N.
"""
import numpy as np
import pytest

from modesel.multibody.bodies import Joint, RigidBody, Rotation
from modesel.multibody.kane import KaneEquations
from modesel.multibody.system import GearboxLoss, System

J_ROTOR = 3.5e7      # kg m^2
I_GEN = 534.116      # kg m^2 (HSS)
RATIO = 97.0
ETA = 0.9
DAMPING = 1.0e6      # N m s/rad on GeAz: the given torque -c w


def drivetrain(efficiency=ETA):
    rotor = RigidBody("rotor", Joint(rotations=[Rotation(0, {"GeAz": 1.0})]), 1.0e5, np.zeros(3),
                      np.diag([J_ROTOR, 1.0e6, 1.0e6]))
    generator = RigidBody("generator", Joint(rotations=[Rotation(0, {"GeAz": RATIO})]), 0.0, np.zeros(3),
                          np.diag([I_GEN, 0.0, 0.0]))
    loss = GearboxLoss("generator", "GeAz", efficiency)
    return KaneEquations(System([rotor, generator], ["GeAz"], gearbox_loss=loss))


@pytest.mark.parametrize("rate, k", [(1.2, 1.0 / ETA), (-1.2, ETA)])
def test_rigid_drivetrain_with_losses_has_the_closed_form(rate, k):
    """Braking (rate > 0: T > 0) and motoring (rate < 0: T < 0): the numpy
    reference and the compiled kernel give GeAz'' = -k N T / (J_r + k N^2 I_g)."""
    eq = drivetrain()
    q, qd = np.array([0.3]), np.array([rate])
    torque = DAMPING * rate / RATIO                      # T [N m] on the HSS
    expected = -k * RATIO * torque / (J_ROTOR + k * RATIO**2 * I_GEN)
    M, F = eq.evaluate_reference(q, qd, generalized=np.array([-DAMPING * rate]))
    assert M[0, 0] == pytest.approx(J_ROTOR + k * RATIO**2 * I_GEN, rel=1e-12)
    assert np.linalg.solve(M, F)[0] == pytest.approx(expected, rel=1e-12)
    compiled = eq.compiled_rhs([("GeAz", "GeAz", 0.0, DAMPING)])
    acc, code = compiled.accelerations(0.0, q, qd)
    assert code == 0 and acc[0] == pytest.approx(expected, rel=1e-12)
    # without losses: the lossless closed form, which differs by more than the tolerance
    lossless = -RATIO * torque / (J_ROTOR + RATIO**2 * I_GEN)
    assert abs(expected / lossless - 1.0) > 0.05
    M1, F1 = drivetrain(1.0).evaluate_reference(q, qd, generalized=np.array([-DAMPING * rate]))
    assert np.linalg.solve(M1, F1)[0] == pytest.approx(lossless, rel=1e-12)


def test_the_linear_model_holds_the_factor_last_decided():
    """NO_SOLVE (the linear model's differences) keeps the factor of the last
    solve, as ElastoDyn keeps the previous step's sign: at w = 0 the shaft
    torque is 0 and the central differences of F straddle the two factors;
    held, the damping on GeAz is c k (k = 1/eta, the factor at the start, the
    shaft driving the generator), not the jump's (1/eta - eta) N T / (2 h)."""
    eq = drivetrain()
    compiled = eq.compiled_rhs([("GeAz", "GeAz", 0.0, DAMPING)])
    M, C, K = compiled.linear_model(0.0, np.array([0.3]), np.array([0.0]), 1e-6)
    assert M[0, 0] == pytest.approx(J_ROTOR + RATIO**2 * I_GEN / ETA, rel=1e-12)
    assert C[0, 0] == pytest.approx(DAMPING / ETA, rel=1e-6)
    compiled.accelerations(0.0, np.array([0.3]), np.array([-1.0]))      # motoring: decides k = eta
    M, C, K = compiled.linear_model(0.0, np.array([0.3]), np.array([0.0]), 1e-6)
    assert C[0, 0] == pytest.approx(DAMPING * ETA, rel=1e-6)
