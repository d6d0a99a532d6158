"""A complete OpenFAST case that runs a chosen mode set.

`export_openfast_case(modeset, case, outdir)` copies an OpenFAST case (its
`.fst` and every file it names, found by following the quoted file names of
each input file: AeroDyn, its blade and airfoil files, InflowWind,
ServoDyn, ...) into `outdir`, keeping their relative layout (so the
references inside the copied files stay valid without rewriting them), and
replaces the ElastoDyn main, tower and blade files by those of
`modesel.export.elastodyn_writer` (constrained sixth-order fits of the mode
set's shapes, DOF flags set to match). The `.fst` copy names the new
ElastoDyn file (and, with `tmax`, a new TMax); nothing else changes.

The shapes are evaluated as `modesel simulate` evaluates them for this case:
on the case's turbine, blade shapes at the case's initial rotor speed
(RotSpeed), so that OpenFAST and modesel run the same shapes. Only the
case's ElastoDyn part is read: modules or options modesel does not simulate
(e.g. turbulent wind, a controller DLL) are copied for OpenFAST unchanged.

A set ElastoDyn cannot hold (more than 2 tower fore-aft, 2 side-side or 2
flap modes, more than 1 edge mode, any tower torsion) is refused with one
line naming each excess: exporting part of it would run another model than
the one chosen.
"""
from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import numpy as np

from modesel.errors import ModeselError

# ElastoDyn's capacity per field (its mode slots); tower torsion has none
ELASTODYN_CAPACITY = {"tower_fa": 2, "tower_ss": 2, "blade_flap": 2, "blade_edge": 1, "tower_torsion": 0}
_QUOTED = re.compile(r'"([^"]+)"')
_SKIP_SUFFIXES = {".dll", ".so", ".dylib"}   # controllers are not case files


def elastodyn_misfit(modeset) -> list:
    """Texts naming what of `modeset` ElastoDyn cannot hold (empty: it fits)."""
    out = []
    for name, modes in modeset.fields.items():
        cap = ELASTODYN_CAPACITY.get(name, 0)
        if modes.count > cap:
            what = "no tower torsion DOF" if cap == 0 else f"at most {cap} {name} mode{'s' * (cap > 1)}"
            out.append(f"{name}={modes.label()} (ElastoDyn has {what})")
    return out


def referenced_files(path: Path, skip_keys=()) -> list:
    """Files `path` names in quoted strings that exist relative to its folder
    (lines whose key, the word after the value, is in `skip_keys` are not followed)."""
    out = []
    for line in path.read_text(errors="replace").splitlines():
        words = line.split()
        if len(words) > 1 and words[1] in skip_keys:
            continue
        for name in _QUOTED.findall(line):
            target = (path.parent / name.strip())
            if name.strip() and target.is_file() and target.suffix.lower() not in _SKIP_SUFFIXES:
                out.append(target.resolve())
    return out


def case_files(fst: Path) -> list:
    """The `.fst` and every file reachable from it, except the ElastoDyn deck."""
    seen, queue = [], [fst.resolve()]
    while queue:
        path = queue.pop(0)
        if path in seen:
            continue
        seen.append(path)
        queue += referenced_files(path, skip_keys=("EDFile",) if path == fst.resolve() else ())
    return seen


def _set_value(text: str, key: str, value: str, file: str) -> str:
    """Replace the value (first word) of the line whose second word is `key`."""
    lines = text.splitlines(keepends=True)
    for i, line in enumerate(lines):
        words = line.split()
        if len(words) > 1 and words[1] == key:
            lines[i] = f"{value:<14} " + line.lstrip()[len(words[0]):].lstrip()
            return "".join(lines)
    raise ModeselError("input missing from the case", file=file, field=key)


def export_openfast_case(modeset, case, outdir, *, tmax: float | None = None,
                         weighting: str = "uniform", source: str | None = None):
    """Write the OpenFAST case `case` (.fst) running `modeset` into `outdir`.

    Returns (path of the new .fst, ElastoDynExport report). Refuses, before
    writing anything, a set ElastoDyn cannot hold, an output folder inside
    the case's files, or a case that is not an OpenFAST main file."""
    from modesel.export.common import field_shapes
    from modesel.export.elastodyn_writer import export_elastodyn
    from modesel.simulation.fst import is_fst, scene_from_elastodyn

    case, outdir = Path(case), Path(outdir)
    if not case.is_file():
        raise ModeselError("OpenFAST case not found", file=str(case))
    if not is_fst(case):
        raise ModeselError("not an OpenFAST main file (it names no EDFile)", file=str(case), field="--case")
    misfit = elastodyn_misfit(modeset)
    if misfit:
        raise ModeselError("ElastoDyn cannot hold this set: " + "; ".join(misfit), file=source,
                           field="fields")
    if tmax is not None and not (np.isfinite(tmax) and tmax > 0):
        raise ModeselError(f"TMax must be > 0 s, got {tmax:g}", field="--tmax")
    # the ElastoDyn part only: OpenFAST runs the rest of the case (wind, control, aero) as it is,
    # also what modesel itself cannot simulate (e.g. turbulent wind)
    scene = scene_from_elastodyn(case)
    from modesel.vocabulary import ROTOR_AZIMUTH
    omega = scene.constant_speed.get(ROTOR_AZIMUTH, scene.initial.get("RotSpeed", 0.0))  # as `build`
    rpm = float(omega) * 30.0 / np.pi
    shapes = field_shapes(modeset, scene.turbine, rpm=rpm, source=source)

    files = case_files(case)
    root = Path(os.path.commonpath([str(f.parent) for f in files]))   # keep the relative layout
    targets = {f: outdir / f.relative_to(root) for f in files}
    if outdir.resolve() == root or any(outdir.resolve() == f.parent for f in files):
        raise ModeselError("the output folder holds the case's own files; choose another one",
                           file=str(outdir))
    for src, dst in targets.items():
        try:
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, dst)
        except OSError as exc:
            raise ModeselError(f"cannot write the case ({exc.strerror})", file=str(dst)) from None
    fst_out = targets[case.resolve()]
    report = export_elastodyn(modeset, shapes, scene.turbine, fst_out.parent, weighting=weighting)
    text = fst_out.read_text()
    text = _set_value(text, "EDFile", f'"{Path(report.files[0]).name}"', str(fst_out))
    if tmax is not None:
        text = _set_value(text, "TMax", f"{tmax:g}", str(fst_out))
    try:
        fst_out.write_text(text)
    except OSError as exc:
        raise ModeselError(f"cannot write ({exc.strerror})", file=str(fst_out)) from None
    report.files = [str(fst_out)] + [str(targets[f]) for f in files if f != case.resolve()] + report.files
    return fst_out, report
