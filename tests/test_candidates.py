"""Candidate families: boundary conditions, derivatives, analytic properties,
bad input and the `modesel candidates` command.

External references: MF1-MF3 of eq. 53-54 of the second paper (published
constants 1.875 and 1.3622), the ElastoDyn tower polynomial of eq. 46 of the
first paper (published a_2..a_6), classical uniform-cantilever results
(Rayleigh quotient omega^2 = beta^4 EI/(m L^4), orthogonality, the tip-mass
root beta_1 = 1.2479 at mu = 1 tabulated by Blevins), and an independent
evaluation of the characteristic determinant in 50-digit arithmetic.
"""
from __future__ import annotations

import json
import time

import mpmath as mp
import numpy as np
import pytest

from modesel.candidates import FieldContext, families, get_family, mode_shapes
from modesel.candidates.base import BENDING_FIELDS
from modesel.candidates.cantilever import characteristic_roots, clamped_free_roots
from modesel.cli import main
from modesel.errors import ModeselError
from modesel.modeset import FIELDS
from modesel.turbine.beam import BeamProperties

# Gauss-Legendre rule on [0, 1]: exact for polynomials of degree < 800,
# ~1e-15 for the smooth shapes of mode <= 20.
GX, GW = np.polynomial.legendre.leggauss(400)
GX, GW = 0.5 * (GX + 1.0), 0.5 * GW

# ElastoDyn TwFAM1Sh of the NREL 5-MW tower as published in the first paper (eq. 46).
PAPER_TWFAM1SH = (0.7004, 2.1963, -5.6202, 6.2275, -2.504)


def tapered_beam(name="tower"):
    """A non-uniform beam (mass and stiffness tapering 3:1) for generic checks."""
    n = 21
    span = np.linspace(0.0, 80.0, n)
    taper = np.linspace(1.0, 1.0 / 3.0, n)
    return BeamProperties(name, span, 6000.0 * taper, 5e11 * taper ** 3, 4e11 * taper ** 3,
                          3e11 * taper ** 3, 3e4 * taper ** 3, np.zeros(n))


def context(field):
    coeffs = {"tower_fa": (PAPER_TWFAM1SH, (-70.5319, -63.7623, 289.737, -176.513, 22.0706)),
              "tower_ss": ((1.385, -1.7684, 3.0871, -2.2395, 0.5357),
                           (-121.21, 184.415, -224.904, 298.536, -135.838)),
              "blade_flap": ((0.0622, 1.7254, -3.2452, 4.7131, -2.2555),
                             (-0.5809, 1.2067, -15.5349, 29.7347, -13.8255)),
              "blade_edge": ((0.3627, 2.5337, -3.5772, 2.376, -0.6952),)}
    blade = field.startswith("blade")
    return FieldContext(field, beam=tapered_beam("blade" if blade else "tower"),
                        tip_mass=0.0 if blade else 3e5, tip_inertia=0.0 if blade else 5e6,
                        rotor_speed=1.2 if blade else 0.0, hub_radius=1.5 if blade else 0.0,
                        precone=-0.0436 if blade else 0.0,
                        elastodyn_coefficients=coeffs.get(field, ()))


def max_count(family, field):
    fam = get_family(family)
    if family == "elastodyn":
        return len(context(field).elastodyn_coefficients)
    return min(fam.max_count or 20, 20 if family in ("clamped", "fem") else 6)


CASES = [(f.name, field) for f in families() for field in f.fields]


@pytest.mark.parametrize("family,field", CASES)
def test_root_tip_finite_and_derivatives(family, field):
    """For counts 1..6 (clamped and fem: 1..20): phi(0) = 0, phi'(0) = 0 for
    bending, phi(1) = 1, finite values, and phi', phi'' consistent with
    central finite differences of phi and phi'."""
    ctx = context(field)
    top = max_count(family, field)
    # stations avoiding the fem element boundaries (multiples of 1/60)
    probe = (np.arange(1, 60) + 0.37) / 60.0
    h = 1e-6
    x = np.concatenate([[0.0, 1.0], probe, probe - h, probe + h])
    n = len(probe)
    for count in range(1, top + 1):
        s = mode_shapes(field, family, count, ctx, x=x)
        assert s.phi.shape == s.dphi.shape == s.ddphi.shape == (count, len(x))
        assert all(np.all(np.isfinite(a)) for a in (s.phi, s.dphi, s.ddphi))
        scale = np.abs(s.phi).max(axis=1)
        np.testing.assert_allclose(s.phi[:, 0], 0.0, atol=1e-12 * scale.max())
        if field in BENDING_FIELDS:
            np.testing.assert_allclose(s.dphi[:, 0], 0.0, atol=1e-11 * np.abs(s.dphi).max())
        np.testing.assert_allclose(s.phi[:, 1], 1.0, rtol=1e-12)
        lo, hi = slice(2 + n, 2 + 2 * n), slice(2 + 2 * n, 2 + 3 * n)
        fd1 = (s.phi[:, hi] - s.phi[:, lo]) / (2 * h)
        fd2 = (s.dphi[:, hi] - s.dphi[:, lo]) / (2 * h)
        mid = slice(2, 2 + n)
        tol1 = 1e-6 * np.abs(s.dphi).max(axis=1, keepdims=True) + 1e-9
        tol2 = 1e-6 * np.abs(s.ddphi).max(axis=1, keepdims=True) + 1e-6 * np.abs(s.dphi).max()
        assert np.all(np.abs(fd1 - s.dphi[:, mid]) <= tol1), (family, field, count)
        assert np.all(np.abs(fd2 - s.ddphi[:, mid]) <= tol2), (family, field, count)


def test_paper_shapes_mf1_mf2_mf3():
    """Mode 1 of polynomial, cosine and clamped are MF1, MF2, MF3 of eq. 53-54."""
    x = np.linspace(0, 1, 101)
    mf1 = x ** 4 / 3 - 4 * x ** 3 / 3 + 2 * x ** 2
    mf2 = 1 - np.cos(np.pi * x / 2)
    b = 1.875
    mf3 = np.sin(b * x) - 1.3622 * np.cos(b * x) - np.sinh(b * x) + 1.3622 * np.cosh(b * x)
    mf3 = mf3 / mf3[-1]
    ctx = FieldContext("blade_flap")
    np.testing.assert_allclose(mode_shapes("blade_flap", "polynomial", 1, ctx, x=x).phi[0], mf1,
                               atol=1e-14)
    np.testing.assert_allclose(mode_shapes("blade_flap", "cosine", 1, ctx, x=x).phi[0], mf2, atol=1e-15)
    # the paper's constants have 4-5 significant digits
    np.testing.assert_allclose(mode_shapes("blade_flap", "clamped", 1, ctx, x=x).phi[0], mf3, atol=2e-4)
    assert clamped_free_roots(1)[0] == pytest.approx(1.875104069, abs=1e-9)


def test_polynomial_clamped_free_and_ill_conditioned():
    """All polynomial shapes meet phi''(1) = 0 and phi'''(1) = 0 (then phi''
    vanishes quadratically at the tip: phi''(1-h) / phi''(1-2h) -> 1/4); the
    raw 12-mode Gram matrix has condition > 1e12."""
    ctx = FieldContext("tower_fa")
    h = 1e-4
    s = mode_shapes("tower_fa", "polynomial", 12, ctx, x=[1.0 - 2 * h, 1.0 - h, 1.0])
    np.testing.assert_allclose(s.ddphi[:, 2], 0.0, atol=1e-11)
    np.testing.assert_allclose(s.ddphi[:, 1] / s.ddphi[:, 0], 0.25, atol=2e-3)
    g = mode_shapes("tower_fa", "polynomial", 12, ctx, x=GX).phi
    gram = (g * GW) @ g.T
    assert np.linalg.cond(gram) > 1e12


def test_clamped_orthogonality_and_rayleigh_to_k20():
    """Uniform cantilever eigenfunctions up to k = 20: normalised inner
    products int phi_i phi_j dx below 1e-8; int EI phi''^2 = beta^4 EI/(m L^4)
    int m phi^2 (relative 1e-8), in physical units of a uniform beam."""
    t0 = time.perf_counter()
    s = mode_shapes("tower_fa", "clamped", 20, FieldContext("tower_fa"), x=GX)
    elapsed = time.perf_counter() - t0
    gram = (s.phi * GW) @ s.phi.T
    d = np.sqrt(np.diag(gram))
    off = gram / np.outer(d, d) - np.eye(20)
    assert np.abs(off).max() < 1e-8
    length, m, ei = 87.6, 4000.0, 3e11
    beta = clamped_free_roots(20)
    strain = ei * ((s.ddphi / length ** 2) ** 2 * GW).sum(axis=1) * length
    kinetic = m * (s.phi ** 2 * GW).sum(axis=1) * length
    np.testing.assert_allclose(strain, beta ** 4 * ei / (m * length ** 4) * kinetic, rtol=1e-8)
    np.testing.assert_allclose(beta[-1], 39 * np.pi / 2, rtol=1e-12)   # asymptote, e^-61 away
    assert elapsed < 0.5


def test_clamped_high_mode_against_extended_precision():
    """Mode 20 at 50 stations agrees with a 60-digit evaluation of the textbook
    form (measured 3e-15; the textbook form in double precision cancels terms of
    size e^61 and returns nan at the tip)."""
    x = np.linspace(0, 1, 50)
    phi = mode_shapes("tower_fa", "clamped", 20, FieldContext("tower_fa"), x=x).phi[-1]
    with mp.workdps(60):
        b = mp.findroot(lambda b: 1 + mp.cos(b) * mp.cosh(b), clamped_free_roots(20)[-1])
        sigma = (mp.cosh(b) + mp.cos(b)) / (mp.sinh(b) + mp.sin(b))
        f = lambda t: mp.cosh(b * t) - mp.cos(b * t) - sigma * (mp.sinh(b * t) - mp.sin(b * t))  # noqa
        ref = np.array([float(f(mp.mpf(float(t))) / f(1)) for t in x])
    np.testing.assert_allclose(phi, ref, atol=1e-13)


def test_tipmass_roots_against_independent_determinant():
    """Roots of the tip-mass/inertia characteristic equation: the classical
    beta_1 = 1.2479 for mu = 1 (Blevins), and the 2x2 boundary-condition
    determinant evaluated independently in 50-digit arithmetic vanishes."""
    assert characteristic_roots(1, 1.0, 0.0)[0] == pytest.approx(1.24792, abs=1e-5)
    with mp.workdps(50):
        for mu, eta in ((1.0, 0.0), (0.0, 0.3), (2.5, 0.05), (5.0, 1.0)):
            for b in characteristic_roots(6, mu, eta):
                b = mp.mpf(float(b))
                u = lambda t: [mp.cosh(b * t) - mp.cos(b * t), mp.sinh(b * t) - mp.sin(b * t)]  # noqa
                d = [mp.diff(lambda t, i=i: u(t)[i], 1, n) for i in range(2) for n in range(4)]
                # rows: phi'' - eta b^4 phi' = 0 and phi''' + mu b^4 phi = 0 at x = 1
                a11, a12 = d[2] - eta * b ** 4 * d[1], d[6] - eta * b ** 4 * d[5]
                a21, a22 = d[3] + mu * b ** 4 * d[0], d[7] + mu * b ** 4 * d[4]
                det = a11 * a22 - a12 * a21
                scale = abs(a11 * a22) + abs(a12 * a21)
                assert float(abs(det) / scale) < 1e-12


@pytest.mark.parametrize("mu,eta", [(0.5, 0.0), (1.006, 0.0028), (5.0, 1.0), (0.0, 0.2)])
def test_relaxed_tipmass_orthogonal_and_rayleigh(mu, eta):
    """Tip-mass eigenfunctions are orthogonal in the mass inner product
    int phi_i phi_j + mu phi_i(1) phi_j(1) + eta phi_i'(1) phi_j'(1) and
    satisfy int phi''^2 = beta^4 * (that mass), i.e. they are the modes."""
    x = np.concatenate([GX, [1.0]])
    s = mode_shapes("tower_fa", "relaxed_tipmass", 8, FieldContext("tower_fa"), x=x,
                    mass_ratio=mu, inertia_ratio=eta)
    p, dp, ddp = s.phi[:, :-1], s.phi[:, -1], s.dphi[:, -1]
    mass = (p * GW) @ p.T + mu * np.outer(dp, dp) + eta * np.outer(ddp, ddp)
    d = np.sqrt(np.diag(mass))
    assert np.abs(mass / np.outer(d, d) - np.eye(8)).max() < 1e-8
    beta = characteristic_roots(8, mu, eta)
    np.testing.assert_allclose((s.ddphi[:, :-1] ** 2 * GW).sum(axis=1), beta ** 4 * np.diag(mass),
                               rtol=1e-8)


def test_relaxed_tipmass_zero_ratios_is_clamped():
    x = np.linspace(0, 1, 301)
    ctx = FieldContext("blade_edge")
    a = mode_shapes("blade_edge", "relaxed_tipmass", 20, ctx, x=x)
    b = mode_shapes("blade_edge", "clamped", 20, ctx, x=x)
    for u, v in ((a.phi, b.phi), (a.dphi, b.dphi), (a.ddphi, b.ddphi)):
        np.testing.assert_allclose(u, v, atol=1e-10 * np.abs(v).max())


def test_relaxed_root_blend():
    """w = 0: monomials x^(k+1); w = 1: the polynomial family; the free-end
    moment residual phi''(1) = (1 - w) k (k + 1)."""
    x = np.linspace(0, 1, 51)
    ctx = FieldContext("tower_ss")
    s0 = mode_shapes("tower_ss", "relaxed_root", 5, ctx, x=x)
    np.testing.assert_allclose(s0.phi, np.array([x ** (k + 1) for k in range(1, 6)]), atol=1e-15)
    s1 = mode_shapes("tower_ss", "relaxed_root", 5, ctx, x=x, free_end_weight=1.0)
    np.testing.assert_allclose(s1.phi, mode_shapes("tower_ss", "polynomial", 5, ctx, x=x).phi,
                               atol=1e-14)
    w = 0.3
    s = mode_shapes("tower_ss", "relaxed_root", 5, ctx, x=[1.0], free_end_weight=w)
    k = np.arange(1, 6)
    np.testing.assert_allclose(s.ddphi[:, 0], (1 - w) * k * (k + 1), rtol=1e-12)


def test_elastodyn_is_eq46():
    """The elastodyn family evaluates eq. 46 with the published coefficients."""
    x = np.linspace(0, 1, 11)
    s = mode_shapes("tower_fa", "elastodyn", 2, context("tower_fa"), x=x)
    a = np.array(PAPER_TWFAM1SH)
    j = np.arange(2, 7)
    np.testing.assert_allclose(s.phi[0], (a[None, :] * x[:, None] ** j).sum(1) / a.sum(), rtol=1e-14)
    np.testing.assert_allclose(s.ddphi[0], (a * j * (j - 1) * x[:, None] ** (j - 2)).sum(1) / a.sum(),
                               rtol=1e-13)


def test_torsion_families():
    """Torsion: clamped is sin((2k-1) pi x/2), linear x^k, sine the shaft with
    tip inertia: g tan g = 1/rho, i.e. phi'(1) = rho g^2 phi(1) (tip balance)."""
    x = np.linspace(0, 1, 101)
    ctx = FieldContext("tower_torsion")
    c = mode_shapes("tower_torsion", "clamped", 4, ctx, x=x)
    np.testing.assert_allclose(np.abs(c.phi), np.abs(np.sin(np.outer([1, 3, 5, 7], x) * np.pi / 2)),
                               atol=1e-15)
    np.testing.assert_allclose(c.dphi[:, -1], 0.0, atol=1e-14)     # torque-free tip
    lin = mode_shapes("tower_torsion", "linear", 3, ctx, x=x)
    np.testing.assert_allclose(lin.phi, [x, x ** 2, x ** 3], atol=1e-15)
    for rho in (0.1, 2.5, 50.0):
        s = mode_shapes("tower_torsion", "sine", 5, ctx, x=x, inertia_ratio=rho)
        g2 = -s.ddphi[:, -1] / s.phi[:, -1]                       # phi'' = -g^2 phi
        np.testing.assert_allclose(s.dphi[:, -1], rho * g2, rtol=1e-10)
        assert np.abs(s.phi[0] - c.phi[0]).max() > 1e-3           # differs from clamped
    near = mode_shapes("tower_torsion", "sine", 1, ctx, x=x, inertia_ratio=50.0).phi[0]
    assert np.abs(near - x).max() < 0.01                          # rho -> inf: linear


def test_bad_input():
    ctx = FieldContext("tower_fa")
    with pytest.raises(ModeselError, match="unknown family 'clampd'.*did you mean 'clamped'"):
        mode_shapes("tower_fa", "clampd", 2, ctx)
    with pytest.raises(ModeselError, match="unknown field"):
        mode_shapes("tower_xx", "clamped", 2, FieldContext("tower_xx"))
    with pytest.raises(ModeselError, match="does not describe field 'tower_torsion'"):
        mode_shapes("tower_torsion", "polynomial", 2, FieldContext("tower_torsion"))
    with pytest.raises(ModeselError, match="does not describe field 'tower_fa'"):
        mode_shapes("tower_fa", "sine", 2, ctx)
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ModeselError, match="count"):
            mode_shapes("tower_fa", "cosine", bad, ctx)
    with pytest.raises(ModeselError, match="at most"):
        mode_shapes("tower_fa", "polynomial", 15, ctx)
    with pytest.raises(ModeselError, match="outside"):
        mode_shapes("tower_fa", "relaxed_tipmass", 2, ctx, mass_ratio=6.0)
    with pytest.raises(ModeselError, match="outside"):
        mode_shapes("tower_fa", "relaxed_root", 2, ctx, free_end_weight=-0.1)
    with pytest.raises(ModeselError, match="unknown parameter"):
        mode_shapes("tower_fa", "clamped", 2, ctx, mass_ratio=1.0)
    with pytest.raises(ModeselError, match="no ElastoDyn mode-shape coefficients"):
        mode_shapes("tower_fa", "elastodyn", 1, ctx)
    with pytest.raises(ModeselError, match="provides at most 1 modes for blade_edge"):
        mode_shapes("blade_edge", "elastodyn", 2, context("blade_edge"))
    with pytest.raises(ModeselError, match="5 finite numbers"):
        mode_shapes("tower_fa", "elastodyn", 1,
                    FieldContext("tower_fa", elastodyn_coefficients=((1, 2),)))
    with pytest.raises(ModeselError, match="sum to zero"):
        mode_shapes("tower_fa", "elastodyn", 1,
                    FieldContext("tower_fa", elastodyn_coefficients=((1, -1, 0, 0, 0),)))


def test_cli_lists_every_family(capsys):
    assert main(["candidates"]) == 0
    out = capsys.readouterr().out
    for fam in families():
        assert fam.name in out
    assert main(["candidates", "--json", "--field", "tower_torsion"]) == 0
    data = json.loads(capsys.readouterr().out)
    names = {f["name"] for f in data["families"]}
    assert names == {"clamped", "linear", "sine", "fem"}
    sine = next(f for f in data["families"] if f["name"] == "sine")
    assert sine["parameters"][0] == {"name": "inertia_ratio", "default": 2.5, "low": 0.1,
                                     "high": 50.0, "description": sine["parameters"][0]["description"]}
    assert main(["candidates", "--field", "tower_xx"]) == 2
    assert "unknown field 'tower_xx'" in capsys.readouterr().err


def test_every_field_has_families():
    names = {f.name for f in families()}
    assert {"polynomial", "cosine", "clamped", "relaxed_root", "relaxed_tipmass", "elastodyn",
            "linear", "sine", "fem"} <= names
    for field in FIELDS:
        assert len(families(field)) >= 3
