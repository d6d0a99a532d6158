"""An OpenFAST case (`.fst` main file) as a modesel `Scene`.

What the case's modules become:

- ElastoDyn (`turbine.elastodyn.read_elastodyn` and `scene_from_elastodyn` below):
  DOF flags, initial conditions, geometry, masses, modal damping,
  drivetrain with its gearbox losses (GBoxEff, `multibody.gearbox`); the
  deck's polynomial mode shapes are the default mode set.
- InflowWind (CompInflow = 1, `turbine.inflowwind.read_inflowwind`) -> the `wind`
  effect; still air (CompInflow = 0) -> zero wind when AeroDyn is on.
- AeroDyn 15 (CompAero = 2, `turbine.aerodyn.aerodyn_case_options`) -> the `aero`
  effect (BEM, the deck's blade and polars, Pitt/Peters skew per the deck)
  with the deck's tower influence (TwrPotent, TwrShadow -> the aero effect's
  tower_potential, tower_shadow) and, with TwrAero, `tower_drag` (on the aero effect's deck and air
  density); AirDens "default" takes the .fst AirDens.
- ServoDyn (CompServo = 1, `turbine.servodyn.read_servodyn`) -> the `generator`
  effect (ServoDyn's simple variable-speed law, simple or
  Thevenin-equivalent induction generator, GenEff, on/off switching) and the pitch held at PitNeut; without
  ServoDyn the generator torque is zero and the pitch stays at BlPitch.
  With YawDOF on, ServoDyn's yaw spring and damper about YawNeut (YCMode 0)
  are the `yaw` effect; without ServoDyn the yaw turns freely, as in OpenFAST.
  With GenDOF off the generator stays for its channels GenTq and GenPwr
  (the law at the fixed speed, as OpenFAST writes them); its torque then
  acts on no free coordinate (GeAz turns at the fixed speed).
- TMax and DT_Out ("default": DT) are the scene's tmax (TMax rounded up to a
  whole number of DT steps, where OpenFAST's last step ends) and dt; TStart its
  output_start (outputs from then on, as OpenFAST writes them).
- The OutLists of ElastoDyn, AeroDyn, ServoDyn and InflowWind are the scene's
  out_list: `modesel simulate` names the channels among them that modesel
  does not compute.
- Integration tolerances looser than a TOML scene's default rtol 1e-8 /
  atol 1e-10: without AeroDyn `SOLVER` (rtol 1e-5, atol 1e-6, DOP853); with
  it `SOLVER_BEM` (rtol 3e-6, atol 3e-7), where "auto" integrates the
  kinked BEM loads with Dormand-Prince 5(4) (`integrate.LOW_ORDER_RTOL`).
  Against compiled-DOP853 at rtol 1e-8 / atol 1e-10 (20 s), every channel
  OpenFAST names stays
  within 1.3e-4 (steady_08) and 2.6e-4 (steady_11p4) of its range, far
  inside its difference to OpenFAST (the coordinates and rates Q_*, QD_*:
  9.9e-4 and 1.4e-3, the second tower mode's rate), with 3968 and 4280
  right-hand sides (DOP853 at the former tolerances 1e-5 / 1e-6: 2.3e-4 and
  6.7e-5, states 9.3e-4 and 3.7e-4, with 4937 and 7346).

Anything switched on that modesel does not model is a one-line
`ModeselError` naming the file and the input: blades that differ (a
BldFile(k) or ADBlFile(k), k <= NumBl, whose parsed values differ from
blade 1's; modesel's rotor has equal blades), BeamDyn or simplified
ElastoDyn (CompElast 2, 3), external inflow, AeroDisk or external loads,
SeaState, HydroDyn, SubDyn, moorings, ice, soil, MHK, mirrored or several
rotors, ElastoDyn's pitch DOF and platform sway/heave/roll/yaw, furling,
and the options listed in the
InflowWind, AeroDyn and ServoDyn readers.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from modesel.errors import ModeselError
from modesel.modeset import FieldModes, ModeSet
from modesel.simulation.scene import INITIAL_KEYS, Scene, use_deck_reader
from modesel.turbine.openfast_inputs import InputFile


#: integration tolerances of an OpenFAST case, with AeroDyn and without (module doc)
SOLVER_BEM = {"rtol": 3e-6, "atol": 3e-7}
SOLVER = {"rtol": 1e-5, "atol": 1e-6}


def is_fst(path) -> bool:
    """Whether `path` is an OpenFAST main file (it names an EDFile)."""
    try:
        lines = Path(path).read_text(errors="replace").splitlines()
    except OSError:
        return False
    return any(line.split()[1:2] == ["EDFile"] for line in lines)


def _check_main(f: InputFile):
    checks = (("CompElast", (1,), "only 1 = ElastoDyn is modelled (BeamDyn and simplified ElastoDyn are not)"),
              ("CompInflow", (0, 1), "external inflow"), ("CompAero", (0, 2), "only 2 = AeroDyn is modelled"),
              ("CompServo", (0, 1), "unknown servo module"), ("CompSeaSt", (0,), "SeaState"),
              ("CompHydro", (0,), "HydroDyn"), ("CompSub", (0,), "substructure"),
              ("CompMooring", (0,), "mooring"), ("CompIce", (0,), "ice loads"), ("CompSoil", (0,), "SoilDyn"),
              ("MHK", (0,), "marine turbine"), ("NRotors", (1,), "several rotors"))
    for label, allowed, what in checks:
        if label in f and f.integer(label) not in allowed:
            raise f.unsupported(label, what)
    if "MirrorRotor" in f and f.flag("MirrorRotor"):
        raise f.unsupported("MirrorRotor", "mirrored (counter-clockwise) rotor")


def _check_elastodyn(ed: InputFile):
    for label, what in (("PitchDOF", "blade pitch DOF"), ("PtfmSwDOF", "platform sway"),
                        ("PtfmHvDOF", "platform heave"), ("PtfmRDOF", "platform roll"),
                        ("PtfmYDOF", "platform yaw")):
        if label in ed and ed.flag(label):
            raise ed.unsupported(label, what)
    for label in ("PtfmSway", "PtfmHeave", "PtfmRoll", "PtfmYaw"):
        if label in ed and ed.number(label) != 0.0:
            raise ed.unsupported(label, "a platform offset modesel has no coordinate for")
    if ed.flag("YawDOF", default=False) and "YawFrctMod" in ed and ed.integer("YawFrctMod") != 0:
        raise ed.unsupported("YawFrctMod", "yaw-bearing friction")


def scene_from_fst(path):
    """The `Scene` of an OpenFAST case (module doc)."""
    from modesel.model.effects import validate as validate_effects
    path = Path(path)
    f = InputFile(path, "OpenFAST main")
    _check_main(f)
    tmax = f.number("TMax")
    if tmax < 0:       # 0: a linearisation case (modesel linearize reads it; simulate needs --tmax)
        raise f.error(f"must be >= 0, got {tmax:g}", "TMax")
    dt_out = f.number("DT_Out", default=f.number("DT"))
    if dt_out <= 0:
        raise f.error(f"must be > 0, got {dt_out:g}", "DT_Out")
    dt = f.number("DT")
    if dt <= 0:
        raise f.error(f"must be > 0, got {dt:g}", "DT")
    _check_output_step(f, dt, dt_out)
    t_start = f.number("TStart", default=0.0)
    if not 0.0 <= t_start <= tmax:
        raise f.error(f"must lie in [0, TMax = {tmax:g}] s, got {t_start:g}", "TStart")
    ed = InputFile(f.referenced("EDFile"), "ElastoDyn")
    _check_elastodyn(ed)
    scene = scene_from_elastodyn(path)
    scene.tmax, scene.dt, scene.output_start = _end_time(tmax, dt), dt_out, t_start
    out_list = ed.outlist()
    decks_with_nodal_outputs = [ed]
    notes = list(scene.notes)
    effects = dict(scene.effects)
    pitch_deg = np.rad2deg(np.atleast_1d(scene.initial.get("BlPitch", 0.0)))
    if f.integer("CompServo") == 1:
        servo = _servodyn(f, tmax, yaw_dof=bool(scene.turbine.dofs.get("YawDOF")))
        out_list += InputFile(f.referenced("ServoFile"), "ServoDyn").outlist()
        effects["generator"] = servo["generator"]
        if servo["yaw"] is not None:
            effects["yaw"] = servo["yaw"]
        pitch_deg = np.array(servo["pitch_deg"][:scene.turbine.num_blades])
        bl = np.rad2deg(np.atleast_1d(scene.initial.get("BlPitch", 0.0)))
        if not np.allclose(bl, pitch_deg):
            notes.append(f"ElastoDyn BlPitch {bl.tolist()} deg differs from ServoDyn PitNeut "
                         f"{pitch_deg.tolist()} deg: OpenFAST 5 (PCMode = 0) holds the pitch at PitNeut.")
    if np.ptp(pitch_deg) > 0:
        raise f.error(f"blade pitch angles differ ({pitch_deg.tolist()} deg): modesel models a collective "
                      f"pitch only", "ServoFile" if f.integer("CompServo") == 1 else "EDFile")
    effects["pitch"] = {"collective_deg": float(pitch_deg[0])}
    scene.initial["BlPitch"] = float(np.deg2rad(pitch_deg[0]))
    if f.integer("CompAero") == 2:
        import modesel.aero  # noqa: F401  (modesel.aero and turbine.aerodyn import each other: aero first)
        from modesel.turbine.aerodyn import aerodyn_case_options
        ad_path = f.referenced("AeroFile")
        ad = aerodyn_case_options(ad_path)
        ad_deck = InputFile(ad_path, "AeroDyn")
        out_list += ad_deck.outlist()
        decks_with_nodal_outputs.append(ad_deck)
        notes += ad["notes"]
        aero = {"aerodyn": str(ad_path.resolve()), "skew": ad["skew"],
                "tower_potential": ad["tower_potential"], "tower_shadow": ad["tower_shadow"]}
        if ad["air_density_default"] and "AirDens" in f:
            aero["air_density"] = f.number("AirDens")
        effects["aero"] = aero
        # the tower drag takes the aero effect's deck and air density (effects/tower_drag.py)
        effects["tower_drag"] = bool(ad["tower_drag"])
        if f.integer("CompInflow") != 1:
            effects["wind"] = {"speed": 0.0}
    if f.integer("CompInflow") == 1:      # the wind, also without AeroDyn: its output points (Wind<k>Vel*)
        from modesel.turbine.inflowwind import read_inflowwind
        effects["wind"] = read_inflowwind(f.referenced("InflowFile"), tmax)
        inflow = InputFile(f.referenced("InflowFile"), "InflowWind")
        out_list += inflow.outlist()
        scene.wind_points = _wind_points(inflow)
    for deck in decks_with_nodal_outputs:
        if (nodal := deck.nodal_outlist()):
            notes.append(f"{deck.path.name}'s nodal output section ({', '.join(nodal)} at every blade node) "
                         f"is not computed by modesel")
    validate_effects(effects, str(path), path.parent)
    scene.solver = dict(SOLVER_BEM if "aero" in effects else SOLVER, **scene.solver)
    scene.effects = effects
    scene.notes = tuple(notes)
    scene.out_list = tuple(dict.fromkeys(out_list))
    return scene


def _wind_points(f: InputFile) -> tuple:
    """InflowWind's output points ((x, y, z) [m], NWindVel of them; inertial
    frame, z above the ground) for the channels Wind<k>VelX/Y/Z."""
    n = f.integer("NWindVel", default=0)
    if not 0 <= n <= 9:
        raise f.error(f"must be 0 to 9, got {n}", "NWindVel")
    if n == 0:
        return ()
    lists = []
    for label in ("WindVxiList", "WindVyiList", "WindVziList"):
        try:
            values = [float(v) for v in re.split(r"[,;\s]+", f.text(label).replace('"', "").strip()) if v]
        except ValueError:
            raise f.error("expected a list of numbers", label) from None
        if len(values) < n:
            raise f.error(f"needs NWindVel = {n} values, got {len(values)}", label)
        lists.append(values[:n])
    return tuple(zip(*lists))


def _check_output_step(f: InputFile, dt: float, dt_out: float):
    """OpenFAST refuses (FAST_Subs) a DT_Out below DT or not a whole
    multiple of it; so does modesel, in one line naming DT_Out."""
    steps = round(dt_out / dt)
    if steps < 1:
        raise f.error(f"must be at least DT = {dt:g} s, got {dt_out:g} s (as OpenFAST requires)", "DT_Out")
    if abs(steps * dt - dt_out) > 1e-6 * dt_out:
        raise f.error(f"must be a whole multiple of DT = {dt:g} s, got {dt_out:g} s (as OpenFAST requires)",
                      "DT_Out")


def _end_time(tmax: float, dt: float) -> float:
    """The time OpenFAST's last step reaches [s]: it takes CEILING(TMax / DT)
    steps of DT (FAST_Subs n_TMax_m1), so a TMax that is not a whole number of
    steps ends after it (TMax 20.01 s, DT 0.00625 s: 20.0125 s)."""
    steps = np.ceil(tmax / dt - 1e-9)
    return float(steps * dt) if abs(steps * dt - tmax) > 1e-9 * tmax else tmax


def _servodyn(f: InputFile, tmax: float, yaw_dof: bool) -> dict:
    from modesel.turbine.servodyn import read_servodyn
    servo_path = f.referenced("ServoFile")
    if servo_path is None:
        raise f.error("CompServo = 1 needs a ServoDyn file", "ServoFile")
    return read_servodyn(servo_path, tmax, yaw_dof=yaw_dof)


def scene_from_elastodyn(path: Path) -> Scene:
    """ElastoDyn main file (or .fst) as a scene: DOF flags, initial conditions,
    masses and geometry as OpenFAST uses them; the deck's polynomials are the
    default mode set. TMax/DT_Out come from the .fst when given (else 10 s /
    0.01 s). A rotor without GenDOF spins at the constant RotSpeed. The
    beams are integrated on the deck's analysis nodes as ElastoDyn does
    (effect flag `elastodyn_nodes`, model.template.build_turbine)."""
    from modesel.turbine.elastodyn import read_elastodyn
    turbine = read_elastodyn(path)
    flags = turbine.dofs
    fields = {}
    if flags.get("TwFADOF1"):
        fields["tower_fa"] = FieldModes("elastodyn", 2 if flags.get("TwFADOF2") else 1)
    if flags.get("TwSSDOF1"):
        fields["tower_ss"] = FieldModes("elastodyn", 2 if flags.get("TwSSDOF2") else 1)
    if flags.get("FlapDOF1"):
        fields["blade_flap"] = FieldModes("elastodyn", 2 if flags.get("FlapDOF2") else 1)
    if flags.get("EdgeDOF"):
        fields["blade_edge"] = FieldModes("elastodyn", 1)
    free, speed, fixed = [], {}, {}
    if flags.get("GenDOF"):
        free.append("GeAz")
    else:
        speed["GeAz"] = turbine.initial.get("RotSpeed", 0.0)
    if flags.get("DrTrDOF"):
        free.append("DrTr")
    if flags.get("YawDOF"):
        free.append("Yaw")
    for flag, dof in (("PtfmSgDOF", "PtfmSurge"), ("PtfmPDOF", "PtfmPitch")):
        if flags.get(flag):
            free.append(dof)
    if not fields and not free:
        raise ModeselError("every ElastoDyn structural and drivetrain DOF is off (FlapDOF1, EdgeDOF, TwFADOF1, "
                           "TwSSDOF1, GenDOF, DrTrDOF, YawDOF all False): modesel simulates at least "
                           "one free DOF", file=getattr(turbine, "source", None) or path,
                           field="FlapDOF1/EdgeDOF/TwFADOF1/TwSSDOF1/GenDOF")
    initial = {k: v for k, v in turbine.initial.items() if k in INITIAL_KEYS}
    for dof, key in (("Yaw", "NacYaw"), ("PtfmSurge", "PtfmSurge"), ("PtfmPitch", "PtfmPitch")):
        if dof not in free and initial.get(key):
            fixed[dof] = initial[key]
    if "Yaw" not in free:       # held at NacYaw, which OpenFAST writes (NacYaw, Q_Yaw, QD_Yaw) as well
        fixed["Yaw"] = initial.get("NacYaw", 0.0)
    sim = getattr(turbine, "simulation", {}) or {}
    return Scene(Path(path).stem, turbine, float(sim.get("TMax", 10.0)), float(sim.get("DT_Out", 0.01)),
                 ModeSet(fields), tuple(free), fixed, speed, initial,
                 {"gravity": True, "geometric_stiffening": True, "damping": True, "elastodyn_nodes": True},
                 {}, str(path))


def load_openfast_scene(path) -> Scene:
    """A scene from an OpenFAST main file (.fst) or an ElastoDyn main file."""
    return scene_from_fst(path) if is_fst(path) else scene_from_elastodyn(path)


use_deck_reader(load_openfast_scene)
