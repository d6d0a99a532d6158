"""The chosen set runs in OpenFAST: `modesel export --case --openfast` writes
a case whose OpenFAST response matches `modesel simulate` of the same set on
the same case.

Case: the parked release of the NREL 5-MW (no aero; modesel matches
OpenFAST's own run of it to 0.1 %), 10 s. The set gives the towers shapes of
another family (`clamped:2` fore-aft and side-side, written as constrained
sixth-order fits) and keeps the deck's blade polynomials. OpenFAST:
environment variable OPENFAST, else ../shared/tools/openfast/openfast
relative to the repository; skipped with the reason when neither exists.
"""
from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from modesel.cli import main
from modesel.modeset import ModeSet
from modesel.simulation.api import load_scene, simulate
from modesel.study.metrics import nrmse
from modesel.turbine.openfast_output import read_openfast_output

REPO = Path(__file__).resolve().parent.parent
CASE = REPO / "tests" / "data" / "openfast_turbine" / "parked_release" / "parked_release.fst"
TMAX = 10.0


def openfast_executable():
    path = os.environ.get("OPENFAST") or str(REPO.parent / "shared" / "tools" / "openfast" / "openfast")
    return path if Path(path).is_file() and os.access(path, os.X_OK) else None


OPENFAST = openfast_executable()
needs_openfast = pytest.mark.skipif(OPENFAST is None, reason="no OpenFAST executable: set OPENFAST or "
                                    "install ../shared/tools/openfast/openfast")


def run_roundtrip(tmp_path, fields):
    ms_path = tmp_path / "ms.json"
    ms_path.write_text(json.dumps({"fields": fields}))
    out = tmp_path / "case"
    assert main(["export", str(ms_path), "--case", str(CASE), "--openfast", str(out),
                 "--tmax", str(TMAX)]) == 0
    fst = out / CASE.name
    proc = subprocess.run([OPENFAST, fst.name], cwd=fst.parent, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0 and "terminated normally" in proc.stdout, proc.stdout[-2000:]
    of = read_openfast_output(fst.with_suffix(".outb"))
    sim = simulate(load_scene(CASE), ModeSet.from_json(ms_path), tmax=TMAX).outputs
    t = sim["Time"].to_numpy()
    return {ch: nrmse(sim[ch].to_numpy(), np.interp(t, of["Time"].to_numpy(), of[ch].to_numpy()), t)
            for ch in ("TTDspFA", "TTDspSS", "OoPDefl1", "IPDefl1")}


@needs_openfast
def test_exported_tower_modes_run_in_openfast_as_in_modesel(tmp_path):
    errors = run_roundtrip(tmp_path, {
        "tower_fa": {"family": "clamped", "count": 2}, "tower_ss": {"family": "clamped", "count": 2},
        "blade_flap": {"family": "elastodyn", "count": 2}, "blade_edge": {"family": "elastodyn", "count": 1}})
    # measured: TTDspFA 0.077 %, TTDspSS 0.081 %, OoPDefl1 0.046 %
    assert errors["TTDspFA"] < 0.01 and errors["OoPDefl1"] < 0.01, errors
    assert errors["TTDspSS"] < 0.01, errors


@needs_openfast
@pytest.mark.xfail(strict=True, reason="blade shapes other than the deck's: modesel and ElastoDyn differ "
                   "on the same shapes (measured OoPDefl1 nrmse: fem:2 flap + fem:1 edge 5.1 %, exact "
                   "polynomial:1 flap 10.6 %, elastodyn flap + fem:1 edge 10.1 %); the structural "
                   "physics of non-ElastoDyn blade shapes is being matched (issue 10/11, w10r)")
def test_exported_blade_modes_run_in_openfast_as_in_modesel(tmp_path):
    errors = run_roundtrip(tmp_path, {
        "tower_fa": {"family": "clamped", "count": 2}, "tower_ss": {"family": "clamped", "count": 2},
        "blade_flap": {"family": "fem", "count": 2}, "blade_edge": {"family": "fem", "count": 1}})
    assert errors["TTDspFA"] < 0.01 and errors["OoPDefl1"] < 0.01, errors
