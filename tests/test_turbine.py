"""The full onshore NREL 5-MW model (second paper sections 2-3) on the engine:
template, effects, scenes, load outputs, linearisation.

References outside the code under test:
- Jonkman et al. 2009 (NREL/TP-500-38060) Table 9-1, FAST linearisation of
  the land-based NREL 5-MW (parked): tower 1st FA 0.3240 Hz, 1st SS 0.3120,
  blade 1st collective flap 0.6993, 1st asymmetric flap yaw 0.6664, pitch
  0.6675, 1st asymmetric edge pitch 1.0793, yaw 1.0898;
- Jonkman 2009 section 7.1: the baseline generator-torque law (k = 0.0255764
  N m/rpm^2, rated torque 43093.55 N m at 1173.7 rpm);
- the bundled C_P/C_T table NREL5MW_CPCTCQ.txt, and the rigid-rotor BEM
  `steady_rotor` (a separate computation with its own geometry);
- closed forms: cantilever compliance from the deck's EI(z), torsional
  chains of 2 and 3 inertias, the whirl split of cyclic rotor modes by the
  rotor speed, static moment balance;
- second formulations: the numpy reference kinematics, `BemSolver.solve`,
  `TowerDrag.load`, Newton-Euler sums of node forces.
"""
import os

import numpy as np
import pytest

from modesel.errors import ModeselError
from modesel.modeset import FieldModes, ModeSet
from modesel.simulation.api import build, linearize_scene, load_scene, simulate
from modesel.multibody.integrate import Integration
from modesel.model.outputs import load_channels
from modesel.simulation.scene import scene_from_dict

HERE = os.path.dirname(__file__)
SCENES = os.path.join(HERE, "..", "studies", "scenes")
DATA = os.path.join(HERE, "..", "modesel", "turbine", "data", "nrel5mw")
RPM = np.pi / 30.0
ONE_MODE = {"tower_fa": {"family": "elastodyn", "count": 1}, "tower_ss": {"family": "elastodyn", "count": 1},
            "tower_torsion": {"family": "linear", "count": 1},
            "blade_flap": {"family": "elastodyn", "count": 1}, "blade_edge": {"family": "elastodyn", "count": 1}}


def scene(name):
    return load_scene(os.path.join(SCENES, f"{name}.toml"))


def state_at(built, t, q, qd):
    q_all, qd_all, _ = built.eq.full_state(q, qd, t)
    return q_all, qd_all


# ----------------------------------------------------------------------------- linearisation

def test_parked_frequencies_match_elastodyn_table_9_1():
    """Parked, generator locked, the deck's DOFs and shapes: coupled
    frequencies within 3 % of FAST (Jonkman 2009 Table 9-1)."""
    modes, _ = linearize_scene(scene("turbine_parked_free_decay"))
    by_label = {}
    for m in modes:
        by_label.setdefault(m.label, []).append(m.frequency_hz)
    published = {"TFA1": 0.3240, "TSS1": 0.3120, "F1_coll": 0.6993,
                 "F1_sin": 0.6664,   # asymmetric flap, yaw (blades 2 and 3 opposite)
                 "F1_cos": 0.6675,   # asymmetric flap, pitch (rotor tilting)
                 "E1_sin": 1.0793,   # asymmetric edge, pitch (vertical hub force)
                 "E1_cos": 1.0898}   # asymmetric edge, yaw (lateral hub force)
    lines = []
    for label, f_ref in published.items():
        f = by_label[label][0]
        lines.append(f"{label}: {f:.4f} Hz vs {f_ref:.4f} ({100 * (f / f_ref - 1):+.2f} %)")
        assert f == pytest.approx(f_ref, rel=0.03), label
    print("\nparked NREL 5-MW vs Jonkman 2009 Table 9-1:\n" + "\n".join(lines))


def test_campbell_cyclic_modes_whirl_by_rotor_speed():
    """Multi-blade coordinates at 12.1 rpm: the cyclic flap and edge pairs
    are the backward and forward whirls, split by +-Omega around their
    rotating-frame frequency: (f_FW - f_BW) / 2 = Omega / 2 pi."""
    modes, model = linearize_scene(scene("turbine_parked_free_decay"), rpm=12.1)
    omega_hz = 12.1 / 60.0
    for field, band in (("F1", (0.4, 1.0)), ("E1", (0.8, 1.5))):
        pair = sorted(m.frequency_hz for m in modes
                      if m.label in (f"{field}_cos", f"{field}_sin") and band[0] < m.frequency_hz < band[1])
        assert len(pair) == 2, (field, pair)
        assert (pair[1] - pair[0]) / 2 == pytest.approx(omega_hz, rel=0.03), field
    assert "F1_coll" in model.names and "B1F1" not in model.names


def test_campbell_whirl_direction_follows_the_frequency_split():
    """The forward whirl of each cyclic pair is the upper frequency
    (f_rotating + Omega / 2 pi), the backward one the lower; parked, no
    mode whirls."""
    modes, _ = linearize_scene(scene("turbine_parked_free_decay"), rpm=12.1)
    for field, band in (("F1", (0.4, 1.0)), ("E1", (0.8, 1.5))):
        pair = sorted((m.frequency_hz, m.whirl) for m in modes
                      if m.label in (f"{field}_cos", f"{field}_sin") and band[0] < m.frequency_hz < band[1])
        assert [w for _, w in pair] == ["backward", "forward"], (field, pair)
    parked, _ = linearize_scene(scene("turbine_parked_free_decay"))
    assert all(m.whirl is None for m in parked)


def test_rated_mode_labels_are_unique_and_name_the_participating_coordinate():
    """At rated speed the drivetrain mode and the collective edge mode (which
    carries the drivetrain along) both move DrTr most in kinetic energy;
    by participation they are DrTr (about 0.65 Hz) and E1_coll (3.6 Hz)."""
    modes, _ = linearize_scene(scene("turbine_rated_gravity"))
    labels = [m.label for m in modes]
    assert len(set(labels)) == len(labels), labels
    by_label = {m.label: m.frequency_hz for m in modes}
    assert 0.6 < by_label["DrTr"] < 0.7 and 3.5 < by_label["E1_coll"] < 3.8
    for m in modes:
        assert m.participation.sum() == pytest.approx(1.0) and np.all(m.participation >= 0)


def test_two_spring_drivetrain_is_a_three_inertia_chain():
    """Rigid tower and blades, generator free: the two-spring drivetrain
    (eq. 17-20) has the torsional frequencies of rotor - gearbox - generator
    on two springs; the ElastoDyn form those of rotor - generator on one."""
    t = scene("turbine_parked_free_decay").turbine
    base = {"turbine": "nrel5mw", "modes": {}, "dofs": {"free": ["GeAz", "DrTr"]},
            "effects": {"gravity": False}}
    # rotor inertia about the shaft from the deck stations (trapezoid), independent of the model's quadrature
    bl = t.blade
    r = (t.hub_radius + bl.span) * np.cos(t.precone[0])
    J_rotor = t.hub_inertia + t.num_blades * np.trapezoid(bl.mass * r**2, bl.span)
    N = t.gearbox_ratio
    J_gen = t.generator_inertia * N**2
    k = t.drivetrain_stiffness
    f_ed = np.sqrt(k * (1 / J_rotor + 1 / J_gen)) / (2 * np.pi)
    modes, _ = linearize_scene(scene_from_dict(base))
    assert [m.frequency_hz for m in modes][-1] == pytest.approx(f_ed, rel=2e-3)

    kl, kh, J_gb = 1.2e9, 3.0e5, 4.0e5          # LSS, HSS [N m/rad], gearbox [kg m^2]
    two = dict(base, effects={"gravity": False, "drivetrain": {
        "model": "two_spring", "lss_stiffness": kl, "hss_stiffness": kh, "gearbox_inertia": J_gb,
        "lss_damping": 0.0, "hss_damping": 0.0}})
    modes, model = linearize_scene(scene_from_dict(two))
    assert "HSSTw" in model.names
    K = np.array([[kl, -kl, 0.0], [-kl, kl + kh * N**2, -kh * N**2], [0.0, -kh * N**2, kh * N**2]])
    M = np.diag([J_rotor, J_gb, J_gen])
    lam = np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real)
    expected = np.sqrt(lam[1:]) / (2 * np.pi)
    got = sorted(m.frequency_hz for m in modes if m.frequency_hz > 0.01)
    np.testing.assert_allclose(got, expected, rtol=2e-3)


def test_stiffness_proportional_damping_equals_modal_with_one_mode():
    """Second paper eq. 46-50 (D = 2 zeta / lambda_1 K) and ElastoDyn's modal
    damping coincide for one mode per field (module claim), and differ for two."""
    def damping(model, modes):
        d = {"turbine": "nrel5mw", "modes": modes, "dofs": {"free": ["DrTr"]}, "effects": {"damping": model}}
        b = build(scene_from_dict(d))
        return {x.name: x.damping for x in b.model.system.flexible_bodies()}
    modal = damping({"model": "modal"}, ONE_MODE)
    paper = damping({"model": "stiffness_proportional"}, ONE_MODE)
    for name in modal:
        np.testing.assert_allclose(paper[name], modal[name], rtol=1e-9, atol=1e-12)
    two = {"tower_fa": {"family": "elastodyn", "count": 2}}
    assert not np.allclose(damping({"model": "modal"}, two)["tower"],
                           damping({"model": "stiffness_proportional"}, two)["tower"])


def test_damping_effect_builds_a_new_model_instead_of_changing_one():
    """Built objects are not mutated (issue 9): `prepare` returns a new model."""
    from modesel.model.effects.damping import StructuralDamping
    from modesel.model.template import build_turbine
    from modesel.modeset import ModeSet
    d = {"turbine": "nrel5mw", "modes": {"tower_fa": {"family": "elastodyn", "count": 2}},
         "dofs": {"free": ["DrTr"]}, "effects": {"damping": {"model": "stiffness_proportional"}}}
    sc = scene_from_dict(d)
    model = build_turbine(sc.turbine, ModeSet.from_dict({"fields": d["modes"]}), free=["DrTr"])
    before = model.system.body("tower").damping.copy()
    effect = next(e for e in build(sc).effects if isinstance(e, StructuralDamping))
    new = effect.prepare(model)
    assert new is not model and new.system is not model.system
    np.testing.assert_array_equal(model.system.body("tower").damping, before)
    assert not np.allclose(new.system.body("tower").damping, before)


# ----------------------------------------------------------------------------- effects on/off

def test_scene_without_aero_never_evaluates_aerodynamics(monkeypatch):
    from modesel.aero import bem
    from modesel.model.effects import aero

    def forbidden(*args, **kwargs):
        raise AssertionError("aerodynamics evaluated")
    monkeypatch.setattr(bem.BemSolver, "__init__", forbidden)
    monkeypatch.setattr(bem.BemSolver, "solve", forbidden)
    monkeypatch.setattr(aero.BladeAerodynamics, "__init__", forbidden)
    result = simulate(scene("turbine_rated_gravity"), tmax=1.0)
    assert "RtAeroFxh" not in result.outputs and "GenPwr" not in result.outputs
    assert "TwrBsMyt" in result.outputs and "RootMyc1" in result.outputs
    with pytest.raises(AssertionError, match="aerodynamics evaluated"):     # the patch is effective
        build(scene("turbine_wind_11p4"))


def test_scene_without_blade_dofs_allocates_no_blade_states():
    d = {"turbine": "nrel5mw", "modes": {"tower_fa": {"family": "elastodyn", "count": 2}},
         "dofs": {"free": ["GeAz"]}}
    b = build(scene_from_dict(d))
    assert b.model.system.free == ["TFA1", "TFA2", "GeAz"]
    assert len(b.q0) == 3 and not any(n.startswith("B") for n in b.eq.names)
    assert all(x.n_elastic == 0 for x in b.model.system.flexible_bodies() if x.name.startswith("blade"))
    assert [e.name for e in b.effects] == ["damping"]


def test_effect_options_are_checked():
    base = {"turbine": "nrel5mw", "modes": ONE_MODE, "dofs": {"free": ["GeAz", "DrTr"]}}
    with pytest.raises(ModeselError, match="effects.aero.skw"):
        scene_from_dict(dict(base, effects={"aero": {"skw": True}}))
    with pytest.raises(ModeselError, match="effects.generator.mode"):
        scene_from_dict(dict(base, effects={"generator": {"mode": "fast"}}))
    with pytest.raises(ModeselError, match="needs a wind"):
        build(scene_from_dict(dict(base, effects={"aero": True})))
    with pytest.raises(ModeselError, match="DrTr"):
        build(scene_from_dict(dict(base, dofs={"free": ["GeAz"]}, effects={"drivetrain": True})))


def test_generator_law_matches_jonkman():
    from modesel.model.effects.generator import (K_REGION2, RATED_TORQUE, TRANSITION,
                                                         variable_speed_torque)
    w = 1000 * RPM                                   # region 2
    assert variable_speed_torque(w) == pytest.approx(0.0255764 * 1000**2, rel=1e-5)
    assert variable_speed_torque(1173.7 * RPM) == pytest.approx(43093.55, rel=1e-6)
    assert variable_speed_torque(600 * RPM) == 0.0
    assert variable_speed_torque(TRANSITION) == pytest.approx(K_REGION2 * TRANSITION**2, rel=1e-9)
    for x in (70.16224, 91.21091, TRANSITION):      # continuous between regions
        assert variable_speed_torque(x * (1 + 1e-9)) == pytest.approx(variable_speed_torque(x * (1 - 1e-9)),
                                                                      rel=1e-6, abs=1e-3)
    assert variable_speed_torque(200.0) == RATED_TORQUE


def test_compiled_integration_equals_python_loads_path():
    """A scene whose only loads are linear (drivetrain) runs in the compiled
    integrator; the Python right-hand side with the same loads agrees."""
    from modesel.multibody.integrate import integrate
    b = build(scene("turbine_rated_gravity"))
    assert not b.acting and b.linear == [("DrTr", "DrTr", b.model.turbine.drivetrain_stiffness,
                                          b.model.turbine.drivetrain_damping)]
    q0 = b.q0.copy()
    q0[b.model.system.free.index("DrTr")] = 1e-3
    fast = integrate(b.rhs(), q0, b.qd0, 2.0, 0.1, rtol=1e-10, atol=1e-12)
    slow = integrate(b.M_F, q0, b.qd0, 2.0, 0.1, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(fast.q, slow.q, atol=1e-9)


def test_time_varying_wind_drives_the_inflow():
    """Wind from a time series: the normal inflow follows U(t) (doubling the
    wind of a parked rotor doubles V_n at every station)."""
    d = {"turbine": "nrel5mw", "modes": {"tower_fa": {"family": "elastodyn", "count": 1}},
         "dofs": {"free": []}, "effects": {"wind": {"time_series": [[0.0, 5.0], [10.0, 10.0]]}, "aero": True}}
    b = build(scene_from_dict(d))
    a = b.effect("aero")
    vn = []
    for t in (0.0, 10.0):
        b.loads(t, *state_at(b, t, b.q0, b.qd0))
        vn.append(a.vn.copy())
    np.testing.assert_allclose(vn[1], 2.0 * vn[0], rtol=1e-12)
    assert np.all(vn[0] > 0)


# ----------------------------------------------------------------------------- compiled twins

@pytest.fixture(scope="module")
def rated():
    """The 11.4 m/s scene built with reactions, and a deflected, moving state."""
    b = build(scene("turbine_wind_11p4"), reactions=True)
    rng = np.random.default_rng(3)
    q = b.q0 + 0.05 * rng.standard_normal(len(b.q0))
    qd = b.qd0 + 0.05 * rng.standard_normal(len(b.q0))
    return b, q, qd


def test_compiled_kinematics_equal_numpy_reference(rated):
    from modesel.multibody.kinematics import PointSet
    b, q, qd = rated
    q_all, qd_all = state_at(b, 0.3, q, qd)
    R, vec = b.frames(q_all, qd_all)
    ref = b.eq.kinematics(q_all, qd_all)
    for i, st in enumerate(ref):
        np.testing.assert_allclose(R[i], st.R, atol=1e-12)
        np.testing.assert_allclose(vec[i, 0], st.r, atol=1e-10)
        np.testing.assert_allclose(vec[i, 1], st.v, atol=1e-10)
        np.testing.assert_allclose(vec[i, 2], st.w, atol=1e-12)
    for name in ("tower", "blade1", "blade3"):
        pos, vel = PointSet.of_body(b.eq, name).kinematics((R, vec), q_all, qd_all)
        p_ref, v_ref, _ = b.eq.node_kinematics(name, ref[b.eq.body_index[name]], q_all, qd_all)
        np.testing.assert_allclose(pos, p_ref, atol=1e-10)
        np.testing.assert_allclose(vel, v_ref, atol=1e-10)


def test_point_motions_at_many_states_equal_the_compiled_points(rated):
    """`PointSet.along` (the numpy reference with a leading axis of states, the
    gauge pass's) gives at each of three states what the compiled `points`
    gives at that state alone."""
    from modesel.multibody.kinematics import PointSet
    b, q, qd = rated
    states = [state_at(b, t, s * q, s * qd) for t, s in ((0.0, 1.0), (0.3, 0.5), (1.1, -0.7))]
    Q, QD = np.array([s[0] for s in states]), np.array([s[1] for s in states])
    frames = b.frame_cache.along(Q, QD)
    for name in ("tower", "blade1", "blade3"):
        ps = PointSet.of_body(b.eq, name)
        pos, vel = ps.along(frames, Q, QD)
        assert pos.shape == vel.shape == (3, len(ps.s0), 3)
        for k in range(3):
            p1, v1 = ps.kinematics((frames[0][k], frames[1][k]), Q[k], QD[k])
            np.testing.assert_allclose(pos[k], p1, rtol=0, atol=1e-10)
            np.testing.assert_allclose(vel[k], v1, rtol=0, atol=1e-10)
        assert np.ptp(pos[:, -1], axis=0).max() > 1e-3 and np.ptp(vel[:, -1], axis=0).max() > 1e-3   # they differ


def test_station_shapes_agree_with_nodes(rated):
    """The AeroDyn stations' shapes are the blade's own fields: at the node
    spans they reproduce the node shapes and shortening."""
    b, _, _ = rated
    body = b.model.system.body("blade2")
    span = b.model.span["blade2"]
    s0, Phi, S = b.model.station_shapes("blade2", span)
    np.testing.assert_allclose(s0, body.nodes, atol=1e-12)
    np.testing.assert_allclose(Phi, body.shapes, atol=1e-12)
    np.testing.assert_allclose(S, body.shortening, atol=1e-12)


def test_station_bem_equals_bem_solver(rated):
    b, q, qd = rated
    a = b.effect("aero")
    b.loads(0.2, *state_at(b, 0.2, q, qd))
    ref = a.bem.solver.solve(a.r, a.vn, a.vt, a.pitch, a.skew, a.psi)
    fn, ft = a.bem(a.r, a.vn, a.vt, a.pitch, a.skew, a.psi)
    np.testing.assert_allclose(fn, ref.f_n, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(ft, ref.f_t, rtol=1e-12, atol=1e-9)


def test_tower_drag_equals_eq51(rated):
    """Eq. 51 by hand at AeroDyn's tower stations (the deck's TwrElev, its
    diameter and Cd there), with the wind and the tower's velocity at the
    stations' current positions, carried linearly to the nodes times their
    weights; InflowWind's wind is zero at and below the ground, so the base
    station (z = 0) has no drag."""
    from modesel.multibody.kinematics import PointSet
    b, q, qd = rated
    q_all, qd_all = state_at(b, 0.0, q, qd)
    gen, nodes = b.loads(0.0, q_all, qd_all)
    eff = b.effect("tower_drag")
    table = eff.drag
    np.testing.assert_allclose(eff.elevation, table.elevation, atol=1e-9)      # the table spans the tower
    t = b.model.turbine
    s0, Phi, S = b.model.station_shapes("tower", table.elevation)              # base at the ground
    pos, vel = PointSet.of_points(b.eq, "tower", s0, Phi, S).kinematics(b.frames(q_all, qd_all), q_all, qd_all)
    u = np.where(pos[:, 2] > 0.0, 11.4, 0.0)
    v_rel = np.stack([u - vel[:, 0], -vel[:, 1]], axis=1)
    p = (0.5 * eff.rho * table.drag_coefficient * table.diameter * np.linalg.norm(v_rel, axis=1))[:, None] * v_rel
    assert p[0, 0] == 0.0 and p[1, 0] > 0.5 * eff.rho * 5.7 * 11.0 ** 2
    z_nodes = b.model.system.body("tower").nodes[:, 2] - t.tower.root_offset
    expected = np.stack([np.interp(z_nodes, table.elevation, p[:, c]) for c in range(2)], axis=1)
    expected *= b.model.weights["tower"][:, None]
    np.testing.assert_allclose(nodes["tower"][:, :2], expected, rtol=1e-12, atol=1e-9)
    # AeroDyn's line load, linear between the stations: its integral over the tower, the trapezoid of
    # the station loads, is what the node quadrature carries to the structure
    assert nodes["tower"][:, 0].sum() == pytest.approx(np.trapezoid(p[:, 0], table.elevation), rel=1e-3)


# ----------------------------------------------------------------------------- rated wind

@pytest.fixture(scope="module")
def rated_run():
    return simulate(scene("turbine_wind_11p4"))


def read_ct(lam, pitch_deg=0.0):
    from test_aero import read_performance_table
    pitch, tsr, CP, CT, CQ = read_performance_table(os.path.join(DATA, "NREL5MW_CPCTCQ.txt"))
    j = np.searchsorted(pitch, pitch_deg)
    w = (pitch_deg - pitch[j - 1]) / (pitch[j] - pitch[j - 1])
    return float(np.interp(lam, tsr, (1 - w) * CT[:, j - 1] + w * CT[:, j]))


def test_rated_wind_thrust_matches_ct_table_and_rigid_bem(rated_run):
    from modesel.aero import steady_rotor
    from modesel.turbine.aerodyn import read_aerodyn
    out = rated_run.outputs
    last = out[out.Time >= out.Time.iloc[-1] - 20.0]
    thrust = last.RtAeroFxh.mean()
    omega = last.RotSpeed.mean() * RPM
    U, R, rho = 11.4, 63.0, 1.225
    table = read_ct(omega * R / U) * 0.5 * rho * np.pi * R**2 * U**2
    t = scene("turbine_wind_11p4").turbine
    rigid = steady_rotor(U, omega, 0.0, read_aerodyn(os.path.join(DATA, "NREL5MW_AD.dat")),
                         precone=t.precone[0], shaft_tilt=t.shaft_tilt, hub_radius=t.hub_radius)["thrust"]
    print(f"\n11.4 m/s: thrust {thrust / 1e3:.1f} kN at {omega / RPM:.2f} rpm; C_T table {table / 1e3:.1f} kN; "
          f"rigid coned/tilted BEM {rigid / 1e3:.1f} kN; published ~800 kN")
    assert 700e3 < thrust < 850e3
    assert thrust == pytest.approx(table, rel=0.05)
    # the flexible rotor's thrust sits below the rigid rotor's: the flap deflection cones the
    # blade further and AeroDyn's elastic twist turns the outer sections to feather; OpenFAST
    # 5.0, 11.4 m/s, 12.1 rpm (steady_11p4 with GenDOF off, 20-30 s): flexible 720.8 kN,
    # rigid blades and tower 739.8 kN, a drop of 2.57 %
    assert thrust == pytest.approx(rigid * (1.0 - 0.0257), rel=0.02)
    # torque balance at steady speed: aerodynamic = gearbox ratio x generator torque
    assert last.RotTorq.mean() == pytest.approx(t.gearbox_ratio * last.GenTq.mean(), rel=0.01)


def test_rated_wind_tower_top_displacement_matches_compliance(rated_run):
    """Mean TTDspFA minus its gravity-only value = thrust x cantilever
    compliance from the deck's EI(z), with the thrust at hub height."""
    out = rated_run.outputs
    last = out[out.Time >= out.Time.iloc[-1] - 20.0]
    t = scene("turbine_wind_11p4").turbine
    tw = t.tower
    z = np.linspace(0.0, tw.length, 4001)
    EI = np.interp(z, tw.span, tw.ei_1)
    H = tw.length
    c_ff = np.trapezoid((H - z) ** 2 / EI, z)          # tip deflection per tip force
    c_fm = np.trapezoid((H - z) / EI, z)               # per tip moment
    b = build(scene("turbine_wind_11p4"))
    dz = b.hub_height() - H
    gravity_only = scene_from_dict({
        "turbine": "nrel5mw", "modes": ONE_MODE, "initial": {"equilibrium": True},
        "dofs": {"free": ["DrTr"], "constant_speed": {"GeAz": float(last.RotSpeed.mean())}}})
    g = build(gravity_only)
    delta_g = g.q0[g.model.system.free.index("TFA1")]
    thrust = last.RtAeroFxh.mean()
    estimate = thrust * (c_ff + dz * c_fm)
    delta = last.TTDspFA.mean() - delta_g
    print(f"\ntower-top FA: {delta:.4f} m from thrust vs cantilever estimate {estimate:.4f} m")
    assert delta == pytest.approx(estimate, rel=0.05)
    # the transient has settled
    assert last.TTDspFA.std() < 0.01 * last.TTDspFA.mean()
    assert last.RotSpeed.std() < 0.01


def test_rated_wind_tower_base_moment_balances(rated_run):
    """Mean TwrBsMyt = moment of the thrust (along the tilted shaft, at the apex) + weight moments of the RNA
    (at rest, plus its weight times the tower-top deflection) + tower drag
    moment: a static balance about the tower base."""
    from modesel.aero import TowerDrag
    out = rated_run.outputs
    last = out[out.Time >= out.Time.iloc[-1] - 20.0]
    t = scene("turbine_wind_11p4").turbine
    g = t.gravity
    tilt = t.shaft_tilt
    xs = np.array([np.cos(-tilt), 0.0, -np.sin(-tilt)])     # shaft axis (ElastoDyn: tilt -5 deg lifts the upwind end)
    apex = np.array([0.0, 0.0, t.tower_height + t.twr2shft]) + t.overhang * xs
    bl = t.blade
    s = t.hub_radius + bl.span
    m_blade = np.trapezoid(bl.mass, bl.span)
    x_blade_cm = apex[0] + np.trapezoid(bl.mass * s, bl.span) / m_blade * np.sin(t.precone[0]) * xs[0]
    m_rna = t.nacelle_mass + t.hub_mass + 3 * m_blade
    weight = g * (t.nacelle_mass * t.nacelle_cm[0] + t.hub_mass * (apex[0] + t.hub_cm * xs[0])
                  + 3 * m_blade * x_blade_cm)
    tower_mass = np.trapezoid(t.tower.mass, t.tower.span)
    p_delta = g * (m_rna + 0.25 * tower_mass) * last.TTDspFA.mean()   # tower weight at ~1/4 of the tip deflection
    z = np.linspace(0.0, t.tower_height, 500)
    drag = TowerDrag.nrel5mw_default(t.tower_height).load(z, 11.4 * np.ones_like(z))
    drag_moment = np.trapezoid(drag * z, z)
    thrust = last.RtAeroFxh.mean()
    estimate = thrust * (apex[2] * xs[0] - apex[0] * xs[2]) + weight + p_delta + drag_moment
    print(f"\nTwrBsMyt {last.TwrBsMyt.mean():.0f} kN m vs static balance {estimate / 1e3:.0f} kN m")
    assert last.TwrBsMyt.mean() * 1e3 == pytest.approx(estimate, rel=0.02)


def test_root_moment_equals_newton_euler_sum(rated):
    """RootMyc1 (reaction row of the virtual root rotation) equals the
    Newton-Euler sum over blade 1's nodes of (p - root) x (F_aero + m g - m a)
    + M_aero (the node moments) about y_c, with node accelerations by central
    differences in time."""
    b, q, qd = rated
    t0 = 0.4
    M, F = b.M_F(t0, q, qd)
    qdd = np.linalg.solve(M, F)
    integ = Integration(np.array([t0]), q[None], qd[None], "none")
    root_myc = load_channels(b, integ)["RootMyc1"][0] * 1e3
    eq = b.eq
    h = 1e-4

    def node_state(dt):
        qq = q + dt * qd + 0.5 * dt * dt * qdd
        qqd = qd + dt * qdd
        q_all, qd_all = state_at(b, t0 + dt, qq, qqd)
        st = eq.kinematics(q_all, qd_all)
        pos, vel, _ = eq.node_kinematics("blade1", st[eq.body_index["blade1"]], q_all, qd_all)
        return pos, vel, st[eq.body_index["blade1"]]
    pos, _, frame = node_state(0.0)
    acc = (node_state(h)[1] - node_state(-h)[1]) / (2 * h)
    q_all, qd_all = state_at(b, t0, q, qd)
    _, nodes = b.loads(t0, q_all, qd_all)
    body = eq.system.body("blade1")
    loads = nodes["blade1"]                 # node forces and the aero's node moments (N, 6)
    force = loads[:, :3] + body.node_mass[:, None] * (np.array([0, 0, -eq.system.gravity]) - acc)
    yc = frame.R[:, 1]                      # pitch 0: the blade frame's y is the coned y_c
    newton_euler = np.sum(np.cross(pos - frame.r, force) @ yc) + np.sum(loads[:, 3:6] @ yc)
    assert root_myc == pytest.approx(newton_euler, rel=2e-4)


# ----------------------------------------------------------------------------- other scenes

def test_parked_free_decay_oscillates_at_the_tower_frequency():
    """Released 1 m fore-aft: zero crossings of TTDspFA give the coupled
    first fore-aft frequency (Jonkman 2009 Table 9-1: 0.3240 Hz)."""
    out = simulate(scene("turbine_parked_free_decay"), tmax=20.0, dt=0.01).outputs
    x = out.TTDspFA.to_numpy() - out.TTDspFA.iloc[-200:].mean()
    crossings = out.Time.to_numpy()[1:][np.diff(np.sign(x)) != 0]
    f = (len(crossings) - 1) / (2 * (crossings[-1] - crossings[0]))
    assert f == pytest.approx(0.3240, rel=0.03)
    assert np.abs(x[-200:]).max() < np.abs(x[:200]).max()          # decays


def test_release_scene_blade_vibrates_at_flap_frequency():
    out = simulate(scene("turbine_release"), tmax=15.0, dt=0.02).outputs
    x = out.OoPDefl1.to_numpy()
    assert x[0] == pytest.approx(3.0)
    spec = np.abs(np.fft.rfft(x - x.mean()))
    freq = np.fft.rfftfreq(len(x), 0.02)
    peak = freq[np.argmax(spec * (freq > 0.5))]
    assert 0.6 < peak < 0.8              # first flap family, 0.67-0.70 Hz (Table 9-1)


def four_modes():
    return ModeSet({f: FieldModes("fem", 4) for f in ("tower_fa", "tower_ss", "tower_torsion",
                                                       "blade_flap", "blade_edge")})


def test_above_rated_all_fields_four_modes_short_run_is_stable():
    r = simulate(scene("turbine_wind_15"), four_modes(), tmax=10.0)
    assert r.n_dofs == 3 * 4 + 3 * 8 + 2
    out = r.outputs
    assert np.all(np.isfinite(out.drop(columns="Time").to_numpy()))
    assert out.TTDspFA.abs().max() < 1.0 and out.OoPDefl1.abs().max() < 6.0


@pytest.mark.slow
def test_above_rated_all_fields_four_modes_600s_is_stable():
    r = simulate(scene("turbine_wind_15"), four_modes(), tmax=600.0, dt=0.1)
    out = r.outputs
    last = out[out.Time >= 500.0]
    assert np.all(np.isfinite(out.drop(columns="Time").to_numpy()))
    assert last.TTDspFA.std() < 0.05 and 11.0 < last.RotSpeed.mean() < 13.0
