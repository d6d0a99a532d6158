"""Results files, report.html and the run/report/worker commands (through
modesel.cli.main) on the fake problem of test_search.py."""
from __future__ import annotations

import json
import re

import numpy as np
import pandas as pd
import pytest

import modesel.study.search.engine
from modesel.cli import main
from test_search import FAKE_ENGINE, make_study, run_fake_study


def read_table(path) -> pd.DataFrame:
    """A CSV modesel writes, by the documented one-liner (README: second header row of units)."""
    return pd.read_csv(path, header=[0, 1]).droplevel(1, axis=1)


@pytest.fixture(autouse=True)
def fake_engine(monkeypatch):
    monkeypatch.setattr(modesel.study.search.engine, "default_engine", lambda: FAKE_ENGINE)


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """One `modesel run` of 25 sets, shared by the read-only tests."""
    return run_fake_study(tmp_path_factory.mktemp("run"), 25)


def test_trials_csv_is_ranked_with_the_documented_columns(finished):
    df = read_table(finished / "trials.csv")
    for col in ("rank", "trial", "modeset", "tower_fa_family", "tower_fa_count", "blade_flap_family",
                "blade_flap_count", "n_dofs", "error_pct", "error_pct_TTDspFA", "error_pct_OoPDefl1",
                "wall_time_s", "speed_x_real_time", "cost_wall_s_per_sim_s", "meets_tolerance", "status",
                "reason", "rank_group"):
        assert col in df.columns, col
    assert list(df["rank"]) == list(range(1, len(df) + 1))
    assert len(df) == 25 and df["modeset"].is_unique          # one row per evaluated set
    meets = df[df["meets_tolerance"]]
    assert meets["rank"].max() < df[~df["meets_tolerance"]]["rank"].min()
    assert list(meets["cost_wall_s_per_sim_s"]) == sorted(meets["cost_wall_s_per_sim_s"])
    rest = df[~df["meets_tolerance"]]
    assert list(rest["error_pct"]) == sorted(rest["error_pct"])
    assert set(meets["rank_group"]) == {"meets tolerance: cheapest first (cost, DOFs, error)"}
    # the error is the worst channel
    np.testing.assert_allclose(df["error_pct"], df[["error_pct_TTDspFA", "error_pct_OoPDefl1"]].max(axis=1))
    # labels are ModeSet.label() and agree with the family/count columns
    row = df.iloc[0]
    assert row["modeset"] == (f"tower_fa={row['tower_fa_family']}:{row['tower_fa_count']} "
                              f"blade_flap={row['blade_flap_family']}:{row['blade_flap_count']}")


def test_pareto_csv_is_the_non_dominated_set(finished):
    trials = read_table(finished / "trials.csv")
    front = read_table(finished / "pareto.csv")
    assert list(front["rank"]) == list(range(1, len(front) + 1))
    assert list(front["cost_wall_s_per_sim_s"]) == sorted(front["cost_wall_s_per_sim_s"])
    assert list(front["error_pct"]) == sorted(front["error_pct"], reverse=True)
    for _, r in trials.iterrows():
        dominated = ((front["cost_wall_s_per_sim_s"] <= r["cost_wall_s_per_sim_s"]) & (front["error_pct"] <= r["error_pct"])).any()
        assert dominated
    for _, f in front.iterrows():
        better = trials[(trials["cost_wall_s_per_sim_s"] <= f["cost_wall_s_per_sim_s"]) & (trials["error_pct"] < f["error_pct"])]
        assert better.empty


def test_best_modeset_is_the_cheapest_meeting_tolerance(finished):
    best = json.loads((finished / "best_modeset.json").read_text())
    trials = read_table(finished / "trials.csv")
    meets = trials[trials["meets_tolerance"]].sort_values(["cost_wall_s_per_sim_s", "n_dofs", "error_pct"])
    assert best["selection"] == "cheapest set meeting the tolerance"
    assert best["label"] == meets.iloc[0]["modeset"] and best["trial"] == meets.iloc[0]["trial"]
    assert best["meets_tolerance"] is True and best["error"] <= best["tolerance"] == 0.035
    from modesel.modeset import ModeSet
    assert ModeSet.from_dict(best).label() == best["label"]


def test_report_is_self_contained_and_states_each_tolerance(finished):
    text = (finished / "report.html").read_text()
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", text)
    assert "http" not in text                                  # not even namespace URIs
    assert "<script" not in text and "<link" not in text
    trials = read_table(finished / "trials.csv")
    order = ["cost_wall_s_per_sim_s", "n_dofs", "error_pct"]
    cheapest = trials[trials["error_pct"] <= 3.5].sort_values(order).iloc[0]
    tight = trials[trials["error_pct"] <= 1.0].sort_values(order).iloc[0]
    per_s = cheapest["wall_time_s"] / cheapest["simulated_time_s"]
    assert (f"3.5 % needs {cheapest['modeset']} ({cheapest['n_dofs']} DOFs, {per_s:.3g} s per simulated s)."
            in text)
    ratio = tight["cost_wall_s_per_sim_s"] / cheapest["cost_wall_s_per_sim_s"]
    assert re.search(rf"1 % needs {re.escape(tight['modeset'])} \({tight['n_dofs']} DOFs, [0-9.e-]+ s per "
                     rf"simulated s\) at {ratio:.3g} times the cost\.", text)
    assert text.count("<svg") == 5         # Pareto, history, one scene's series, its error over time, shapes


def test_report_axes_units_layout_and_pareto_titles(finished):
    """The issue's check: every axis label of a physical channel carries a unit,
    no table is wider than its container, nothing external, every Pareto point
    identifiable, legends outside the data."""
    text = (finished / "report.html").read_text()
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", text)
    # every reference is to an element of the page itself
    refs = re.findall(r"url\(([^)]*)\)", text) + re.findall(r"""(?:xlink:)?href\s*=\s*["']([^"']*)""", text)
    assert refs and all(r.strip("'\" ").startswith("#") for r in refs), sorted(set(refs))[:5]
    # tables sit in a box that scrolls sideways; the page is at most 1300 px wide
    style = re.search(r"<style>(.*?)</style>", text, re.S).group(1)
    assert re.search(r"\.scroll\{[^}]*max-width:100%[^}]*overflow-x:auto", style)
    assert text.count("<table") == text.count("<div class='scroll'><table")
    assert "max-width:1300px" in style
    # axis labels (svg.fonttype none: <text> elements) of every channel carry its unit
    labels = re.findall(r"<text[^>]*>([^<]*)</text>", text)
    from modesel.model.outputs import channel_unit
    for ch in ("TTDspFA", "OoPDefl1"):
        assert f"{ch} [{channel_unit(ch)}]" in labels, (ch, labels[:40])
    assert "time [s]" in labels and any(lab.startswith("error [%]") for lab in labels)
    assert "cost [wall s per simulated s]" in labels and "error over time" in " ".join(labels)
    # every completed set is a hoverable point with its trial number and set
    trials = read_table(finished / "trials.csv")
    titles = re.findall(r"<title>#(\d+) (.+?): error ", text)
    done = trials[trials["status"] == "COMPLETE"]
    assert {int(n) for n, _ in titles} == set(done["trial"])
    assert all(dict(zip(done["trial"], done["modeset"]))[int(n)] == label for n, label in titles)
    # percent everywhere: no level written as a fraction
    assert "cheapest within 3.5 %" in text and "within 0.035" not in text


def test_report_rerenders_from_storage(finished, capsys):
    before = read_table(finished / "trials.csv")
    (finished / "trials.csv").unlink()
    (finished / "report.html").unlink()
    for path in (finished / "timeseries").glob("trial_*.csv"):
        path.unlink()
    assert main(["report", str(finished)]) == 0
    pd.testing.assert_frame_equal(read_table(finished / "trials.csv"), before)
    assert (finished / "report.html").exists()
    # the featured sets were simulated again for the overlays
    assert "simulating again trials" in capsys.readouterr().err
    assert len(list((finished / "timeseries").glob("trial_*.csv"))) >= 2


def test_failed_trials_and_unmet_levels_in_the_report(tmp_path, capsys):
    study = make_study(tmp_path, tower_families='["test_exact", "test_unstable"]', n_trials=8)
    study.write_text(study.read_text().replace("levels = [0.01]", "levels = [0.01, 1e-9]"))
    assert main(["run", str(study), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "0.0000001 % is not met by any of the" in out or "1e-07 % is not met by any of the" in out
    text = (tmp_path / "out/report.html").read_text()
    assert "Failed trials" in text and "diverged at t=3.25 s" in text
    trials = read_table(tmp_path / "out/trials.csv")
    failed = trials[trials["status"] == "FAIL"]
    assert not failed.empty and failed["reason"].str.contains("beyond bounds").all()
    assert failed["rank"].min() > trials[trials["status"] == "COMPLETE"]["rank"].max()


def test_run_twice_resumes(tmp_path, capsys):
    study = make_study(tmp_path, n_trials=5)
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out)]) == 0
    assert main(["run", str(study), "--out", str(out), "--seed", "3"]) == 0
    assert "this run evaluated 5 new mode sets" in capsys.readouterr().out
    assert len(read_table(out / "trials.csv")) == 10


def test_worker_with_sqlite_then_report(tmp_path, capsys):
    study = make_study(tmp_path, n_trials=3)
    url = f"sqlite:///{tmp_path / 'shared.db'}"
    assert main(["worker", str(study), "--storage", url]) == 0
    assert main(["worker", str(study), "--storage", url, "--n-trials", "2"]) == 0
    assert "this worker evaluated 2 new mode sets" in capsys.readouterr().out
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out), "--storage", url, "--n-trials", "1"]) == 0
    trials = read_table(out / "trials.csv")
    assert len(trials) == 6
    assert json.loads((out / "run.json").read_text())["storage"] == url
    # the workers kept no time series: the featured sets are simulated again for the report
    # (whether `run`'s own trial is featured depends on the workers' host/pid-salted seeds, so
    # the report is rendered again with no trial series kept at all)
    capsys.readouterr()
    for series in (out / "timeseries").glob("trial_*.csv"):
        series.unlink()
    assert main(["report", str(out)]) == 0
    assert "simulating again trials" in capsys.readouterr().err
    assert (out / "report.html").read_text().count("<svg") == 5


@pytest.mark.parametrize("make_args, pattern", [
    (lambda d, s: ["run", str(s), "--out", str(d / "out")], r"study\.toml: not valid TOML: .*\(at line 3"),
    (lambda d, s: ["run", str(s), "--out", str(d / "file.txt" / "out")], r"cannot create output folder"),
    (lambda d, s: ["run", str(s), "--out", str(d / "out"), "--storage", "postgresql://u:pw@127.0.0.1:1/x"],
     r"postgresql://u:\*\*\*@127\.0\.0\.1:1/x: cannot open storage"),
    (lambda d, s: ["report", str(d)], r"not a modesel output folder \(no run\.json\)"),
    (lambda d, s: ["worker", str(s), "--storage", f"sqlite:///{d / 'none' / 'x.db'}"], r"cannot open storage"),
])
def test_cli_errors_are_one_line_and_exit_2(tmp_path, capsys, make_args, pattern):
    study = make_study(tmp_path, n_trials=2)
    (tmp_path / "file.txt").write_text("x")
    if "TOML" in pattern:
        study.write_text("[study]\nname = 'x'\n[[scene]\n")
    assert main(make_args(tmp_path, study)) == 2
    err = capsys.readouterr().err
    assert err.startswith("modesel: error: ") and err.count("\n") == 1, err
    assert re.search(pattern, err), err
    assert "pw" not in err


def test_cli_unknown_key_is_one_line(tmp_path, capsys):
    study = make_study(tmp_path, n_trials=2)
    study.write_text(study.read_text().replace("n_trials = 2", "n_trails = 2"))
    assert main(["run", str(study), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "budget.n_trails: unknown key 'n_trails' (did you mean 'n_trials'?)" in err
    assert err.count("\n") == 1


def test_campbell_diagram_in_the_report_of_a_rotating_scene(finished, tmp_path):
    """The chosen set's Campbell diagram is drawn when the scene turns a rotor
    (here the paper's rotating blade at 12.1 rpm, frequencies against rpm)."""
    from pathlib import Path

    from modesel.simulation.api import effective_modeset, load_scene
    from modesel.study import report
    from modesel.study.results import read_run_info, write_results
    from modesel.study.search import open_study
    from modesel.study.spec import parse_study
    info = read_run_info(finished)
    study = parse_study(info["study_toml"], info["study_file"])
    summary = write_results(tmp_path, open_study(study, info["storage"], create=False), study)
    scene = load_scene(Path(__file__).resolve().parents[1] / "studies/scenes/paper_rotating_blade.toml")
    assert report.has_rotor(scene) and abs(report.scene_rpm(scene) - 12.1) < 1e-9
    notes = []
    page = report.render(finished, study, summary, [], effective_modeset(scene, None), scene, notes, {})
    assert "<h2>Campbell diagram</h2>" in page, notes
    campbell = page[page.index("<div class='fig campbell'>"):]
    campbell = campbell[:campbell.index("</svg>")]
    texts = re.findall(r"<text[^>]*>([^<]*)</text>", campbell)
    assert {"1P", "3P", "6P", "rotor speed [rpm]", "frequency [Hz]"} <= {t.strip() for t in texts}, texts


def test_linearize_plot_writes_a_campbell_svg(tmp_path, capsys):
    from pathlib import Path
    scene = Path(__file__).resolve().parents[1] / "studies/scenes/paper_rotating_blade.toml"
    out = tmp_path / "campbell.svg"
    assert main(["linearize", str(scene), "--rpm", "0,6,12.1", "--plot", str(out)]) == 0
    svg = out.read_text()
    assert svg.startswith("<svg") and "rotor speed [rpm]" in svg and "6P" in svg
    # a standalone file: valid XML with the SVG namespaces, and no other URL
    import re
    import xml.dom.minidom
    xml.dom.minidom.parseString(svg)
    assert "http" not in re.sub(r'\sxmlns(:\w+)?="[^"]*"', "", svg)
    assert main(["linearize", str(scene), "--plot", str(out)]) == 2
    assert "needs rotor speeds" in capsys.readouterr().err


def test_report_lists_what_ran_and_draws_every_blade(finished, tmp_path):
    """The chosen set simulated once more on the scene (a real rotating rotor):
    the page lists its DOFs and effects as `modesel simulate` prints them and
    draws every blade's tip OoP/IP panels with units, although the study
    compares only blade 1."""
    from dataclasses import replace
    from pathlib import Path

    from modesel.simulation import api
    from modesel.study import report
    from modesel.study.results import read_run_info, write_results
    from modesel.study.search import open_study
    from modesel.study.search.engine import Engine
    from modesel.study.spec import parse_study
    info = read_run_info(finished)
    study = parse_study(info["study_toml"], info["study_file"])
    summary = write_results(tmp_path, open_study(study, info["storage"], create=False), study)
    scene = api.load_scene(Path(__file__).resolve().parents[1] / "studies/scenes/paper_rotating_blade.toml")
    scene = replace(scene, tmax=1.0)
    engine = Engine(lambda path: scene, api.simulate)
    chosen = api.effective_modeset(scene, None)
    page = report.render(finished, study, summary, [], chosen, None, [], {}, engine=engine)
    ran = page[page.index("<h2>What ran</h2>"):page.index("<h2>Accuracy versus cost</h2>")]
    dofs = api.simulate(scene, chosen, tmax=0.1).dof_names
    assert ", ".join(dofs) in ran and f"<td class=''>{len(dofs)}</td>" in ran
    from modesel.model.effects import effects_in_scene
    on, flags, _ = effects_in_scene(scene, dofs)
    assert f">{', '.join(on) or 'none'}</td><td class='l wrap'>{', '.join(flags)}</td>" in ran
    series = page[page.index("<h2>Time series</h2>"):page.index("<h2>Error of the chosen")]
    texts = {t.strip() for t in re.findall(r"<text[^>]*>([^<]*)</text>", series)}
    for b in (2, 3):
        assert {f"OoPDefl{b} [m]", f"IPDefl{b} [m]", f"OoPDefl{b} (not compared)"} <= texts, sorted(texts)
    assert "OoPDefl1 [m]" in texts and "TTDspFA [m]" in texts      # compared: drawn as before


def test_what_ran_passes_on_the_inert_settings_warnings():
    from dataclasses import replace
    from pathlib import Path
    from types import SimpleNamespace

    from modesel.simulation.api import load_scene
    from modesel.study import report
    scene = load_scene(Path(__file__).resolve().parents[1] / "studies/scenes/turbine_wind_08.toml")
    still = replace(scene, effects=dict(scene.effects, aero=False, tower_drag=False))
    rows = report.what_ran({"s": (still, SimpleNamespace(dof_names=["TFA1", "GeAz"], n_dofs=2))})
    assert rows[0]["n_dofs"] == 2 and rows[0]["dofs"] == "TFA1, GeAz"
    assert "aero" not in rows[0]["effects"].split(", ") and "wind" in rows[0]["effects"]
    assert any("the wind loads nothing" in w for w in rows[0]["warnings"])


def test_tolerance_sentences_name_the_model_cost_they_rank_by():
    """With cost = "model" the sentence gives the ranked (model) cost and the measured wall
    time separately, and the ratio is of model costs."""
    from types import SimpleNamespace
    from modesel.study.report import tolerance_sentences
    ranked = pd.DataFrame([
        dict(trial=3, modeset="a:1", n_dofs=3, error=0.02, cost=0.10, wall_time_s=2.0, simulated_time_s=100.0,
             status="COMPLETE", meets_tolerance=True),
        dict(trial=5, modeset="a:2", n_dofs=5, error=0.005, cost=0.15, wall_time_s=1.0, simulated_time_s=100.0,
             status="COMPLETE", meets_tolerance=True)])
    study = SimpleNamespace(compare=SimpleNamespace(levels=[0.035, 0.01]), search=SimpleNamespace(cost="model"))
    text = tolerance_sentences(ranked, study)
    assert text[0] == "3.5 % needs a:1 (3 DOFs, model cost 0.1 s per simulated s, measured 0.02 s)."
    assert text[1] == ("1 % needs a:2 (5 DOFs, model cost 0.15 s per simulated s, measured 0.01 s) "
                       "at 1.5 times the model cost.")
