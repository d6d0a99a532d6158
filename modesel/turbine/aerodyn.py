"""Read an AeroDyn input deck: main file, blade file(s), airfoil polars, tower table.

The blade file and the airfoil tables are read with openfast-io
(`read_AeroDynBlade`, `read_AeroDynPolar`). The main file is first given to
openfast-io's `read_AeroDyn`; that reader is positional and follows the
AeroDyn layout of OpenFAST 4 (it expects e.g. `BEM_Mod`, `SkewMomCorr`,
`SectAvg`, `AoA34`, `NacArea` lines). Decks in the older AeroDyn v15 layout
(OpenFAST 3, like the bundled NREL 5-MW `NREL5MW_AD.dat`) lack those lines and
make it fail (or misread earlier values before failing). In that case the few
fields used here are looked up by their keyword (second token of the line),
which is layout independent, and the fallback is recorded in `notes`.
Values "default" take AeroDyn's documented defaults (`DEFAULTS`).
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from modesel.errors import ModeselError
from modesel.aero.airfoils import PolarSet, read_polars
from modesel.aero.bem import PITT_PETERS_FACTOR, BemOptions
from modesel.aero.blade import AeroBlade
from modesel.aero.tower_drag import TowerDrag
from modesel.aero.tower_influence import POTENTIAL_NAMES, SHADOW_NAMES, check_tower_table
from modesel.turbine.deck_cache import cached, remembered
from modesel.turbine.openfast_inputs import TOKEN

#: AeroDyn/OpenFAST defaults for "default" entries: air at sea level (the
#: OpenFAST glue code's AirDens 1.225 kg/m^3, KinVisc 1.464e-5 m^2/s,
#: SpdSound 335 m/s) and the Pitt/Peters constant (`aero.bem.PITT_PETERS_FACTOR`).
DEFAULTS = {"AirDens": 1.225, "KinVisc": 1.464e-5, "SpdSound": 335.0,
            "SkewModFactor": PITT_PETERS_FACTOR}


@dataclass
class AeroDynDeck:
    """What the reduced model uses from an AeroDyn deck (SI units).

    blades : one `AeroBlade` per blade file (identical files are read once
        and shared).
    air_density [kg/m^3], kinematic_viscosity [m^2/s], speed_of_sound [m/s].
    bem : the BEM switches as `BemOptions`: tip_loss, hub_loss,
        tangential_induction, axial_drag, tangential_drag from the AeroDyn
        flags TipLoss, HubLoss, TanInd, AIDrag, TIDrag; skew_correction
        (Pitt/Peters; v15: SkewMod = 2; OpenFAST 4: Skew_Mod = 1 with
        SkewRedistr_Mod = 1); skew_factor from SkewModFactor (v15) /
        SkewRedistrFactor (OpenFAST 4).
    tower : `TowerDrag` from TwrElev/TwrDiam/TwrCd (and TwrTI where the
        table has it), or None if absent.
    tower_aero : TwrAero flag (apply tower drag).
    pitching_moment : UseBlCm flag (apply the sectional pitching moment
        Cm q c^2; AeroDyn's default True where the file has no UseBlCm).
    notes : one sentence per documented default or fallback applied.
    """

    blades: list
    air_density: float = DEFAULTS["AirDens"]
    kinematic_viscosity: float = DEFAULTS["KinVisc"]
    speed_of_sound: float = DEFAULTS["SpdSound"]
    bem: BemOptions = field(default_factory=BemOptions)
    tower: TowerDrag | None = None
    tower_aero: bool = False
    pitching_moment: bool = True
    source: str | None = None
    notes: tuple = field(default_factory=tuple)

    @property
    def blade(self) -> AeroBlade:
        """The first blade (modesel's rotor has equal blades: `check_equal_blades`)."""
        return self.blades[0]

    def check_equal_blades(self, num_blades: int) -> None:
        """Refuse, naming ADBlFile(k), a blade k in 2..num_blades whose stations
        differ from blade 1's: modesel models a rotor of equal blades (OpenFAST
        reads each blade's file)."""
        first = self.blades[0]
        names = ("span", "chord", "twist", "airfoil", "crv_ac", "swp_ac", "crv_angle")
        for k, other in enumerate(self.blades[1:num_blades], start=2):
            if other is not first and not all(np.array_equal(getattr(first, n), getattr(other, n)) for n in names):
                raise ModeselError(f"blade {k} differs from blade 1 ({os.path.basename(str(other.source))} against "
                                   f"{os.path.basename(str(first.source))}); modesel models a rotor of equal blades",
                                   file=self.source, field=f"ADBlFile({k})")


def _openfast_io_main(path: str) -> dict:
    """Main-file fields via openfast-io's positional reader; raises on mismatch."""
    from openfast_io.FAST_reader import InputReader_OpenFAST

    reader = InputReader_OpenFAST()
    reader.FAST_directory = os.path.dirname(path)
    reader.fst_vt["Fst"]["AeroFile"] = os.path.basename(path)
    reader.fst_vt["Fst"]["AeroFile_path"] = ""
    reader.fst_vt["ElastoDyn"]["NumBl"] = 3
    reader.read_AeroDyn()
    ad = reader.fst_vt["AeroDyn"]
    out = {key: ad[key] for key in ("AirDens", "KinVisc", "SpdSound", "TipLoss", "HubLoss",
                                    "TanInd", "AIDrag", "TIDrag", "TwrAero", "NumAFfiles",
                                    "InCol_Alfa", "InCol_Cl", "InCol_Cd", "InCol_Cm")}
    out["SkewCorr"] = ad.get("Skew_Mod") == 1 and ad.get("SkewRedistr_Mod") == 1
    out["UseBlCm"] = ad.get("UseBlCm", True)
    out["SkewModFactor"] = ad.get("SkewRedistrFactor", "default")
    out["tower"] = np.array([ad["TwrElev"], ad["TwrDiam"], ad["TwrCd"]], float).T
    ti = ad.get("TwrTI")
    out["TwrTI"] = None if ti is None or any(v is None for v in ti) else np.asarray(ti, float)
    # sanity: a positional misread shows up as non-numeric physics values
    for key in ("AirDens", "KinVisc", "SpdSound"):
        value = out[key]
        if not (isinstance(value, float) or str(value).strip('"').lower() == "default"):
            raise ValueError(f"{key} read as {value!r}")
    return out


def _keyword_lines(path: str) -> list:
    """The tokens of each line; a quoted file name with blanks is one token."""
    with open(path) as f:
        return [TOKEN.findall(line) for line in f]


def _file_names(lines: list, path: str) -> dict:
    """AFNames and ADBlFile(1..3) from a file's `_keyword_lines`, as OpenFAST
    reads them: quoted names may hold blanks (openfast-io's reader cuts them
    at the first blank)."""
    first, _ = _by_keyword(lines, "AFNames", path)
    n_af = int(float(_by_keyword(lines, "NumAFfiles", path)[1]))
    return {"AFNames": [lines[first + k][0].strip('"\'') for k in range(n_af)],
            "ADBlFile": [_by_keyword(lines, f"ADBlFile({i})", path)[1].strip('"\'') for i in (1, 2, 3)]}


def _by_keyword(lines, key, path):
    for i, tokens in enumerate(lines):
        if len(tokens) >= 2 and tokens[1] == key:
            return i, tokens[0]
    raise ModeselError("keyword not found in AeroDyn file", file=path, field=key)


def _keyword_main(path: str) -> dict:
    """Main-file fields looked up by keyword (layout independent)."""
    lines = _keyword_lines(path)
    out = {}
    for key in ("AirDens", "KinVisc", "SpdSound", "TipLoss", "HubLoss", "TanInd", "AIDrag",
                "TIDrag", "TwrAero", "NumAFfiles", "InCol_Alfa", "InCol_Cl", "InCol_Cd",
                "InCol_Cm"):
        out[key] = _by_keyword(lines, key, path)[1]
    found = {}
    for key in ("SkewMod", "Skew_Mod", "SkewRedistr_Mod", "SkewModFactor", "SkewRedistrFactor", "UseBlCm"):
        try:
            found[key] = _by_keyword(lines, key, path)[1]
        except ModeselError:
            pass
    if "SkewMod" in found:  # AeroDyn v15 layout: 2 = Pitt/Peters
        out["SkewCorr"] = found["SkewMod"] == "2"
    else:  # OpenFAST 4 layout
        out["SkewCorr"] = found.get("Skew_Mod") == "1" and found.get("SkewRedistr_Mod", "1") == "1"
    out["SkewModFactor"] = found.get("SkewModFactor", found.get("SkewRedistrFactor", "default"))
    out["UseBlCm"] = found.get("UseBlCm", "True")
    out.update(_file_names(lines, path))
    out["TwrTI"] = None
    try:
        row, n_twr = _by_keyword(lines, "NumTwrNds", path)
        n_twr = int(n_twr)
        # two header lines (names, units) follow NumTwrNds
        table = [lines[row + 3 + k] for k in range(n_twr)]
        out["tower"] = np.array([[float(v) for v in cells[:3]] for cells in table])
        names = lines[row + 1]
        if "TwrTI" in names:
            out["TwrTI"] = np.array([float(cells[names.index("TwrTI")]) for cells in table])
    except ModeselError:
        out["tower"] = None
    return out


def _flag(value, path, key) -> bool:
    if isinstance(value, bool):
        return value
    text = str(value).strip('"').lower()
    if text in ("true", "t"):
        return True
    if text in ("false", "f"):
        return False
    raise ModeselError(f"expected True/False, got {value!r}", file=path, field=key)


def _number(value, path, key, notes):
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    text = str(value).strip('"')
    if text.lower() == "default":
        notes.append(f"{key} 'default' taken as {DEFAULTS[key]:.6g} (AeroDyn/OpenFAST default).")
        return DEFAULTS[key]
    try:
        return float(text)
    except ValueError:
        raise ModeselError(f"expected a number or 'default', got {value!r}",
                           file=path, field=key) from None


def read_aerodyn_blade(path: str, polars: PolarSet) -> AeroBlade:
    """Read an AeroDyn blade file with openfast-io and attach `polars`."""
    from openfast_io.FAST_reader import InputReader_OpenFAST

    if not os.path.isfile(path):
        raise ModeselError("AeroDyn blade file not found", file=path, field="ADBlFile")
    reader = InputReader_OpenFAST()
    try:
        reader.read_AeroDynBlade(path, 0)
        data = reader.fst_vt["AeroDynBlade"][0]
        span = np.asarray(data["BlSpn"], float)
        chord = np.asarray(data["BlChord"], float)
        twist = np.radians(np.asarray(data["BlTwist"], float))
        afid = np.asarray(data["BlAFID"], float)
        offsets = {k: np.asarray(data.get(k, np.zeros(span.shape)), float) for k in ("BlCrvAC", "BlSwpAC")}
        crv_angle = np.radians(np.asarray(data.get("BlCrvAng", np.zeros(span.shape)), float))
    except Exception as exc:
        raise ModeselError(f"cannot read AeroDyn blade file ({type(exc).__name__}: {exc})",
                           file=path) from exc
    if np.any(afid != np.round(afid)) or np.any(afid < 1) or np.any(afid > len(polars)):
        raise ModeselError(f"BlAFID must be integers in 1..{len(polars)}", file=path,
                           field="BlAFID")
    return AeroBlade(span=span, chord=chord, twist=twist, airfoil=afid.astype(int) - 1,
                     polars=polars, source=path, crv_ac=offsets["BlCrvAC"], swp_ac=offsets["BlSwpAC"],
                     crv_angle=crv_angle)


#: the modules whose code a cached deck depends on (`deck_cache.cached`'s code)
_DECK_CODE = (__name__, "modesel.aero.airfoils")


def read_aerodyn(path) -> AeroDynDeck:
    """Read an AeroDyn main file and everything it references (see module doc).
    Parsed decks are cached on disk (`modesel.turbine.deck_cache`)."""
    return cached(_read_aerodyn, os.path.abspath(str(path)), files=_aerodyn_sources, code=_DECK_CODE)


def shared_aerodyn(path) -> AeroDynDeck:
    """`read_aerodyn`, the same object again while the main, blade and airfoil
    files are unchanged (`deck_cache.remembered`): for callers that do not
    change it (the aero effects, built many times by one process)."""
    return remembered(_read_aerodyn, os.path.abspath(str(path)), files=_aerodyn_sources, code=_DECK_CODE)


def _aerodyn_sources(deck: AeroDynDeck) -> list:
    """The files an `AeroDynDeck` was read from: main, blade and airfoil files."""
    polars = {p.name for blade in deck.blades for p in blade.polars.polars}
    return [deck.source, *sorted({b.source for b in deck.blades}), *sorted(polars)]


def _read_aerodyn(path) -> AeroDynDeck:
    path = os.path.abspath(str(path))
    if not os.path.isfile(path):
        raise ModeselError("AeroDyn file not found", file=path)
    notes = []
    try:
        main = _openfast_io_main(path)
    except Exception as exc:  # positional layout mismatch
        notes.append("openfast-io read_AeroDyn does not match this file's layout "
                     f"({type(exc).__name__}: {exc}); fields were looked up by keyword.")
        main = _keyword_main(path)
    else:
        main.update(_file_names(_keyword_lines(path), path))
    folder = os.path.dirname(path)
    columns = [int(main[k]) for k in ("InCol_Alfa", "InCol_Cl", "InCol_Cd", "InCol_Cm")]
    af_paths = [os.path.join(folder, p) for p in main["AFNames"]]
    polars = read_polars(af_paths, columns)
    blade_files = [os.path.join(folder, p) for p in main["ADBlFile"]]
    blades, seen = [], {}
    for bf in blade_files:
        key = os.path.abspath(bf)
        if key not in seen:
            seen[key] = read_aerodyn_blade(key, polars)
        blades.append(seen[key])
    tower = None
    table = main.get("tower")
    if table is not None and len(table):
        tower = TowerDrag(elevation=table[:, 0], diameter=table[:, 1], drag_coefficient=table[:, 2],
                          turbulence=main.get("TwrTI"), source=path)
    deck = AeroDynDeck(
        blades=blades,
        air_density=_number(main["AirDens"], path, "AirDens", notes),
        kinematic_viscosity=_number(main["KinVisc"], path, "KinVisc", notes),
        speed_of_sound=_number(main["SpdSound"], path, "SpdSound", notes),
        bem=BemOptions(
            tip_loss=_flag(main["TipLoss"], path, "TipLoss"),
            hub_loss=_flag(main["HubLoss"], path, "HubLoss"),
            tangential_induction=_flag(main["TanInd"], path, "TanInd"),
            axial_drag=_flag(main["AIDrag"], path, "AIDrag"),
            tangential_drag=_flag(main["TIDrag"], path, "TIDrag"),
            skew_correction=bool(main["SkewCorr"]),
            skew_factor=_number(main["SkewModFactor"], path, "SkewModFactor", notes)),
        tower=tower,
        tower_aero=_flag(main["TwrAero"], path, "TwrAero"),
        pitching_moment=_flag(main["UseBlCm"], path, "UseBlCm"),
        source=path,
        notes=tuple(notes),
    )
    if deck.air_density <= 0:
        raise ModeselError("air density must be > 0", file=path, field="AirDens")
    return deck


def aerodyn_case_options(path) -> dict:
    """The AeroDyn main file of an OpenFAST case mapped to modesel's BEM
    (`BemSolver` via the `aero` effect) and tower drag (`tower_drag`), in
    either layout: AeroDyn 15 of OpenFAST 3 (WakeMod, AFAeroMod, SkewMod)
    or OpenFAST 4/5 (Wake_Mod, BEM_Mod, Skew_Mod, SkewRedistr_Mod, UA_Mod,
    DBEMT_Mod, ...). Returns {"skew": bool, "tower_drag": bool, "tower_potential": str,
    "tower_shadow": str, "air_density_default": bool, "notes": [...]}. Every switched-on option modesel does not model
    is a ModeselError naming the file and the input:

    - wake/induction other than quasi-steady BEMT (Wake_Mod/WakeMod != 1,
      dynamic BEMT DBEMT_Mod > 0 with Wake_Mod 1, OLAF), BEM_Mod 2 (polar),
      skew correction other than none / Pitt-Peters (Skew_Mod -1, SkewMod 3,
      SkewMomCorr), sector averaging (SectAvg);
    - unsteady airfoil aerodynamics (UA_Mod > 0 / AFAeroMod 2);
    - cavitation, buoyancy, nacelle drag, tail fin, aeroacoustics.

    Mapped: Skew_Mod 1 with SkewRedistr_Mod 1 (SkewMod 2) -> Pitt/Peters
    correction; Skew_Mod 0, Skew_Mod 1 with SkewRedistr_Mod 0 (SkewMod 1)
    -> none. TwrAero -> modesel's tower drag, the same quasi-steady load as
    AeroDyn's ADTwr_CalcOutput (1/2 rho Cd d |V_n| V_n with V_n the
    relative wind normal to the tower). TwrPotent and TwrShadow -> the aero
    effect's tower_potential and tower_shadow (`aero.tower_influence`,
    AeroDyn's TwrInfl), returned by name as "tower_potential" and
    "tower_shadow". TipLoss, HubLoss, TanInd, AIDrag,
    TIDrag, SkewRedistrFactor and the polars are read by `read_aerodyn`.
    UseBlCm -> the sectional pitching moment (`AeroDynDeck.pitching_moment`,
    applied by the aero effect as node moments). AoA34 (angle of attack at
    the 3/4 chord, default True) is accepted either way: AeroDyn 5.0 reads it
    (AeroDyn_IO.f90) and no computation uses it without unsteady aerodynamics
    (OpenFAST 5.0 writes the same outputs for steady_08 with True and False).
    """
    from modesel.turbine.openfast_inputs import InputFile
    f = InputFile(path, "AeroDyn")
    notes = []
    new = "Wake_Mod" in f
    wake = f.integer("Wake_Mod" if new else "WakeMod")
    if wake != 1:
        raise f.unsupported("Wake_Mod" if new else "WakeMod", "only 1 = quasi-steady BEMT is modelled")
    if new:
        if "BEM_Mod" in f and f.integer("BEM_Mod") != 1:
            raise f.unsupported("BEM_Mod", "only 1 = legacy BEM is modelled")
        if "DBEMT_Mod" in f and f.integer("DBEMT_Mod") != 0:
            raise f.unsupported("DBEMT_Mod", "dynamic inflow")
        if "UA_Mod" in f and f.integer("UA_Mod") != 0:
            raise f.unsupported("UA_Mod", "unsteady airfoil aerodynamics")
        skew_mod = f.integer("Skew_Mod")
        if skew_mod not in (0, 1):
            raise f.unsupported("Skew_Mod", "only 0 and 1 are modelled")
        if skew_mod == 1 and "SkewMomCorr" in f and f.flag("SkewMomCorr"):
            raise f.unsupported("SkewMomCorr", "skew momentum correction")
        redistr = f.integer("SkewRedistr_Mod", default=1) if "SkewRedistr_Mod" in f else 1
        if redistr not in (0, 1):
            raise f.unsupported("SkewRedistr_Mod", "only 0 and 1 = Pitt/Peters are modelled")
        skew = skew_mod == 1 and redistr == 1
        if "SectAvg" in f and f.flag("SectAvg"):
            raise f.unsupported("SectAvg", "sector averaging")
    else:
        if f.integer("AFAeroMod") != 1:
            raise f.unsupported("AFAeroMod", "unsteady airfoil aerodynamics")
        skew_mod = f.integer("SkewMod")
        if skew_mod not in (1, 2):
            raise f.unsupported("SkewMod", "only 1 = uncoupled and 2 = Pitt/Peters are modelled")
        skew = skew_mod == 2
    potential, shadow = f.integer("TwrPotent"), f.integer("TwrShadow")
    if potential not in (0, 1, 2):
        raise f.unsupported("TwrPotent", "only 0, 1 = baseline and 2 = Bak are modelled")
    if shadow not in (0, 1, 2):
        raise f.unsupported("TwrShadow", "only 0, 1 = Powles and 2 = Eames are modelled")
    if potential or shadow:
        check_tower_table(read_aerodyn(path).tower, potential, shadow, str(path))
    for label, what in (("CavitCheck", "cavitation check"), ("Buoyancy", "buoyancy"),
                        ("NacelleDrag", "nacelle drag"), ("TFinAero", "tail-fin aerodynamics"),
                        ("CompAA", "aeroacoustics")):
        if label in f and f.flag(label):
            raise f.unsupported(label, what)
    return {"skew": skew, "tower_drag": f.flag("TwrAero"), "tower_potential": POTENTIAL_NAMES[potential],
            "tower_shadow": SHADOW_NAMES[shadow],
            "air_density_default": f.string("AirDens").lower() == "default", "notes": notes}
