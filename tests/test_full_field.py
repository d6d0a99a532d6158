"""TurbSim full-field wind (InflowWind WindType 3, `modesel.aero.full_field`)
against analytic fields: trilinear interpolation reproduces a field linear
in (y, z, t) exactly (to the file's int16 resolution), the frozen turbulence
moves downwind at the file's mean speed (Taylor's hypothesis, as InflowWind
shifts the time), a periodic file wraps, the tower points carry the wind
below the grid and down to zero at the ground. The match with OpenFAST
itself is `tests/test_openfast_more.py::test_turbulent_wind_matches_openfast`
(its Wind1VelX/Y/Z are InflowWind's own interpolation of the same file);
the numpy / compiled twins are in `tests/test_twins.py`. Bad files and
options: one line naming the file and what is wrong."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from modesel.aero import Wind
from modesel.aero.full_field import GRID_TOL, read_turbsim, write_turbsim
from modesel.errors import ModeselError

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "tests" / "data" / "openfast_more" / "turbulent_08"

NT, NZ, NY, NTW = 40, 9, 11, 3
DY, DZ, DT, U, BASE = 12.0, 10.0, 0.25, 9.0, 40.0
#: velocity = A[:, 0] + A[:, 1] y + A[:, 2] z + A[:, 3] T (rows u, v, w)
A = np.array([[9.0, 0.02, 0.03, 0.4], [0.5, -0.01, 0.02, 0.1], [-0.2, 0.01, -0.015, 0.05]])


def linear(y, z, T):
    return np.stack([A[c, 0] + A[c, 1] * y + A[c, 2] * z + A[c, 3] * T for c in range(3)], axis=-1)


@pytest.fixture(scope="module")
def field(tmp_path_factory):
    T = np.arange(NT) * DT
    Z = BASE + np.arange(NZ) * DZ
    Y = -0.5 * (NY - 1) * DY + np.arange(NY) * DY
    grid = linear(Y[None, None, :], Z[None, :, None], T[:, None, None])
    tower_z = BASE - np.arange(NTW) * DZ                  # tower point k at GridBase - k dz (0-based)
    tower = linear(0.0, tower_z[None, :], T[:, None])
    path = tmp_path_factory.mktemp("bts") / "linear.bts"
    write_turbsim(path, grid, tower, DY, DZ, DT, U, 90.0, BASE)
    return read_turbsim(path)


#: int16 resolution of the written field: the values' range / 64000 per component
RESOLUTION = 2e-4


def test_round_trip_keeps_the_header_and_values(field):
    assert field.grid.shape == (NT, NZ, NY, 3) and field.tower.shape == (NT, NTW, 3)
    assert (field.dy, field.dz, field.dt, field.mean_speed, field.grid_base) == (DY, DZ, DT, U, BASE)
    assert not field.periodic and field.init_x == pytest.approx(0.5 * (NY - 1) * DY)
    assert field.duration == pytest.approx((NT - 1) * DT)


def test_trilinear_interpolation_reproduces_a_linear_field(field):
    rng = np.random.default_rng(3)
    n = 3000
    half = field.half_width * (1 - 2 * GRID_TOL)
    pts = np.column_stack([rng.uniform(-10, 10, n), rng.uniform(-half, half, n),
                           rng.uniform(BASE + 0.01, field.top - 0.01, n)])
    for t in (0.0, 0.9, 1.7):                                  # T within the file: < 9.75 s
        T = t + (field.init_x - pts[:, 0]) / U                   # InflowWind's shifted time
        v = field.velocity(pts, t)
        assert np.all(np.isfinite(v))
        assert np.abs(v - linear(pts[:, 1], pts[:, 2], T)).max() < RESOLUTION


def test_tower_points_carry_the_wind_below_the_grid_and_to_zero_at_the_ground(field):
    t, x = 1.0, 2.0
    T = t + (field.init_x - x) / U
    z_on = np.linspace(BASE - (NTW - 1) * DZ + 0.01, BASE - 0.5, 25)
    on = field.velocity(np.column_stack([np.full(25, x), np.full(25, 33.0), z_on]), t)
    assert np.abs(on - linear(0.0, z_on, T)).max() < RESOLUTION       # y plays no part below the grid
    z_last = BASE - (NTW - 1) * DZ
    z_low = np.linspace(0.5, z_last, 10)
    low = field.velocity(np.column_stack([np.full(10, x), np.zeros(10), z_low]), t)
    expected = (z_low / z_last)[:, None] * linear(0.0, z_last, T)
    assert np.abs(low - expected).max() < RESOLUTION
    assert np.all(field.velocity([[x, 0.0, 0.0], [x, 5.0, -3.0]], t) == 0.0)


def test_frozen_turbulence_moves_downwind_at_the_mean_speed(tmp_path):
    """A point s*U m downstream sees at t + s what the upstream point saw at t."""
    rng = np.random.default_rng(5)
    path = tmp_path / "random.bts"
    write_turbsim(path, rng.normal(10.0, 1.0, (60, 7, 7, 3)), np.zeros((60, 0, 3)), 15.0, 15.0, 0.2, 11.0,
                  90.0, 45.0)
    f = read_turbsim(path)
    pts = np.column_stack([np.full(50, -4.0), rng.uniform(-40, 40, 50), rng.uniform(50, 130, 50)])
    for s in (0.37, 1.9):
        later = pts + [s * f.mean_speed, 0.0, 0.0]
        np.testing.assert_allclose(f.velocity(later, 2.0 + s), f.velocity(pts, 2.0), rtol=0, atol=1e-12)


def test_periodic_file_wraps_and_a_non_periodic_one_ends(tmp_path):
    rng = np.random.default_rng(6)
    grid = rng.normal(10.0, 1.0, (30, 5, 5, 3))
    for periodic in (True, False):
        path = tmp_path / f"p{periodic}.bts"
        write_turbsim(path, grid, np.zeros((30, 0, 3)), 20.0, 20.0, 0.5, 10.0, 90.0, 50.0, periodic=periodic)
        f = read_turbsim(path)
        pts = np.array([[0.0, 7.0, 90.0], [3.0, -12.0, 110.0]])
        if periodic:
            assert f.init_x == 0.0 and f.duration == pytest.approx(15.0)
            np.testing.assert_allclose(f.velocity(pts, 3.3 + f.duration), f.velocity(pts, 3.3), atol=1e-12)
            assert np.all(np.isfinite(f.velocity(pts, 14.9)))      # across the wrap: last -> first instant
        else:
            assert np.all(np.isnan(f.velocity(pts, f.duration + 1.0)))
            assert np.all(np.isnan(f.velocity([[0.0, 0.0, f.top + 5.0], [0.0, f.half_width + 3, 90.0]], 1.0)))


def test_wind_params_carry_the_field_to_the_compiled_velocity(field):
    from modesel.aero.wind import wind_velocity
    wind = Wind(full_field=field)
    p = wind.params(1.5)
    T = 1.5 + (field.init_x - 1.0) / U
    assert np.allclose(wind_velocity(p, 1.0, 3.0, 77.0), linear(3.0, 77.0, T), atol=RESOLUTION)
    assert np.all(np.isnan(wind_velocity(p, 1.0, 3.0, field.top + 10.0)))


def bts_bytes(path):
    return bytearray(Path(path).read_bytes())


def test_bad_files_name_the_file(tmp_path, field):
    good = tmp_path / "good.bts"
    write_turbsim(good, field.grid, field.tower, DY, DZ, DT, U, 90.0, BASE)
    cases = {"short.bts": bts_bytes(good)[:500], "header.bts": bts_bytes(good)[:40]}
    bad_id = bts_bytes(good)
    bad_id[0:2] = (9).to_bytes(2, "little")
    cases["id.bts"] = bad_id
    zero_dy = bts_bytes(good)
    zero_dy[22:26] = np.float32(0.0).tobytes()                  # dy
    cases["dy.bts"] = zero_dy
    for name, data in cases.items():
        path = tmp_path / name
        path.write_bytes(bytes(data))
        with pytest.raises(ModeselError) as err:
            read_turbsim(path)
        assert name in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(ModeselError, match="cannot read"):
        read_turbsim(tmp_path / "missing.bts")


def test_rotor_outside_the_grid_is_refused_before_integrating(field):
    with pytest.raises(ModeselError, match="top row"):
        field.check_covers(90.0, 63.0, 5.0)
    with pytest.raises(ModeselError, match="frozen turbulence"):
        field.check_covers(field.grid_base + 20, 10.0, 60.0)
    field.check_covers(field.grid_base + 40, 30.0, 1.0)


def edited_case(tmp_path, label, value):
    """The committed turbulent case with one InflowWind input changed: the .fst and
    the InflowWind deck copied to tmp_path, every other file named by its path."""
    fst = (CASE / "turbulent_08.fst").read_text()
    for name in ("turbulent_08_ElastoDyn.dat", "turbulent_08_ServoDyn.dat",
                 "../../../../studies/data/openfast/common/NREL5MW_AD_v5.dat"):
        fst = fst.replace(f'"{name}"', f'"{(CASE / name).resolve()}"')
    ifw = (CASE / "turbulent_08_InflowWind.dat").read_text().replace('"turbulent_08.bts"',
                                                                     f'"{CASE / "turbulent_08.bts"}"')
    lines = [f"{value:>14}   {label}  - edited" if line.split()[1:2] == [label] else line
             for line in ifw.splitlines()]
    (tmp_path / "turbulent_08_InflowWind.dat").write_text("\n".join(lines) + "\n")
    (tmp_path / "case.fst").write_text(fst)
    return tmp_path / "case.fst"


@pytest.mark.parametrize("label, value", [("WindType", "4"), ("VFlowAng", "8.0")])
def test_unsupported_inflowwind_options_exit_2(tmp_path, label, value):
    """WindType 4 (Bladed full field) and a full field tilted by an upflow
    (a full field turned by PropagationDir is modelled since session 28:
    tests/test_openfast_more.py -k turned): one line naming the InflowWind
    deck and the input, exit code 2."""
    proc = subprocess.run([sys.executable, "-m", "modesel", "simulate", str(edited_case(tmp_path, label, value)),
                           "--tmax", "1", "--out", str(tmp_path / "out.csv")], capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    line, = proc.stderr.strip().splitlines()
    assert "turbulent_08_InflowWind.dat" in line and label in line and "Traceback" not in proc.stderr


def test_a_toml_scene_takes_a_full_field(tmp_path):
    """[effects.wind] full_field = "file.bts" in a TOML scene: the rotor turns in
    the field (the committed turbulent_08 file), the wind's other keys are
    refused beside it, and a rotor the grid does not cover is named before
    anything is integrated."""
    from modesel.simulation.api import load_scene, simulate
    bts = CASE / "turbulent_08.bts"
    scene_text = (ROOT / "studies" / "scenes" / "turbine_wind_11p4.toml").read_text()
    scene_text = scene_text.replace("wind = { speed = 11.4 }", f"wind = {{ full_field = {str(bts)!r} }}")
    scene_text = scene_text.replace("equilibrium = true", "equilibrium = false")
    path = tmp_path / "turbulent.toml"
    path.write_text(scene_text)
    out = simulate(load_scene(path), tmax=2.0).outputs
    assert np.all(np.isfinite(out.RotSpeed)) and out.RtVAvgxh.iloc[-1] == pytest.approx(7.5, abs=1.0)
    both = tmp_path / "both.toml"
    both.write_text(scene_text.replace(f"full_field = {str(bts)!r}", f"full_field = {str(bts)!r}, speed = 8.0"))
    with pytest.raises(ModeselError, match="full_field"):
        simulate(load_scene(both), tmax=1.0)
    with pytest.raises(ModeselError, match="frozen turbulence") as err:      # 70 s of file, 8.75 s shift
        simulate(load_scene(path), tmax=65.0)
    assert "turbulent_08.bts" in str(err.value)
