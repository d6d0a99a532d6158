"""Turbine description from an OpenFAST ElastoDyn deck, read with openfast_io.

Front functions: `load_turbine(name_or_path)` (a deck path or the built-in
name `nrel5mw`) and `read_elastodyn(path)` (an ElastoDyn main file or an
OpenFAST `.fst` main file whose `EDFile` is followed). Raw deck access for
writers (`modesel.export.elastodyn_writer`): `Deck` (one input file, its
labelled values and its normalised text), `read_deck(path, kind)` (openfast_io's
dictionary of a normalised file), `referenced_file` and `has_label`.

How the deck is read
--------------------
openfast_io 5.0 reads input files line by line in the layout of the newest
OpenFAST release (`InputReader_OpenFAST.read_ElastoDyn` expects e.g. a
`PitchDOF` line, pitch-bearing inertias and a yaw-friction section;
`read_ElastoDynBlade` expects a station table without the `PitchAxis`
column; `read_MainInput` expects `ModCoupling`, `NRotors`, an environmental
section ...). Decks written for earlier releases (like the NREL 5-MW decks
shipped here) would be mis-read silently. So every file is first
*normalised* into the layout openfast_io expects, then read by openfast_io:

1. The expected layout is taken from openfast_io itself: its writer
   (`InputWriter_OpenFAST.write_ElastoDyn`, `write_ElastoDynTower`,
   `write_ElastoDynBlade`, `write_MainInput`) is run once on placeholder
   values, which yields the ordered list of input labels, separators and
   station-table columns that the matching reader consumes.
2. The deck's lines are matched to that layout by their input label
   (`TowerHt`, `BldFile(1)` ...), independently of their position. Deck
   lines are copied verbatim; station-table columns are picked by their
   header name (so the old `PitchAxis` column is dropped); the OutList
   section is copied unchanged.
3. Inputs the deck does not have (introduced by later OpenFAST releases)
   get the neutral value that reproduces the older behaviour (`_DEFAULTS`:
   pitch DOF off, zero pitch-bearing inertia, no yaw friction ...); each
   one is recorded in `Turbine.notes`. A missing input without such a
   default is an error naming the file and the label.
4. openfast_io reads the normalised temporary file; every value used below
   comes from its result.

`Gravity` moved from ElastoDyn to the `.fst` file in OpenFAST 4; openfast_io
5.0 reads it from the `.fst` only. Precedence here: the `.fst` value when a
`.fst` with a Gravity line is given, else the ElastoDyn `Gravity` line of an
older deck (converted with openfast_io's `float_read`), else 9.80665 m/s^2
(recorded in the notes).

Units: the deck's degrees become rad, rpm become rad/s, percent become
fractions; everything else is SI as in the deck.
"""
from __future__ import annotations

import copy
import functools
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from openfast_io.FAST_reader import InputReader_OpenFAST, float_read, fix_path
from openfast_io.FAST_vars_out import FstOutput
from openfast_io.FAST_writer import InputWriter_OpenFAST

from modesel.errors import ModeselError, did_you_mean
from modesel.turbine.beam import BeamProperties
from modesel.turbine.description import Turbine
from modesel.turbine.deck_cache import cached
from modesel.turbine.openfast_inputs import TOKEN

from modesel.turbine.builtin import BUILTIN_TURBINES, builtin_elastodyn

# Torsion properties ElastoDyn does not have (tower: thin-walled steel tube).
# GJ = E J / (2 (1 + nu)) with J = 2 I  ->  GJ = EI / (1 + nu);
# polar mass inertia per length rho J = 2 rho EI / E.
# E, nu and the effective density (8500 kg/m^3, steel plus paint, bolts,
# welds and flanges) are those of the NREL 5-MW tower definition
# (Jonkman et al. 2009, NREL/TP-500-38060, section 6).
STEEL_YOUNG_MODULUS = 210.0e9     # Pa
STEEL_POISSON_RATIO = 0.3         # -
TOWER_EFFECTIVE_DENSITY = 8500.0  # kg/m^3

TOWER_COLUMNS = ("HtFract", "TMassDen", "TwFAStif", "TwSSStif")
BLADE_COLUMNS = ("BlFract", "StrcTwst", "BMassDen", "FlpStff", "EdgStff")


@dataclass(frozen=True)
class _FileKind:
    """How openfast_io writes/reads one kind of input file."""

    writer: str            # InputWriter_OpenFAST method producing the layout
    reader: str            # InputReader_OpenFAST method reading it
    branch: str            # fst_vt key the reader fills
    overrides: tuple = ()  # placeholder values the writer needs typed
    table: tuple = ()      # (count label, column names) of a station table
    extra_labels: tuple = ()  # labels of older layouts we also pick up


_KINDS = {
    "main": _FileKind("write_MainInput", "read_MainInput", "Fst",
                      overrides=(("OutFileFmt", 0), ("MirrorRotor", [True]), ("LinTimes", [0.0]))),
    "elastodyn": _FileKind("write_ElastoDyn", "read_ElastoDyn", "ElastoDyn",
                           overrides=(("TwrGagNd", 0), ("BldGagNd", 0)),
                           extra_labels=("Gravity",)),
    "tower": _FileKind("write_ElastoDynTower", "read_ElastoDynTower", "ElastoDynTower",
                       overrides=tuple((c, []) for c in TOWER_COLUMNS),
                       table=("NTwInpSt", TOWER_COLUMNS)),
    "blade": _FileKind("write_ElastoDynBlade", "read_ElastoDynBlade", "ElastoDynBlade",
                       overrides=tuple((c, []) for c in BLADE_COLUMNS),
                       table=("NBlInpSt", BLADE_COLUMNS)),
}

# Neutral values for inputs added by later OpenFAST releases (older behaviour).
_DEFAULTS = {
    "elastodyn": {
        "PitchDOF": "False", "PtfmRefxt": "0", "PtfmRefyt": "0",
        "PBrIner(1)": "0", "PBrIner(2)": "0", "PBrIner(3)": "0",
        "BlPIner(1)": "0", "BlPIner(2)": "0", "BlPIner(3)": "0",
        "HubIner_Teeter": "0", "PtfmXYIner": "0", "PtfmYZIner": "0", "PtfmXZIner": "0",
        "YawFrctMod": "0", "M_CSmax": "0", "M_FCSmax": "0", "M_MCSmax": "0", "M_CD": "0",
        "M_FCD": "0", "M_MCD": "0", "sig_v": "0", "sig_v2": "0", "OmgCut": "0",
    },
    "main": {
        "ModCoupling": "1", "RhoInf": "1.0", "ConvTol": "1e-4", "MaxConvIter": "6",
        "NRotors": "1", "CompSeaSt": "0", "CompSoil": "0", "MHK": "0", "MirrorRotor": "False",
        "Gravity": "9.80665", "AirDens": "1.225", "WtrDens": "1025", "KinVisc": "1.464e-5",
        "SpdSound": "335", "Patm": "103500", "Pvap": "1700", "WtrDpth": "0", "MSL2SWL": "0",
        "SeaStFile": '"unused"', "SoilFile": '"unused"',
    },
}

_BOOL_WORDS = {"true", "false", "t", "f"}


# --------------------------------------------------------------------------
# Front functions
# --------------------------------------------------------------------------

def load_turbine(name_or_path) -> Turbine:
    """A built-in turbine by name (`nrel5mw`) or a deck (ElastoDyn or .fst) by path."""
    text = str(name_or_path)
    builtin = builtin_elastodyn(text)
    if builtin is not None:
        return read_elastodyn(builtin)
    path = Path(text)
    if not path.is_file():
        hint = did_you_mean(text, BUILTIN_TURBINES) if not path.suffix else ""
        raise ModeselError(f"turbine deck not found (give an ElastoDyn or .fst file, or one of "
                           f"{', '.join(BUILTIN_TURBINES)}){hint}", file=text)
    return read_elastodyn(path)


def read_elastodyn(path) -> Turbine:
    """Read an ElastoDyn main file (or a .fst main file) and its tower/blade files."""
    path = Path(path)
    if not path.is_file():
        raise ModeselError("file not found", file=str(path))
    notes = []
    gravity = None
    if has_label(path, "EDFile"):
        fst, fst_deck = read_deck(path, "main")
        if "Gravity" in fst_deck.found:
            gravity = _number(fst, "Gravity", "Gravity", fst_deck)
        ed_path = referenced_file(path, fst_deck.file_name("EDFile"), "EDFile")
        notes += fst_deck.notes(ignore=("Gravity",))
    else:
        ed_path = path
    ed, ed_deck = read_deck(ed_path, "elastodyn")
    notes += ed_deck.notes()
    if gravity is None and "Gravity" in ed_deck.found:
        gravity = _checked_float(float_read(ed_deck.value("Gravity")), "Gravity", ed_deck)
    if gravity is None:
        gravity = 9.80665
        notes.append(f"{ed_path.name} has no Gravity input: standard gravity 9.80665 m/s^2 used.")

    num = functools.partial(_number, ed, deck=ed_deck)
    num_blades = int(num("NumBl", "NumBl"))
    if num_blades not in (1, 2, 3):
        raise ModeselError(f"NumBl must be 1, 2 or 3, got {num_blades}", file=str(ed_path), field="NumBl")
    per_blade = range(1, num_blades + 1)

    tower_height, tower_base = num("TowerHt", "TowerHt"), num("TowerBsHt", "TowerBsHt")
    tip_radius, hub_radius = num("TipRad", "TipRad"), num("HubRad", "HubRad")
    if tower_height <= tower_base:
        raise ModeselError(f"TowerHt ({tower_height:g} m) must exceed TowerBsHt ({tower_base:g} m)",
                           file=str(ed_path), field="TowerHt")
    if tip_radius <= hub_radius:
        raise ModeselError(f"TipRad ({tip_radius:g} m) must exceed HubRad ({hub_radius:g} m)",
                           file=str(ed_path), field="TipRad")

    gearbox_efficiency = num("GBoxEff", "GBoxEff")
    if not 0.0 < gearbox_efficiency <= 100.0:
        raise ModeselError(f"GBoxEff must be in (0, 100] %, got {gearbox_efficiency:g}", file=str(ed_path),
                           field="GBoxEff")

    tower_file = referenced_file(ed_path, ed_deck.file_name("TwrFile"), "TwrFile")
    tower, tower_shapes = _tower(tower_file, tower_height - tower_base)
    blade_files = [referenced_file(ed_path, ed_deck.file_name(f"BldFile({k})"), f"BldFile({k})")
                   for k in per_blade]
    blade, blade_shapes = _blade(blade_files[0], tip_radius - hub_radius, hub_radius)
    first_values = read_deck(blade_files[0], "blade")[0]
    for k, other in zip(per_blade[1:], blade_files[1:]):
        if other.read_bytes() != blade_files[0].read_bytes() and not _same(read_deck(other, "blade")[0],
                                                                          first_values):
            raise ModeselError(f"blade {k} differs from blade 1 ({other.name} against {blade_files[0].name}); "
                               f"modesel models a rotor of equal blades", file=str(ed_path), field=f"BldFile({k})")
    notes += list(tower.notes) + list(blade.notes)

    def deg(value):
        return float(np.deg2rad(value))

    dof_labels = ("FlapDOF1", "FlapDOF2", "EdgeDOF", "PitchDOF", "TeetDOF", "DrTrDOF", "GenDOF",
                  "YawDOF", "TwFADOF1", "TwFADOF2", "TwSSDOF1", "TwSSDOF2", "PtfmSgDOF",
                  "PtfmSwDOF", "PtfmHvDOF", "PtfmRDOF", "PtfmPDOF", "PtfmYDOF")
    dofs = {label: _flag(ed, label, ed_deck) for label in dof_labels if label in ed_deck.found}
    if "Furling" in ed_deck.found and _flag(ed, "Furling", ed_deck):
        raise ModeselError("unsupported: rotor and tail furling (FurlFile) is not modelled (set Furling to False)",
                           file=str(ed_deck.path), field="Furling")
    azimuth_b1_up = deg(num("AzimB1Up", "AzimB1Up")) if "AzimB1Up" in ed_deck.found else 0.0
    initial = {
        "OoPDefl": num("OoPDefl", "OoPDefl"), "IPDefl": num("IPDefl", "IPDefl"),
        "BlPitch": tuple(deg(num(f"BlPitch{k}", f"BlPitch({k})")) for k in per_blade),
        "TeetDefl": deg(num("TeetDefl", "TeetDefl")),
        # blade 1's azimuth from up; the deck's Azimuth reads AzimB1Up there (ElastoDyn.f90 Init_ContStates)
        "Azimuth": deg(num("Azimuth", "Azimuth")) - azimuth_b1_up,
        "RotSpeed": num("RotSpeed", "RotSpeed") * np.pi / 30.0,
        "NacYaw": deg(num("NacYaw", "NacYaw")),
        "TTDspFA": num("TTDspFA", "TTDspFA"), "TTDspSS": num("TTDspSS", "TTDspSS"),
        "PtfmSurge": num("PtfmSurge", "PtfmSurge"), "PtfmSway": num("PtfmSway", "PtfmSway"),
        "PtfmHeave": num("PtfmHeave", "PtfmHeave"), "PtfmRoll": deg(num("PtfmRoll", "PtfmRoll")),
        "PtfmPitch": deg(num("PtfmPitch", "PtfmPitch")), "PtfmYaw": deg(num("PtfmYaw", "PtfmYaw")),
    }
    undersling, hub_teeter_inertia, delta3 = _two_blader(ed, ed_deck, num_blades, dofs, initial, num)
    return Turbine(
        tower=tower, blade=blade, num_blades=num_blades,
        tower_height=tower_height, tower_base_height=tower_base,
        tip_radius=tip_radius, hub_radius=hub_radius,
        precone=tuple(deg(num(f"PreCone({k})", f"PreCone({k})")) for k in per_blade),
        shaft_tilt=deg(num("ShftTilt", "ShftTilt")), overhang=num("OverHang", "OverHang"),
        twr2shft=num("Twr2Shft", "Twr2Shft"), shaft_gage=num("ShftGagL", "ShftGagL"),
        nacelle_cm=(num("NacCMxn", "NacCMxn"), num("NacCMyn", "NacCMyn"), num("NacCMzn", "NacCMzn")),
        nacelle_imu=tuple(num(k, k) if ed.get(k) is not None else 0.0 for k in ("NcIMUxn", "NcIMUyn", "NcIMUzn")),
        hub_cm=num("HubCM", "HubCM"), hub_mass=num("HubMass", "HubMass"),
        hub_inertia=num("HubIner", "HubIner"), hub_teeter_inertia=hub_teeter_inertia,
        undersling=undersling, delta3=delta3, generator_inertia=num("GenIner", "GenIner"),
        azimuth_b1_up=azimuth_b1_up,
        nacelle_mass=num("NacMass", "NacMass"), nacelle_yaw_inertia=num("NacYIner", "NacYIner"),
        yaw_bearing_mass=num("YawBrMass", "YawBrMass"),
        tip_mass=tuple(num(f"TipMass({k})", f"TipMass({k})") for k in per_blade),
        platform_mass=num("PtfmMass", "PtfmMass"),
        platform_inertia=(num("PtfmRIner", "PtfmRIner"), num("PtfmPIner", "PtfmPIner"),
                          num("PtfmYIner", "PtfmYIner")),
        platform_cm=(num("PtfmCMxt", "PtfmCMxt"), num("PtfmCMyt", "PtfmCMyt"),
                     num("PtfmCMzt", "PtfmCMzt")),
        platform_ref_z=num("PtfmRefzt", "PtfmRefzt"),
        gearbox_ratio=num("GBRatio", "GBRatio"), gearbox_efficiency=gearbox_efficiency / 100.0,
        drivetrain_stiffness=num("DTTorSpr", "DTTorSpr"), drivetrain_damping=num("DTTorDmp", "DTTorDmp"),
        gravity=gravity,
        elastodyn_shapes={**tower_shapes, **blade_shapes},
        dofs=dofs, initial=initial, source=str(path), notes=tuple(notes),
        blade_nodes=_node_count(num("BldNodes", "BldNodes"), "BldNodes", ed_deck),
        blade_gauges=_gauges(ed, ed_deck, "NBlGages", "BldGagNd", num("BldNodes", "BldNodes")),
        tower_gauges=_gauges(ed, ed_deck, "NTwGages", "TwrGagNd", num("TwrNodes", "TwrNodes")),
        tower_nodes=_node_count(num("TwrNodes", "TwrNodes"), "TwrNodes", ed_deck),
    )


def _node_count(value: float, label: str, deck) -> int:
    """An analysis node count (BldNodes, TwrNodes): a positive integer."""
    if value != int(value) or value < 1:
        raise ModeselError(f"must be a positive integer, got {deck.value(label)!r}", file=str(deck.path), field=label)
    return int(value)


# --------------------------------------------------------------------------
# Tower and blade files -> BeamProperties
# --------------------------------------------------------------------------

def _tower(path: Path, length: float):
    tw, deck = read_deck(path, "tower")
    num = functools.partial(_number, tw, deck=deck)
    fraction = _column(tw, "HtFract", deck)
    mass = _column(tw, "TMassDen", deck) * num("AdjTwMa", "AdjTwMa")
    ei_fa = _column(tw, "TwFAStif", deck) * num("AdjFASt", "AdjFASt")
    ei_ss = _column(tw, "TwSSStif", deck) * num("AdjSSSt", "AdjSSSt")
    _check_fractions(fraction, "HtFract", deck)
    for values, label in ((mass, "TMassDen"), (ei_fa, "TwFAStif"), (ei_ss, "TwSSStif")):
        _check_positive(values, label, deck)
    ei_mean = 0.5 * (ei_fa + ei_ss)
    note = (f"{path.name}: no torsion properties in ElastoDyn; tower GJ = EI/(1+nu) and polar mass "
            f"inertia 2*rho*EI/E of a thin-walled steel tube (E={STEEL_YOUNG_MODULUS:.3g} Pa, "
            f"nu={STEEL_POISSON_RATIO}, rho={TOWER_EFFECTIVE_DENSITY:g} kg/m^3, EI the mean of "
            f"fore-aft and side-side).")
    beam = BeamProperties(
        name="tower", span=fraction * length, mass=mass, ei_1=ei_fa, ei_2=ei_ss,
        gj=ei_mean / (1.0 + STEEL_POISSON_RATIO),
        polar_inertia=2.0 * TOWER_EFFECTIVE_DENSITY * ei_mean / STEEL_YOUNG_MODULUS,
        twist=np.zeros_like(fraction), root_offset=0.0,
        damping_ratio={"tower_fa": [num("TwrFADmp1", "TwrFADmp(1)") / 100.0,
                                    num("TwrFADmp2", "TwrFADmp(2)") / 100.0],
                       "tower_ss": [num("TwrSSDmp1", "TwrSSDmp(1)") / 100.0,
                                    num("TwrSSDmp2", "TwrSSDmp(2)") / 100.0]},
        notes=(note,) + tuple(deck.notes()),
        stiffness_tuners={"tower_fa": [num("FAStTunr1", "FAStTunr(1)"), num("FAStTunr2", "FAStTunr(2)")],
                          "tower_ss": [num("SSStTunr1", "SSStTunr(1)"), num("SSStTunr2", "SSStTunr(2)")]},
        source=str(path))
    shapes = {"tower_fa": [_coefficients(tw, "TwFAM1Sh", deck), _coefficients(tw, "TwFAM2Sh", deck)],
              "tower_ss": [_coefficients(tw, "TwSSM1Sh", deck), _coefficients(tw, "TwSSM2Sh", deck)]}
    return beam, shapes


def _blade(path: Path, length: float, hub_radius: float):
    bl, deck = read_deck(path, "blade")
    num = functools.partial(_number, bl, deck=deck)
    fraction = _column(bl, "BlFract", deck)
    _check_fractions(fraction, "BlFract", deck)
    note = (f"{path.name}: ElastoDyn blades have no torsion properties or torsion DOF; blade GJ and "
            f"polar mass inertia are set to 0 (no modesel field uses blade torsion).")
    beam = BeamProperties(
        name="blade", span=fraction * length,
        mass=_column(bl, "BMassDen", deck) * num("AdjBlMs", "AdjBlMs"),
        ei_1=_column(bl, "FlpStff", deck) * num("AdjFlSt", "AdjFlSt"),
        ei_2=_column(bl, "EdgStff", deck) * num("AdjEdSt", "AdjEdSt"),
        gj=np.zeros_like(fraction), polar_inertia=np.zeros_like(fraction),
        twist=np.deg2rad(_column(bl, "StrcTwst", deck)), root_offset=hub_radius,
        damping_ratio={"blade_flap": [num("BldFlDmp1", "BldFlDmp(1)") / 100.0,
                                      num("BldFlDmp2", "BldFlDmp(2)") / 100.0],
                       "blade_edge": [num("BldEdDmp1", "BldEdDmp(1)") / 100.0]},
        notes=(note,) + tuple(deck.notes()),
        stiffness_tuners={"blade_flap": [num("FlStTunr1", "FlStTunr(1)"), num("FlStTunr2", "FlStTunr(2)")]},
        source=str(path))
    for values, label in ((beam.mass, "BMassDen"), (beam.ei_1, "FlpStff"), (beam.ei_2, "EdgStff")):
        _check_positive(values, label, deck)
    shapes = {"blade_flap": [_coefficients(bl, "BldFl1Sh", deck), _coefficients(bl, "BldFl2Sh", deck)],
              "blade_edge": [_coefficients(bl, "BldEdgSh", deck)]}
    return beam, shapes


def _check_positive(values, label, deck):
    """Distributed mass and stiffness (adjustment factors applied) must be > 0."""
    bad = np.flatnonzero(~(np.asarray(values, float) > 0))
    if len(bad):
        raise ModeselError(f"must be > 0 at every station (adjustment factor applied), got "
                           f"{values[bad[0]]:g} at station {bad[0] + 1}", file=str(deck.path), field=label)


def _check_fractions(fraction, label, deck):
    if fraction[0] != 0.0 or fraction[-1] != 1.0 or np.any(np.diff(fraction) <= 0):
        raise ModeselError(f"station fractions must increase from 0 to 1, got {fraction[0]:g}..{fraction[-1]:g}",
                           file=str(deck.path), field=label)


# --------------------------------------------------------------------------
# Values out of openfast_io's result, checked against the deck text
# --------------------------------------------------------------------------

def _checked_float(value, label, deck) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) or not np.isfinite(value):
        raise ModeselError(f"non-numeric value {deck.value(label)!r}", file=str(deck.path), field=label)
    return float(value)


def _gauges(ed, deck, count_label, nodes_label, nodes) -> tuple:
    """The ElastoDyn nodes (1-based) that carry strain gauges: `count_label`
    (NBlGages, NTwGages: 0 to 9) entries of `nodes_label` (BldGagNd,
    TwrGagNd), each between 1 and the beam's node count `nodes`."""
    count = int(_checked_float(ed.get(count_label), count_label, deck))
    if not 0 <= count <= 9:
        raise ModeselError(f"{count_label} must be 0 to 9, got {count}", file=str(deck.path), field=count_label)
    if count == 0:
        return ()
    raw = ed.get(nodes_label)
    values = list(raw) if isinstance(raw, (list, tuple)) else [raw]
    if len(values) < count:
        raise ModeselError(f"{count_label} = {count} but {len(values)} node(s) given", file=str(deck.path),
                           field=nodes_label)
    gauges = tuple(int(_checked_float(v, nodes_label, deck)) for v in values[:count])
    if any(not 1 <= g <= nodes for g in gauges):
        raise ModeselError(f"gauge nodes must be 1 to {int(nodes)}, got {list(gauges)}", file=str(deck.path),
                           field=nodes_label)
    return gauges


def _two_blader(ed, deck, num_blades, dofs, initial, num):
    """(UndSling [m], hub inertia about the teeter axis through the hub's CM
    [kg m^2], Delta3 [rad]) of a two-bladed rotor, (0, 0, 0) for other rotors,
    as ElastoDyn sets them (ElastoDyn.f90: UndSling and the teeter inputs are
    read for NumBl = 2 only; Hubf2Iner = HubIner_Teeter - HubMass (UndSling -
    HubCM)^2; SetCoordSy turns the blades' frame g by Delta3 about the shaft
    from the teeter frame f, teetered or not). The teeter hinge itself is not
    modelled: TeetDOF and a fixed TeetDefl are refused in one line naming the input."""
    if num_blades != 2:
        return 0.0, 0.0, 0.0
    if dofs.get("TeetDOF"):
        raise ModeselError("unsupported: the rotor-teeter DOF is not modelled (set TeetDOF to False)",
                           file=str(deck.path), field="TeetDOF")
    if initial["TeetDefl"] != 0.0:
        raise ModeselError("unsupported: a rotor teetered at a fixed angle is not modelled (set TeetDefl to 0)",
                           file=str(deck.path), field="TeetDefl")
    undersling = num("UndSling", "UndSling")
    inertia = num("HubIner_Teeter", "HubIner_Teeter") - num("HubMass", "HubMass") * (undersling - num("HubCM", "HubCM")) ** 2
    if inertia < 0.0:
        raise ModeselError(f"HubIner_Teeter must be at least HubMass (UndSling - HubCM)^2 for a two-bladed rotor "
                           f"(the hub's inertia about the teeter axis through its CM would be {inertia:.4g} kg m^2)",
                           file=str(deck.path), field="HubIner_Teeter")
    return undersling, inertia, float(np.deg2rad(num("Delta3", "Delta3")))


def _number(values: dict, key: str, label: str, deck) -> float:
    """openfast_io's value for `key` (deck label `label`) as a finite float."""
    return _checked_float(values.get(key), label, deck)


def _flag(values: dict, label: str, deck) -> bool:
    """A flag; the deck text must be a boolean word (openfast_io maps any other text to False)."""
    if deck.value(label).strip('"').lower() not in _BOOL_WORDS:
        raise ModeselError(f"expected True or False, got {deck.value(label)!r}", file=str(deck.path), field=label)
    return bool(values[label])


def _column(values: dict, name: str, deck) -> np.ndarray:
    return np.array([_checked_float(v, name, deck) for v in values[name]], dtype=float)


def _coefficients(values: dict, key: str, deck) -> list:
    """Mode-shape polynomial coefficients of x^2..x^6."""
    return [_checked_float(v, f"{key}({k + 2})", deck) for k, v in enumerate(values[key])]


def _same(a, b) -> bool:
    """Whether two parsed deck values are equal (dicts, lists, arrays, numbers, text)."""
    if isinstance(a, dict) or isinstance(b, dict):
        return isinstance(a, dict) and isinstance(b, dict) and a.keys() == b.keys() and all(
            _same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple, np.ndarray)) or isinstance(b, (list, tuple, np.ndarray)):
        try:
            return np.array_equal(np.asarray(a), np.asarray(b))
        except (TypeError, ValueError):
            return False
    return a == b


def referenced_file(parent: Path, name: str, label: str) -> Path:
    """A file named in `parent` (relative names are relative to parent's folder)."""
    name = str(name).strip()
    target = Path(fix_path(name))
    if not target.is_absolute():
        target = parent.parent / target
    if not name or not target.is_file():
        raise ModeselError(f"referenced file '{name}' not found (looked for {target})",
                           file=str(parent), field=label)
    return target


# --------------------------------------------------------------------------
# Normalising a deck into openfast_io's layout
# --------------------------------------------------------------------------

class _Placeholders(dict):
    """fst_vt branch whose missing entries are their own key (for the writer)."""

    def __missing__(self, key):
        return key


@functools.lru_cache(maxsize=None)
def _layout(kind: str) -> tuple:
    """The line layout openfast_io's reader expects for `kind`, taken from its writer.

    Returns a tuple of entries: ("text",) header line, ("sep", line),
    ("value", label), ("table",) station table (column names + units line),
    ("outlist",) the OutList section (rest of the file).
    """
    spec = _KINDS[kind]
    writer = InputWriter_OpenFAST()
    with tempfile.TemporaryDirectory() as folder:
        writer.FAST_runDirectory, writer.FAST_namingOut = folder, "layout"
        writer.fst_vt = {b: _Placeholders() for b in ("Fst", "ElastoDyn", "ElastoDynTower", "ElastoDynBlade")}
        writer.fst_vt[spec.branch].update(dict(spec.overrides))
        writer.fst_vt["outlist"] = copy.deepcopy(FstOutput)
        getattr(writer, spec.writer)()
        (written,) = os.listdir(folder)
        lines = Path(folder, written).read_text().splitlines()
    columns = list(spec.table[1]) if spec.table else None
    entries, skip = [], 0
    for i, line in enumerate(lines):
        if skip:
            skip -= 1
        elif i < 2:
            entries.append(("text",))
        elif line.split() == columns:
            entries.append(("table",))
            skip = 1                      # the units line
        elif line.startswith(("---", "===")):
            entries.append(("sep", line))
        elif line.split()[0] == "OutList":
            entries.append(("outlist",))
            break
        else:
            entries.append(("value", line[23:].split()[0]))
    return tuple(entries)


class Deck:
    """The text of one input file, its labelled values and its station table."""

    def __init__(self, path: Path, kind: str):
        self.path, self.kind = Path(path), kind
        try:
            self.lines = self.path.read_text(errors="replace").splitlines()
        except OSError as exc:
            raise ModeselError(f"cannot read file: {exc.strerror}", file=str(path)) from None
        layout = _layout(kind)
        labels = {e[1] for e in layout if e[0] == "value"} | set(_KINDS[kind].extra_labels)
        self.found = {}       # label -> (line index, value text)
        self.outlist_at = None
        self.defaulted = []
        for i, line in enumerate(self.lines[2:], start=2):
            tokens = TOKEN.findall(line)      # a quoted file name with blanks is one token
            if tokens and tokens[0] == "OutList":
                self.outlist_at = i
                break
            for j, token in enumerate(tokens):
                if token in labels and (j > 0 or token in ("TwrGagNd", "BldGagNd")):
                    if token in self.found:
                        raise ModeselError(f"input '{token}' given twice (lines {self.found[token][0] + 1} "
                                           f"and {i + 1})", file=str(path), field=token)
                    self.found[token] = (i, " ".join(tokens[:j]))
                    break

    def value(self, label: str) -> str:
        """The deck's value text of `label` ('' when absent)."""
        return self.found.get(label, (None, ""))[1]

    def file_name(self, label: str) -> str:
        """The file name of `label` as OpenFAST reads it: the value without its
        quotes, blanks included (openfast-io's value is cut at the first blank)."""
        return self.value(label).strip().strip("\"'")

    def notes(self, ignore=()) -> list:
        names = [d for d in self.defaulted if d not in ignore]
        if not names:
            return []
        return [f"{self.path.name} predates inputs that openfast_io 5.0 reads; neutral values used for "
                f"{', '.join(names)} (the behaviour of the older format)."]

    def _check_value(self, label: str):
        text = self.value(label)
        first = text.replace(",", " ").split()[0] if text else ""
        if label in ("TwrGagNd", "BldGagNd"):
            return
        if not first:
            raise ModeselError("value missing", file=str(self.path), field=label)
        if first.startswith(('"', "'")) or first.lower() in _BOOL_WORDS or "default" in first.lower():
            return
        try:
            float(first)
        except ValueError:
            raise ModeselError(f"non-numeric value {first!r}", file=str(self.path), field=label) from None

    def _table(self) -> list:
        count_label, columns = _KINDS[self.kind].table
        if count_label not in self.found:
            raise ModeselError("station count missing", file=str(self.path), field=count_label)
        try:
            count = int(self.value(count_label).split()[0])
        except ValueError:
            raise ModeselError(f"station count must be an integer, got {self.value(count_label)!r}",
                               file=str(self.path), field=count_label) from None
        if count < 2:
            raise ModeselError(f"need at least 2 stations, got {count}", file=str(self.path), field=count_label)
        header = next((i for i, line in enumerate(self.lines) if line.split()[:1] == [columns[0]]), None)
        if header is None:
            raise ModeselError(f"station table (header starting with '{columns[0]}') not found",
                               file=str(self.path), field=columns[0])
        names = self.lines[header].split()
        missing = [c for c in columns if c not in names]
        if missing:
            raise ModeselError(f"station table lacks column(s) {', '.join(missing)}",
                               file=str(self.path), field=missing[0])
        picks = [names.index(c) for c in columns]
        rows = []
        for k in range(count):
            i = header + 2 + k
            tokens = self.lines[i].split() if i < len(self.lines) else []
            numeric = len(tokens) >= len(names)
            for token in tokens[:len(names)]:
                try:
                    float(token)
                except ValueError:
                    numeric = False
            if not numeric:
                raise ModeselError(f"station table has {k} complete numeric rows but {count_label} = {count}"
                                   f" (line {i + 1}: {' '.join(tokens)[:40]!r})",
                                   file=str(self.path), field=count_label)
            rows.append(" ".join(tokens[p] for p in picks))
        return [" ".join(columns), " ".join("(-)" for _ in columns)] + rows

    def normalised(self) -> str:
        """The deck rewritten in openfast_io's layout (see module docstring)."""
        out, header = [], iter(self.lines[:2] + ["", ""])
        defaults = _DEFAULTS.get(self.kind, {})
        for entry in _layout(self.kind):
            if entry[0] == "text":
                out.append(next(header))
            elif entry[0] == "sep":
                out.append(entry[1])
            elif entry[0] == "table":
                out.extend(self._table())
            elif entry[0] == "outlist":
                if self.outlist_at is None:
                    out += ["OutList", "END"]
                else:
                    rest = self.lines[self.outlist_at:]
                    # openfast_io loops forever on an OutList without its END line
                    if not any(line[:3].upper() == "END" for line in rest[1:]):
                        rest = rest + ["END of input file (added by modesel: the deck had none)"]
                    out += rest
            elif entry[1] in self.found:
                self._check_value(entry[1])
                out.append(self.lines[self.found[entry[1]][0]])
            elif entry[1] in defaults:
                self.defaulted.append(entry[1])
                out.append(f"{defaults[entry[1]]:<22} {entry[1]}   - modesel: not in deck, neutral value")
            else:
                raise ModeselError("input missing from the deck", file=str(self.path), field=entry[1])
        return "\n".join(out) + "\n"


def read_deck(path: Path, kind: str):
    """Normalise `path` and read it with openfast_io; return (values, deck).
    Parsed decks are cached on disk (`modesel.turbine.deck_cache`); errors
    name `path` as given here."""
    values, deck = cached(_read_deck, path, kind)
    deck.path = Path(path)
    return values, deck


def _read_deck(path: Path, kind: str):
    deck = Deck(path, kind)
    text = deck.normalised()
    spec = _KINDS[kind]
    reader = InputReader_OpenFAST()
    reader.FAST_directory = str(Path(path).parent)
    with tempfile.TemporaryDirectory() as folder:
        normalised = Path(folder, Path(path).name)
        normalised.write_text(text)
        try:
            if kind == "main":
                reader.FAST_directory, reader.FAST_InputFile = folder, normalised.name
                getattr(reader, spec.reader)()
            elif kind == "blade":
                getattr(reader, spec.reader)(str(normalised), BladeNumber=0)
            else:
                getattr(reader, spec.reader)(str(normalised))
        except (ValueError, IndexError, TypeError) as exc:
            raise ModeselError(f"openfast_io could not read the deck: {exc}", file=str(path)) from None
    values = reader.fst_vt[spec.branch]
    return (values[0] if isinstance(values, list) else values), deck


def has_label(path: Path, label: str) -> bool:
    """Whether some line of `path` carries the input label `label` (a .fst has EDFile)."""
    try:
        lines = path.read_text(errors="replace").splitlines()
    except OSError as exc:
        raise ModeselError(f"cannot read file: {exc.strerror}", file=str(path)) from None
    return any(label in line.split()[1:2] for line in lines)
