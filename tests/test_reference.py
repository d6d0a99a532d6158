"""References: reading and checking files, resampling onto the simulation
grid, units, and the converged internal reference."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from modesel.errors import ModeselError
from modesel.study.reference import internal_reference, load_reference, unit_factor
from test_search import FAKE_ENGINE, RATIO, FakeScene, fake_simulate, response

DECAY = Path(__file__).parent / "data/openfast_free_decay/tower_fa_ss_shaft/Main_Spar_ED.outb"


def write_csv(path: Path, columns: dict) -> Path:
    pd.DataFrame(columns).to_csv(path, index=False)
    return path


def sim_frame(t, **channels) -> pd.DataFrame:
    return pd.DataFrame({"Time": t, **channels})


def test_csv_with_units_mapping_and_offset(tmp_path):
    t = np.linspace(0.0, 10.0, 11)
    path = write_csv(tmp_path / "ref.csv", {"Time [s]": t, "TwrTpFA (m)": 2 * t + 1, "Other": t})
    ref = load_reference(path, "csv", ["TTDspFA"], mapping={"TTDspFA": "TwrTpFA"}, time_offset=0.5)
    np.testing.assert_array_equal(ref.time, t + 0.5)
    np.testing.assert_array_equal(ref.channels["TTDspFA"], 2 * t + 1)
    assert ref.units == {"TTDspFA": "m"}


def test_align_interpolates_linearly_within_the_overlap_and_window(tmp_path):
    """A reference finer than the simulation is interpolated onto the
    simulation's samples in the overlap (and window); a coarser one keeps its
    own samples there and the simulation is interpolated onto them, so that
    the coarse series' interpolation error is not counted as the model's
    (a format sweep: a 0.1-s OpenFAST output against 0.05-s outputs scored the
    deck's own modes 0.87 % instead of 0.08 %)."""
    t_fine = np.arange(2.0, 8.0 + 1e-9, 0.125)          # finer than the simulation, starts late, ends early
    fine = write_csv(tmp_path / "fine.csv", {"Time": t_fine, "TTDspFA": 3 * t_fine - 1})
    t_sim = np.arange(0.0, 10.0 + 1e-9, 0.25)
    sim = sim_frame(t_sim, TTDspFA=t_sim ** 2)
    aligned = load_reference(fine, "csv", ["TTDspFA"]).align(sim, ["TTDspFA"])
    np.testing.assert_array_equal(aligned.time, t_sim[(t_sim >= 2.0) & (t_sim <= 8.0)])
    # a linear function is reproduced exactly by linear interpolation
    np.testing.assert_allclose(aligned.ref["TTDspFA"], 3 * aligned.time - 1, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(aligned.sim["TTDspFA"], aligned.time ** 2)
    windowed = load_reference(fine, "csv", ["TTDspFA"], window=(4.0, 5.0)).align(sim, ["TTDspFA"])
    np.testing.assert_array_equal(windowed.time, [4.0, 4.25, 4.5, 4.75, 5.0])

    t_coarse = np.linspace(2.0, 8.0, 7)
    coarse = write_csv(tmp_path / "coarse.csv", {"Time": t_coarse, "TTDspFA": t_coarse ** 2})
    aligned = load_reference(coarse, "csv", ["TTDspFA"]).align(sim, ["TTDspFA"])
    np.testing.assert_array_equal(aligned.time, t_coarse)
    np.testing.assert_array_equal(aligned.ref["TTDspFA"], t_coarse ** 2)
    # the simulation's t^2 at the reference's samples (on its own grid: exact at these times)
    np.testing.assert_allclose(aligned.sim["TTDspFA"], t_coarse ** 2, rtol=0, atol=1e-12)


def test_openfast_binary_reference():
    ref = load_reference(DECAY, "openfast", ["Q_TFA1", "Q_TSS1"])
    assert ref.units == {"Q_TFA1": "m", "Q_TSS1": "m"}
    assert ref.time[0] == 0.0 and ref.time[-1] == pytest.approx(4.0)
    # the deck starts the decay from TTDspFA = TTDspSS = 2 m (Q_TSS1 = +2 for TTDspSS = -2)
    assert ref.channels["Q_TFA1"][0] == pytest.approx(2.0, abs=1e-6)
    assert ref.channels["Q_TSS1"][0] == pytest.approx(2.0, abs=1e-6)


def test_a_channel_under_another_of_elastodyns_names(tmp_path):
    """A compared channel the reference file holds under another of
    ElastoDyn's names of the same output (RootMEdg1 = RootMxb1, YawBrTDxt =
    TTDspFA; matched without case) is read from that column; an explicit
    mapping still wins, and a name of no computed output stays unknown."""
    t = np.linspace(0.0, 1.0, 5)
    path = write_csv(tmp_path / "ref.csv", {"Time": t, "RootMxb1": 2 * t, "YAWBRTDXT": 3 * t, "Other": t})
    ref = load_reference(path, "csv", ["RootMEdg1", "TTDspFA", "Q_TFA1"], mapping={"Q_TFA1": "Other"})
    np.testing.assert_array_equal(ref.channels["RootMEdg1"], 2 * t)
    np.testing.assert_array_equal(ref.channels["TTDspFA"], 3 * t)
    assert ref.info["channels"] == {"RootMEdg1": "RootMxb1", "TTDspFA": "YAWBRTDXT", "Q_TFA1": "Other"}
    with pytest.raises(ModeselError, match="RootMzc1"):
        load_reference(path, "csv", ["RootMzc1"])


def test_unit_conversion_and_mismatch():
    assert unit_factor("deg", "rad") == pytest.approx(math.pi / 180)
    assert unit_factor("(rpm)", "rad/s") == pytest.approx(math.pi / 30)
    assert unit_factor("kN-m", "N-m") == 1e3
    assert unit_factor("m", "deg") is None
    t = np.linspace(0, 1, 5)
    ref = load_reference(DECAY, "openfast", ["Azimuth"])
    sim = sim_frame(t, Azimuth=np.zeros(5))
    sim.attrs["units"] = {"Azimuth": "rad"}
    aligned = ref.align(sim, ["Azimuth"])
    np.testing.assert_allclose(aligned.ref["Azimuth"], np.deg2rad(np.interp(t, ref.time, ref.channels["Azimuth"])))
    sim.attrs["units"] = {"Azimuth": "m"}
    with pytest.raises(ModeselError, match=r"Main_Spar_ED\.outb: Azimuth: reference unit 'deg' does not "
                                           r"match the simulation unit 'm'"):
        ref.align(sim, ["Azimuth"])


@pytest.mark.parametrize("columns, pattern", [
    ({"Time": [0.0, 1.0, 1.0, 2.0], "TTDspFA": [0, 1, 2, 3]}, r"Time: duplicated time 1 s at row 2"),
    ({"Time": [0.0, 2.0, 1.0, 3.0], "TTDspFA": [0, 1, 2, 3]}, r"Time: time is not increasing: 2 s then 1 s"),
    ({"Time": [0.0, 1.0, float("nan"), 3.0], "TTDspFA": [0, 1, 2, 3]}, r"Time: NaN, infinite or non-numeric value at row 2"),
    ({"Time": [0.0, 1.0, 2.0, 3.0], "TTDspFA": [0, float("nan"), 2, 3]},
     r"TTDspFA: NaN, infinite or non-numeric value at row 1"),
    ({"Time": [0.0, 1.0, 2.0, 3.0], "TTDspFA": [0, float("inf"), 2, 3]},
     r"TTDspFA: NaN, infinite or non-numeric value at row 1"),
    ({"Time": [0.0, 1.0, 2.0, 3.0], "TTDspFA": [0, "x", 2, 3]}, r"TTDspFA: NaN, infinite or non-numeric"),
    ({"Time": [0.0, 1.0, 2.0, 3.0], "TTDspFX": [0, 1, 2, 3]},
     r"TTDspFA: unknown channel 'TTDspFA' \(did you mean 'TTDspFX'\?\)"),
    ({"time": [0.0, 1.0, 2.0, 3.0], "TTDspFA": [0, 1, 2, 3]},
     r"Time: unknown time column 'Time' \(did you mean 'time'\?\)"),
    ({"Time": [0.0], "TTDspFA": [1.0]}, r"Time: needs at least 2 time samples"),
])
def test_bad_reference_files(tmp_path, columns, pattern):
    path = write_csv(tmp_path / "ref.csv", columns)
    with pytest.raises(ModeselError, match=str(path).replace(".", r"\.") + ": " + pattern) as info:
        load_reference(path, "csv", ["TTDspFA"])
    assert "\n" not in str(info.value)


def test_missing_and_unreadable_files(tmp_path):
    with pytest.raises(ModeselError, match="reference file not found"):
        load_reference(tmp_path / "none.csv", "csv", ["TTDspFA"])
    with pytest.raises(ModeselError, match="not found"):
        load_reference(tmp_path / "none.outb", "openfast", ["TTDspFA"])
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(ModeselError, match="empty.csv: cannot read CSV"):
        load_reference(tmp_path / "empty.csv", "csv", ["TTDspFA"])


def test_align_errors(tmp_path):
    path = write_csv(tmp_path / "ref.csv", {"Time": [10.0, 11.0, 12.0], "TTDspFA": [0.0, 1.0, 0.0]})
    ref = load_reference(path, "csv", ["TTDspFA"])
    t = np.linspace(0.0, 5.0, 11)
    with pytest.raises(ModeselError, match=r"ref\.csv: Time: simulation \[0, 5\] s and reference \[10, 12\] s "
                                           r"share fewer than 2 samples"):
        ref.align(sim_frame(t, TTDspFA=t), ["TTDspFA"])
    t_late = np.linspace(10.0, 12.0, 5)
    with pytest.raises(ModeselError, match=r"TTDspFA: unknown simulation channel 'TTDspFA' "
                                           r"\(did you mean 'TTDspSS'\?\)"):
        ref.align(sim_frame(t_late, TTDspSS=t_late), ["TTDspFA"])
    with pytest.raises(ModeselError, match=r"ref\.csv: OoPDefl1: unknown reference channel 'OoPDefl1'"):
        ref.align(sim_frame(t_late, OoPDefl1=t_late), ["OoPDefl1"])
    with pytest.raises(ModeselError, match=r"duplicated time"):
        ref.align(sim_frame(np.zeros(3), TTDspFA=np.zeros(3)), ["TTDspFA"])


class Counting:
    def __init__(self):
        self.calls = []

    def __call__(self, scene, modeset=None, *, tmax=None, dt=None):
        self.calls.append(modeset.label())
        return fake_simulate(scene, modeset, tmax=tmax, dt=dt)


def test_internal_reference_converges_field_by_field_and_is_cached(tmp_path):
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text("# fake\n")
    scene = FAKE_ENGINE.load_scene(scene_file)
    sim = Counting()
    kwargs = dict(family="test_exact", tolerance=1e-3, tmax=20.0, dt=0.05, cache_dir=tmp_path / "cache")
    ref = internal_reference(scene, ["TTDspFA", "OoPDefl1"], sim, **kwargs)
    counts = ref.info["counts"]
    history = ref.info["changes"]
    for fld in ("tower_fa", "blade_flap"):
        steps = [h for h in history if h["field"] == fld]
        assert steps[-1]["count"] == counts[fld]
        assert steps[-1]["change"] < 1e-3 <= steps[-2]["change"]      # stopped at the first small change
        # one more harmonic of amplitude RATIO**(n-1) changes the response by about that much
        assert all(0.2 < b["change"] / a["change"] < 0.45 for a, b in zip(steps, steps[1:]))
    assert min(counts.values()) >= 3
    t = np.arange(0.0, 20.0 + 0.025, 0.05)
    np.testing.assert_allclose(ref.channels["TTDspFA"], response("tower_fa", t, counts["tower_fa"]))
    n_calls = len(sim.calls)
    assert n_calls == 1 + sum(counts.values()) - 2        # start at 1 mode each, one run per step
    again = internal_reference(scene, ["TTDspFA", "OoPDefl1"], sim, **kwargs)
    assert len(sim.calls) == n_calls                      # served from the cache
    assert again.info == ref.info
    np.testing.assert_allclose(again.channels["OoPDefl1"], ref.channels["OoPDefl1"], rtol=1e-15)
    internal_reference(scene, ["TTDspFA", "OoPDefl1"], sim, **dict(kwargs, tolerance=1e-2))
    assert len(sim.calls) > n_calls                       # other settings, other cache entry


def test_internal_reference_that_does_not_converge(tmp_path):
    scene = FakeScene("s", str(tmp_path / "s.toml"))
    with pytest.raises(ModeselError, match=r"tower_fa: internal reference did not converge: test_exact:3 "
                                           r"still changes the response by"):
        internal_reference(scene, ["TTDspFA"], fake_simulate, family="test_exact", tolerance=1e-3,
                           max_count=3, tmax=20.0, dt=0.05)
    assert RATIO ** 2 > 1e-3   # the third harmonic still matters at 3 modes
