"""The report's Campbell sweep (`study.report.campbell_sweep`): the
structure linearised at constant rotor speeds, labelled by participation in
multi-blade coordinates, against OpenFAST 5.0's own linearisation of the
same ElastoDyn deck (tests/data/openfast_lin) parked and at 12.1 rpm, and a
turbine scene with aerodynamics whose 0 rpm point keeps every mode."""
from pathlib import Path

import pytest

from modesel.simulation.api import load_scene
from modesel.simulation.coleman import openfast_modes
from modesel.study import report
from modesel.turbine.openfast_output import read_openfast_lin

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "openfast_lin"
TOLERANCE = 0.005          # as tests/test_openfast_linearization.py


def _check(modes, ref):
    ours = [(m.frequency_hz, m.label) for m in modes]
    assert [label for _, label in ours] == [label for _, _, label in ref], (ours, ref)
    for (f, label), (f_ref, _, _) in zip(ours, ref):
        assert abs(f / f_ref - 1.0) <= TOLERANCE, (label, f, f_ref)


def test_sweep_matches_openfast_parked_and_rotating_labels_included():
    scene = load_scene(DATA / "parked" / "parked_lin_ElastoDyn.dat")
    (_, parked), (_, turning) = report.campbell_sweep(scene, None, [0.0, 12.1])
    _check(parked, openfast_modes([read_openfast_lin(DATA / "parked" / "parked_lin.1.lin.gz")]))
    files = sorted((DATA / "rotating").glob("rotating_lin_az*.1.lin.gz"))
    _check(turning, openfast_modes([read_openfast_lin(p) for p in files]))
    # the parked cyclic pair is cos/sin; turning, the same pair whirls backward and forward
    assert {report.mode_kind(m) for m in parked if m.label.startswith("E1")} == \
        {("E1", "cyclic (cos)"), ("E1", "cyclic (sin)"), ("E1", "collective")}
    assert {report.mode_kind(m) for m in turning if m.label.startswith("E1")} == \
        {("E1", "backward whirl"), ("E1", "forward whirl"), ("E1", "collective")}


def test_parked_point_of_a_scene_with_aerodynamics_keeps_every_mode():
    """turbine_wind_08 (BEM in 8 m/s): the sweep is structural, so its 0 rpm
    point has the modes of 0.5 rpm and of 12.1 rpm, each with its own label
    (TFA1 near 0.32 Hz, not the drivetrain; E1_coll present), none overdamped."""
    scene = load_scene(ROOT / "studies" / "scenes" / "turbine_wind_08.toml")
    sweep = report.campbell_sweep(scene, None, [0.0, 0.5, 12.1])
    labels = [sorted(m.label for m in modes) for _, modes in sweep]
    assert labels[0] == labels[1] == labels[2], labels
    assert {"TFA1", "TSS1", "DrTr", "TTor1", "F1_coll", "E1_coll"} <= set(labels[0])
    at = [{m.label: m for m in modes} for _, modes in sweep]
    for label, m in at[0].items():
        assert abs(m.damping_ratio) < 0.1, (label, m.damping_ratio)
        assert abs(at[1][label].frequency_hz / m.frequency_hz - 1.0) < 0.01, label   # continuous from rest
    assert at[0]["TFA1"].frequency_hz < 0.4 < at[0]["DrTr"].frequency_hz


def test_linearize_warns_about_aerodynamics_at_rest(capsys):
    from modesel.cli import main
    scene = ROOT / "studies" / "scenes" / "turbine_wind_08.toml"
    assert main(["linearize", str(scene), "--rpm", "0"]) == 0
    assert "at 0 rpm the rotor has no tangential inflow" in capsys.readouterr().err
    assert report.aero_at_rest_warning(load_scene(scene), [6.0]) is None
    # --no-aero: the structure, as the report's diagram; every mode there at rest, no warning
    import json
    assert main(["linearize", str(scene), "--rpm", "0", "--no-aero", "--json"]) == 0
    captured = capsys.readouterr()
    labels = {m["label"] for m in json.loads(captured.out)["campbell"][0]["modes"]}
    assert {"TFA1", "DrTr", "E1_coll"} <= labels and "warning" not in captured.err
