"""Write ElastoDyn input files whose mode shapes are a chosen mode set.

ElastoDyn describes tower and blade bending by at most two fore-aft
(TwFAM1Sh, TwFAM2Sh), two side-side (TwSSM1Sh, TwSSM2Sh), two flap
(BldFl1Sh, BldFl2Sh) and one edge (BldEdgSh) mode, each a polynomial
sum_k c_k x^k, k = 2..6, with sum c_k = 1 (first paper, eq. 46). For every
field of the mode set:

- modes 1..min(count, capacity) are replaced by the constrained fit of the
  mode set's shape (`modesel.export.polyfit`), their DOF flag set True;
- slots beyond `count` get their DOF flag False and keep the deck's
  polynomial; modes beyond the capacity are not exported (a warning says so);
- `tower_torsion` cannot be represented (ElastoDyn has no tower torsion DOF):
  a warning says so and nothing is written for it.

Fields absent from the mode set keep the deck's polynomials and DOF flags.

What OpenFAST then runs is the polynomials, not the chosen shapes: a
sixth-order polynomial cannot hold every shape (e.g. `fem` blade modes of
the NREL 5-MW, whose curvature follows the stiffness steps near the root).
For every exported mode the report gives the frequency ElastoDyn derives
for it (its beam-only modal frequency sqrt(K/M)/2pi on the deck's analysis
nodes, midpoint rule, untwisted: the frequency its BldFlDmp/TwrFADmp
damping refers to) for the chosen shape and for the polynomial, and warns
above FREQUENCY_WARNING. It also writes `<stem>_modesel_modeset.json`: the
exported set (family `elastodyn`, the written counts), which modesel
simulates with the written deck (the exported .fst or ElastoDyn main file)
exactly as OpenFAST runs it.

Raw deck access. The deck is read with openfast-io after being normalised to
the layout openfast-io 5.0 reads, by the normaliser of
`modesel.turbine.elastodyn` (`Deck`, `read_deck`: older decks lack
`PitchDOF`, pitch-bearing inertias and yaw friction, have a `Gravity` line or
a `PitchAxis` blade column). This module is the one place that needs the
raw openfast-io dictionaries (to rewrite files); it reuses that normaliser
rather than parsing decks a second way. The main file is read here (not via
`read_deck`) because writing it back needs openfast-io's OutList as well.

The files are written by openfast-io's `InputWriter_OpenFAST`
(write_ElastoDyn, write_ElastoDynTower, write_ElastoDynBlade), i.e. in the
layout of openfast-io 5.0 (OpenFAST 4.x/5.x): `Gravity` is then an input of
the .fst file, not of ElastoDyn. Every written file is read back with
openfast-io's readers and compared with what was meant to be written.
"""
from __future__ import annotations

import copy
import json
import os
import re
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from openfast_io.FAST_reader import InputReader_OpenFAST
from openfast_io.FAST_writer import InputWriter_OpenFAST

from modesel.errors import ModeselError
from modesel.export.common import stations, write_text
from modesel.export.polyfit import PolynomialFit, evaluate_polynomial, fit_mode_polynomial
from modesel.model.flexible_beam import elastodyn_nodes
from modesel.modeset import FIELDS
from modesel.turbine.elastodyn import Deck, has_label, read_deck, referenced_file
from modesel.vocabulary import TOWER_FIELDS

# field -> ElastoDyn mode slots: (file branch, coefficient key, DOF flag, modal stiffness tuner)
ELASTODYN_MODES = {
    "tower_fa": (("ElastoDynTower", "TwFAM1Sh", "TwFADOF1", "FAStTunr1"),
                 ("ElastoDynTower", "TwFAM2Sh", "TwFADOF2", "FAStTunr2")),
    "tower_ss": (("ElastoDynTower", "TwSSM1Sh", "TwSSDOF1", "SSStTunr1"),
                 ("ElastoDynTower", "TwSSM2Sh", "TwSSDOF2", "SSStTunr2")),
    "blade_flap": (("ElastoDynBlade", "BldFl1Sh", "FlapDOF1", "FlStTunr1"),
                   ("ElastoDynBlade", "BldFl2Sh", "FlapDOF2", "FlStTunr2")),
    "blade_edge": (("ElastoDynBlade", "BldEdgSh", "EdgeDOF", None),),
}
#: relative change of a mode's ElastoDyn frequency by the polynomial fit above
#: which the report warns (0.1 % shifts the phase of that mode by 0.01 cycle
#: after 10 periods)
FREQUENCY_WARNING = 1e-3


# --------------------------------------------------------------------------- raw deck
@dataclass
class RawDeck:
    """openfast-io dictionaries of an ElastoDyn deck.

    `elastodyn`, `tower`: fst_vt['ElastoDyn'], fst_vt['ElastoDynTower'];
    `blades`: one ElastoDynBlade dict per distinct blade file, `blade_of[k]`
    the index in `blades` of blade k+1; `outlist`: fst_vt['outlist'];
    `inputs`: the files read (never overwritten); `notes`: what the
    normalisation changed or could not carry over.
    """

    main: Path
    elastodyn: dict
    tower: dict
    blades: list
    blade_of: list
    outlist: dict
    inputs: tuple
    notes: list = field(default_factory=list)


def read_raw_deck(path) -> RawDeck:
    """Read an ElastoDyn main file (or the EDFile of a .fst) and its tower/blade files."""
    path = Path(path)
    if not path.is_file():
        raise ModeselError("turbine deck not found", file=str(path))
    inputs = [path]
    if has_label(path, "EDFile"):
        _, fst_deck = read_deck(path, "main")
        path = referenced_file(path, fst_deck.file_name("EDFile"), "EDFile")
        inputs.append(path)
    deck = Deck(path, "elastodyn")
    text = deck.normalised()
    _check_outlists_end(text, path)
    reader = InputReader_OpenFAST()
    with tempfile.TemporaryDirectory() as folder:
        normalised = Path(folder, path.name)
        normalised.write_text(text)
        try:
            reader.read_ElastoDyn(str(normalised))
            channels = _read_outlists(reader, normalised)
        except (ValueError, IndexError, TypeError) as exc:
            raise ModeselError(f"openfast_io could not read the deck: {exc}", file=str(path)) from None
    ed = reader.fst_vt["ElastoDyn"]
    notes = deck.notes()
    if "Gravity" in deck.found:
        notes.append(f"{path.name}: Gravity = {deck.value('Gravity')} is not written: in the written "
                     f"(openfast-io 5.0) layout gravity is an input of the .fst file.")
    dropped = [c for c in channels if not _channel_on(reader.fst_vt["outlist"], c)]
    if dropped:
        notes.append(f"{path.name}: output channel(s) unknown to openfast-io dropped: {', '.join(dropped)}.")
    if ed.get("Furling") is True:
        ed["FurlFile"] = str(referenced_file(path, os.path.basename(ed["FurlFile"]), "FurlFile").resolve())

    tower_path = referenced_file(path, deck.file_name("TwrFile"), "TwrFile")
    tower, tower_deck = read_deck(tower_path, "tower")
    notes += tower_deck.notes()
    inputs.append(tower_path)
    blades, blade_of, seen = [], [], {}
    for k in range(1, int(ed["NumBl"]) + 1):
        blade_path = referenced_file(path, deck.file_name(f"BldFile({k})"), f"BldFile({k})").resolve()
        if blade_path not in seen:
            blade, blade_deck = read_deck(blade_path, "blade")
            notes += blade_deck.notes()
            seen[blade_path] = len(blades)
            blades.append(blade)
            inputs.append(blade_path)
        blade_of.append(seen[blade_path])
    return RawDeck(path, ed, tower, blades, blade_of, reader.fst_vt["outlist"], tuple(inputs),
                   list(dict.fromkeys(notes)))


def _read_outlists(reader, normalised: Path) -> list:
    """Fill the OutList (and optional nodal OutList) with openfast-io's `read_outlist`;
    return the channel names the deck asks for.

    The nodal channels go to 'ElastoDyn_Nodes' (openfast-io 5.0's read_ElastoDyn
    files them under 'ElastoDyn', where they are not found). The returned names
    are the quoted words of each line (the first word of an unquoted line), so
    that comments after a channel are not taken for channels.
    """
    lines = normalised.read_text().splitlines()
    starts = [i for i, line in enumerate(lines) if line.split()[:1] == ["OutList"]]
    channels = []
    for start, module in zip(starts, ("ElastoDyn", "ElastoDyn_Nodes")):
        with open(normalised) as fh:
            for _ in range(start + 1):
                fh.readline()
            reader.read_outlist(fh, module)
        for line in lines[start + 1:]:
            if line.strip().startswith("END"):
                break
            quoted = re.findall(r'"([^"]*)"', line)
            words = re.split(r"[\s,;]+", " ".join(quoted)) if quoted else line.split()[:1]
            channels += [w for w in words if w]
    return channels


def _check_outlists_end(text: str, path: Path):
    """Every OutList section must end with an END line (openfast-io loops forever otherwise)."""
    lines = text.splitlines()
    starts = [i for i, line in enumerate(lines) if line.split()[:1] == ["OutList"]]
    for n, start in enumerate(starts):
        stop = starts[n + 1] if n + 1 < len(starts) else len(lines)
        if not any(line.strip().startswith("END") for line in lines[start + 1:stop]):
            raise ModeselError("OutList section has no END line", file=str(path), field="OutList")


def _channel_on(outlist: dict, channel: str) -> bool:
    def walk(tree):
        return any(walk(v) if isinstance(v, dict) else (k == channel and bool(v)) for k, v in tree.items())
    return walk(outlist.get("ElastoDyn", {})) or walk(outlist.get("ElastoDyn_Nodes", {}))


# --------------------------------------------------------------------------- report
@dataclass(frozen=True)
class ExportedMode:
    """One mode written as an ElastoDyn polynomial."""

    field: str
    mode: int           # 1-based
    family: str
    key: str            # TwFAM1Sh, ...
    dof: str            # TwFADOF1, ...
    file: str
    fit: PolynomialFit
    #: ElastoDyn's beam-only frequency [Hz] of the chosen shape and of the polynomial
    #: (`elastodyn_frequency`)
    frequency_shape_hz: float = float("nan")
    frequency_fit_hz: float = float("nan")

    @property
    def frequency_change(self) -> float:
        """Relative change of the ElastoDyn frequency by the fit (fit / shape - 1)."""
        return self.frequency_fit_hz / self.frequency_shape_hz - 1.0

    def to_dict(self) -> dict:
        return {"field": self.field, "mode": self.mode, "family": self.family, "key": self.key,
                "dof": self.dof, "file": self.file, **self.fit.to_dict(),
                "frequency_shape_hz": self.frequency_shape_hz, "frequency_fit_hz": self.frequency_fit_hz}


@dataclass
class ElastoDynExport:
    """What `export_elastodyn` wrote and how well the polynomials fit."""

    deck: str
    outdir: str
    weighting: str
    modes: list = field(default_factory=list)       # ExportedMode
    disabled: list = field(default_factory=list)    # (field, mode, key, dof)
    kept: list = field(default_factory=list)        # fields left as in the deck
    warnings: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    files: list = field(default_factory=list)
    sidecar: str | None = None
    #: the exported set (family `elastodyn`) to simulate with the written deck
    modeset_file: str | None = None
    frequency_basis: str = ""

    def to_dict(self) -> dict:
        return {"deck": self.deck, "outdir": self.outdir, "weighting": self.weighting,
                "residuals_relative_to": "unit tip value (curvature_rms: RMS curvature of the shape)",
                "frequencies": self.frequency_basis, "exported_modeset": self.modeset_file,
                "modes": [m.to_dict() for m in self.modes],
                "disabled": [{"field": f, "mode": k, "key": key, "dof": dof} for f, k, key, dof in self.disabled],
                "kept_from_deck": list(self.kept), "warnings": list(self.warnings),
                "notes": list(self.notes), "files": list(self.files)}

    def lines(self) -> list:
        out = [f"ElastoDyn files in {self.outdir}: {', '.join(Path(f).name for f in self.files)}",
               f"  polynomial fits ({self.weighting} weighting; residuals relative to the unit tip value):",
               f"  frequencies: {self.frequency_basis}",
               f"  {'field':<11} {'mode':>4}  {'family':<15} {'ElastoDyn':<9} {'DOF':<9} "
               f"{'rms':>9} {'max|err|':>9} {'curv.rms':>9} {'f shape':>10} {'f poly':>10} {'change':>8}"]
        for m in self.modes:
            curv = "-" if m.fit.curvature_rms is None else f"{m.fit.curvature_rms:.2e}"
            out.append(f"  {m.field:<11} {m.mode:>4}  {m.family:<15} {m.key:<9} {m.dof:<9} "
                       f"{m.fit.rms:>9.2e} {m.fit.max_abs:>9.2e} {curv:>9} {m.frequency_shape_hz:>7.4f} Hz "
                       f"{m.frequency_fit_hz:>7.4f} Hz {100 * m.frequency_change:>+7.2f} %")
        for f, k, key, dof in self.disabled:
            out.append(f"  {dof} = False: {f} has no mode {k} in the mode set ({key} kept from the deck)")
        if self.kept:
            out.append(f"  kept from the deck (not in the mode set): {', '.join(self.kept)}")
        out += [f"  warning: {w}" for w in self.warnings]
        out += [f"  note: {n}" for n in self.notes]
        if self.sidecar:
            out.append(f"  residuals written to {self.sidecar}")
        if self.modeset_file:
            out.append(f"  exported set (what OpenFAST runs; simulate it with the written deck): {self.modeset_file}")
        return out


def elastodyn_frequency(beam, name: str, nodes: int | None, shape) -> float:
    """ElastoDyn's beam-only modal frequency [Hz] of one bending shape:
    sqrt(K/M) / 2pi with K = sum EI phi''^2 dr and M = sum m phi^2 dr on the
    deck's `nodes` analysis nodes (midpoint rule, ElastoDyn's KBF/MBF, KTFA/MTFA
    without tip or top mass), untwisted. EI: ei_1 for fore-aft/flap, ei_2 for
    side-side/edge. `shape(x, derivative)` takes the normalised span x = s/L.
    Without a node count: 100 midpoint nodes."""
    s, w = elastodyn_nodes(beam.length, nodes or 100)
    x = s / beam.length
    ei = beam.ei_1 if name in ("tower_fa", "blade_flap") else beam.ei_2
    K = np.sum(np.interp(s, beam.span, ei) * w * shape(x, 2) ** 2) / beam.length ** 4
    M = np.sum(np.interp(s, beam.span, beam.mass) * w * shape(x, 0) ** 2)
    return float(np.sqrt(K / M) / (2.0 * np.pi))


# --------------------------------------------------------------------------- export
def export_elastodyn(modeset, shapes: dict, turbine, outdir, *, weighting: str = "uniform") -> ElastoDynExport:
    """Write ElastoDyn main/tower/blade files for `modeset` into `outdir`.

    `shapes` is {field: FieldShapes} (`modesel.export.common.field_shapes`) on
    `turbine` (whose `source` is the deck). Returns the report; also writes it
    as `<stem>_modesel_fits.json` next to the files.
    """
    raw = read_raw_deck(turbine.source)
    ed, tower = copy.deepcopy(raw.elastodyn), copy.deepcopy(raw.tower)
    blades = copy.deepcopy(raw.blades)
    branches = {"ElastoDynTower": [tower], "ElastoDynBlade": blades}
    report = ElastoDynExport(deck=str(raw.main), outdir=str(outdir), weighting=weighting,
                             notes=list(raw.notes))
    x = stations()
    stem = raw.main.stem
    names = output_names(stem, len(blades))
    written_in = {"ElastoDynTower": names["tower"], "ElastoDynBlade": ", ".join(names["blades"])}

    for name in FIELDS:
        if name not in modeset:
            if name in ELASTODYN_MODES:
                report.kept.append(name)
            continue
        fs = shapes[name]
        if name not in ELASTODYN_MODES:
            report.warnings.append(f"{name} ({fs.family}:{fs.count}) cannot be represented in ElastoDyn "
                                   f"(no tower torsion DOF); not exported.")
            continue
        slots = ELASTODYN_MODES[name]
        sampled = fs.sample(x)
        beam = turbine.tower if name in TOWER_FIELDS else turbine.blade
        nodes = getattr(turbine, "tower_nodes" if name in TOWER_FIELDS else "blade_nodes", None)
        mass = np.interp(x * beam.length, beam.span, beam.mass) if weighting == "mass" else None
        ei = beam.ei_1 if name in ("tower_fa", "blade_flap") else beam.ei_2
        stiffness = np.interp(x * beam.length, beam.span, ei) if weighting == "stiffness" else None
        for k, (branch, key, dof, tuner) in enumerate(slots):
            if k >= fs.count:
                ed[dof] = False
                report.disabled.append((name, k + 1, key, dof))
                continue
            fit = fit_mode_polynomial(x, sampled.phi[k], ddphi=sampled.ddphi[k], weighting=weighting,
                                      mass=mass, stiffness=stiffness, field=f"{name} mode {k + 1}")
            for values in branches[branch]:
                values[key] = [float(c) for c in fit.coefficients]
            ed[dof] = True

            def chosen(xs, derivative, k=k):
                sampled_k = fs.sample(xs)
                return (sampled_k.phi, sampled_k.dphi, sampled_k.ddphi)[derivative][k]
            mode = ExportedMode(name, k + 1, fs.family, key, dof, written_in[branch], fit,
                                elastodyn_frequency(beam, name, nodes, chosen),
                                elastodyn_frequency(beam, name, nodes, fit))
            report.modes.append(mode)
            if abs(mode.frequency_change) > FREQUENCY_WARNING:
                report.warnings.append(
                    f"{name} mode {k + 1} ({fs.family}): the polynomial's ElastoDyn frequency differs from "
                    f"the shape's by {100 * mode.frequency_change:+.2f} % ({mode.frequency_shape_hz:.4f} Hz -> "
                    f"{mode.frequency_fit_hz:.4f} Hz); OpenFAST runs the polynomial (the exported set).")
            tuned = [float(v[tuner]) for v in branches[branch]] if tuner and fs.family != "elastodyn" else []
            if any(t != 1.0 for t in tuned):
                report.warnings.append(f"{tuner} = {tuned[0]:g} in the deck was tuned for the deck's own "
                                       f"mode; it now scales the stiffness of the exported {key}.")
        if fs.count > len(slots):
            left_out = (f"mode {fs.count}" if fs.count == len(slots) + 1
                        else f"modes {len(slots) + 1}..{fs.count}")
            report.warnings.append(f"{name} has {fs.count} modes but ElastoDyn holds {len(slots)}: exported "
                                   f"the first {len(slots)}, {left_out} not exported.")

    report.frequency_basis = (f"ElastoDyn's beam-only modal frequency (midpoint rule on the deck's "
                              f"{getattr(turbine, 'tower_nodes', None) or 100} tower / "
                              f"{getattr(turbine, 'blade_nodes', None) or 100} blade nodes, untwisted, "
                              f"no tip/top mass) of the shape and of its polynomial")
    report.files = _write(raw, ed, tower, blades, Path(outdir), names)
    _check_read_back(report, ed, tower, blades)
    exported = {}
    for m in report.modes:
        exported[m.field] = {"family": "elastodyn", "count": max(m.mode, exported.get(m.field, {}).get("count", 0))}
    modeset_file = Path(outdir) / f"{stem}_modesel_modeset.json"
    write_text(modeset_file, json.dumps({"fields": exported, "exported_from": {
        f: {"family": fs.family, "count": fs.count, **({"params": fs.params} if fs.params else {})}
        for f, fs in shapes.items() if f in modeset}}, indent=2) + "\n")
    report.modeset_file = str(modeset_file)
    sidecar = Path(outdir) / f"{stem}_modesel_fits.json"
    write_text(sidecar, json.dumps(report.to_dict(), indent=2) + "\n")
    report.sidecar = str(sidecar)
    return report


def output_names(stem: str, blade_files: int) -> dict:
    """File names openfast-io's writer gives the main, tower and blade files."""
    blades = ([f"{stem}_ElastoDynBlade.dat"] if blade_files == 1
              else [f"{stem}_ElastoDynBlade_{i + 1}.dat" for i in range(blade_files)])
    return {"stem": stem, "main": f"{stem}_ElastoDyn.dat", "tower": f"{stem}_ElastoDyn_tower.dat",
            "blades": blades}


def _write(raw: RawDeck, ed: dict, tower: dict, blades: list, outdir: Path, names: dict) -> list:
    """Write main, tower and blade files with openfast-io; return their paths."""
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ModeselError(f"cannot create the output folder ({exc.strerror})", file=str(outdir)) from None
    if not os.access(outdir, os.W_OK):
        raise ModeselError("output folder is not writable", file=str(outdir))
    blade_names = names["blades"]
    targets = [outdir / names["main"], outdir / names["tower"]] + [outdir / n for n in blade_names]
    inputs = {p.resolve() for p in raw.inputs}
    for target in targets:
        if target.resolve() in inputs:
            raise ModeselError("would overwrite an input file of the deck; choose another output folder",
                               file=str(target))

    writer = InputWriter_OpenFAST()
    writer.FAST_runDirectory, writer.FAST_namingOut = str(outdir), names["stem"]
    writer.fst_vt = {"Fst": {}, "ElastoDyn": ed, "ElastoDynTower": tower, "outlist": raw.outlist}
    try:
        writer.write_ElastoDynTower()                      # sets ed['TwrFile']
        for values, blade_name in zip(blades, blade_names):
            writer.fst_vt["ElastoDynBlade"] = values
            ed["BldFile1"] = blade_name
            writer.write_ElastoDynBlade()                 # writes to ed['BldFile1']
        for k in range(1, 4):
            used = k <= len(raw.blade_of)
            ed[f"BldFile{k}"] = blade_names[raw.blade_of[k - 1] if used else 0]
        writer.write_ElastoDyn()
    except OSError as exc:
        raise ModeselError(f"cannot write ElastoDyn files ({exc.strerror})", file=str(outdir)) from None
    return [str(t) for t in targets]


def _check_read_back(report: ElastoDynExport, ed: dict, tower: dict, blades: list):
    """Read the written files with openfast-io and compare DOF flags and coefficients."""
    main, tower_file, *blade_files = (Path(f) for f in report.files)
    reader = InputReader_OpenFAST()
    reader.read_ElastoDyn(str(main))
    reader.read_ElastoDynTower(str(tower_file))
    got_blades = []
    for blade_file in blade_files:
        reader.read_ElastoDynBlade(str(blade_file), BladeNumber=0)
        got_blades.append(dict(reader.fst_vt["ElastoDynBlade"][0]))
    pairs = [(reader.fst_vt["ElastoDynTower"], tower, tower_file)]
    pairs += [(got, want, f) for got, want, f in zip(got_blades, blades, blade_files)]
    for slots in ELASTODYN_MODES.values():
        for branch, key, dof, _ in slots:
            if reader.fst_vt["ElastoDyn"][dof] != ed[dof]:
                raise ModeselError(f"{dof} reads back as {reader.fst_vt['ElastoDyn'][dof]}", file=str(main))
            for got, want, path in pairs:
                if key in want and list(got[key]) != list(want[key]):
                    raise ModeselError(f"{key} reads back as {got[key]}, wrote {want[key]}", file=str(path))

