"""AeroDyn's tower influence on the blades' wind (`aero.tower_influence`):
the baseline potential flow against the exact potential flow around a
cylinder (complex potential w = U (z + a^2 / z)), the numpy reference
against its compiled twin on random towers and stations, and the inputs
refused in one line. The OpenFAST comparisons are in test_openfast_more.py
(tower_potential, downwind_tower_shadow)."""
from __future__ import annotations

import numpy as np
import pytest

from modesel.aero.tower_influence import TowerInfluence, deficit, tower_disturbance
from modesel.errors import ModeselError


def _straight_tower(m=9, height=80.0, diameter=4.0):
    pos = np.zeros((m, 3))
    pos[:, 2] = np.linspace(0.0, height, m)
    return pos, TowerInfluence(1, 0, np.full(m, diameter), np.ones(m), np.full(m, 0.1))


def test_baseline_potential_flow_is_the_flow_around_a_cylinder():
    """A vertical tower of diameter 4 m in a 10 m/s wind at 30 deg from x: at
    stations around it (mid-height, 1.05 to 10 radii away) the wind plus
    the influence equals U conj(1 - a^2 / zeta^2) in the frame of the wind
    (zeta = the station's position over the radius a in that frame), the
    exact potential flow, and its polar form just off the surface."""
    pos, tower = _straight_tower()
    U, angle, a = 10.0, np.radians(30.0), 2.0
    direction = np.array([np.cos(angle), np.sin(angle), 0.0])
    wind = np.tile(U * direction, (len(pos), 1))
    rng = np.random.default_rng(3)
    radius = a * rng.uniform(1.05, 10.0, 40)
    theta = rng.uniform(-np.pi, np.pi, 40)
    stations = np.stack([radius * np.cos(theta), radius * np.sin(theta), rng.uniform(20.0, 60.0, 40)], axis=1)
    dv = tower.velocity(stations, pos, np.zeros_like(pos), wind)
    zeta = (stations[:, 0] + 1j * stations[:, 1]) * np.exp(-1j * angle)      # in the wind's frame
    exact = U * np.conj(1.0 - (a / zeta) ** 2) * np.exp(1j * angle)          # u + i v, turned back
    total = U * direction[None, :] + dv
    assert np.allclose(total[:, 0] + 1j * total[:, 1], exact, rtol=1e-12, atol=1e-12)
    assert np.allclose(dv[:, 2], 0.0)
    # in polar form just off the surface (r = 1.03 a, outside AeroDyn's D/100 cut): u_r = U (1 - a^2/r^2)
    # cos(phi) -> 0 on the surface, u_phi = -U (1 + a^2/r^2) sin(phi) -> 2 U at the sides
    r = 1.03 * a
    close = np.stack([r * np.cos(theta), r * np.sin(theta), np.full(40, 40.0)], axis=1)
    v = tower.velocity(close, pos, np.zeros_like(pos), wind) + U * direction
    e_r = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    e_phi = np.stack([-np.sin(theta), np.cos(theta)], axis=1)
    phi = theta - angle
    assert np.allclose(np.einsum("ij,ij->i", v[:, :2], e_r), U * (1 - (a / r) ** 2) * np.cos(phi), atol=1e-12)
    assert np.allclose(np.einsum("ij,ij->i", v[:, :2], e_phi), -U * (1 + (a / r) ** 2) * np.sin(phi), atol=1e-12)


def test_stations_inside_or_far_from_the_tower_keep_the_wind():
    """AeroDyn keeps the undisturbed wind within D/100 of the surface and
    beyond 20 D of it (getLocalTowerProps)."""
    pos, tower = _straight_tower()
    wind = np.tile([8.0, 0.0, 0.0], (len(pos), 1))
    near = np.array([[-2.0 - 0.03, 0.0, 40.0], [-2.0 - 81.0, 0.0, 40.0], [-2.0 - 0.05, 0.0, 40.0]])
    dv = tower.velocity(near, pos, np.zeros_like(pos), wind)
    assert np.all(dv[:2] == 0.0)
    assert dv[2, 0] < -7.0                 # 0.05 m in front: close to the stagnation point


def test_shadow_models_behind_the_tower():
    """Powles: -Cd / d cos^2(pi ybar / (2 d)) with d = (xbar^2 + ybar^2)^(1/4)
    within |ybar| < d; Eames: the Gaussian wake -Cd / (TI xbar sqrt(2 pi))
    exp(-(ybar / (TI xbar))^2 / 2); none upstream; no deficit below -0.5."""
    x, y = np.array([4.0, 9.0, 16.0, -4.0]), np.array([0.0, 1.0, 3.9, 0.0])
    u, v = deficit(0, 1, x, y, 0.0, 1.2, 0.1)
    d = (x ** 2 + y ** 2) ** 0.25
    powles = np.where(np.abs(y) < d, -1.2 / d * np.cos(np.pi * y / (2 * d)) ** 2, 0.0)
    assert np.allclose(u[:3], np.maximum(powles[:3], -0.5)) and u[3] == 0.0 and np.all(v == 0.0)
    assert u[0] == -0.5                    # -0.6 floored
    u, _ = deficit(0, 2, x, y, 0.0, 1.0, 0.2)
    s = 0.2 * x[:3]
    assert np.allclose(u[:3], np.maximum(-1.0 / (s * np.sqrt(2 * np.pi)) * np.exp(-0.5 * (y[:3] / s) ** 2), -0.5))
    assert u[3] == 0.0


@pytest.mark.parametrize("potential, shadow", [(1, 0), (2, 0), (0, 1), (0, 2), (2, 1), (1, 2)])
def test_compiled_twin_equals_the_reference(potential, shadow):
    """`tower_disturbance` equals `TowerInfluence.velocity` to 1e-10 on a
    bent, moving tower of tapering diameter: stations beside its elements,
    above its top (the tapered half-diameter of AeroDyn's end nodes) and
    below its base, up- and downstream."""
    rng = np.random.default_rng(11 + 3 * potential + shadow)
    m = 7
    z = np.linspace(0.0, 60.0, m)
    pos = np.stack([0.02 * z ** 2 / 60.0, -0.01 * z, z], axis=1)
    vel = rng.normal(0.0, 0.3, (m, 3))
    wind = np.stack([9.0 + 0.02 * z, 1.5 * np.ones(m), 0.2 * np.ones(m)], axis=1)
    tower = TowerInfluence(potential, shadow, np.linspace(5.0, 3.0, m), rng.uniform(0.6, 1.2, m),
                           rng.uniform(0.05, 0.2, m))
    B, M = 3, 40
    stations = np.empty((B, M, 3))
    stations[..., 0] = rng.uniform(-12.0, 12.0, (B, M))
    stations[..., 1] = rng.uniform(-12.0, 12.0, (B, M))
    stations[..., 2] = rng.uniform(-2.0, 62.5, (B, M))
    stations[0, :5, 2] = 60.0 + rng.uniform(0.1, 1.4, 5)           # within half a diameter above the top
    stations[0, :5, :2] = pos[-1, :2] + rng.uniform(-4.0, 4.0, (5, 2))
    reference = tower.velocity(stations, pos, vel, wind)
    compiled = np.empty((B, M, 3))
    tower_disturbance(potential, shadow, stations, pos, vel, wind, tower.packed(), compiled)
    scale = np.abs(reference).max()
    assert scale > 0.1
    assert np.allclose(compiled, reference, rtol=1e-10, atol=1e-10 * scale)
    assert np.count_nonzero(np.linalg.norm(reference[0, :5], axis=1)) >= 1      # the tapered end acts


def test_unsupported_tower_influence_inputs_are_one_line(tmp_path):
    """TwrShadow 2 without TwrTI > 0 and a TwrPotent outside 0-2 are refused
    naming the AeroDyn file and the input."""
    from pathlib import Path

    from modesel.turbine.aerodyn import aerodyn_case_options
    source = Path(__file__).resolve().parent / "data" / "openfast_more" / "downwind_tower_shadow"
    text = (source / "downwind_tower_shadow_AeroDyn.dat").read_text()
    lines = text.splitlines()
    first = next(i for i, line in enumerate(lines) if line.split()[:1] == ["0.0000000E+00"])
    cells = lines[first].split()
    cells[3] = "0.0"
    lines[first] = "  ".join(cells)
    bad = tmp_path / "AeroDyn.dat"
    bad.write_text("\n".join(lines).replace('"../../../../studies', f'"{source}/../../../../studies') + "\n")
    with pytest.raises(ModeselError) as err:
        aerodyn_case_options(bad)
    assert err.value.field == "TwrTI" and str(bad) in str(err.value)
    bad.write_text(text.replace("          2   TwrPotent", "          3   TwrPotent"))
    with pytest.raises(ModeselError) as err:
        aerodyn_case_options(bad)
    assert err.value.field == "TwrPotent"
