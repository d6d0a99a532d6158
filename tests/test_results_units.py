"""Every CSV modesel writes carries its units (a second header row, as
OpenFAST text outputs), read back by the one-liner the README documents;
the study-file reference matches the validator's schema; `simulate` says
which DOFs and effects ran and warns about settings that act on nothing."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from modesel.cli import main
from modesel.files import read_unit_csv
from modesel.study import schema
from test_search import make_study, run_fake_study

REPO = Path(__file__).resolve().parents[1]


def read_with_units(path):
    """The README's one-liner."""
    return pd.read_csv(path, header=[0, 1])


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    return run_fake_study(tmp_path_factory.mktemp("units"), 10, "--quiet")


def test_trials_and_pareto_csv_carry_units_and_rank(finished):
    for name in ("trials.csv", "pareto.csv"):
        df = read_with_units(finished / name)
        units = dict(df.columns)
        assert units["error_pct"] == "(%)" and units["error_pct_TTDspFA"] == "(%)", name
        assert units["wall_time_s"] == "(s)" and units["cost_wall_s_per_sim_s"] == "(s/s)", name
        assert units["speed_x_real_time"] == "(sim s/wall s)", name
        assert list(df["rank"].iloc[:, 0]) == list(range(1, len(df) + 1)), name
        flat = df.droplevel(1, axis=1)
        # percent: the worst channel, 100 x the fraction the criterion uses
        np.testing.assert_allclose(flat["error_pct"], flat[["error_pct_TTDspFA", "error_pct_OoPDefl1"]].max(axis=1))
        done = flat[flat["status"] == "COMPLETE"]
        np.testing.assert_allclose(done["speed_x_real_time"] * done["cost_wall_s_per_sim_s"], 1.0, rtol=1e-6)
    trials = read_with_units(finished / "trials.csv").droplevel(1, axis=1)
    assert trials["rank_group"].iloc[0].startswith("meets tolerance: cheapest first")
    meets = trials[trials["meets_tolerance"]]
    assert (meets["error_pct"] <= 3.5).all() and (trials.loc[~trials["meets_tolerance"], "error_pct"] > 3.5).all()


def test_time_series_csv_carry_units_and_read_back(finished):
    files = sorted((finished / "timeseries").glob("*.csv"))
    assert any(p.name == "reference.csv" for p in files) and len(files) >= 2
    for path in files:
        df = read_with_units(path)
        units = dict(df.columns)
        assert units["scene"] == "(-)" and units["Time"] == "(s)"
        assert units["TTDspFA"] == "(m)" and units["OoPDefl1"] == "(m)"
        flat = read_unit_csv(path)
        assert flat.attrs["units"]["TTDspFA"] == "m" and flat["Time"].dtype == float


def test_csv_reference_accepts_a_unit_row(tmp_path):
    from modesel.study.reference import _read_csv
    t = np.linspace(0, 1, 5)
    (tmp_path / "plain.csv").write_text("Time,TTDspFA\n" + "".join(f"{a},{2 * a}\n" for a in t))
    (tmp_path / "units.csv").write_text("Time,TTDspFA\n(s),(m)\n" + "".join(f"{a},{2 * a}\n" for a in t))
    plain, units = _read_csv(tmp_path / "plain.csv"), _read_csv(tmp_path / "units.csv")
    pd.testing.assert_frame_equal(plain, units)
    assert units.attrs["units"] == {"Time": "s", "TTDspFA": "m"} and plain.attrs["units"] == {}


def test_columns_csv_is_the_pandas_csv_without_pandas(tmp_path):
    """`modesel simulate` writes its CSV from the result's columns
    (`files.columns_csv_text`): the text pandas writes for the same table
    (NaN empty, signed zeros and infinities, "%.9g"), read back alike."""
    from modesel.files import columns_csv_text, unit_csv_text
    rng = np.random.default_rng(3)
    columns = {"Time": np.arange(7) * 0.05, "RtAeroMxh": rng.normal(size=7) * 1e7,
               "GenPwr": np.array([np.nan, -0.0, np.inf, -np.inf, 1e-300, 5.0, np.nan]),
               "Q_B1F1": rng.normal(size=7) * 1e-9}
    units = {"Time": "s", "RtAeroMxh": "N m", "GenPwr": "kW"}
    text = columns_csv_text(columns, units)
    assert text == unit_csv_text(pd.DataFrame(columns), units)
    (tmp_path / "out.csv").write_text(text)
    back = read_unit_csv(tmp_path / "out.csv")
    assert back.attrs["units"] == {"Time": "s", "RtAeroMxh": "N m", "GenPwr": "kW", "Q_B1F1": "-"}
    np.testing.assert_allclose(back["RtAeroMxh"], columns["RtAeroMxh"], rtol=1e-8)
    assert back["GenPwr"].isna().tolist() == [True, False, False, False, False, False, True]


def test_study_file_reference_is_generated_from_the_schema():
    """docs/study-file.md is what `modesel docs study-file` prints (a fresh
    process: the tests register fake families in this one)."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    text = subprocess.run([sys.executable, "-m", "modesel", "docs", "study-file"], cwd=REPO, env=env,
                          capture_output=True, text=True, check=True).stdout
    assert (REPO / "docs" / "study-file.md").read_text() == text, \
        "docs/study-file.md is stale: run `modesel docs study-file > docs/study-file.md`"
    for t in schema.TABLES:
        for k in t.keys:
            assert f"| `{k.name}` |" in text
    from modesel.study.metrics import METRICS
    assert all(m.formula for m in METRICS.values())


def test_validator_allows_exactly_the_schema_keys(tmp_path, capsys):
    """spec.py takes its allowed keys and defaults from schema.py."""
    from modesel.study.spec import parse_study
    study = make_study(tmp_path, n_trials=2)
    parsed = parse_study(study.read_text(), study)
    assert parsed.search.sampler == schema.default("search", "sampler")
    assert parsed.run.n_jobs == schema.default("run", "n_jobs")
    assert parsed.budget.keep_searching_trials == schema.default("budget", "keep_searching_trials")
    assert parsed.compare.metric == schema.default("compare", "metric")
    study.write_text(study.read_text().replace("[run]", "[run]\nnot_a_key = 1"))
    assert main(["run", str(study), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "run.not_a_key: unknown key" in err and err.count("\n") == 1


def test_run_help_points_to_the_study_file_reference(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    assert "docs/study-file.md" in capsys.readouterr().out


def test_simulate_csv_units_dofs_effects_and_inert_wind(tmp_path, capsys):
    scene = tmp_path / "wind_no_aero.toml"
    scene.write_text((REPO / "studies/scenes/paper_2dof_tower_shaft.toml").read_text()
                     .replace("[effects]", "[effects]\nwind = { speed = 8.0 }"))
    out = tmp_path / "o.csv"
    assert main(["simulate", str(scene), "--tmax", "0.5", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    df = read_with_units(out)
    units = dict(df.columns)
    assert units["Time"] == "(s)" and units["TTDspFA"] == "(m)" and units["RotSpeed"] == "(rpm)"
    assert "2 DOFs (TFA1, GeAz)" in captured.out and "effects evaluated: " in captured.out
    assert "x real time" in captured.out
    assert "wind" in captured.out.split("effects evaluated: ")[1].split(";")[0]
    assert "neither aero nor tower_drag is on: the wind loads nothing" in captured.err


def test_progress_bar_and_simulation_line(capsys):
    from modesel.simulation.progress import SimulationProgress, speed_text
    from modesel.study.search.progress import Progress
    bar = Progress(4, "s", enabled=True, quiet=False)
    bar.set(2, 0.0123, 1)
    bar.close()
    err = capsys.readouterr().err
    assert "2/4 trials" in err and "best error 1.23 %" in err and "1 failed" in err and "ETA" in err
    quiet = Progress(4, "s", enabled=False)          # --quiet: no bar, no compile notice
    quiet.set(1, 0.5, 0)
    quiet.close()
    assert quiet.bar is None and capsys.readouterr().err == ""
    # 20 s simulated in 87 s: two significant digits, not "0x"
    assert speed_text(20.0, 87.0) == "0.23x real time"
    assert speed_text(800.0, 4.58) == "170x real time"         # not "1.7e+02x"
    line = SimulationProgress("scene: ", enabled=True).line(5.0, 20.0, 10.0)
    assert line == "scene: simulated 5 of 20 s, 0.5x real time, ETA 30 s"


def test_simulate_leaves_out_the_channels_a_search_does_not_compare():
    """`simulate(..., channels=...)` (what a search trial asks for): the rotor
    aerodynamics, generator and reaction-load channels are left out unless
    named, the rest is the full run's, value for value; each effect's
    `CHANNELS` names what its `channels` returns."""
    from modesel.simulation.api import build, load_scene, simulate
    path = Path(__file__).resolve().parents[1] / "studies" / "scenes" / "turbine_wind_11p4.toml"
    scene = load_scene(str(path))
    full = simulate(scene, tmax=1.0).outputs
    some = simulate(load_scene(str(path)), tmax=1.0, channels=["TTDspFA", "OoPDefl1", "GenPwr"]).outputs
    assert {"RtAeroFxh", "RtAeroCp", "RootMxc1"} <= set(full.columns)
    left_out = set(full.columns) - set(some.columns)
    assert {"RtAeroFxh", "RtAeroMxh", "RtAeroPwr", "RtAeroCp", "RootMxc1", "TwrBsMyt", "RotThrust"} <= left_out
    assert "GenPwr" in some.columns and "GenTq" in some.columns      # the generator's channels come together
    for c in some.columns:
        assert np.array_equal(some[c].to_numpy(), full[c].to_numpy()), c
    built = build(load_scene(str(path)))
    for e in built.acting:
        if e.CHANNELS:
            q_all, qd_all, _ = built.eq.full_state(built.q0, built.qd0 + 0.1, 0.0)
            e(built, 0.0, q_all, qd_all, np.zeros(built.eq.n_all), {})
            assert set(e.channels(built)) == set(e.CHANNELS), e.name
