"""File names and per-blade files of an OpenFAST case, as OpenFAST reads them.

Found by a sweep of edited copies of steady_08 run in OpenFAST 5.0 and
modesel (session 32):

- a quoted file name with a blank ("../common files/x.dat") is one name to
  OpenFAST (NWTC ParseVar reads the quoted string); modesel cut it at the
  blank (openfast-io's readers split lines on blanks) and refused the case;
- BldFile(2) or ADBlFile(2) naming another blade than blade 1: OpenFAST
  models each blade (a 10 % heavier blade 2 moved RotSpeed by 8.9 % NRMSE),
  modesel used blade 1's files for every blade and wrote the base run's CSV
  byte for byte. modesel's rotor has equal blades, so such a case is now
  refused in one line naming the input; blade files that differ only in
  their text (comments, layout) are still accepted;
- HWindSpeed <= 0 for a steady wind: InflowWind refuses it
  (InflowWind_Subs.f90), modesel's message named an internal option.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from modesel.errors import ModeselError
from modesel.simulation.scene import load_scene
from tests.test_fst_scene import CASES, copy_case, edit

REPO = CASES.parents[2]


def _rename(case_fst, old_rel: str, new_rel: str, deck: str, label: str):
    """Move the file `old_rel` (relative to the case folder) to `new_rel` and
    point `label` of `deck` at it, quoted."""
    folder = case_fst.parent
    (folder / new_rel).parent.mkdir(parents=True, exist_ok=True)
    shutil.copy(folder / old_rel, folder / new_rel)
    edit(folder / deck, label, f'"{new_rel}"')


def test_quoted_file_names_with_blanks_give_the_same_run(tmp_path):
    """The whole case with its ElastoDyn tower and blade files and its
    AeroDyn blade file under names with blanks: the same outputs as the case."""
    fst = copy_case(tmp_path)
    folder = fst.parent
    cmd = [sys.executable, "-m", "modesel", "simulate", str(fst), "--tmax", "0.5"]
    env = dict(os.environ, MODESEL_SERVER="off")
    proc = subprocess.run(cmd + ["--out", str(tmp_path / "a.csv")], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    _rename(fst, "../common/NRELOffshrBsline5MW_Onshore_ElastoDyn_Tower.dat", "my decks/tower file.dat",
            "steady_08_ElastoDyn.dat", "TwrFile")
    shutil.copy(folder / "../common/NRELOffshrBsline5MW_Blade.dat", folder / "my decks/blade file.dat")
    for k in (1, 2, 3):
        edit(folder / "steady_08_ElastoDyn.dat", f"BldFile({k})", '"my decks/blade file.dat"')
    ad = folder.parent / "common" / "NREL5MW_AD_v5.dat"
    shutil.copy(folder.parent / "common" / "NRELOffshrBsline5MW_AeroDyn_blade.dat",
                folder.parent / "common" / "aero blade.dat")
    for k in (1, 2, 3):
        edit(ad, f"ADBlFile({k})", '"aero blade.dat"')
    proc = subprocess.run(cmd + ["--out", str(tmp_path / "b.csv")], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    a, b = (_columns(tmp_path / name) for name in ("a.csv", "b.csv"))
    assert list(a) == list(b)
    for name in a:     # a first (compiling) run may differ from a cached one by ~1e-8 of the range (docs/benchmarks.md, "First run")
        span = max(float(np.ptp(a[name])), 1e-12)
        assert np.max(np.abs(a[name] - b[name])) <= 1e-6 * span, name


def _columns(path) -> dict:
    """The CSV modesel writes (a units row under the names), as arrays."""
    table = pd.read_csv(path, skiprows=[1])
    return {c: table[c].to_numpy(float) for c in table.columns}


def test_a_different_structural_blade_is_refused(tmp_path):
    fst = copy_case(tmp_path)
    folder = fst.parent
    blade = (folder / "../common/NRELOffshrBsline5MW_Blade.dat").read_text()
    # the same blade with other comments and blanks: accepted
    (folder / "same.dat").write_text(blade.replace("BldFlDmp(1)", "BldFlDmp(1)  ", 1) + "\n! a trailing comment\n")
    edit(folder / "steady_08_ElastoDyn.dat", "BldFile(2)", '"same.dat"')
    load_scene(fst)
    # 10 % more mass on blade 2: refused, naming BldFile(2)
    heavier = folder / "heavier.dat"
    shutil.copy(folder / "../common/NRELOffshrBsline5MW_Blade.dat", heavier)
    edit(heavier, "AdjBlMs", "1.10")
    edit(folder / "steady_08_ElastoDyn.dat", "BldFile(2)", '"heavier.dat"')
    with pytest.raises(ModeselError) as err:
        load_scene(fst)
    assert err.value.field == "BldFile(2)" and "equal blades" in str(err.value)


def test_a_different_aerodynamic_blade_is_refused_on_the_command_line(tmp_path):
    fst = copy_case(tmp_path)
    common = fst.parent.parent / "common"
    text = (common / "NRELOffshrBsline5MW_AeroDyn_blade.dat").read_text().splitlines()
    # blade 3 with a 10 % wider chord at its fifth node (the table's rows start on line 7)
    row = text[10].split()
    row[5] = f"{float(row[5]) * 1.1:.6f}"
    (common / "wide.dat").write_text("\n".join(text[:10] + ["  ".join(row)] + text[11:]) + "\n")
    edit(common / "NREL5MW_AD_v5.dat", "ADBlFile(3)", '"wide.dat"')
    proc = subprocess.run([sys.executable, "-m", "modesel", "simulate", str(fst), "--tmax", "0.1",
                           "--out", str(tmp_path / "x.csv")], capture_output=True, text=True,
                          env=dict(os.environ, MODESEL_SERVER="off"))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "ADBlFile(3)" in lines[0] and "NREL5MW_AD_v5.dat" in lines[0]
    assert not (tmp_path / "x.csv").exists()


@pytest.mark.parametrize("value", ["-8.0", "0.0"])
def test_a_steady_wind_needs_a_positive_speed(tmp_path, value):
    fst = copy_case(tmp_path)
    edit(fst.parent / "steady_08_InflowWind.dat", "HWindSpeed", value)
    with pytest.raises(ModeselError) as err:
        load_scene(fst)
    assert err.value.field == "HWindSpeed" and err.value.file.endswith("steady_08_InflowWind.dat")


def test_a_toml_scene_with_differing_aerodyn_blades_is_refused(tmp_path):
    """The same check where a TOML scene names the AeroDyn deck (`effects.aero.aerodyn`)."""
    from modesel.simulation.transient import simulate
    common = tmp_path / "common"
    shutil.copytree(CASES / "common", common)
    text = (common / "NRELOffshrBsline5MW_AeroDyn_blade.dat").read_text().splitlines()
    row = text[10].split()
    row[4] = f"{float(row[4]) + 1.0:.6f}"        # one degree more twist at the fifth node
    (common / "twisted.dat").write_text("\n".join(text[:10] + ["  ".join(row)] + text[11:]) + "\n")
    edit(common / "NREL5MW_AD_v5.dat", "ADBlFile(2)", '"twisted.dat"')
    scene_text = (REPO / "studies/scenes/turbine_wind_08.toml").read_text().replace(
        "aero = true", f'aero = {{ aerodyn = "{(common / "NREL5MW_AD_v5.dat").as_posix()}" }}')
    path = tmp_path / "scene.toml"
    path.write_text(scene_text)
    with pytest.raises(ModeselError) as err:
        simulate(load_scene(path), tmax=0.1)
    assert err.value.field == "ADBlFile(2)" and err.value.file.endswith("NREL5MW_AD_v5.dat")
