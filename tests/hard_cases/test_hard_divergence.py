"""Divergence detection: a simulation that blows up stops early with a typed
failure (`SimulationDiverged`: reason and time), of each kind the integrator
watches for, and in a study that trial is marked failed with its reason while
the study goes on.

Kinds, each provoked on the NREL 5-MW tower (paper_2dof_tower_shaft):
- non-finite: a pathological load that turns NaN at t = 0.5 s;
- state beyond its physical bound: a tower-top mass beyond buckling with the
  stability pre-check switched off ([solver] stability_check = false);
- step-size collapse: a load that is rough at every scale (white noise drawn
  anew at every evaluation, 1e8 m/s^2 per unit modal mass): no step is small
  enough to meet the tolerance.
"""
import numpy as np
import pandas as pd
import pytest

from hardcase_tools import modes, scene
from modesel.cli import main
from modesel.errors import PhysicallyUnstable, SimulationDiverged
from modesel.simulation import api, assembly
from modesel.model.effects.base import Effect

#: nacelle mass between the buckling masses of 1-mode and 2-mode bases
#: (clamped: 1.61e7 and 1.20e7 kg; polynomial: 1.76e7 and 1.27e7 kg)
NEAR_BUCKLING_NACELLE = 1.35e7


class Pathological(Effect):
    """A load on TFA1 from t0 on: NaN, or white noise of `accel` m/s^2 per unit modal mass."""

    name = "pathological"
    loads = True

    def __init__(self, scene_, kind, t0, accel=0.0):
        super().__init__(scene_, {})
        self.kind, self.t0, self.accel = kind, t0, accel
        self.rng = np.random.default_rng(0)

    def __call__(self, built, t, q_all, qd_all, generalized, node_forces):
        if t < self.t0:
            return
        i = built.eq.index["TFA1"]
        if self.kind == "nan":
            generalized[i] += np.nan
        else:
            generalized[i] += self.accel * 4.4e5 * self.rng.standard_normal()


@pytest.fixture
def with_effect(monkeypatch):
    def install(kind, t0, accel=0.0):
        original = assembly.select_effects
        monkeypatch.setattr(assembly, "select_effects",
                            lambda sc: original(sc) + [Pathological(sc, kind, t0, accel)])
    return install


def test_non_finite_load_stops_at_once(with_effect):
    with_effect("nan", 0.5)
    sc = scene("paper_2dof_tower_shaft")
    with pytest.raises(SimulationDiverged) as info:
        api.simulate(sc, tmax=10.0)
    assert info.value.reason == "non-finite acceleration"
    assert 0.5 <= info.value.time < 0.6
    assert info.value.file == sc.path and "diverged at t=0.5" in str(info.value)


def test_state_beyond_bound_without_the_stability_check():
    sc = scene("paper_2dof_tower_shaft")
    sc.turbine.nacelle_mass = NEAR_BUCKLING_NACELLE
    ms = modes(tower_fa=("clamped", 2))
    with pytest.raises(PhysicallyUnstable):
        api.simulate(sc, ms, tmax=60.0)
    sc.solver = {"stability_check": False}
    with pytest.raises(SimulationDiverged) as info:
        api.simulate(sc, ms, tmax=60.0)
    assert info.value.reason == "coordinate TFA1 beyond its physical bound"
    assert 0.0 < info.value.time < 60.0


def test_step_size_collapse(with_effect):
    with_effect("noise", 0.05, accel=1e8)
    sc = scene("paper_2dof_tower_shaft")
    sc.solver = {"max_step": 1e-4}      # so that no stage leaves the state bounds first
    with pytest.raises(SimulationDiverged) as info:
        api.simulate(sc, tmax=1.0)
    assert "step size is less than spacing" in info.value.reason
    assert info.value.time == pytest.approx(0.05, abs=1e-3)


# --------------------------------------------------------------------------- in a study

SCENE = """\
name = "near_buckling"
turbine = "nrel5mw"
tmax = 20.0
dt = 0.05
[overrides]
nacelle_mass = {mass}
[modes]
tower_fa = {{ family = "clamped", count = 1 }}
[dofs]
free = ["GeAz"]
[initial]
TTDspFA = 1.0
RotSpeed = 5.0
[effects]
gravity = true
geometric_stiffening = true
damping = true
{solver}
"""

STUDY = """\
[study]
name = "near_buckling"
[[scene]]
path = "near_buckling.toml"
[reference]
kind = "csv"
path = "reference.csv"
[compare]
channels = ["TTDspFA"]
tolerance = 0.05
[search.fields.tower_fa]
families = ["clamped", "polynomial"]
max_count = 2
[budget]
n_trials = 4
stop_when_met = false
[run]
n_jobs = 1
"""


def make_study(folder, check: bool):
    solver = "" if check else "[solver]\nstability_check = false\n"
    (folder / "near_buckling.toml").write_text(SCENE.format(mass=NEAR_BUCKLING_NACELLE, solver=solver))
    sc = api.load_scene(folder / "near_buckling.toml")
    out = api.simulate(sc).outputs                  # clamped:1, stable: the reference
    out[["Time", "TTDspFA"]].to_csv(folder / "reference.csv", index=False)
    (folder / "study.toml").write_text(STUDY)
    return folder / "study.toml"


@pytest.mark.parametrize("check,reason", [
    (True, "physically unstable configuration (refused before simulating)"),
    (False, "beyond its physical bound"),
])
def test_diverging_trials_fail_with_their_reason_and_the_study_goes_on(tmp_path, capsys, check, reason):
    study = make_study(tmp_path, check)
    assert main(["run", str(study), "--out", str(tmp_path / "out")]) == 0
    trials = pd.read_csv(tmp_path / "out" / "trials.csv", header=[0, 1]).droplevel(1, axis=1)   # row 2: units
    by_set = {row.modeset: row for row in trials.itertuples()}
    assert set(by_set) == {f"tower_fa={f}:{n}" for f in ("clamped", "polynomial") for n in (1, 2)}
    for label in ("tower_fa=clamped:1", "tower_fa=polynomial:1"):      # stable: they ran
        assert by_set[label].status == "COMPLETE"
    assert by_set["tower_fa=clamped:1"].error_pct < 1e-4                   # the reference itself
    for label in ("tower_fa=clamped:2", "tower_fa=polynomial:2"):      # beyond their buckling mass
        row = by_set[label]
        assert row.status == "FAIL" and reason in row.reason and "tower_fa" in row.reason.replace("TFA", "tower_fa")
        assert "near_buckling.toml" in row.reason
    assert list(trials["status"]) == ["COMPLETE", "COMPLETE", "FAIL", "FAIL"]   # failed ranked last
    html = (tmp_path / "out" / "report.html").read_text()
    assert "Failed trials" in html and reason.split(" (")[0] in html
