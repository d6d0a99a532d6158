"""Tests of `modesel export`: constrained polynomial fit, ElastoDyn files, JSON.

Checks against things outside the code under test: exact polynomials and the
MF1 shape (second paper, eq. 53) must be recovered; the cosine shape MF2 is
compared with an independent formulation of the same constrained
least-squares problem (KKT system on analytic Gram integrals + adaptive
quadrature); exported files are read back with openfast-io's own readers.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate

from modesel.errors import ModeselError
from modesel.export.polyfit import evaluate_polynomial, fit_mode_polynomial

X = np.linspace(0.0, 1.0, 201)


# --------------------------------------------------------------------------- polyfit
@pytest.mark.parametrize("raw", [
    [0.7004, 2.1963, -5.6202, 6.2275, -2.504],          # NREL 5-MW TwFAM1Sh
    [-70.5319, -63.7623, 289.737, -176.513, 22.0706],   # NREL 5-MW TwFAM2Sh (large, alternating)
    [0.3627, 2.5337, -3.5772, 2.376, -0.6952],          # BldEdgSh
])
def test_exact_sixth_order_polynomial_is_recovered(raw):
    c = np.array(raw) / np.sum(raw)
    fit = fit_mode_polynomial(X, evaluate_polynomial(c, X))
    assert np.max(np.abs(fit.coefficients - c)) <= 1e-12 * max(1.0, np.max(np.abs(c)))
    assert abs(np.sum(fit.coefficients) - 1.0) < 1e-13
    assert fit.rms < 1e-12 and fit.max_abs < 1e-12


def test_mf1_is_recovered_exactly():
    """MF1 = x^4/3 - 4x^3/3 + 2x^2 (second paper, eq. 53): unit tip, in the polynomial space."""
    phi = X ** 4 / 3 - 4 * X ** 3 / 3 + 2 * X ** 2
    fit = fit_mode_polynomial(X, phi, ddphi=4 * X ** 2 - 8 * X + 4)
    np.testing.assert_allclose(fit.coefficients, [2.0, -4.0 / 3.0, 1.0 / 3.0, 0.0, 0.0], atol=1e-13)
    assert fit.max_abs < 1e-14 and fit.curvature_rms < 1e-12


def _kkt_reference(phi):
    """Independent formulation: minimise int_0^1 (sum c_k x^k - phi)^2 dx subject to
    sum c_k = 1 by the KKT system [G 1; 1^T 0][c; l] = [b; 1], with the exact Gram
    matrix G_jk = 1/(j+k+1) and b_j = int x^j phi dx by adaptive quadrature."""
    p = np.arange(2, 7)
    gram = 1.0 / (p[:, None] + p[None, :] + 1.0)
    b = np.array([integrate.quad(lambda s, k=k: s ** k * phi(s), 0, 1, epsabs=1e-15)[0] for k in p])
    kkt = np.block([[gram, np.ones((5, 1))], [np.ones((1, 5)), np.zeros((1, 1))]])
    c = np.linalg.solve(kkt, np.append(b, 1.0))[:5]
    rms = np.sqrt(integrate.quad(lambda s: (evaluate_polynomial(c, [s])[0] - phi(s)) ** 2, 0, 1,
                                 epsabs=1e-20, limit=200)[0])
    return c, rms


def test_cosine_residual_matches_independent_kkt_solution():
    """MF2 = 1 - cos(pi x / 2) (second paper, eq. 53) is not a polynomial: measured
    residual RMS 4.654e-7, max 9.31e-7 (tip = 1)."""
    shape = lambda s: 1.0 - np.cos(np.pi * np.asarray(s) / 2)
    x = np.linspace(0, 1, 2001)
    fit = fit_mode_polynomial(x, shape(x))
    c_ref, rms_ref = _kkt_reference(shape)
    np.testing.assert_allclose(fit.coefficients, c_ref, atol=1e-6)
    assert fit.rms == pytest.approx(rms_ref, rel=1e-3)
    assert 4.0e-7 < fit.rms < 5.0e-7 and 8.0e-7 < fit.max_abs < 1.0e-6
    assert abs(np.sum(fit.coefficients) - 1.0) < 1e-14


def test_mass_weighting_changes_a_non_polynomial_fit_but_keeps_exact_ones():
    shape = np.sin(1.875 * X) - 1.3622 * np.cos(1.875 * X) - np.sinh(1.875 * X) + 1.3622 * np.cosh(1.875 * X)
    mass = 5590.87 - 3054.6 * X           # tower-like taper [kg/m]
    uni = fit_mode_polynomial(X, shape)
    heavy = fit_mode_polynomial(X, shape, weighting="mass", mass=mass)
    assert not np.allclose(uni.coefficients, heavy.coefficients, rtol=0, atol=1e-9)
    # the weighted optimum is worse in the unweighted norm, never better
    assert heavy.rms >= uni.rms * (1 - 1e-9)
    mf1 = X ** 4 / 3 - 4 * X ** 3 / 3 + 2 * X ** 2
    np.testing.assert_allclose(fit_mode_polynomial(X, mf1, weighting="mass", mass=mass).coefficients,
                               [2.0, -4.0 / 3.0, 1.0 / 3.0, 0.0, 0.0], atol=1e-12)


def test_stiffness_weighting_matches_independent_kkt_solution():
    """weighting 'stiffness': minimise int_0^1 EI (phi_fit'' - phi'')^2 dx with sum c = 1; the
    reference solves the KKT system on exact Gram integrals of a linear EI(x) (quadrature only for
    the right-hand side), for the first clamped-beam mode."""
    b, sig = 1.8751040687, 1.3622205
    curv = lambda s: b ** 2 * (np.cosh(b * s) + np.cos(b * s) - sig * (np.sinh(b * s) + np.sin(b * s)))
    shape = lambda s: np.cosh(b * s) - np.cos(b * s) - sig * (np.sinh(b * s) - np.sin(b * s))
    e0, e1 = 6.0e11, -4.0e11                   # tapering EI [N m^2]
    x = np.linspace(0, 1, 4001)
    tip = shape(1.0)
    fit = fit_mode_polynomial(x, shape(x), ddphi=curv(x), weighting="stiffness", stiffness=e0 + e1 * x)
    p = np.arange(2, 7)
    f = p * (p - 1.0)
    gram = np.outer(f, f) * (e0 / (p[:, None] + p[None, :] - 3.0) + e1 / (p[:, None] + p[None, :] - 2.0))
    rhs = np.array([integrate.quad(lambda s, k=k: (e0 + e1 * s) * k * (k - 1) * s ** (k - 2) * curv(s) / tip,
                                   0, 1, epsabs=1e-6)[0] for k in p])
    kkt = np.block([[gram / e0, np.ones((5, 1))], [np.ones((1, 5)), np.zeros((1, 1))]])
    c_ref = np.linalg.solve(kkt, np.append(rhs / e0, 1.0))[:5]
    np.testing.assert_allclose(fit.coefficients, c_ref, atol=1e-6)      # measured 1.5e-7 (trapezoid rule)
    assert abs(np.sum(fit.coefficients) - 1.0) < 1e-14
    mf1 = X ** 4 / 3 - 4 * X ** 3 / 3 + 2 * X ** 2          # exact polynomials stay exact
    np.testing.assert_allclose(fit_mode_polynomial(X, mf1, ddphi=4 * X ** 2 - 8 * X + 4, weighting="stiffness",
                                                   stiffness=e0 + e1 * X).coefficients,
                               [2.0, -4.0 / 3.0, 1.0 / 3.0, 0.0, 0.0], atol=1e-12)


def test_shape_is_scaled_to_unit_tip():
    mf1 = X ** 4 / 3 - 4 * X ** 3 / 3 + 2 * X ** 2
    np.testing.assert_allclose(fit_mode_polynomial(X, -2.5 * mf1).coefficients,
                               [2.0, -4.0 / 3.0, 1.0 / 3.0, 0.0, 0.0], atol=1e-12)


@pytest.mark.parametrize("kwargs, phi", [
    ({}, np.sin(np.pi * X)),                              # zero tip
    ({"weighting": "energy"}, X ** 2),
    ({"weighting": "mass"}, X ** 2),                       # mass missing
    ({"weighting": "stiffness", "stiffness": np.ones(X.size)}, X ** 2),   # curvature missing
    ({"weighting": "stiffness", "ddphi": np.full(X.size, 2.0)}, X ** 2),  # stiffness missing
    ({}, np.full(X.size, np.nan)),
])
def test_fit_rejects_bad_input(kwargs, phi):
    with pytest.raises(ModeselError):
        fit_mode_polynomial(X, phi, **kwargs)


# --------------------------------------------------------------------------- ElastoDyn files
import json  # noqa: E402
import shutil  # noqa: E402
from pathlib import Path  # noqa: E402

from openfast_io.FAST_reader import InputReader_OpenFAST  # noqa: E402

from modesel.cli import main  # noqa: E402
from modesel.export import export_modeset  # noqa: E402
from modesel.modeset import ModeSet  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
NREL = REPO / "modesel" / "turbine" / "data" / "nrel5mw"
DECK = NREL / "NREL5MW_ED_Onshore.dat"
SPAR_FST = REPO / "tests" / "data" / "openfast_free_decay" / "tower_fa_ss_shaft" / "Main_Spar_ED.fst"

# the deck's polynomials, copied from the files (x^2..x^6)
DECK_BLDFL2SH = [-0.5809, 1.2067, -15.5349, 29.7347, -13.8255]
DECK_BLDEDGSH = [0.3627, 2.5337, -3.5772, 2.376, -0.6952]


def read_back(outdir: Path, stem: str) -> dict:
    """The written files, read by openfast-io's own readers (no modesel code)."""
    reader = InputReader_OpenFAST()
    reader.read_ElastoDyn(str(outdir / f"{stem}_ElastoDyn.dat"))
    ed = reader.fst_vt["ElastoDyn"]
    reader.read_ElastoDynTower(str(outdir / ed["TwrFile"]))
    reader.read_ElastoDynBlade(str(outdir / ed["BldFile1"]), BladeNumber=0)
    return {"ed": ed, "tower": reader.fst_vt["ElastoDynTower"], "blade": reader.fst_vt["ElastoDynBlade"][0],
            "outlist": reader.fst_vt["outlist"]}


def shapes_of(field, family, count, deck=DECK, **params):
    """The mode set's shapes, computed directly from the candidate library."""
    from modesel.candidates.base import mode_shapes
    from modesel.candidates.context import field_context
    from modesel.turbine.elastodyn import load_turbine
    return mode_shapes(field, family, count, field_context(load_turbine(deck), field), x=X, **params)


@pytest.fixture(scope="module")
def nrel_export(tmp_path_factory):
    out = tmp_path_factory.mktemp("ed")
    ms = ModeSet.from_dict({"fields": {"tower_fa": {"family": "clamped", "count": 2},
                                       "tower_ss": {"family": "clamped", "count": 2},
                                       "blade_flap": {"family": "cosine", "count": 1}}})
    report, _ = export_modeset(ms, DECK, elastodyn_dir=out)
    return report, read_back(out, DECK.stem), out


def test_written_polynomials_reproduce_the_shapes_within_the_reported_residual(nrel_export):
    report, files, _ = nrel_export
    where = {"tower_fa": ("tower", ["TwFAM1Sh", "TwFAM2Sh"]), "tower_ss": ("tower", ["TwSSM1Sh", "TwSSM2Sh"]),
             "blade_flap": ("blade", ["BldFl1Sh"])}
    measured = {}
    for mode in report.modes:
        branch, keys = where[mode.field]
        c = np.array(files[branch][keys[mode.mode - 1]], dtype=float)
        assert abs(c.sum() - 1.0) < 1e-12
        phi = shapes_of(mode.field, mode.family, mode.mode).phi[mode.mode - 1]
        err = evaluate_polynomial(c, X) - phi
        assert np.max(np.abs(err)) == pytest.approx(mode.fit.max_abs, rel=1e-9, abs=1e-15)
        rms = np.sqrt(np.trapezoid(err ** 2, X))
        assert rms == pytest.approx(mode.fit.rms, rel=1e-6, abs=1e-15)
        measured[(mode.field, mode.mode)] = (mode.fit.rms, mode.fit.max_abs)
    # measured: clamped:2 tower, rms 1.49e-6 / 2.97e-4, max 2.76e-6 / 6.33e-4;
    # cosine:1 flap is MF2 again: rms 4.65e-7
    assert measured[("tower_fa", 1)][0] < 5e-6 and measured[("tower_fa", 2)][0] < 1e-3
    assert measured[("tower_fa", 1)] == measured[("tower_ss", 1)]
    assert measured[("blade_flap", 1)][0] == pytest.approx(4.654e-7, rel=1e-3)


def test_dof_flags_and_unchanged_values(nrel_export):
    report, files, out_dir = nrel_export
    ed, tower, blade = files["ed"], files["tower"], files["blade"]
    assert [ed[k] for k in ("TwFADOF1", "TwFADOF2", "TwSSDOF1", "TwSSDOF2")] == [True] * 4
    assert ed["FlapDOF1"] is True and ed["FlapDOF2"] is False        # cosine:1 -> 2nd flap mode off
    assert ed["EdgeDOF"] is True                                       # blade_edge not in the set: as in deck
    assert report.disabled == [("blade_flap", 2, "BldFl2Sh", "FlapDOF2")]
    assert report.kept == ["blade_edge"]
    np.testing.assert_array_equal(blade["BldFl2Sh"], DECK_BLDFL2SH)   # kept polynomial
    np.testing.assert_array_equal(blade["BldEdgSh"], DECK_BLDEDGSH)
    # distributed properties unchanged; the old blade file's PitchAxis column dropped, not shifted
    reader = InputReader_OpenFAST()
    reader.read_ElastoDynTower(str(NREL / "NRELOffshrBsline5MW_Onshore_ElastoDyn_Tower.dat"))
    for key in ("HtFract", "TMassDen", "TwFAStif", "TwSSStif", "AdjTwMa", "TwrFADmp1"):
        np.testing.assert_array_equal(tower[key], reader.fst_vt["ElastoDynTower"][key])
    assert blade["NBlInpSt"] == 49 and blade["AdjBlMs"] == 1.04536
    assert (blade["BlFract"][2], blade["StrcTwst"][2], blade["BMassDen"][2], blade["FlpStff"][2],
            blade["EdgStff"][2]) == (1.951e-2, 13.308, 773.363, 1.94249e10, 1.95586e10)
    assert blade["StrcTwst"][-1] == 0.0 and blade["EdgStff"][-1] == 5.01e6
    # main-file values, as in NREL5MW_ED_Onshore.dat
    assert (ed["TowerHt"], ed["OverHang"], ed["NacMass"], ed["RotSpeed"], ed["GBRatio"], ed["TwrNodes"]) == \
        (87.6, -5.0191, 240000.0, 10.0, 97.0, 20)
    assert ed["YawDOF"] is True and ed["PitchDOF"] is False and ed["PtfmPDOF"] is False
    assert ed["BldFile1"] == ed["BldFile2"] == ed["BldFile3"]
    out = files["outlist"]
    assert out["ElastoDyn"]["Q_DrTr"] and out["ElastoDyn"]["TTDspFA"] and out["ElastoDyn"]["RootMyb1"]
    # nodal outputs carried over (openfast-io's reader files them elsewhere: check the text)
    _, nodal = (out_dir / f"{DECK.stem}_ElastoDyn.dat").read_text().split("BldNd_BladesOut")
    assert '"TDx"' in nodal and '"FLz"' in nodal


def test_sidecar_holds_the_printed_residuals(nrel_export):
    report, _, out = nrel_export
    side = json.loads((out / f"{DECK.stem}_modesel_fits.json").read_text())
    assert [(m["field"], m["mode"], m["key"]) for m in side["modes"]] == \
        [(m.field, m.mode, m.key) for m in report.modes]
    assert [m["rms"] for m in side["modes"]] == [m.fit.rms for m in report.modes]
    text = "\n".join(report.lines())
    assert "TwFAM2Sh" in text and f"{report.modes[1].fit.rms:.2e}" in text


def test_deck_polynomials_round_trip_through_the_elastodyn_family(tmp_path):
    """Exporting the deck's own modes writes the deck's coefficients (normalised by their sum)."""
    ms = ModeSet.from_dict({"fields": {f: {"family": "elastodyn", "count": n} for f, n in
                                       (("tower_fa", 2), ("tower_ss", 2), ("blade_flap", 2), ("blade_edge", 1))}})
    report, _ = export_modeset(ms, DECK, elastodyn_dir=tmp_path, weighting="mass")
    files = read_back(tmp_path, DECK.stem)
    deck_fa2 = np.array([-70.5319, -63.7623, 289.737, -176.513, 22.0706])
    np.testing.assert_allclose(files["tower"]["TwFAM2Sh"], deck_fa2 / deck_fa2.sum(), rtol=0, atol=1e-10)
    np.testing.assert_allclose(files["blade"]["BldEdgSh"], np.array(DECK_BLDEDGSH) / sum(DECK_BLDEDGSH),
                               rtol=0, atol=1e-12)
    assert max(m.fit.max_abs for m in report.modes) < 1e-12
    assert not report.warnings and not report.disabled and not report.kept


def test_too_many_modes_and_torsion_are_reported(tmp_path):
    ms = ModeSet.from_dict({"fields": {"blade_edge": {"family": "clamped", "count": 3},
                                       "tower_torsion": {"family": "linear", "count": 1}}})
    report, _ = export_modeset(ms, DECK, elastodyn_dir=tmp_path)
    assert [(m.field, m.mode) for m in report.modes] == [("blade_edge", 1)]
    assert any("blade_edge has 3 modes" in w and "holds 1" in w for w in report.warnings)
    assert any(w.startswith("tower_torsion") and "cannot be represented" in w for w in report.warnings)
    assert sorted(report.kept) == ["blade_flap", "tower_fa", "tower_ss"]
    files = read_back(tmp_path, DECK.stem)
    np.testing.assert_array_equal(files["tower"]["TwFAM1Sh"], [0.7004, 2.1963, -5.6202, 6.2275, -2.504])


def test_fst_deck_with_gravity_line(tmp_path):
    """A .fst whose ElastoDyn file has the older Gravity line and TowerBsHt = 20 m."""
    ms = ModeSet.from_dict({"fields": {"tower_fa": {"family": "clamped", "count": 1}}})
    report, _ = export_modeset(ms, SPAR_FST, elastodyn_dir=tmp_path)
    files = read_back(tmp_path, "Spar_ED_ForED")
    ed = files["ed"]
    assert (ed["TwFADOF1"], ed["TwFADOF2"], ed["TwSSDOF1"], ed["TwSSDOF2"]) == (True, False, True, False)
    assert ed["TowerBsHt"] == 20.0 and ed["TTDspSS"] == -2.0
    assert any("Gravity" in n for n in report.notes)
    c = np.array(files["tower"]["TwFAM1Sh"])
    phi = shapes_of("tower_fa", "clamped", 1, deck=SPAR_FST).phi[0]
    assert np.max(np.abs(evaluate_polynomial(c, X) - phi)) <= report.modes[0].fit.max_abs * (1 + 1e-9)


def test_refuses_to_overwrite_the_deck(tmp_path):
    for name in ("NRELOffshrBsline5MW_Blade.dat",):
        shutil.copy(NREL / name, tmp_path / name)
    shutil.copy(NREL / "NRELOffshrBsline5MW_Onshore_ElastoDyn_Tower.dat", tmp_path / "ED_ElastoDyn_tower.dat")
    text = DECK.read_text().replace("NRELOffshrBsline5MW_Onshore_ElastoDyn_Tower.dat", "ED_ElastoDyn_tower.dat")
    (tmp_path / "ED.dat").write_text(text)
    ms = ModeSet.from_dict({"fields": {"tower_fa": {"family": "clamped", "count": 1}}})
    with pytest.raises(ModeselError, match="overwrite"):
        export_modeset(ms, tmp_path / "ED.dat", elastodyn_dir=tmp_path)
    assert (tmp_path / "ED_ElastoDyn_tower.dat").read_text() == \
        (NREL / "NRELOffshrBsline5MW_Onshore_ElastoDyn_Tower.dat").read_text()


# --------------------------------------------------------------------------- JSON
def test_json_export_shapes_and_integrals(tmp_path):
    """Sampled shapes and shape integrals; the deck's TwFAM1Sh mode reproduces the
    first paper's NREL 5-MW numbers (sec. 4.4): M_e = 5.4e4, K_e = 1.91e6,
    K_g = -5.2e4 - 1.0e4, nu_y = 0.0185; tower mass 347,460 kg (Jonkman et al. 2009)."""
    ms = ModeSet.from_dict({"fields": {"tower_fa": {"family": "elastodyn", "count": 1},
                                       "tower_ss": {"family": "clamped", "count": 2}}})
    path = tmp_path / "out.json"
    _, data = export_modeset(ms, DECK, json_path=path)
    assert json.loads(path.read_text()) == data
    assert data["modeset"] == ms.to_dict()
    fa = data["fields"]["tower_fa"]
    integ = fa["integrals"]
    assert integ["mass"][0][0] == pytest.approx(5.4e4, rel=0.01)
    assert integ["stiffness"][0][0] == pytest.approx(1.91e6, rel=0.005)
    assert integ["geometric_stiffness"]["gravity_top_mass"][0][0] == pytest.approx(-5.2e4, rel=0.02)
    assert integ["geometric_stiffness"]["gravity_self_weight"][0][0] == pytest.approx(-1.0e4, rel=0.05)
    assert integ["tip_slope"][0] == pytest.approx(0.0185, rel=0.005)
    assert integ["total_mass"] == pytest.approx(347460, rel=1e-5)
    ss = data["fields"]["tower_ss"]
    x = np.array(ss["x"])
    for mode in ss["modes"]:
        phi, dphi = np.array(mode["phi"]), np.array(mode["dphi"])
        assert abs(phi[0]) < 1e-12 and phi[-1] == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(np.gradient(phi, x, edge_order=2), dphi, atol=2e-3 * np.max(np.abs(dphi)))
    np.testing.assert_allclose(np.array(ss["integrals"]["tip_slope"]),
                               [m["dphi"][-1] / ss["length"] for m in ss["modes"]], rtol=1e-9)
    assert len(ss["integrals"]["frequencies_hz"]) == 2 and ss["integrals"]["orthonormalised"] is False


# --------------------------------------------------------------------------- CLI
def write_modeset(path, fields):
    path.write_text(json.dumps({"fields": fields}))
    return str(path)


def test_cli_smoke(tmp_path, capsys):
    ms = write_modeset(tmp_path / "ms.json", {"tower_fa": {"family": "clamped", "count": 2}})
    out, js = tmp_path / "ed", tmp_path / "ms_out.json"
    assert main(["export", ms, "--turbine", str(DECK), "--elastodyn", str(out), "--json", str(js),
                 "--weighting", "mass"]) == 0
    text = capsys.readouterr().out
    assert "TwFAM1Sh" in text and "mass weighting" in text and js.exists()
    assert (out / f"{DECK.stem}_ElastoDyn.dat").exists()


@pytest.mark.parametrize("case", ["missing_modeset", "unknown_family", "unwritable_outdir", "missing_deck",
                                  "no_target", "bad_weighting"])
def test_cli_bad_input_is_one_line_exit_2(tmp_path, capsys, case):
    good = write_modeset(tmp_path / "ms.json", {"tower_fa": {"family": "clamped", "count": 1}})
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    args = {
        "missing_modeset": [str(tmp_path / "nope.json"), "--turbine", str(DECK), "--elastodyn", str(tmp_path)],
        "unknown_family": [write_modeset(tmp_path / "bad.json", {"tower_fa": {"family": "clampd", "count": 1}}),
                           "--turbine", str(DECK), "--elastodyn", str(tmp_path / "o")],
        "unwritable_outdir": [good, "--turbine", str(DECK), "--elastodyn", str(blocker / "sub")],
        "missing_deck": [good, "--turbine", str(tmp_path / "no_deck.dat"), "--elastodyn", str(tmp_path / "o")],
        "no_target": [good, "--turbine", str(DECK)],
        "bad_weighting": [good, "--turbine", str(DECK), "--elastodyn", str(tmp_path / "o"), "--weighting", "x"],
    }[case]
    assert main(["export"] + args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("modesel: error:") and "\n" not in err
    expected = {"missing_modeset": "not found", "unknown_family": "did you mean 'clamped'",
                "unwritable_outdir": "output folder", "missing_deck": "not found",
                "no_target": "nothing to export", "bad_weighting": "weighting"}[case]
    assert expected in err
    assert not (tmp_path / "o").exists()


# --------------------------------------------------------------------------- OpenFAST case
CASE = Path(__file__).parent / "data" / "openfast_turbine" / "parked_release" / "parked_release.fst"
STEADY = Path(__file__).parent.parent / "studies" / "data" / "openfast" / "steady_11p4" / "steady_11p4.fst"


def test_openfast_case_is_complete_and_names_the_new_elastodyn(tmp_path, capsys):
    """Every file the steady 11.4 m/s case names (AeroDyn, its blade and airfoil
    files, InflowWind, ServoDyn) is copied with its relative layout; the .fst
    names the new ElastoDyn file, whose tower file carries the fits."""
    from modesel.export.openfast_case import case_files, referenced_files
    ms = write_modeset(tmp_path / "ms.json", {"tower_fa": {"family": "clamped", "count": 2},
                                              "blade_edge": {"family": "fem", "count": 1}})
    out = tmp_path / "case"
    assert main(["export", ms, "--case", str(STEADY), "--openfast", str(out), "--tmax", "12.5"]) == 0
    assert "OpenFAST case written" in capsys.readouterr().out
    fst = out / "steady_11p4" / "steady_11p4.fst"
    sources = case_files(STEADY)
    assert len(sources) > 10     # fst, AeroDyn, its blade, airfoils, InflowWind, ServoDyn
    written = case_files(fst)
    assert {p.name for p in written} >= {p.name for p in sources}
    assert all(p.is_relative_to(out.resolve()) for p in written)    # nothing points back to the source
    names = {line.split()[1]: line.split()[0].strip('"') for line in fst.read_text().splitlines()
             if len(line.split()) > 1}
    assert names["TMax"] == "12.5" and names["EDFile"] == "steady_11p4_ElastoDyn_ElastoDyn.dat"
    reader = InputReader_OpenFAST()
    reader.read_ElastoDyn(str(fst.parent / names["EDFile"]))
    reader.read_ElastoDynTower(str(fst.parent / reader.fst_vt["ElastoDyn"]["TwrFile"]))
    ed = reader.fst_vt["ElastoDyn"]
    assert ed["TwFADOF1"] and ed["TwFADOF2"] and ed["EdgeDOF"]
    assert referenced_files(fst.parent / names["EDFile"])      # tower and blade files exist beside it
    from modesel.candidates import mode_shapes
    clamped = fit_mode_polynomial(X, mode_shapes("tower_fa", "clamped", 2, x=X).phi[0])
    np.testing.assert_allclose(reader.fst_vt["ElastoDynTower"]["TwFAM1Sh"], clamped.coefficients, rtol=1e-6)


def test_openfast_case_with_what_modesel_does_not_simulate(tmp_path, capsys):
    """Only the case's ElastoDyn part is read: a case with turbulent wind from a
    Bladed-style file (InflowWind WindType 4, which `modesel simulate` refuses)
    is exported for OpenFAST unchanged, its InflowWind file copied as it is."""
    import shutil
    src = tmp_path / "src"
    shutil.copytree(STEADY.parent.parent, src)
    iw = src / "steady_11p4" / "steady_11p4_InflowWind.dat"
    text = iw.read_text()
    line = next(ln for ln in text.splitlines() if "WindType" in ln.split()[1:2])
    iw.write_text(text.replace(line, "          4   WindType       - Bladed-style full-field wind (edited)"))
    fst = src / "steady_11p4" / "steady_11p4.fst"
    from modesel.simulation.api import load_scene
    with pytest.raises(ModeselError, match="WindType"):
        load_scene(fst)
    ms = write_modeset(tmp_path / "ms.json", {"tower_fa": {"family": "clamped", "count": 1}})
    assert main(["export", ms, "--case", str(fst), "--openfast", str(tmp_path / "o")]) == 0
    assert "OpenFAST case written" in capsys.readouterr().out
    copied = next((tmp_path / "o").rglob("steady_11p4_InflowWind.dat"))
    assert "4   WindType" in copied.read_text()


@pytest.mark.parametrize("fields, reason", [
    ({"tower_fa": {"family": "clamped", "count": 3}}, "tower_fa=clamped:3 (ElastoDyn has at most 2 tower_fa modes)"),
    ({"blade_edge": {"family": "fem", "count": 2}}, "blade_edge=fem:2 (ElastoDyn has at most 1 blade_edge mode)"),
    ({"tower_torsion": {"family": "linear", "count": 1}}, "tower_torsion=linear:1 (ElastoDyn has no tower torsion DOF)"),
])
def test_openfast_case_refuses_a_set_elastodyn_cannot_hold(tmp_path, capsys, fields, reason):
    ms = write_modeset(tmp_path / "ms.json", fields)
    assert main(["export", ms, "--case", str(CASE), "--openfast", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "ElastoDyn cannot hold this set: " + reason in err
    assert not (tmp_path / "o").exists()


def test_export_takes_the_turbine_from_the_study(tmp_path, capsys):
    """best_modeset.json names the study's scenes: no --turbine needed."""
    best = tmp_path / "best_modeset.json"
    best.write_text(json.dumps({"fields": {"tower_fa": {"family": "clamped", "count": 1}},
                                "study": "s", "scenes": [str(CASE)]}))
    assert main(["export", str(best), "--elastodyn", str(tmp_path / "ed")]) == 0
    assert (tmp_path / "ed" / "parked_release_ElastoDyn_ElastoDyn.dat").exists()
    no_scene = write_modeset(tmp_path / "ms.json", {"tower_fa": {"family": "clamped", "count": 1}})
    assert main(["export", no_scene, "--elastodyn", str(tmp_path / "ed2")]) == 2
    assert "no turbine: give --turbine DECK" in capsys.readouterr().err


# --------------------------------------------------------------------------- ElastoDyn frequencies
def test_elastodyn_frequency_of_a_uniform_cantilever_is_the_analytic_one():
    """Midpoint rule on many nodes -> (1.8751^2 / 2 pi) sqrt(EI / (m L^4)) for the exact first mode."""
    from types import SimpleNamespace

    from modesel.export.elastodyn_writer import elastodyn_frequency
    L, m, EI, b = 30.0, 120.0, 4.0e8, 1.8751040687
    beam = SimpleNamespace(length=L, span=np.array([0.0, L]), mass=np.full(2, m), ei_1=np.full(2, EI),
                           ei_2=np.full(2, 2 * EI))
    sigma = (np.cosh(b) + np.cos(b)) / (np.sinh(b) + np.sin(b))

    def clamped(x, derivative):
        if derivative == 0:
            return np.cosh(b * x) - np.cos(b * x) - sigma * (np.sinh(b * x) - np.sin(b * x))
        return b ** 2 * (np.cosh(b * x) + np.cos(b * x) - sigma * (np.sinh(b * x) + np.sin(b * x)))
    exact = b ** 2 / (2 * np.pi) * np.sqrt(EI / (m * L ** 4))
    assert elastodyn_frequency(beam, "blade_flap", 4000, clamped) == pytest.approx(exact, rel=1e-6)
    assert elastodyn_frequency(beam, "blade_edge", 4000, clamped) == pytest.approx(exact * np.sqrt(2), rel=1e-6)


def test_fem_flap_export_reports_the_frequency_no_polynomial_reaches(tmp_path):
    """fem flap 1 of the NREL 5-MW blade: the written polynomial's ElastoDyn frequency (from the
    coefficients read back by openfast-io) is the reported one, above the shape's; no polynomial in
    x^2..x^6 reaches the shape's frequency (lowest Ritz value of that space on the 17 nodes), so the
    warning is the fit's limit, not its method. The exported set names what OpenFAST runs."""
    from scipy.linalg import eigh

    from modesel.export.elastodyn_writer import elastodyn_frequency
    from modesel.model.flexible_beam import elastodyn_nodes
    from modesel.turbine.elastodyn import load_turbine
    ms = ModeSet.from_dict({"fields": {"blade_flap": {"family": "fem", "count": 2},
                                       "tower_fa": {"family": "clamped", "count": 1}}})
    report, _ = export_modeset(ms, DECK, elastodyn_dir=tmp_path)
    flap1 = next(m for m in report.modes if (m.field, m.mode) == ("blade_flap", 1))
    blade = load_turbine(DECK).blade
    written = np.array(read_back(tmp_path, DECK.stem)["blade"]["BldFl1Sh"], float)
    assert elastodyn_frequency(blade, "blade_flap", 17, lambda x, d: evaluate_polynomial(written, x, d)) == \
        pytest.approx(flap1.frequency_fit_hz, rel=1e-6)
    s, w = elastodyn_nodes(blade.length, 17)
    x = s / blade.length
    p = np.arange(2, 7)
    d0 = np.stack([x ** k for k in p])
    d2 = np.stack([k * (k - 1) * x ** (k - 2) for k in p]) / blade.length ** 2
    K = (d2 * np.interp(s, blade.span, blade.ei_1) * w) @ d2.T
    M = (d0 * np.interp(s, blade.span, blade.mass) * w) @ d0.T
    lowest = np.sqrt(eigh(K, M, eigvals_only=True)[0]) / (2 * np.pi)
    # measured: shape 0.6727 Hz, lowest polynomial +0.36 %, the L2 fit +0.59 %
    assert flap1.frequency_shape_hz * 1.003 < lowest <= flap1.frequency_fit_hz
    assert any(w.startswith("blade_flap mode 1 (fem)") and "+0.5" in w for w in report.warnings)
    tower = next(m for m in report.modes if m.field == "tower_fa")
    assert abs(tower.frequency_change) < 1e-4 and not any(w.startswith("tower_fa") for w in report.warnings)
    # the strain-energy fit keeps the frequencies better (measured flap 1 +0.40 %, flap 2 +1.33 %,
    # against +0.59 % and +6.69 % with the L2 fit)
    stiff, _ = export_modeset(ms, DECK, elastodyn_dir=tmp_path / "stiffness", weighting="stiffness")
    for a, b in zip(report.modes, stiff.modes):
        if a.field == "blade_flap":
            assert 0 < b.frequency_change < a.frequency_change
    exported = json.loads(Path(report.modeset_file).read_text())
    assert exported["fields"] == {"tower_fa": {"family": "elastodyn", "count": 1},
                                  "blade_flap": {"family": "elastodyn", "count": 2}}
    assert ModeSet.from_json(report.modeset_file)["blade_flap"].count == 2
