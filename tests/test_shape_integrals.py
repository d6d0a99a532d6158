"""Shape integrals against the first paper (sections 4.3-4.4), analytic
solutions of uniform beams, adaptive quadrature, and the `modesel shapes` CLI."""
import dataclasses
import functools
import json

import numpy as np
import pytest
from scipy.integrate import quad

from modesel.candidates import families, mode_shapes
from modesel.candidates.base import ShapeSet
from modesel.candidates.context import field_context
from modesel.cli import main
from modesel.turbine.beam import BeamProperties
from modesel.turbine.elastodyn import load_turbine
from modesel.multibody.shape_integrals import evaluate_shapes, shape_integrals, skew

G = 9.80665


@pytest.fixture(scope="module")
def nrel():
    return load_turbine("nrel5mw")


def deck_polynomial(field, coefficients, x):
    """ElastoDyn mode shape (first paper eq. 46), written out here independently."""
    a = np.asarray(coefficients, dtype=float)
    p = np.arange(2, 7)
    x = np.asarray(x, dtype=float)[None, :]
    phi = (a[:, :, None] * x[:, None, :] ** p[None, :, None]).sum(1)
    dphi = (a[:, :, None] * p[None, :, None] * x[:, None, :] ** (p[None, :, None] - 1)).sum(1)
    ddphi = (a[:, :, None] * (p * (p - 1))[None, :, None] * x[:, None, :] ** (p[None, :, None] - 2)).sum(1)
    tip = a.sum(axis=1)[:, None]
    return ShapeSet(field, "deck", x[0], phi / tip, dphi / tip, ddphi / tip)


def uniform_beam(name="tower", length=80.0, mass=500.0, ei=2.0e10, root_offset=0.0, stations=9):
    span = np.linspace(0.0, length, stations)
    one = np.ones_like(span)
    return BeamProperties(name, span, mass * one, ei * one, ei * one, ei / 1.3 * one, 10.0 * one,
                          0 * one, root_offset=root_offset)


# --- first paper, section 4.4: NREL 5-MW tower, ElastoDyn fore-aft mode 1 -------------

@pytest.fixture(scope="module")
def tower_fa1(nrel):
    shapes = deck_polynomial("tower_fa", nrel.elastodyn_shapes["tower_fa"][:1], np.linspace(0, 1, 401))
    return shape_integrals(nrel.tower, shapes, top_mass=3.5e5, gravity=G)   # M_N + M_R of the paper


def test_tower_paper_section_4_4(tower_fa1):
    si = tower_fa1
    assert si.mass[0, 0] == pytest.approx(5.40e4, rel=0.01)          # measured 5.398e4
    assert si.stiffness[0, 0] == pytest.approx(1.91e6, rel=0.01)     # measured 1.913e6
    assert si.tip_slope[0] == pytest.approx(0.0185, rel=0.01)        # nu_y, measured 0.018521
    assert si.tip_deflection[0] == pytest.approx(1.0)
    k_gt = si.geometric_stiffness["gravity_top_mass"][0, 0]
    k_gw = si.geometric_stiffness["gravity_self_weight"][0, 0]
    assert k_gt == pytest.approx(-5.2e4, rel=0.01)                   # eq. 33, measured -5.153e4
    assert k_gw == pytest.approx(-1.0e4, abs=0.05e4)                 # eq. 34, 2 digits published; -1.044e4
    assert k_gt + k_gw == pytest.approx(-6.20e4, rel=0.01)           # K_g, 3 digits published
    omega = np.sqrt((si.stiffness[0, 0] + k_gt + k_gw) / si.mass[0, 0])
    assert omega == pytest.approx(5.85, rel=0.01)                    # eq. 35, measured 5.855 rad/s
    assert 2 * np.pi * si.frequencies_hz[0] == pytest.approx(omega, rel=1e-12)
    assert si.geometric_stiffness["gravity_self_weight"] == pytest.approx(
        G * si.geometric_stiffness["gravity_axial_per_g"])


def test_tower_family_elastodyn_matches_hand_polynomial(nrel, tower_fa1):
    """The registered `elastodyn` family, evaluated exactly at the quadrature
    points, agrees with the hand-written polynomial sampled on 401 points
    (quintic Hermite resampling)."""
    ctx = field_context(nrel, "tower_fa")
    exact = shape_integrals(nrel.tower, functools.partial(mode_shapes, "tower_fa", "elastodyn", 1, ctx),
                            top_mass=3.5e5, gravity=G)
    for a, b in ((exact.mass, tower_fa1.mass), (exact.stiffness, tower_fa1.stiffness),
                 (exact.geometric_stiffness["gravity_self_weight"],
                  tower_fa1.geometric_stiffness["gravity_self_weight"])):
        assert a == pytest.approx(b, rel=1e-9)


def test_tower_self_weight_against_adaptive_quadrature(nrel, tower_fa1):
    """eq. 34 with N(z) = int_z^L m, by scipy.integrate.quad as a second formulation."""
    span, m = nrel.tower.span, nrel.tower.mass
    L = span[-1]
    a = np.array(nrel.elastodyn_shapes["tower_fa"][0])
    p = np.arange(2, 7)

    def slope(z):
        return (a * p * (z / L) ** (p - 1)).sum() / a.sum() / L

    def axial(z):
        return quad(lambda t: np.interp(t, span, m), z, L, points=span[span > z], limit=200)[0]

    k_gw = -G * quad(lambda z: axial(z) * slope(z) ** 2, 0, L, points=span[1:-1], limit=200)[0]
    assert tower_fa1.geometric_stiffness["gravity_self_weight"][0, 0] == pytest.approx(k_gw, rel=1e-7)


# --- first paper, section 4.3: NREL 5-MW blade, ElastoDyn flap 1, edge 1, flap 2 ------

def blade_modes(nrel, root_offset=None):
    beam = nrel.blade if root_offset is None else dataclasses.replace(nrel.blade, root_offset=root_offset)
    out = []
    for field, k in (("blade_flap", 0), ("blade_edge", 0), ("blade_flap", 1)):
        shapes = deck_polynomial(field, [nrel.elastodyn_shapes[field][k]], np.linspace(0, 1, 401))
        out.append(shape_integrals(beam, shapes, precone=0.0, rotor_speed=1.0))   # paper: cone 0
    return out


def within_published_digits(value, published, digits):
    """|value - published| <= half a unit of the last published digit."""
    unit = 10.0 ** (np.floor(np.log10(abs(published))) - (digits - 1))
    return abs(value - published) <= 0.5 * unit


def test_blade_paper_section_4_3(nrel):
    flap1, edge1, flap2 = blade_modes(nrel)
    m_e = [s.mass[0, 0] for s in (flap1, edge1, flap2)]          # measured [910.8, 1416.1, 548.8]
    k_e = [s.stiffness[0, 0] for s in (flap1, edge1, flap2)]     # measured [1.675e4, 6.713e4, 8.541e4]
    # diag K_e = [1.7e4, 6.7e4, 8.7e4] (eq. 27): flap 1 and edge 1 agree to the published digits;
    # flap 2 is 1.8 % below the published 8.7e4
    assert within_published_digits(k_e[0], 1.7e4, 2) and within_published_digits(k_e[1], 6.7e4, 2)
    assert k_e[2] == pytest.approx(8.7e4, rel=0.02)
    # the published diag M_e = [9.5e3, 1.5e4, 5.7e3] are 10 * AdjBlMs = 10.45 times ours for all
    # three modes (to the published digits); ours are the consistent ones: they give the known
    # NREL 5-MW blade frequencies (flap 0.68 Hz, edge 1.10 Hz, flap-2 1.99 Hz), the published ones
    # would give 0.21 Hz for flap 1
    adj = 1.04536                         # AdjBlMs of NRELOffshrBsline5MW_Blade.dat
    for value, published in zip(m_e, (9.5e3, 1.5e4, 5.7e3)):
        assert within_published_digits(10 * adj * value, published, 2)
    f0 = [np.sqrt(k / m) / (2 * np.pi) for k, m in zip(k_e, m_e)]
    assert f0 == pytest.approx([0.68, 1.10, 1.99], abs=0.01)


def test_blade_southwell_coefficients(nrel):
    """k_Omega = K_g(Omega) / M_e / Omega^2 (eq. 30-31). The paper's [1.7, 1.4, 5.5]
    are reproduced (to the published digits) with r measured from the blade root
    (its L_B = R; measured [1.725, 1.394, 5.510]); with r from the rotation axis
    (hub radius 1.5 m, what modesel uses) they are [1.779, 1.442, 5.680]."""
    def southwell(modes):
        return [s.geometric_stiffness["centrifugal_per_omega2"][0, 0] / s.mass[0, 0] for s in modes]

    from_root = southwell(blade_modes(nrel, root_offset=0.0))
    for value, published in zip(from_root, (1.7, 1.4, 5.5)):
        assert within_published_digits(value, published, 2)
    axis_modes = blade_modes(nrel)
    from_axis = southwell(axis_modes)
    # N_axis(s) = N_root(s) + h int_s^L m: the difference is h times the unit axial load of eq. C3
    for k_axis, k_root, s in zip(from_axis, from_root, axis_modes):
        c3 = -s.geometric_stiffness["gravity_axial_per_g"][0, 0] / s.mass[0, 0]
        assert k_axis - k_root == pytest.approx(1.5 * c3, rel=1e-9)


def test_edge_frequency_rise_eq_32(nrel):
    """Edge mode: K_omega = -Omega^2 M_e (spin softening from O_e, eq. A10/A12), so
    omega(Omega)^2 = omega_0^2 + (k_Omega - 1) Omega^2 (eq. 32); flap: eq. 31."""
    omega = 12.1 * np.pi / 30
    for field in ("blade_edge", "blade_flap"):
        shapes = functools.partial(mode_shapes, field, "elastodyn", 1, field_context(nrel, field))
        parked = shape_integrals(nrel.blade, shapes, precone=0.0)
        spinning = shape_integrals(nrel.blade, shapes, precone=0.0, rotor_speed=omega)
        k = spinning.geometric_stiffness["centrifugal_per_omega2"][0, 0] / spinning.mass[0, 0]
        softening = 1.0 if field == "blade_edge" else 0.0
        expected = np.sqrt((2 * np.pi * parked.frequencies_hz[0]) ** 2 + (k - softening) * omega ** 2)
        assert 2 * np.pi * spinning.frequencies_hz[0] == pytest.approx(expected, rel=1e-12)
        assert spinning.spin_softening_per_omega2[0, 0] == pytest.approx(-softening * spinning.mass[0, 0])


def test_centrifugal_against_adaptive_quadrature_with_cone(nrel):
    """eq. 29-30 / C5 with r = hub radius + s and the cos^2(precone) factor."""
    blade, cone = nrel.blade, nrel.precone[0]
    span, m, h = blade.span, blade.mass, blade.root_offset
    L = span[-1]
    a = np.array(nrel.elastodyn_shapes["blade_flap"][0])
    p = np.arange(2, 7)

    def slope(s):
        return (a * p * (s / L) ** (p - 1)).sum() / a.sum() / L

    def axial(s):
        return quad(lambda t: np.interp(t, span, m) * (h + t), s, L, points=span[span > s], limit=200)[0]

    expected = np.cos(cone) ** 2 * quad(lambda s: axial(s) * slope(s) ** 2, 0, L, points=span[1:-1],
                                        limit=400)[0]
    shapes = deck_polynomial("blade_flap", [a], np.linspace(0, 1, 401))
    si = shape_integrals(blade, shapes, precone=cone)
    assert si.geometric_stiffness["centrifugal_per_omega2"][0, 0] == pytest.approx(expected, rel=1e-7)


# --- analytic: uniform beams -----------------------------------------------------

BETA_L = np.array([1.875104068711961, 4.694091132974175, 7.854757438237613, 10.99554073487547])


def test_clamped_uniform_beam_stiffness_and_mass():
    """K_e = (beta_k L)^4 EI / (m L^4) M_e, M_e = m L / 4 per tip-normalised mode,
    and the modes are M- and K-orthogonal."""
    beam = uniform_beam()
    m, ei, L = 500.0, 2.0e10, 80.0
    si = shape_integrals(beam, functools.partial(mode_shapes, "tower_fa", "clamped", 4,
                                                 field_context_stub("tower_fa")),
                         points_per_interval=16)
    assert np.diag(si.mass) == pytest.approx(np.full(4, m * L / 4), rel=1e-9)
    expected = BETA_L ** 4 * ei / (m * L ** 4) * si.mass
    assert si.stiffness == pytest.approx(expected, rel=1e-8, abs=1e-7 * si.stiffness[0, 0])
    omega = BETA_L ** 2 * np.sqrt(ei / (m * L ** 4))
    assert 2 * np.pi * shape_integrals(beam, functools.partial(
        mode_shapes, "tower_fa", "clamped", 4, field_context_stub("tower_fa")),
        gravity=0.0, points_per_interval=16).frequencies_hz == pytest.approx(omega, rel=1e-8)


def field_context_stub(field):
    from modesel.candidates.base import FieldContext
    return FieldContext(field)


def test_top_mass_buckling_load_eq_33():
    """1 - cos(pi z / 2L) is the exact buckling mode of a column with a top load:
    K_e + K_gt = 0 at g M_top = pi^2 EI / (4 L^2) (Euler)."""
    beam = uniform_beam()
    euler = np.pi ** 2 * 2.0e10 / (4 * 80.0 ** 2)
    si = shape_integrals(beam, functools.partial(mode_shapes, "tower_fa", "cosine", 1,
                                                 field_context_stub("tower_fa")),
                         top_mass=euler / G, gravity=G)
    assert si.geometric_stiffness["gravity_top_mass"][0, 0] == pytest.approx(-si.stiffness[0, 0], rel=1e-10)


def test_uniform_rotating_beam_centrifugal_closed_form():
    """Uniform blade, hub radius h: N(s) = m ((h+L)^2 - (h+s)^2) / 2 (eq. 29)."""
    h, L, m = 3.0, 40.0, 200.0
    beam = uniform_beam("blade", length=L, mass=m, root_offset=h)
    ctx = field_context_stub("blade_flap")
    si = shape_integrals(beam, functools.partial(mode_shapes, "blade_flap", "clamped", 2, ctx), precone=0.0)
    x = np.linspace(0, 1, 4001)
    shapes = mode_shapes("blade_flap", "clamped", 2, ctx, x=x)
    s = x * L
    n = m * ((h + L) ** 2 - (h + s) ** 2) / 2
    slopes = shapes.dphi / L
    expected = np.trapezoid(n * slopes[:, None, :] * slopes[None, :, :], s, axis=-1)
    assert si.geometric_stiffness["centrifugal_per_omega2"] == pytest.approx(expected, rel=1e-5)


# --- every family: symmetric positive definite mass --------------------------------

@pytest.mark.parametrize("field", ["tower_fa", "tower_ss", "blade_flap", "blade_edge", "tower_torsion"])
def test_mass_matrix_spd_for_every_family(nrel, field):
    ctx = field_context(nrel, field, rotor_speed=1.2)
    beam = nrel.tower if field.startswith("tower") else nrel.blade
    checked = []
    for fam in families(field):
        count = min(4, fam.max_count or 4)
        if fam.name == "elastodyn":
            count = len(nrel.elastodyn_shapes[field])
        si = shape_integrals(beam, functools.partial(fam.shapes, count=count, context=ctx),
                             top_mass=ctx.tip_mass)
        assert np.array_equal(si.mass, si.mass.T), fam.name
        assert np.linalg.eigvalsh(si.mass).min() > 0, fam.name
        assert np.all(np.linalg.eigvalsh(si.stiffness) > 0), fam.name
        checked.append(fam.name)
    assert len(checked) >= 2


# --- conditioning -------------------------------------------------------------------

def test_polynomial_many_modes_is_orthonormalised(nrel):
    ctx = field_context(nrel, "blade_flap")
    shapes = functools.partial(mode_shapes, "blade_flap", "polynomial", 12, ctx)
    si = shape_integrals(nrel.blade, shapes)
    assert si.orthonormalised and si.condition_number > 1e8
    assert any("orthonormalised" in n for n in si.notes)
    assert si.mass == pytest.approx(np.eye(12), abs=1e-6)
    few = shape_integrals(nrel.blade, functools.partial(mode_shapes, "blade_flap", "polynomial", 3, ctx))
    assert not few.orthonormalised and few.condition_number < 1e8


def test_orthonormalisation_is_a_change_of_basis(nrel):
    ctx = field_context(nrel, "tower_fa")
    shapes = functools.partial(mode_shapes, "tower_fa", "polynomial", 4, ctx)
    raw = shape_integrals(nrel.tower, shapes, top_mass=ctx.tip_mass, orthonormalise=False)
    new = shape_integrals(nrel.tower, shapes, top_mass=ctx.tip_mass, orthonormalise=True)
    t = new.transform
    assert new.mass == pytest.approx(np.eye(4), abs=1e-10)
    assert new.stiffness == pytest.approx(t.T @ raw.stiffness @ t, rel=1e-8)
    assert new.frequencies_hz == pytest.approx(raw.frequencies_hz, rel=1e-8)
    assert new.tip_deflection == pytest.approx(t.T @ raw.tip_deflection)
    assert new.C_t == pytest.approx(t.T @ raw.C_t, rel=1e-8, abs=1e-6)


# --- damping, tuners, SID terms -------------------------------------------------------

def test_damping_is_modal(nrel):
    ctx = field_context(nrel, "tower_fa")
    si = shape_integrals(nrel.tower, functools.partial(mode_shapes, "tower_fa", "elastodyn", 2, ctx),
                         damping_ratios=[0.01, 0.02])
    import scipy.linalg
    lam, v = scipy.linalg.eigh(si.stiffness, si.mass)
    assert v.T @ si.damping @ v == pytest.approx(np.diag(2 * np.array([0.01, 0.02]) * np.sqrt(lam)),
                                                 rel=1e-8, abs=1e-8)
    one = shape_integrals(nrel.tower, functools.partial(mode_shapes, "tower_fa", "elastodyn", 1, ctx))
    assert one.damping[0, 0] == pytest.approx(2 * 0.01 * np.sqrt(one.stiffness[0, 0] * one.mass[0, 0]))


def test_stiffness_tuners_elastodyn_rule(nrel):
    ctx = field_context(nrel, "tower_fa")
    shapes = functools.partial(mode_shapes, "tower_fa", "elastodyn", 2, ctx)
    plain = shape_integrals(nrel.tower, shapes)
    tuned = shape_integrals(nrel.tower, shapes, stiffness_tuners=[1.1, 0.9])
    assert tuned.stiffness == pytest.approx(np.sqrt(np.outer([1.1, 0.9], [1.1, 0.9])) * plain.stiffness)


def test_sid_terms(nrel):
    ctx = field_context(nrel, "tower_ss")
    si = shape_integrals(nrel.tower, functools.partial(mode_shapes, "tower_ss", "elastodyn", 2, ctx))
    assert si.total_mass == pytest.approx(nrel.tower.total_mass, rel=1e-12)   # linear m: exact
    assert si.O_e_j == pytest.approx(-0.5 * np.transpose(si.G_r, (0, 2, 1)), abs=1e-6)   # eq. A12
    assert np.all(si.C_t[:, [0, 2]] == 0)
    assert si.C_t[0, 1] < 0                      # side-side shapes point along -y (ElastoDyn)
    for j in range(2):                           # eq. D4
        assert si.M_xtheta_1[j] == pytest.approx(-skew(si.C_t[j]))
    assert np.abs(si.G_e).max() == 0.0           # single-direction shapes: Phi^T skew(Phi) = 0
    z, m = nrel.tower.span, nrel.tower.mass
    assert si.J[0, 0] == pytest.approx(quad(lambda t: np.interp(t, z, m) * t * t, 0, z[-1],
                                            points=z[1:-1])[0], rel=1e-9)


def test_sampled_shapes_resampling_is_accurate(nrel):
    ctx = field_context(nrel, "blade_edge")
    exact = shape_integrals(nrel.blade, functools.partial(mode_shapes, "blade_edge", "cosine", 3, ctx))
    sampled = mode_shapes("blade_edge", "cosine", 3, ctx, x=np.linspace(0, 1, 401))
    approx = shape_integrals(nrel.blade, sampled)
    assert approx.stiffness == pytest.approx(exact.stiffness, rel=1e-7)
    assert approx.mass == pytest.approx(exact.mass, rel=1e-9)
    assert evaluate_shapes(sampled, np.array([1.0])).phi[:, 0] == pytest.approx(1.0)


# --- CLI --------------------------------------------------------------------------

def nrel_folder():
    from pathlib import Path
    return Path(__file__).resolve().parent.parent / "modesel" / "turbine" / "data" / "nrel5mw"


def run_cli(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_shapes_json(capsys):
    code, out, err = run_cli(capsys, "shapes", "nrel5mw", "--field", "tower_fa", "--family", "elastodyn",
                             "--count", "1", "--json")
    assert code == 0, err
    data = json.loads(out)
    for key in ("field", "family", "count", "mass", "stiffness", "geometric_stiffness", "tip_deflection",
                "tip_slope", "frequencies_hz", "condition_number"):
        assert key in data
    assert set(data["geometric_stiffness"]) >= {"gravity_top_mass", "gravity_self_weight",
                                                "centrifugal_per_omega2"}
    assert data["field"] == "tower_fa" and data["family"] == "elastodyn" and data["count"] == 1
    assert data["mass"][0][0] == pytest.approx(5.40e4, rel=0.01)
    assert data["stiffness"][0][0] == pytest.approx(1.91e6, rel=0.01)
    assert data["tip_slope"][0] == pytest.approx(0.0185, rel=0.01)
    assert data["condition_number"] == pytest.approx(1.0)
    # deck RNA mass (3.496e5 kg) as top mass
    assert data["geometric_stiffness"]["gravity_top_mass"][0][0] == pytest.approx(-5.15e4, rel=0.01)


def test_cli_shapes_table(capsys):
    code, out, _ = run_cli(capsys, "shapes", "nrel5mw", "--field", "blade_edge", "--family", "clamped",
                           "--count", "2", "--rpm", "12.1")
    assert code == 0 and "condition number" in out and "rotor speed 12.1 rpm" in out


@pytest.mark.parametrize("argv, message", [
    (["--field", "tower_xx", "--family", "elastodyn", "--count", "1"], "unknown field"),
    (["--field", "tower_fa", "--family", "elastodin", "--count", "1"], "unknown family"),
    (["--field", "tower_fa", "--family", "elastodyn", "--count", "0"], "count"),
    (["--field", "tower_fa", "--family", "elastodyn", "--count", "two"], "count"),
])
def test_cli_bad_input(capsys, argv, message):
    code, out, err = run_cli(capsys, "shapes", "nrel5mw", *argv)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1 and out == ""


def test_cli_deck_errors(capsys, tmp_path):
    code, _, err = run_cli(capsys, "shapes", str(tmp_path / "nope.dat"), "--field", "tower_fa",
                           "--family", "elastodyn", "--count", "1")
    assert code == 2 and "nope.dat" in err and len(err.strip().splitlines()) == 1
    deck = nrel_folder()
    for name in ("NREL5MW_ED_Onshore.dat", "NRELOffshrBsline5MW_Onshore_ElastoDyn_Tower.dat",
                 "NRELOffshrBsline5MW_Blade.dat"):
        (tmp_path / name).write_text((deck / name).read_text())
    main_file = tmp_path / "NREL5MW_ED_Onshore.dat"
    tower = tmp_path / "NRELOffshrBsline5MW_Onshore_ElastoDyn_Tower.dat"
    lines = tower.read_text().splitlines()
    start = next(i for i, l in enumerate(lines) if l.split()[:1] == ["HtFract"])
    tower.write_text("\n".join(lines[:start]) + "\n")
    code, _, err = run_cli(capsys, "shapes", str(main_file), "--field", "tower_fa", "--family", "elastodyn",
                           "--count", "1")
    assert code == 2 and tower.name in err and "HtFract" in err and len(err.strip().splitlines()) == 1
