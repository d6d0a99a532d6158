"""`Scene`: what to simulate — which DOFs are free, fixed or prescribed, which
effects act, initial conditions, time span, and the default mode set.

A scene is a TOML file, an OpenFAST ElastoDyn main file (.dat), or an
OpenFAST case (.fst: ElastoDyn with InflowWind, AeroDyn and ServoDyn as
OpenFAST runs them, `fst.scene_from_fst`). TOML format (units as in OpenFAST input files: m, deg, rpm)::

    name = "land_3dof"
    turbine = "nrel5mw"              # built-in name or ElastoDyn deck path (relative to this file)
    tmax = 60.0                      # s
    dt = 0.01                        # output step, s
    [modes]                          # default mode set (search varies these fields only)
    tower_fa = { family = "elastodyn", count = 1 }
    tower_ss = { family = "elastodyn", count = 1 }
    [dofs]
    free = ["GeAz"]                  # rigid DOFs: GeAz, DrTr, Yaw, PtfmSurge, PtfmPitch
    fixed = { DrTr = 0.0 }           # value in m or deg
    constant_speed = { GeAz = 12.1 } # prescribed constant rotor speed, rpm
    [initial]                        # ElastoDyn names: TTDspFA TTDspSS [m], RotSpeed [rpm],
    TTDspFA = 1.0                    # Azimuth NacYaw PtfmPitch BlPitch [deg], OoPDefl IPDefl PtfmSurge [m]
    equilibrium = false              # true: start the elastic DOFs at their static equilibrium
    [effects]                        # each effect is `true`, `false` or a table of its options
    gravity = true                   # (see modesel/model/effects/ for every effect)
    geometric_stiffening = true
    damping = true                   # on unless false; { model = "stiffness_proportional" }
    [effects.wind]                   # wind, pitch, drivetrain, yaw, generator, aero, tower_drag
    speed = 11.4
    [solver]
    method = "auto"                  # auto | compiled-DOP853 | compiled-RK45 | compiled-Radau | RK45 | DOP853 |
                                     # Radau | BDF | LSODA
    rtol = 1e-8                      # default 1e-8 (atol 1e-10) explicit, 1e-6 (atol 1e-6) implicit
    stability_check = true           # refuse statically unstable configurations (simulation/stability.py)
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from modesel.candidates.base import check_field_modes
from modesel.errors import ModeselError, did_you_mean, unknown_name
from modesel.modeset import FieldModes, ModeSet
from modesel.turbine.builtin import BUILTIN_TURBINES, builtin_elastodyn
from modesel.model.effects import KEYS as EFFECT_KEYS
from modesel.model.effects import validate as validate_effects
from modesel.vocabulary import FIELDS, ROTOR_AZIMUTH, SCENE_DOFS, is_translation

TOP_KEYS = ("name", "description", "turbine", "tmax", "dt", "modes", "dofs", "initial", "effects",
            "solver", "outputs", "overrides")
# scene-level changes to the turbine: key -> (Turbine attribute, unit conversion to SI)
OVERRIDES = {
    "precone_deg": ("precone", "deg3"),
    "shaft_tilt_deg": ("shaft_tilt", "deg"),
    "tower_base_height": ("tower_base_height", None),
    "platform_mass": ("platform_mass", None),
    "platform_inertia": ("platform_inertia", "vec3"),
    "platform_cm_z": ("platform_cm", "z"),
    "platform_ref_z": ("platform_ref_z", None),
    "generator_inertia": ("generator_inertia", None),
    "hub_radius": ("hub_radius", "hub"),
    "nacelle_yaw_inertia": ("nacelle_yaw_inertia", None),
    "nacelle_mass": ("nacelle_mass", None),
}
NON_NEGATIVE_OVERRIDES = ("platform_mass", "platform_inertia", "generator_inertia", "hub_radius",
                          "nacelle_yaw_inertia", "nacelle_mass")
DOF_KEYS = ("free", "fixed", "constant_speed")
INITIAL_KEYS = ("TTDspFA", "TTDspSS", "TTDspTwst", "RotSpeed", "Azimuth", "NacYaw", "PtfmSurge",
                "PtfmPitch", "BlPitch", "OoPDefl", "IPDefl", "equilibrium")
SOLVER_KEYS = ("method", "rtol", "atol", "max_step", "stability_check")
#: "auto" and multibody.integrate.METHODS (not imported here: scene loading stays light)
SOLVER_METHODS = ("auto", "compiled-DOP853", "compiled-RK45", "compiled-Radau", "RK45", "DOP853", "Radau", "BDF",
                  "LSODA")
ANGLE_KEYS = ("Azimuth", "NacYaw", "PtfmPitch", "BlPitch", "TTDspTwst")


@dataclass
class Scene:
    """A simulation case. Angles in `initial` are rad, RotSpeed rad/s, lengths m."""

    name: str
    turbine: object
    tmax: float = 10.0
    dt: float = 0.01
    modes: ModeSet = field(default_factory=ModeSet)
    free: tuple = ()
    fixed: dict = field(default_factory=dict)
    constant_speed: dict = field(default_factory=dict)   # dof -> rad/s
    initial: dict = field(default_factory=dict)
    effects: dict = field(default_factory=dict)
    solver: dict = field(default_factory=dict)
    path: str | None = None
    notes: tuple = ()
    #: an OpenFAST case's requested output channels (its modules' OutLists), for
    #: the note on those modesel does not compute; output_start [s]: the first
    #: output time (the case's TStart), earlier rows are simulated but not output
    out_list: tuple = ()
    output_start: float = 0.0
    #: an OpenFAST case's InflowWind output points (WindVxiList, WindVyiList,
    #: WindVziList) [m]: channels Wind<k>VelX/Y/Z [m/s] of the undisturbed wind there
    wind_points: tuple = ()

    @property
    def fields(self) -> tuple:
        """Active flexible fields (those with modes)."""
        return tuple(f for f in FIELDS if f in self.modes)

    @property
    def default_modeset(self) -> ModeSet:
        return self.modes

    def effect(self, name: str, default=True):
        return self.effects.get(name, default)


#: the most output rows (tmax/dt + 1) a simulation may produce: more would
#: need gigabytes for the state history and the output table
MAX_OUTPUT_ROWS = 10_000_000


def check_time_grid(tmax: float, dt: float, *, file=None, where: str = "") -> int:
    """The number of output rows of [0, tmax] every dt [s]; a one-line error
    naming `tmax`/`dt` (prefixed `where`, e.g. 'scene[0].') when dt > tmax or
    the rows would exceed MAX_OUTPUT_ROWS."""
    if dt > tmax:
        raise ModeselError(f"dt = {dt:g} s is larger than tmax = {tmax:g} s: the simulation would "
                           f"produce no output step", file=file, field=f"{where}dt")
    rows = tmax / dt + 1
    if rows > MAX_OUTPUT_ROWS:
        raise ModeselError(f"tmax / dt = {tmax:g} s / {dt:g} s gives {rows:.3g} output rows, more than "
                           f"the {MAX_OUTPUT_ROWS:.0e} a simulation may hold in memory; shorten tmax or "
                           f"raise dt", file=file, field=f"{where}tmax/dt")
    return int(rows)


def _number(value, file, fld, positive=False):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ModeselError(f"must be a number, got {value!r}", file=file, field=fld)
    value = float(value)
    if not np.isfinite(value) or (positive and value <= 0):
        raise ModeselError(f"must be a {'positive ' if positive else ''}finite number, got {value!r}",
                           file=file, field=fld)
    return value


def _check_keys(table, allowed, file, where):
    if not isinstance(table, dict):
        raise ModeselError("must be a table", file=file, field=where)
    for k in table:
        if k not in allowed:
            raise ModeselError(f"unknown key '{k}'" + _dym(k, allowed), file=file,
                               field=f"{where}.{k}" if where else k)


def _dym(k, allowed):
    from modesel.errors import did_you_mean
    return did_you_mean(k, allowed)


def _initial_si(name, value):
    if name in ANGLE_KEYS:
        return np.deg2rad(value)
    if name == "RotSpeed":
        return value * np.pi / 30.0
    return value


#: reader of OpenFAST input decks (.fst, ElastoDyn .dat) as scenes,
#: registered by `simulation.fst` (which builds on this module, not the reverse)
_DECK_READER = None


def use_deck_reader(reader) -> None:
    """Register `reader(path) -> Scene` for OpenFAST decks (`simulation.fst`)."""
    global _DECK_READER
    _DECK_READER = reader


def load_scene(path) -> Scene:
    """Scene from a TOML file or an ElastoDyn/OpenFAST main file."""
    path = Path(path)
    if not path.exists():
        raise ModeselError("scene file not found", file=str(path))
    if not path.is_file():
        raise ModeselError("not a file (give a TOML scene, an ElastoDyn .dat or an .fst)", file=str(path))
    if path.suffix.lower() in (".dat", ".fst"):
        return _DECK_READER(path)     # set when modesel.simulation (its package) was imported
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ModeselError(f"malformed TOML: {exc}", file=str(path)) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ModeselError(f"cannot read the scene: {exc}", file=str(path)) from None
    return scene_from_dict(data, path)


def scene_from_dict(data: dict, path: Path | None = None) -> Scene:
    from modesel.turbine.elastodyn import load_turbine
    file = None if path is None else str(path)
    _check_keys(data, TOP_KEYS, file, "")
    if "turbine" not in data:
        raise ModeselError("missing key 'turbine' (built-in name or ElastoDyn deck path)", file=file,
                           field="turbine")
    tname = data["turbine"]
    if not isinstance(tname, str):
        raise ModeselError("must be a string", file=file, field="turbine")
    given = tname
    if builtin_elastodyn(tname) is None:
        if path is not None and not Path(tname).is_absolute():
            tname = str((path.parent / tname).resolve())
        if not Path(tname).is_file():
            hint = did_you_mean(given, BUILTIN_TURBINES) if not Path(given).suffix else ""
            raise ModeselError(f"'{given}' is neither a built-in turbine ({', '.join(BUILTIN_TURBINES)}) "
                               f"nor an existing ElastoDyn/.fst file (paths are relative to the scene "
                               f"file){hint}", file=file, field="turbine")
    turbine = load_turbine(tname)
    tmax = _number(data.get("tmax", 10.0), file, "tmax", positive=True)
    dt = _number(data.get("dt", 0.01), file, "dt", positive=True)
    check_time_grid(tmax, dt, file=file)
    modes_tbl = data.get("modes", {})
    _check_keys(modes_tbl, FIELDS, file, "modes")
    try:
        modes = ModeSet.from_dict({"fields": modes_tbl}, file=file)
    except ModeselError as exc:
        sub = (exc.field or "").removeprefix("fields").lstrip(".")
        raise ModeselError(exc.message, file=file, field=f"modes.{sub}".rstrip(".")) from None
    for fld, fm in modes.fields.items():
        check_field_modes(fld, fm.family, fm.count, fm.params, file=file, where=f"modes.{fld}")
    dofs = data.get("dofs", {})
    _check_keys(dofs, DOF_KEYS, file, "dofs")
    free = dofs.get("free", [])
    if not isinstance(free, list) or not all(isinstance(d, str) for d in free):
        raise ModeselError(f"must be a list of DOF names, e.g. [\"GeAz\"], got {free!r}", file=file,
                           field="dofs.free")
    free = tuple(free)
    for d in free:
        if d not in SCENE_DOFS:
            raise unknown_name("rigid DOF", d, SCENE_DOFS, file=file, field="dofs.free")
    for key in ("fixed", "constant_speed"):
        if not isinstance(dofs.get(key, {}), dict):
            raise ModeselError(f"must be a table {{DOF = value}}, got {dofs[key]!r}", file=file,
                               field=f"dofs.{key}")
    fixed = {}
    for d, v in dofs.get("fixed", {}).items():
        if d not in SCENE_DOFS:
            raise unknown_name("rigid DOF", d, SCENE_DOFS, file=file, field="dofs.fixed")
        v = _number(v, file, f"dofs.fixed.{d}")
        fixed[d] = v if is_translation(d) else np.deg2rad(v)
    speed = {}
    for d, v in dofs.get("constant_speed", {}).items():
        if d != ROTOR_AZIMUTH:
            raise ModeselError(f"only {ROTOR_AZIMUTH} can have a constant speed", file=file,
                               field=f"dofs.constant_speed.{d}")
        speed[d] = _number(v, file, f"dofs.constant_speed.{d}") * np.pi / 30.0
    initial = {}
    init_tbl = data.get("initial", {})
    _check_keys(init_tbl, INITIAL_KEYS, file, "initial")
    for k, v in init_tbl.items():
        if k == "equilibrium":
            if not isinstance(v, bool):
                raise ModeselError(f"must be true or false, got {v!r}", file=file, field="initial.equilibrium")
            initial[k] = v
            continue
        initial[k] = _initial_si(k, _number(v, file, f"initial.{k}"))
    effects = data.get("effects", {})
    _check_keys(effects, EFFECT_KEYS, file, "effects")
    validate_effects(effects, file, None if path is None else path.parent)
    solver = data.get("solver", {})
    _check_keys(solver, SOLVER_KEYS, file, "solver")
    solver = _solver(solver, file)
    over = data.get("overrides", {})
    _check_keys(over, OVERRIDES, file, "overrides")
    if over:
        turbine = apply_overrides(turbine, over, file)
    return Scene(str(data.get("name", path.stem if path else "scene")), turbine, tmax, dt, modes, free, fixed,
                 speed, initial, dict(effects), dict(solver), file)


def _solver(table: dict, file) -> dict:
    """[solver] with checked values: method name, positive tolerances and step."""
    out = dict(table)
    if "method" in out:
        if not isinstance(out["method"], str) or out["method"] not in SOLVER_METHODS:
            raise unknown_name("solver method", out["method"], SOLVER_METHODS, file=file, field="solver.method")
    for key in ("rtol", "atol", "max_step"):
        if key in out:
            out[key] = _number(out[key], file, f"solver.{key}", positive=True)
    if "stability_check" in out and not isinstance(out["stability_check"], bool):
        raise ModeselError(f"must be true or false, got {out['stability_check']!r}", file=file,
                           field="solver.stability_check")
    return out


def apply_overrides(turbine, over: dict, file=None):
    """Copy of `turbine` with scene overrides (see OVERRIDES) in SI units."""
    import copy
    t = copy.deepcopy(turbine)
    for key, value in over.items():
        attr, unit = OVERRIDES[key]
        if unit == "vec3":
            if not isinstance(value, list) or len(value) != 3:
                raise ModeselError("must be a list of 3 numbers", file=file, field=f"overrides.{key}")
            value = tuple(_number(v, file, f"overrides.{key}") for v in value)
        else:
            value = _number(value, file, f"overrides.{key}")
        if key in NON_NEGATIVE_OVERRIDES and min(np.atleast_1d(value)) < 0:
            raise ModeselError(f"must be >= 0, got {value!r}", file=file, field=f"overrides.{key}")
        if unit == "deg":
            value = np.deg2rad(value)
        elif unit == "deg3":
            value = tuple([np.deg2rad(value)] * t.num_blades)
        elif unit == "z":
            value = (0.0, 0.0, value)
        elif unit == "hub":            # the blade root moves with the hub radius
            t.blade.root_offset = value
        setattr(t, attr, value)
    return t
