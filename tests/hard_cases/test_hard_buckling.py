"""Hard case: the tower-top mass raised until the tower approaches buckling,
K_e + K_g -> 0 (first paper eq. 33-34: the top mass and the tower's own
weight soften the fore-aft stiffness).

The critical nacelle mass comes from the engine: the linearised stiffness is
affine in the nacelle mass, K(m) = K_0 + m K_1, so m_crit is the smallest
positive root of det(K_0 + m K_1) = 0. It is checked against a second
formulation written from the shape integrals: K_e + K_gw + M_RNA K_gt
(eq. 33-34 with the whole rotor-nacelle assembly as top mass) minus
g (M_RNA z_RNA) s s^T, the softening by the RNA's centre of mass at height
z_RNA above the tower top (a tip rotation theta lowers it by z theta^2/2; s =
tip slopes).

Below m_crit (0.9 m_crit: first frequency 0.02 Hz instead of 0.32 Hz) the run
finishes, conserves energy, and the frequencies agree with a richer basis.
Beyond it the configuration is physically unstable and `api.simulate`
refuses it before integrating (`PhysicallyUnstable`, naming the field); with
the check switched off the tower falls over and the integrator stops at the
state bound (`SimulationDiverged`).
"""
import numpy as np
import pytest
import scipy.linalg

from hardcase_tools import assert_method_justified, conservative, frequencies, modes, scene, simulate
from modesel.candidates.base import mode_shapes
from modesel.candidates.context import field_context
from modesel.errors import PhysicallyUnstable, SimulationDiverged
from modesel.simulation import api
from modesel.simulation.stability import STABILITY_NOISE
from modesel.multibody import linearize as lin
from modesel.multibody.bodies import FlexibleBody
from modesel.multibody.shape_integrals import shape_integrals

BASIS = ("relaxed_root", 6)        # free tip curvature: m_crit converged to 1e-7 at 6 modes
RICH = ("fem", 12)


def with_nacelle_mass(mass, ms=None):
    sc = conservative(scene("paper_2dof_tower_shaft"))
    sc.turbine.nacelle_mass = float(mass)
    return sc


def fore_aft_stiffness(sc, ms):
    b = api.build(sc, ms)
    model = lin.linearize(b.M_F, np.zeros_like(b.q0), b.qd0, b.model.system.free)
    i = [k for k, n in enumerate(model.names) if n.startswith("TFA")]
    return model.K[np.ix_(i, i)], b


def critical_mass(k0, k1) -> float:
    mu = scipy.linalg.eigvals(k0, -k1)
    return float(np.min(mu.real[(mu.real > 0) & (np.abs(mu.imag) < 1e-9 * np.abs(mu).max())]))


def rna_first_moment(built):
    """(mass, sum m z) of every body above the tower (rigid CMs and blade nodes) at rest."""
    eq = built.eq
    q_all, qd_all, _ = eq.full_state(np.zeros_like(built.q0), np.zeros_like(built.qd0), 0.0)
    m = mz = 0.0
    for (body, _, f), st in zip(eq.bodies, eq.kinematics(q_all, qd_all)):
        if body.name == "tower":
            continue
        if isinstance(body, FlexibleBody):
            pos, _, _ = eq.node_kinematics(body.name, st, q_all, qd_all)
            m, mz = m + f.m.sum(), mz + f.m @ pos[:, 2]
        else:
            m += body.mass
            mz += body.mass * (st.r + st.R @ np.asarray(body.cm, float))[2]
    return m, mz


@pytest.fixture(scope="module")
def m_crit():
    ms = modes(tower_fa=BASIS)
    k0, b0 = fore_aft_stiffness(with_nacelle_mass(0.0), ms)
    k1m, b1 = fore_aft_stiffness(with_nacelle_mass(1e6), ms)
    engine = critical_mass(k0, (k1m - k0) / 1e6)
    # second formulation: shape integrals + the RNA's centre-of-mass height
    t = b0.model.turbine
    ctx = field_context(t, "tower_fa")
    shapes = lambda x: mode_shapes("tower_fa", BASIS[0], BASIS[1], ctx, x=x)     # noqa: E731
    si = shape_integrals(t.tower, shapes, top_mass=1.0, gravity=t.gravity, orthonormalise=False)
    top = t.tower_base_height + t.tower.length
    s = si.tip_slope

    def k_formula(b):
        m, mz = rna_first_moment(b)
        return (si.stiffness + si.geometric_stiffness["gravity_self_weight"]
                + m * si.geometric_stiffness["gravity_top_mass"] - t.gravity * (mz - m * top) * np.outer(s, s))

    f0, f1 = k_formula(b0), k_formula(b1)
    formula = critical_mass(f0, (f1 - f0) / 1e6)
    assert engine == pytest.approx(formula, rel=1e-5)          # measured 1.8e-7
    assert 40 < engine / 240e3 < 60                             # ~47 times the real nacelle
    return engine


def test_near_buckling_runs_conserves_energy_and_matches_a_richer_basis(m_crit):
    sc = with_nacelle_mass(0.9 * m_crit)
    ms = modes(tower_fa=BASIS)
    f = frequencies(sc, ms)
    rich = frequencies(sc, modes(tower_fa=RICH))
    assert f[0] < 0.025                                         # 0.32 Hz at the real nacelle mass
    assert f[0] == pytest.approx(rich[0], rel=1e-3)             # measured 2e-4
    assert f[1] == pytest.approx(rich[1], rel=1e-3)
    run = simulate(sc, ms, tmax=1.0, dt=0.01)
    assert run.finite()
    assert_method_justified(run, sc, ms)
    assert run.method in ("compiled-Radau", "Radau") and run.ratio > 200            # the softened mode makes it stiff
    assert run.energy_drift() < 1e-6


@pytest.mark.parametrize("factor", [1.001, 1.1])
def test_beyond_buckling_is_refused_before_simulating(m_crit, factor):
    sc = with_nacelle_mass(factor * m_crit)
    with pytest.raises(PhysicallyUnstable) as info:
        api.simulate(sc, modes(tower_fa=BASIS), tmax=600.0)
    assert "tower_fa" in str(info.value) and info.value.growth > 0
    assert info.value.file == sc.path


def test_beyond_buckling_without_the_check_diverges_at_the_bound(m_crit):
    sc = with_nacelle_mass(1.1 * m_crit)
    sc.solver = {"stability_check": False}
    with pytest.raises(SimulationDiverged) as info:
        api.simulate(sc, modes(tower_fa=BASIS), tmax=600.0)
    assert "beyond its physical bound" in info.value.reason and "TFA" in info.value.reason
    assert 0 < info.value.time < 60.0


@pytest.mark.parametrize("name", ["paper_2dof_tower_shaft", "paper_3dof_floating", "paper_rotating_blade",
                                  "turbine_rated_gravity", "turbine_wind_11p4"])
def test_stable_scenes_are_not_flagged(name):
    """Zero-frequency rotor modes, a free platform and the aero-coupled rotor
    speed (a slowly drifting real eigenvalue of GeAz with the generator law)
    are not elastic instabilities."""
    sc = scene(name)
    b = api.build(sc)
    model = lin.linearize(b.M_F, np.zeros_like(b.q0), b.qd0, b.model.system.free)
    api.check_static_stability(model)


@pytest.mark.parametrize("name, factor", [("paper_2dof_tower_shaft", 1.1), ("turbine_wind_08", None),
                                          ("turbine_wind_15", None)])
def test_simple_participation_equals_eigen_s(m_crit, name, factor):
    """The stability check takes the participation in a simple real
    eigenvalue from one SVD of A - lambda I (numpy only,
    `linearize.simple_participation`); `linearize.eigen` (scipy's left and
    right eigenvectors) gives the same participation for every real
    eigenvalue beyond round-off: the buckled tower's, the rotor speed's under
    the generator law (8 m/s) and under pitch control (15 m/s). A free
    coordinate (no stiffness, no damping: a defective double zero) is not
    simple, and the check falls back to `eigen`."""
    sc = with_nacelle_mass(factor * m_crit) if factor else scene(name)
    b = api.build(sc)
    model = lin.linearize(b.M_F, np.zeros_like(b.q0), b.qd0, b.model.system.free)
    lam, _, participation = lin.eigen(model)
    noise = STABILITY_NOISE * np.abs(lam).max() + 1e-6              # below it the check asks nothing
    real = np.flatnonzero((np.abs(lam.imag) <= noise) & (np.abs(lam.real) > noise))
    assert len(real) >= 1
    A, n = lin.state_matrix(model), len(model.names)
    for i in real:
        assert lin.simple_participation(A, lam, int(i), n) == pytest.approx(participation[i], abs=1e-9)
    if factor:
        assert model.names[int(np.argmax(participation[int(np.argmax(lam.real))]))].startswith("TFA")
    free = lin.LinearModel(["GeAz"] + model.names, *(scipy.linalg.block_diag(0.0 if k else 1.0, X)
                                                     for k, X in enumerate((model.M, model.C, model.K))))
    lam_free = lin.eigenvalues(free)
    zero = np.flatnonzero(np.abs(lam_free) < 1e-9 * np.abs(lam_free).max())
    assert len(zero) >= 2                                       # its double zero (and GeAz's, if free)
    assert all(lin.simple_participation(lin.state_matrix(free), lam_free, int(i), n + 1) is None for i in zero)
    if factor:                                                  # the fallback to eigen still names the tower
        with pytest.raises(PhysicallyUnstable, match="TFA"):
            api.check_static_stability(free)
    else:
        api.check_static_stability(free)
