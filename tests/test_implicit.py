"""The compiled implicit integrator "compiled-Radau" (multibody/implicit.py):
its Jacobian against central differences of the numpy equations, its
results against scipy's Radau (same algorithm), against compiled-DOP853 at
tight tolerance, against OpenFAST's free decay, its energy behaviour, and
the automatic choice of method by stiffness."""
import numpy as np
import pytest

from modesel.modeset import FieldModes, ModeSet
from modesel.multibody.integrate import (COMPILED_DOP853, COMPILED_RADAU, COMPILED_RK45, LOW_ORDER_RTOL, STIFF_RATIO,
                                        choose_method, integrate)
from modesel.simulation.api import build, load_scene
from modesel.simulation.transient import divergence_bounds

SCENES = "studies/scenes"


def _tower(count, damping=True):
    scene = load_scene(f"{SCENES}/paper_3dof_land.toml")
    scene.effects["damping"] = damping
    ms = ModeSet({"tower_fa": FieldModes("cosine", count), "tower_ss": FieldModes("cosine", count)})
    return build(scene, ms)


def test_jacobian_equals_central_differences_of_numpy_equations():
    """dqdd/dq and dqdd/dqd of the compiled forward differences equal central
    differences of M^-1 F from the Python M_F (numpy solve) at a deflected,
    moving state, to 1e-5 of the largest entry (forward differences: about
    sqrt(eps) relative)."""
    b = _tower(3)
    rhs = b.rhs()
    n = len(b.q0)
    rng = np.random.default_rng(3)
    q = b.q0 + 0.1 * rng.standard_normal(n)
    qd = b.qd0 + 0.2 * rng.standard_normal(n)
    A, B = rhs.jacobian(0.0, q, qd)

    def acc(qq, vv):
        M, F = b.M_F(0.0, qq, vv)
        return np.linalg.solve(M, F)

    Ar, Br = np.zeros((n, n)), np.zeros((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = 1e-5
        Ar[:, j] = (acc(q + e, qd) - acc(q - e, qd)) / 2e-5
        Br[:, j] = (acc(q, qd + e) - acc(q, qd - e)) / 2e-5
    assert np.max(np.abs(A - Ar)) <= 1e-5 * np.max(np.abs(Ar))
    assert np.max(np.abs(B - Br)) <= 1e-5 * np.max(np.abs(Br))


def test_compiled_radau_follows_scipy_radau():
    """Same algorithm as scipy.integrate.Radau (only the Jacobian's finite
    differences and when a new one is taken differ): outputs agree to 1e-6 m / rad over 10 s of the 3-DOF
    land model at rtol 1e-8, atol 1e-10, with about the same work."""
    b = build(load_scene(f"{SCENES}/paper_3dof_land.toml"))
    rhs = b.rhs()
    ours = integrate(rhs, b.q0, b.qd0, 10.0, 0.05, method=COMPILED_RADAU)
    ref = integrate(rhs, b.q0, b.qd0, 10.0, 0.05, method="Radau")
    assert ours.method == COMPILED_RADAU
    assert np.max(np.abs(ours.q - ref.q)) < 1e-6
    assert ours.n_rhs == pytest.approx(ref.n_rhs, rel=0.2)
    assert ours.info["n_jac"] >= 1 and ours.info["n_steps"] > 0


def test_compiled_radau_matches_dop853_on_13_dofs():
    """cosine:6 per tower direction (13 DOFs, modes up to 44 Hz): 5 s of
    compiled-Radau at rtol 1e-8, atol 1e-10 against compiled-DOP853 at
    rtol 1e-11: tower coordinates within 1e-6 m (of a 1-m decay)."""
    b = _tower(6)
    rhs = b.rhs()
    bounds = divergence_bounds(b)
    radau = integrate(rhs, b.q0, b.qd0, 5.0, 0.05, method=COMPILED_RADAU, bounds=bounds)
    exact = integrate(rhs, b.q0, b.qd0, 5.0, 0.05, method=COMPILED_DOP853, rtol=1e-11, atol=1e-12,
                      bounds=bounds)
    assert len(radau.t) == len(exact.t) == 101
    assert np.max(np.abs(radau.q - exact.q)) < 1e-6
    assert np.max(np.abs(radau.qd - exact.qd)) < 1e-5


def test_held_loads_reproduce_the_right_hand_side_where_they_were_taken():
    """SOLVE_HELD (the columns of Radau's Jacobian) keeps the BEM loads and
    the tower drag of the previous call: at that state it gives the
    right-hand side bit for bit; the held Jacobian keeps the structure's
    (the displacement columns within 1 % of the full one's largest entry)
    and leaves out the BEM's own damping (the blades' flap-rate diagonal,
    about -6.6 1/s at 11.4 m/s with it, under 0.2 1/s without)."""
    from modesel.multibody import kernel
    from modesel.multibody.system_function import FREE_SYSTEM
    b = build(load_scene(f"{SCENES}/turbine_wind_11p4.toml"))
    rhs, names = b.rhs(), list(b.model.system.free)
    q, qd = np.asarray(b.q0, float), np.asarray(b.qd0, float)
    x, inf, p = np.concatenate([q, qd]), np.full(len(q), np.inf), rhs.packed
    outs = []
    for mode in (kernel.SOLVE, kernel.SOLVE_HELD):
        out = np.zeros_like(x)
        code, _ = kernel.call_system(FREE_SYSTEM, 0.0, x, out, mode, inf, rhs.prob, rhs.rwork, p.data, p.work)
        assert code == kernel.OK
        outs.append(out)
    np.testing.assert_array_equal(outs[0], outs[1])
    A, B = rhs.jacobian(0.0, q, qd)
    Ah, Bh = rhs.jacobian(0.0, q, qd, held=True)
    assert np.max(np.abs(A - Ah)) < 1e-2 * np.max(np.abs(A))
    flap = [names.index(f"B{k}F1") for k in (1, 2, 3)]
    assert np.all(np.diag(B)[flap] < -3.0)
    assert np.all(np.abs(np.diag(Bh)[flap]) < 0.2)


def test_compiled_radau_with_held_loads_matches_dop853_with_bem():
    """The held Jacobian changes Newton's iterations, not what they converge
    to: 3 s of the turbine with BEM (11 DOFs) by compiled-Radau at rtol 1e-8,
    atol 1e-10 against compiled-DOP853 at rtol 1e-11: all coordinates within
    1e-7 (m, rad) of flap and edge motions of 0.4-0.9 m (measured 3e-9)."""
    b = build(load_scene(f"{SCENES}/turbine_wind_11p4.toml"))
    rhs, bounds = b.rhs(), divergence_bounds(b)
    radau = integrate(rhs, b.q0, b.qd0, 3.0, 0.05, method=COMPILED_RADAU, rtol=1e-8, atol=1e-10, bounds=bounds)
    exact = integrate(rhs, b.q0, b.qd0, 3.0, 0.05, method=COMPILED_DOP853, rtol=1e-11, atol=1e-13, bounds=bounds)
    assert radau.method == COMPILED_RADAU and len(radau.t) == len(exact.t) == 61
    assert np.max(np.ptp(exact.q, axis=0)) > 0.3
    assert np.max(np.abs(radau.q - exact.q)) < 1e-7


def test_compiled_radau_conserves_energy_without_damping():
    """Radau IIA damps modes the step does not resolve (L-stable); with the
    step resolving the motion (rtol 1e-10) the 3-DOF land model without
    damping keeps its energy over 60 s to 1e-6 of the vibration energy (the
    bound test_engine sets for DOP853)."""
    from modesel.multibody.energy import total_energy
    scene = load_scene(f"{SCENES}/paper_3dof_land.toml")
    scene.effects["damping"] = False
    b = build(scene)
    run = integrate(b.rhs(), b.q0, b.qd0, 60.0, 1.0, method=COMPILED_RADAU, rtol=1e-10, atol=1e-12)
    energy = np.array([total_energy(b, q, qd) for q, qd in zip(run.q, run.qd)])
    vibration = energy[0] - total_energy(b, np.zeros_like(b.q0), b.qd0)
    assert vibration > 1e5
    assert np.ptp(energy) / vibration < 1e-6


def test_auto_choice_by_stiffness_ratio():
    """"auto": compiled-Radau from STIFF_RATIO on (cosine:20 per tower
    direction has a ratio of about 2100), below it compiled-DOP853, or
    compiled-RK45 for kinked (BEM) loads from a relative tolerance of
    LOW_ORDER_RTOL on; scipy's
    names when the right-hand side does not run compiled; a forced method is
    kept."""
    rhs = build(load_scene(f"{SCENES}/paper_3dof_land.toml")).rhs()
    stiff = np.array([2.0, 2.0 * (STIFF_RATIO + 1)])
    soft = np.array([2.0, 2.0 * (STIFF_RATIO - 1)])
    assert choose_method(stiff, "auto", rhs)[0] == COMPILED_RADAU
    assert choose_method(soft, "auto", rhs)[0] == COMPILED_DOP853
    assert choose_method(stiff, "auto", None)[0] == "Radau"
    assert choose_method(soft, "auto", None)[0] == "DOP853"
    assert choose_method(stiff, COMPILED_DOP853, rhs) == (COMPILED_DOP853, pytest.approx(STIFF_RATIO + 1))
    assert choose_method(soft, "auto", rhs, LOW_ORDER_RTOL, kinked=True)[0] == COMPILED_RK45
    assert choose_method(soft, "auto", rhs, LOW_ORDER_RTOL)[0] == COMPILED_DOP853           # smooth
    assert choose_method(soft, "auto", rhs, 0.5 * LOW_ORDER_RTOL, kinked=True)[0] == COMPILED_DOP853
    assert choose_method(soft, "auto", None, LOW_ORDER_RTOL, kinked=True)[0] == "RK45"
    assert choose_method(stiff, "auto", rhs, LOW_ORDER_RTOL, kinked=True)[0] == COMPILED_RADAU


def test_scene_solver_methods_are_the_integrator_methods():
    """`[solver] method` accepts "auto" and every method `integrate` runs
    (scene.py lists them without importing the integrator)."""
    from modesel.multibody.integrate import METHODS
    from modesel.simulation.scene import SOLVER_METHODS
    assert SOLVER_METHODS == ("auto",) + METHODS


def test_a_fast_overdamped_mode_makes_the_case_stiff(tmp_path):
    """An overdamped drivetrain is stiff though it does not oscillate: steady_08
    with GBRatio 1 (the generator's 534 kg m^2 on the low-speed shaft, the
    drivetrain's damper then gives a real eigenvalue of about -1.2e4 1/s).
    "auto" picked compiled-RK45 from the oscillating modes alone and crawled
    (10 s simulated: 242672 right-hand sides, 12.6 s); it now counts the fastest
    decaying real mode and picks compiled-Radau (8939, 0.6 s), and the result
    agrees with compiled-DOP853 at rtol 1e-8 (largest error 6.4e-7 of a
    channel's range over 10 s; here 1 s against 1e-4)."""
    from modesel.simulation.transient import simulate
    from tests.test_fst_scene import copy_case, edit
    fst = copy_case(tmp_path)
    edit(fst.parent / "steady_08_ElastoDyn.dat", "GBRatio", "1")
    scene = load_scene(fst)
    channels = ["RotSpeed", "GenTq", "TTDspFA", "OoPDefl1", "IPDefl1"]
    auto = simulate(scene, tmax=1.0, channels=channels)
    assert auto.method == COMPILED_RADAU and auto.stiffness_ratio >= STIFF_RATIO
    ref_scene = load_scene(fst)
    ref_scene.solver = dict(ref_scene.solver, method=COMPILED_DOP853, rtol=1e-8, atol=1e-9)
    ref = simulate(ref_scene, tmax=1.0, channels=channels)
    for c in channels:
        span = max(float(np.ptp(ref.columns[c])), 1e-12)
        assert np.max(np.abs(auto.columns[c] - ref.columns[c])) <= 1e-4 * span, c
