"""The chosen set runs in OpenFAST: `modesel export --case --openfast` writes
a case whose OpenFAST response matches `modesel simulate` of the same set on
the same case.

Case: the parked release of the NREL 5-MW (no aero; modesel matches
OpenFAST's own run of it to 0.1 %), 10 s. ElastoDyn integrates any shape on
the deck's analysis nodes (17 blade, 20 tower nodes, midpoint rule), and so
does modesel in a scene read from an OpenFAST case, whatever the family
(`model.template._elastodyn_discrete`): on the converged quadrature the same
shapes have other frequencies (blade flap 1 +1.4 %, edge 1 +0.9 %), which
put OoPDefl1 8.97 % off for clamped:2 flap + fem:1 edge (0.34 % on ElastoDyn's
nodes).

What OpenFAST runs is the constrained sixth-order fit. Where a fit keeps the
shape's ElastoDyn frequency (tower and blade `clamped`, `fem` edge: < 0.2 %)
the chosen set itself matches. `fem` flap modes do not fit: fem flap 1 is
(nearly) the blade's own first mode and no polynomial in x^2..x^6 reaches
its frequency (the lowest is +0.36 %; the L2 fit +0.59 %, flap 2 +6.7 %;
tests/test_export.py), so the export warns and OpenFAST is compared with
the exported set (`<stem>_modesel_modeset.json`) that modesel simulates with
the written deck. OpenFAST's own linearisation of that exported case and
`modesel linearize` of the exported set agree within 0.03 % on every mode.

OpenFAST: environment variable OPENFAST, else ../shared/tools/openfast/openfast
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


CHANNELS = ("TTDspFA", "TTDspSS", "OoPDefl1", "IPDefl1")


def run_roundtrip(tmp_path, fields):
    """Export `fields` into an OpenFAST case, run it; return (OpenFAST outputs,
    the exported .fst, the mode-set file, the exported-set file)."""
    ms_path = tmp_path / "ms.json"
    ms_path.write_text(json.dumps({"fields": fields}))
    out = tmp_path / "case"
    assert main(["export", str(ms_path), "--case", str(CASE), "--openfast", str(out),
                 "--tmax", str(TMAX)]) == 0
    fst = out / CASE.name
    proc = subprocess.run([OPENFAST, fst.name], cwd=fst.parent, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0 and "terminated normally" in proc.stdout, proc.stdout[-2000:]
    exported, = out.glob("*_modesel_modeset.json")
    return read_openfast_output(fst.with_suffix(".outb")), fst, ms_path, exported


def errors_against(of, scene, ms_path):
    """NRMSE of `modesel simulate` of the set in `ms_path` on `scene` against OpenFAST's outputs."""
    sim = simulate(load_scene(scene), ModeSet.from_json(ms_path), tmax=TMAX).outputs
    t = sim["Time"].to_numpy()
    return {ch: nrmse(sim[ch].to_numpy(), np.interp(t, of["Time"].to_numpy(), of[ch].to_numpy()), t)
            for ch in CHANNELS}


@needs_openfast
def test_exported_tower_modes_run_in_openfast_as_in_modesel(tmp_path):
    of, _, ms_path, _ = run_roundtrip(tmp_path, {
        "tower_fa": {"family": "clamped", "count": 2}, "tower_ss": {"family": "clamped", "count": 2},
        "blade_flap": {"family": "elastodyn", "count": 2}, "blade_edge": {"family": "elastodyn", "count": 1}})
    errors = errors_against(of, CASE, ms_path)
    # measured: TTDspFA 0.077 %, TTDspSS 0.081 %, OoPDefl1 0.046 %
    assert errors["TTDspFA"] < 0.01 and errors["OoPDefl1"] < 0.01, errors
    assert errors["TTDspSS"] < 0.01, errors


@needs_openfast
def test_exported_blade_modes_run_in_openfast_as_in_modesel(tmp_path):
    """Blade shapes other than the deck's: the chosen set on the original case."""
    of, _, ms_path, _ = run_roundtrip(tmp_path, {
        "tower_fa": {"family": "clamped", "count": 2}, "tower_ss": {"family": "clamped", "count": 2},
        "blade_flap": {"family": "clamped", "count": 2}, "blade_edge": {"family": "fem", "count": 1}})
    errors = errors_against(of, CASE, ms_path)
    # measured: TTDspFA 0.047 %, TTDspSS 0.035 %, OoPDefl1 0.336 %, IPDefl1 0.98 %
    # (before the blades used ElastoDyn's nodes: 0.91, 0.61, 8.97, 1.68 %)
    assert errors["TTDspFA"] < 0.01 and errors["OoPDefl1"] < 0.01, errors


@needs_openfast
def test_exported_fem_blade_set_runs_in_openfast_as_modesel_simulates_it(tmp_path, capsys):
    """`fem` flap modes: OpenFAST runs the exported set, as modesel does."""
    of, fst, ms_path, exported = run_roundtrip(tmp_path, {
        "tower_fa": {"family": "clamped", "count": 2}, "tower_ss": {"family": "clamped", "count": 2},
        "blade_flap": {"family": "fem", "count": 2}, "blade_edge": {"family": "fem", "count": 1}})
    printed = capsys.readouterr().out
    assert "warning: blade_flap mode 1 (fem): the polynomial's ElastoDyn frequency differs" in printed
    errors = errors_against(of, fst, exported)
    # measured: TTDspFA 0.001 %, TTDspSS 0.010 %, OoPDefl1 0.003 %, IPDefl1 0.013 %
    # (the chosen set itself: 0.29, 0.30, 4.4, 0.84 %, the flap frequencies of the fit)
    assert max(errors.values()) < 0.001, errors
