"""The `fem` family and `field_context` against analytic solutions, a second
formulation, published numbers and pyBmodes.

* uniform cantilever: omega_k = beta_k^2 sqrt(EI/(m L^4));
* uniform cantilever with tip mass/inertia: the roots of the tip-body
  characteristic equation (checked independently in test_candidates);
* Euler buckling (P_cr = pi^2 EI/(4 L^2)) and Greenhill's self-weight
  buckling ((q L^3/EI)_cr = 7.837) for the geometric stiffness;
* rotating uniform blade: a Rayleigh-Ritz solution on 12 clamped
  eigenfunctions with the same centrifugal loads (eq. 29-32 of the first
  paper), a different discretisation;
* torsion: uniform shaft with tip inertia (g tan g = 1/rho);
* NREL 5-MW: blade K_e and Southwell coefficients published in the first
  paper (section 4.3), RNA mass (Jonkman et al. 2009: 350 t), and pyBmodes
  (tower with its RNA, blade at 12.1 rpm).
"""
from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest
from scipy.linalg import eigh

from modesel.candidates import FieldContext, get_family, mode_shapes
from modesel.candidates import beam_fem
from modesel.candidates.cantilever import characteristic_roots, clamped_free_roots
from modesel.candidates.fem import axial_force
from modesel.candidates.sine import tip_inertia_shaft_roots
from modesel.errors import ModeselError
from modesel.turbine.beam import BeamProperties

FEM = get_family("fem")
DEFAULTS = {p.name: p.default for p in FEM.parameters}
L, M, EI, GJ, IP = 80.0, 5000.0, 4e11, 2e11, 3e4
GX, GW = np.polynomial.legendre.leggauss(200)
GX, GW = 0.5 * (GX + 1.0), 0.5 * GW


def uniform(name="tower", n=5):
    span = np.linspace(0.0, L, n)
    one = np.ones(n)
    return BeamProperties(name, span, M * one, EI * one, 0.5 * EI * one, GJ * one, IP * one,
                          np.zeros(n))


def omega(context, count, **params):
    return FEM.modal_analysis(context, count, {**DEFAULTS, **params})[0]


def test_uniform_cantilever_frequencies():
    np.testing.assert_allclose(clamped_free_roots(3), [1.87510407, 4.69409113, 7.85475744],
                               rtol=1e-8)                 # textbook values
    w = omega(FieldContext("tower_fa", beam=uniform()), 8)
    exact = clamped_free_roots(8) ** 2 * np.sqrt(EI / (M * L ** 4))
    np.testing.assert_allclose(w, exact, rtol=1e-3)
    assert np.abs(w[:6] / exact[:6] - 1).max() < 1e-5     # measured: 5e-6 with 60 elements
    w_ss = omega(FieldContext("tower_ss", beam=uniform()), 3)   # ei_2 = EI / 2
    np.testing.assert_allclose(w_ss, exact[:3] / np.sqrt(2), rtol=1e-5)


@pytest.mark.parametrize("mu,eta", [(1.0, 0.0), (1.006, 0.0028), (0.3, 0.05), (5.0, 1.0)])
def test_tip_mass_cantilever_frequencies_and_shapes(mu, eta):
    ctx = FieldContext("tower_fa", beam=uniform(), tip_mass=mu * M * L, tip_inertia=eta * M * L ** 3)
    w = omega(ctx, 5)
    beta = characteristic_roots(5, mu, eta)
    np.testing.assert_allclose(w, beta ** 2 * np.sqrt(EI / (M * L ** 4)), rtol=1e-3)
    x = np.linspace(0, 1, 101)
    fem = mode_shapes("tower_fa", "fem", 3, ctx, x=x).phi
    exact = mode_shapes("tower_fa", "relaxed_tipmass", 3, ctx, x=x, mass_ratio=mu,
                        inertia_ratio=eta).phi
    assert np.abs(fem - exact).max() < 1e-4 * np.abs(exact).max()


def test_buckling_loads():
    """Geometric stiffness: tip-load Euler buckling and self-weight (Greenhill)."""
    nodes = np.linspace(0, L, 61)
    span, ones = np.array([0.0, L]), np.ones(2)
    k, _ = beam_fem.bending_matrices(nodes, span, ones, EI * ones)
    k_tip, _ = beam_fem.bending_matrices(nodes, span, ones, 0 * ones, axial_force=lambda s: -1.0 + 0 * s)
    load = eigh(k, -k_tip, eigvals_only=True, subset_by_index=[0, 0])[0]
    assert load == pytest.approx(np.pi ** 2 * EI / (4 * L ** 2), rel=1e-6)
    weight = axial_force(span, ones, L, lambda s: -np.ones_like(s), 0.0)   # q = 1 N/m
    k_self, _ = beam_fem.bending_matrices(nodes, span, ones, 0 * ones, axial_force=weight)
    q = eigh(k, -k_self, eigvals_only=True, subset_by_index=[0, 0])[0]
    assert q * L ** 3 / EI == pytest.approx(7.837, abs=1e-3)


def test_gravity_softening_and_instability():
    ctx = FieldContext("tower_fa", beam=uniform(), tip_mass=M * L)
    w0, wg = omega(ctx, 2), omega(ctx, 2, gravity_factor=1.0)
    assert np.all(wg < w0)
    p_cr = np.pi ** 2 * EI / (4 * L ** 2)
    heavy = replace(ctx, tip_mass=2.0 * p_cr / ctx.gravity)
    with pytest.raises(ModeselError, match="unstable"):
        mode_shapes("tower_fa", "fem", 1, heavy, gravity_factor=1.0)


@pytest.mark.parametrize("field,precone",
                         [("blade_flap", 0.0), ("blade_flap", -0.2), ("blade_edge", -0.0436)])
def test_rotating_blade_against_rayleigh_ritz(field, precone):
    """FE eigenvalues of a rotating uniform blade equal a Rayleigh-Ritz
    solution on 12 cantilever eigenfunctions with the same loads:
    K = EI phi''^2 + N phi'^2 - kappa Omega^2 m phi^2 (eq. 29-32)."""
    r_hub, speed = 2.0, 1.5      # rad/s: Omega^2 well above omega_1^2 to make it matter
    ctx = FieldContext(field, beam=uniform("blade"), rotor_speed=speed, hub_radius=r_hub,
                       precone=precone)
    w = omega(ctx, 4)
    s = mode_shapes(field, "clamped", 12, FieldContext(field), x=GX)
    p, dp, ddp = s.phi, s.dphi / L, s.ddphi / L ** 2
    r = GX * L
    tension = M * speed ** 2 * np.cos(precone) ** 2 * (r_hub * (L - r) + 0.5 * (L ** 2 - r ** 2))
    kappa = 1.0 if field == "blade_edge" else np.sin(precone) ** 2
    ei = EI if field == "blade_flap" else 0.5 * EI
    k = ((ei * ddp * GW) @ ddp.T + (tension * dp * GW) @ dp.T) * L
    m = M * (p * GW) @ p.T * L
    ritz = np.sqrt(eigh(k - kappa * speed ** 2 * m, m, eigvals_only=True)[:4])
    np.testing.assert_allclose(w, ritz, rtol=2e-5)
    still = omega(replace(ctx, rotor_speed=0.0), 4)
    assert w[0] > still[0] * 1.01          # net stiffening (edge: k_Omega - 1 > 0, eq. 32)


def test_torsion_uniform_shaft_with_tip_inertia():
    rho = 2.5
    ctx = FieldContext("tower_torsion", beam=uniform(), tip_inertia=rho * IP * L)
    w = omega(ctx, 3, elements=200)
    g = tip_inertia_shaft_roots(3, rho)
    np.testing.assert_allclose(w, g * np.sqrt(GJ / (IP * L ** 2)), rtol=1e-4)
    x = np.linspace(0, 1, 101)
    fem = mode_shapes("tower_torsion", "fem", 3, ctx, x=x, elements=200).phi
    exact = mode_shapes("tower_torsion", "sine", 3, FieldContext("tower_torsion"), x=x,
                        inertia_ratio=rho).phi
    assert np.abs(fem - exact).max() < 1e-3 * np.abs(exact).max()


def test_fem_bad_input():
    with pytest.raises(ModeselError, match="needs the beam properties"):
        mode_shapes("tower_fa", "fem", 2, FieldContext("tower_fa"))
    with pytest.raises(ModeselError, match="has 8 modes, asked for 9"):
        mode_shapes("tower_torsion", "fem", 9, FieldContext("tower_torsion", beam=uniform()),
                    elements=8)
    bad = uniform()
    bad.ei_1 = bad.ei_1.copy()
    bad.ei_1[2] = 0.0
    with pytest.raises(ModeselError, match="'ei_1' must be finite and > 0"):
        mode_shapes("tower_fa", "fem", 2, FieldContext("tower_fa", beam=bad))
    with pytest.raises(ModeselError, match="outside"):
        mode_shapes("tower_fa", "fem", 2, FieldContext("tower_fa", beam=uniform()), elements=2)


# ----------------------------------------------------------------------------
# NREL 5-MW
# ----------------------------------------------------------------------------

RATED = 12.1 * np.pi / 30.0


@pytest.fixture(scope="module")
def nrel():
    elastodyn = pytest.importorskip("modesel.turbine.elastodyn")
    return elastodyn.load_turbine("nrel5mw")


@pytest.fixture(scope="module")
def pyb():
    pybmodes = pytest.importorskip("pybmodes.models")
    from modesel.turbine.builtin import builtin_elastodyn
    deck = builtin_elastodyn("nrel5mw")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tower = pybmodes.Tower.from_elastodyn(deck)
        tower_hz = tower.run(10).frequencies
        blade = pybmodes.RotatingBlade.from_elastodyn(deck)
        blade._bmi.rot_rpm = 12.1          # the deck says 10 rpm; compare at rated
        blade_hz = blade.run(8).frequencies
    # pyBmodes' tower modes alternate: fore-aft carries the tip inertia about y
    # plus m * cm_axial^2 (its cantilever convention), side-side the one about x
    # (identified from its tip-mass assembly; the pairs below are FA/SS).
    return {"tip": tower._bmi.tip_mass,
            "tower_fa": tower_hz[[0, 2]], "tower_ss": tower_hz[[1, 3]],
            "blade_flap": blade_hz[[0, 2]], "blade_edge": blade_hz[[1, 3]]}


def test_rna_mass_and_context(nrel, pyb):
    from modesel.candidates.context import field_context, rna_mass_and_inertia
    mass, inertia = rna_mass_and_inertia(nrel)
    assert mass == pytest.approx(350e3, rel=5e-3)              # Jonkman et al. 2009
    assert mass == pytest.approx(pyb["tip"].mass, rel=1e-9)    # pyBmodes' own RNA lump
    fa, ss, tors = (field_context(nrel, f) for f in ("tower_fa", "tower_ss", "tower_torsion"))
    assert fa.tip_mass == ss.tip_mass == mass
    assert (fa.tip_inertia, ss.tip_inertia, tors.tip_inertia) == (inertia[1, 1], inertia[0, 0],
                                                                   inertia[2, 2])
    assert tors.tip_inertia > nrel.nacelle_yaw_inertia
    assert fa.elastodyn_coefficients[0] == tuple(nrel.elastodyn_shapes["tower_fa"][0])
    blade = field_context(nrel, "blade_flap", rotor_speed=RATED)
    assert (blade.rotor_speed, blade.hub_radius, blade.precone) == (RATED, 1.5, nrel.precone[0])
    assert blade.beam is nrel.blade and len(blade.elastodyn_coefficients) == 2


def test_tower_against_pybmodes(nrel, pyb):
    """Same RNA lump as pyBmodes: first two FA and SS modes within 1 %; with
    field_context's RNA inertia: the first FA and SS modes within 1 %."""
    from modesel.candidates.context import field_context
    tip = pyb["tip"]
    for field, inertia in (("tower_fa", tip.iyy + tip.mass * tip.cm_axial ** 2), ("tower_ss", tip.ixx)):
        ctx = replace(field_context(nrel, field), tip_mass=tip.mass, tip_inertia=inertia)
        hz = omega(ctx, 2) / (2 * np.pi)
        np.testing.assert_allclose(hz, pyb[field], rtol=0.01)
        own = omega(field_context(nrel, field), 1) / (2 * np.pi)
        np.testing.assert_allclose(own, pyb[field][0], rtol=0.01)


def test_blade_against_pybmodes(nrel, pyb):
    from modesel.candidates.context import field_context
    for field in ("blade_flap", "blade_edge"):
        hz = omega(field_context(nrel, field, rotor_speed=RATED), 2) / (2 * np.pi)
        np.testing.assert_allclose(hz, pyb[field], rtol=0.01)


def test_blade_published_stiffness_and_southwell(nrel):
    """First paper, section 4.3 (ElastoDyn shapes, no cone, r from the blade
    root as in eq. 29): diag(K_e) = [1.7e4, 6.7e4, 8.7e4] N/m and
    k_Omega = K_g/(M_e Omega^2) = [1.7, 1.4, 5.5] for flap 1, edge 1, flap 2."""
    from modesel.candidates.context import field_context
    blade, length = nrel.blade, nrel.blade.length
    s = GX * length
    m = np.interp(s, blade.span, blade.mass)
    n_per_omega2 = axial_force(blade.span, blade.mass, length, lambda r: r, 0.0)(s)
    got_k, got_south = [], []
    for field, mode, ei in (("blade_flap", 0, blade.ei_1), ("blade_edge", 0, blade.ei_2),
                            ("blade_flap", 1, blade.ei_1)):
        sh = mode_shapes(field, "elastodyn", mode + 1, field_context(nrel, field), x=GX)
        phi, dphi, ddphi = sh.phi[mode], sh.dphi[mode] / length, sh.ddphi[mode] / length ** 2
        m_e = (m * phi ** 2 * GW).sum() * length
        got_k.append((np.interp(s, blade.span, ei) * ddphi ** 2 * GW).sum() * length)
        got_south.append((n_per_omega2 * dphi ** 2 * GW).sum() * length / m_e)
    np.testing.assert_allclose(got_k, [1.7e4, 6.7e4, 8.7e4], rtol=0.03)
    np.testing.assert_allclose(got_south, [1.7, 1.4, 5.5], rtol=0.03)


def test_fem_close_to_deck_polynomials(nrel):
    """The deck's ElastoDyn first-mode polynomials (fitted to BModes shapes)
    are close to the fem modes: modal assurance criterion > 0.999."""
    from modesel.candidates.context import field_context
    x = np.linspace(0, 1, 201)
    for field in ("tower_fa", "tower_ss", "blade_flap", "blade_edge"):
        ctx = field_context(nrel, field, rotor_speed=RATED)
        a = mode_shapes(field, "elastodyn", 1, ctx, x=x).phi[0]
        b = mode_shapes(field, "fem", 1, ctx, x=x).phi[0]
        assert (a @ b) ** 2 / ((a @ a) * (b @ b)) > 0.999, field
