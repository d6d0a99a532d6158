"""Symbolic layer (modesel.multibody.symbolic) against the numeric engine
(a second formulation) and the first paper's published numbers and
equations (sections 4.3-4.5, eq. 37-45, Appendix E2).
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from modesel.cli import main
from modesel.simulation.api import build, load_scene
from modesel.multibody.symbolic import write_latex, write_python
from modesel.simulation.symbolic import derive_scene

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "studies" / "scenes"
MODELS = {
    "2dof": "paper_2dof_tower_shaft.toml",       # first paper 4.4 / E1
    "land": "paper_3dof_land.toml",              # 4.5 / E2
    "floating": "paper_3dof_floating.toml",      # 4.6 / E3
    "blade": "paper_rotating_blade.toml",        # 4.3
}
TOL = 1e-9


@pytest.fixture(scope="module")
def models():
    """name -> (scene, numeric Built, exact SymbolicModel)."""
    out = {}
    for key, fname in MODELS.items():
        scene = load_scene(SCENES / fname)
        out[key] = (scene, build(scene), derive_scene(scene))
    return out


def random_state(names, rng):
    q, qd = [], []
    for n in names:
        if n == "GeAz":
            q.append(rng.uniform(0, 2 * np.pi)); qd.append(rng.normal(1.0, 0.5))
        elif n == "PtfmSurge":
            q.append(rng.normal(0, 2.0)); qd.append(rng.normal(0, 0.3))
        elif n == "PtfmPitch":
            q.append(rng.normal(0, 0.1)); qd.append(rng.normal(0, 0.05))
        else:                                            # elastic, tip-normalised [m]
            q.append(rng.normal(0, 0.7)); qd.append(rng.normal(0, 0.7))
    return np.array(q), np.array(qd)


def rel(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def hub_loads(eq, q, qd, t, thrust, torque):
    """Generalised forces of a thrust along the shaft at the hub origin and a
    torque about the shaft (numeric engine kinematics, eq. 9)."""
    q_all, qd_all, _ = eq.full_state(q, qd, t)
    st = eq.kinematics(q_all, qd_all)[eq.body_index["hub"]]
    xs = st.R[:, 0]
    return st.Jv.T @ (thrust * xs) + st.Jw.T @ (torque * xs)


@pytest.mark.parametrize("key", list(MODELS))
def test_symbolic_equals_numeric_engine(models, key):
    scene, built, model = models[key]
    assert model.coordinates == list(built.model.system.free)
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(6):
        q, qd = random_state(model.coordinates, rng)
        t = rng.uniform(0, 10)
        M_num, F_num = built.eq.evaluate_reference(q, qd, t)
        M_sym, F_sym = model.evaluate(q, qd, t)
        worst = max(worst, rel(M_sym, M_num), rel(F_sym, F_num))
    assert worst < TOL, f"{key}: max relative difference {worst:.2e}"


@pytest.mark.parametrize("key", ["2dof", "land"])
def test_rotor_inputs_equal_numeric_generalised_forces(models, key):
    """Thrust f_a and torque tau_a inputs against the engine's eq. 9 projection."""
    _, built, model = models[key]
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, qd = random_state(model.coordinates, rng)
        u = (rng.normal(7e5, 1e5), rng.normal(4e6, 1e6))
        gen = hub_loads(built.eq, q, qd, 0.0, *u)
        _, F_num = built.eq.evaluate_reference(q, qd, 0.0, generalized=gen)
        _, F_sym = model.evaluate(q, qd, 0.0, u=u)
        assert rel(F_sym, F_num) < TOL


def test_2dof_paper_numbers_and_equations(models):
    """Section 4.4: nu_y = 0.0185, M_e = 5.4e4, K_e = 1.91e6, K_g = -5.2e4 - 1.0e4,
    M_q = 4.375e5 (eq. 37-39) and f = 0.3272 Hz from the linearised stiffness (eq. 45)."""
    _, _, model = models["2dof"]
    p = model.parameters()
    g, nu, u = p["g"], p["nu_yT"], p["u_xTFA1"]
    assert nu == pytest.approx(0.0185, abs=5e-5)
    assert p["Me_T11"] == pytest.approx(5.4e4, rel=0.01)
    assert p["K_eT11"] == pytest.approx(1.91e6, rel=0.005)
    MN, MR = p["M_N"], p["M_R"]
    K_gt = -g * (MN + MR) * p["G_T11"]                       # eq. 33
    K_gw = -g * p["Gw_T11"]                                  # eq. 34
    assert K_gt == pytest.approx(-5.2e4, rel=0.02) and K_gw == pytest.approx(-1.0e4, rel=0.05)
    # rotor centre of mass in the nacelle frame (tilted shaft, rotor cm on the shaft)
    th = p["theta_t"]
    xR, zR = p["x_NR"] + p["x_RG"] * np.cos(th), p["z_NR"] - p["x_RG"] * np.sin(th)
    Mq_paper = (p["Me_T11"] + (MN + MR) * u ** 2                                     # eq. 37
                + (p["J_oR"] + MN * (p["x_NG"] ** 2 + p["z_NG"] ** 2) + MR * (xR ** 2 + zR ** 2)) * nu ** 2
                + 2 * (MN * p["z_NG"] + MR * zR) * nu * u)                          # eq. 38-39 at q = 0
    M0, C0, K0 = model.linear_matrices()
    assert M0[0, 0] == pytest.approx(Mq_paper, rel=1e-12)
    assert M0[0, 0] == pytest.approx(4.375e5, rel=1e-3)
    Kq_paper = p["K_eT11"] + K_gt + K_gw - nu ** 2 * g * (MN * p["z_NG"] + MR * zR)   # eq. 45, f_a = 0
    assert K0[0, 0] == pytest.approx(Kq_paper, rel=1e-12)
    f = np.sqrt(K0[0, 0] / M0[0, 0]) / (2 * np.pi)
    assert f == pytest.approx(0.3272, abs=5e-4)
    # the paper's own approximation (tilt to first order, slope to second) gives the same numbers
    approx = model.with_small_angles("tilt=1,slope=2")
    M0a, _, K0a = approx.linear_matrices()
    assert M0a[0, 0] == pytest.approx(4.375e5, rel=1e-3)
    assert np.sqrt(K0a[0, 0] / M0a[0, 0]) / (2 * np.pi) == pytest.approx(0.3272, abs=5e-4)


def test_land_small_angle_reproduces_appendix_E2(models):
    """With first order in theta_t and second order in nu (section 4.5) the
    shaft couplings are the paper's E16, E20, E21 and E26 (side-side slope
    sign: ElastoDyn's Q_TSS displaces along -y; the generator adds n_gb J_Gen)."""
    _, _, model = models["land"]
    m = model.with_small_angles({"tilt": 1, "slope": 2})
    S = {s.name: s for s in m.table.symbols()}
    q1, q2 = m.q_symbols()[:2]
    q1d, q2d = m.qd_symbols()[:2]
    Jx = S["J_xR"] + S["n_gb"] * S["J_xGen"]
    th, nux, nuy = S["theta_t"], S["nu_xT"], S["nu_yT"]
    tau = m.derivation.inputs[1]
    assert sp.expand(m.M[0, 2] - Jx * th * nux * nuy * q2) == 0                       # E16
    assert sp.expand(m.M[1, 2] - Jx * nux) == 0                                       # E20
    assert sp.expand(m.M[2, 2] - (S["J_xR"] + S["n_gb"] ** 2 * S["J_xGen"])) == 0      # E21
    assert sp.expand(m.F[2] - (-Jx * th * nux * nuy * q1d * q2d + tau)) == 0           # E26


def test_floating_small_angle_reproduces_appendix_E3(models):
    """Section 4.6 approximation (first order in theta_t and phi_y, second in
    nu) with the zeroth-order displacement field of the paper (shortening
    integrals set to zero): E27, E29 and E32."""
    _, _, model = models["floating"]
    m = model.with_small_angles("tilt=1,slope=2,pitch=1")
    S = {s.name: s for s in m.table.symbols()}
    zeroth = {s: 0 for n, s in S.items() if n.startswith(("G_", "Gw_", "Gs_", "Gp_", "Gq_"))}
    i = {n: k for k, n in enumerate(m.coordinates)}
    qT, phi = m.q_symbols()[i["TFA1"]], m.q_symbols()[i["PtfmPitch"]]
    MN, nu, u, x, z = S["M_N"], S["nu_yT"], S["u_xTFA1"], S["x_NG"], S["z_NG"]

    def entry(a, b):
        return sp.expand(m.M[i[a], i[b]].xreplace(zeroth))

    assert entry("PtfmSurge", "PtfmSurge") == S["M_F"] + S["M_T"] + MN                         # E27
    E29 = S["Ct_T1"] + MN * (u + nu * z - nu ** 2 * x * qT - phi * (nu ** 2 * z * qT + nu * x))
    assert sp.expand(entry("PtfmSurge", "TFA1") - E29) == 0                                   # E29
    E32 = (S["Me_T11"] + MN * u ** 2 + (S["J_yN"] + MN * (x ** 2 - 2 * x * qT * u + z ** 2)) * nu ** 2
           + 2 * MN * nu * z * u)
    assert sp.expand(entry("TFA1", "TFA1") - E32) == 0                                        # E32


def test_small_angle_error_shrinks_with_order(models):
    """Taylor truncation in tilt and slope: the difference to the exact
    equations falls with the order (2-DOF model, 1 m tower-top deflection)."""
    _, _, model = models["2dof"]
    q, qd = np.array([1.0, 0.4]), np.array([0.8, 1.2])
    M_exact, F_exact = model.evaluate(q, qd)
    errs = []
    for k in (1, 2, 3):
        M, F = model.with_small_angles(k).evaluate(q, qd)
        errs.append(max(rel(M, M_exact), rel(F, F_exact)))
    assert errs[0] > errs[1] > errs[2] and errs[2] < 1e-6


def test_rotating_blade_southwell_coefficients(models):
    """Section 4.3: K_e = [1.7e4, 6.7e4, 8.7e4] and rise factors k_Omega =
    [1.7, 1.4, 5.5] (1st flap, 1st edge, 2nd flap) from the symbolic
    linearisation at the prescribed rotor speed (edge: (k - 1) Omega^2, eq. 32)."""
    _, _, model = models["blade"]
    omega = model.prescribed["GeAz"][1]
    M0, _, K0 = model.linear_matrices()
    _, _, K_parked = model.with_prescribed({"GeAz": (0.0, 0.0, 0.0)}).linear_matrices()
    idx = {n: i for i, n in enumerate(model.coordinates)}
    for dof, ke, k_paper, edge in (("B1F1", 1.7e4, 1.7, 0), ("B1E1", 6.7e4, 1.4, 1), ("B1F2", 8.7e4, 5.5, 0)):
        i = idx[dof]
        assert K_parked[i, i] == pytest.approx(ke, rel=0.03)
        k = (K0[i, i] - K_parked[i, i]) / (M0[i, i] * omega ** 2) + edge
        assert k == pytest.approx(k_paper, abs=0.05), dof


@pytest.mark.parametrize("key", ["2dof", "blade"])
def test_exported_module_reproduces_engine(models, key, tmp_path):
    _, built, model = models[key]
    path = write_python(model, tmp_path / f"eom_{key}.py")
    spec = importlib.util.spec_from_file_location(f"eom_{key}", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.COORDINATES == model.coordinates
    assert mod.PARAMETERS == model.parameters()
    rng = np.random.default_rng(11)
    for _ in range(3):
        q, qd = random_state(model.coordinates, rng)
        t = rng.uniform(0, 10)
        M_num, F_num = built.eq.evaluate_reference(q, qd, t)
        assert rel(mod.mass_matrix(q, qd, t=t), M_num) < TOL
        assert rel(mod.forcing(q, qd, t=t), F_num) < TOL
    n = len(model.coordinates)
    M0, C0, K0, Q0 = mod.linear_matrices(np.zeros(n), np.zeros(n))
    for a, b in zip((M0, C0, K0), model.linear_matrices()):
        assert np.allclose(a, b, rtol=1e-10, atol=1e-10 * np.max(np.abs(b)))
    if key == "2dof":
        assert np.sqrt(K0[0, 0] / M0[0, 0]) / (2 * np.pi) == pytest.approx(0.3272, abs=5e-4)


def test_cli_derive_writes_python_and_latex(tmp_path, capsys):
    py, tex = tmp_path / "eom.py", tmp_path / "eom.tex"
    rc = main(["derive", str(SCENES / MODELS["2dof"]), "--python", str(py), "--latex", str(tex),
               "--small-angle", "tilt=1,slope=2"])
    assert rc == 0
    out = capsys.readouterr().out
    assert "0.327" in out
    text = tex.read_text()
    assert text.startswith(r"\documentclass") and text.rstrip().endswith(r"\end{document}")
    assert r"M(q)\,\ddot{q} = F(q, \dot{q}, t, u)" in text
    assert r"\begin{dmath*} M_{1,1} = " in text and r"M_{e,T11}" in text and r"\theta_t" in text
    assert r"\begin{dmath*} F_{1} = " in text and r"\nu_{y,T}" in text
    spec = importlib.util.spec_from_file_location("eom_cli", py)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    M = mod.mass_matrix([0.0, 0.0], [0.0, 0.0])
    assert M[0, 0] == pytest.approx(4.375e5, rel=1e-3)


def test_cli_derive_rejects_large_models_and_bad_options(tmp_path, capsys):
    deck = ROOT / "modesel" / "turbine" / "data" / "nrel5mw" / "NREL5MW_ED_Onshore.dat"
    assert main(["derive", str(deck), "--python", str(tmp_path / "x.py")]) == 2
    err = capsys.readouterr().err.strip()
    assert "small models only" in err and "\n" not in err
    assert main(["derive", str(SCENES / MODELS["2dof"]), "--small-angle", "wobble=2"]) == 2
    assert "unknown small-angle group 'wobble'" in capsys.readouterr().err
    assert not (tmp_path / "x.py").exists()


def test_latex_lists_all_nonzero_entries(models, tmp_path):
    _, _, model = models["floating"]
    text = write_latex(model, tmp_path / "f.tex", linear=False).read_text()
    n = len(model.coordinates)
    for i in range(n):
        for j in range(i, n):
            assert (rf"M_{{{i + 1},{j + 1}}} = " in text) == (model.M[i, j] != 0)
    assert text.count(r"\begin{dmath*}") == text.count(r"\end{dmath*}")
    for p in model.table.params.values():
        assert f"${p.latex}$" in text
    plain = text.replace(r"\{", "").replace(r"\}", "")
    assert plain.count("{") == plain.count("}")


@pytest.mark.slow
@pytest.mark.parametrize("key", list(MODELS))
def test_symbolic_equals_compiled_engine(models, key):
    """Same comparison against the engine's compiled kernel (Built.M_F)."""
    _, built, model = models[key]
    rng = np.random.default_rng(13)
    for _ in range(3):
        q, qd = random_state(model.coordinates, rng)
        t = rng.uniform(0, 10)
        M_num, F_num = built.M_F(t, q, qd)
        M_sym, F_sym = model.evaluate(q, qd, t)
        assert rel(M_sym, M_num) < TOL and rel(F_sym, F_num) < TOL
