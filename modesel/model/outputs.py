"""OpenFAST-named output channels from the integrated coordinates.

Channels (units as OpenFAST writes them):

- always: Time [s]; Q_<dof> [m or rad] and QD_<dof> for every free
  coordinate (ElastoDyn's DOF channels: Q_TFA1, Q_TSS1, Q_B1F1, Q_B1E1,
  Q_DrTr ...; Q_GeAz in ElastoDyn's convention, the rotor azimuth minus
  90 deg in [0, 2 pi)); Azimuth [deg, 0-360) of blade 1; RotSpeed [rpm];
  GenSpeed [rpm]; LSSGagPxa [deg, 0-360) and LSSGagVxa [rpm], the
  shaft's azimuth and speed at its strain gauge (GeAz, the generator's side of
  the drivetrain spring); TTDspFA, TTDspSS [m] tower-top displacement (SS = -Q_TSS,
  positive along +y); TTDspTwst [deg]; TipDxc<b> = OoPDefl<b>, TipDyc<b> =
  IPDefl<b>, TipDzc<b> [m] blade-tip deflection in the coned frame and
  TipDxb<b>, TipDyb<b> [m] in the pitched blade frame (`tip_deflections`:
  twisted shapes, as ElastoDyn); YawBrTDxp, YawBrTDyp, YawBrTDzp [m] the
  tower-top deflection in the tower-top frame p and TipRDzc<b> = TwstDefl<b>
  [deg] = 0 (`tower_top_deflection`); BldPitch<b> [deg]; PtfmSurge [m]; PtfmPitch [deg];
  NacYaw [deg] (when those DOFs exist).
- with the ElastoDyn drivetrain spring (DrTr free): RotTorq = LSShftTq
  [kN m], RotPwr [kW], HSShftTq [kN m] (`shaft_torque`).
- from effects (only when switched on): RtAeroFxh [N], RtAeroMxh [N m],
  RtAeroPwr [W], RtAeroCp [-], RtAeroFyh, RtAeroFzh [N], RtAeroMyh, RtAeroMzh
  [N m] (aero: AeroDyn's rotor loads, model/effects/aero.py);
  GenTq [kN m], GenPwr [kW] (generator).
- reaction loads (when the model has reaction coordinates, model/template.py):
  TwrBsMxt, TwrBsMyt [kN m] tower-base side-side (roll) and fore-aft
  (pitching) moments, RootMxc<b>, RootMyc<b> [kN m] blade-root moments
  about the coned x_c, y_c axes, RotThrust [kN] the force along the shaft
  the rotor (hub and blades: aero, weight and inertia) exerts on it
  (ElastoDyn's LSShftFxa).
- the other reaction loads, where the model has their coordinates
  (`reaction_forces`, which `needs_reaction_forces` asks of the wanted
  channels): TwrBsFxt, TwrBsFyt, TwrBsFzt [kN], TwrBsMzt [kN m] at the
  tower base (frame t); YawBrFxp, YawBrFyp, YawBrFzp [kN], YawBrMxp,
  YawBrMyp, YawBrMzp [kN m] at the yaw bearing, below the nacelle (frame p,
  the tower top's, not yawed); RootFxc<b>, RootFyc<b>, RootFzc<b> [kN],
  RootMzc<b> [kN m] at blade b's root (coned frame c); and in the pitched
  blade frame b, turned from the coned one by the pitch as ElastoDyn turns
  j1 = cos(pitch) i1 - sin(pitch) i2, j2 = sin(pitch) i1 + cos(pitch) i2
  (ElastoDyn.f90 SetCoordSy): RootMxb<b>, RootMyb<b> [kN m], RootFxb<b>,
  RootFyb<b> [kN].

Reaction loads: each is the generalised force of a rotation (for a moment)
or translation (for a force) coordinate that is fixed at 0 (e.g. about the
ground y axis at the tower base; about the blade's coned y_c axis at its
root; along the ground x axis at the tower base). With the full equations M qdd = F + R over all
coordinates, the constraint reaction of that row is R = M_row qdd - F_row,
and the moment the bodies beyond the joint exert on it (external + gravity
- inertial moments about the joint, i.e. sum over the bodies above of
r x (f_ext + m g - m a) plus their rotational inertia terms) is
-R = F_row - M_row qdd, with qdd the free accelerations of the solved
equations, the prescribed accelerations, and zero for fixed coordinates.
Positive TwrBsMyt bends the tower downwind, positive RootMyc bends the
blade downwind, as in OpenFAST.
"""
from __future__ import annotations

import re

import numpy as np

from modesel.model.effects.base import Effect
from modesel.model.gauges import (GAUGE_CHANNEL, GAUGE_UNITS, TIP_CHANNEL, TOWER_GAUGE_CHANNEL, YAW_BEARING_LOADS,
                                  gauge_loads, wanted_gauges, wanted_tips, wanted_tower_gauges)
from modesel.multibody.rotations import elementary_rotation
from modesel.vocabulary import FIELD_PREFIX, RIGID_DOFS, dof_unit, parse_dof

#: units of the channels (OpenFAST's); <b> stands for a blade number. A
#: coordinate's Q_<dof> / QD_<dof> take its unit (vocabulary.dof_unit).
CHANNEL_UNITS = {
    "Time": "s", "Azimuth": "deg", "RotSpeed": "rpm", "GenSpeed": "rpm", "LSSGagPxa": "deg", "LSSGagVxa": "rpm",
    "TTDspFA": "m", "TTDspSS": "m", "TTDspTwst": "deg", "OoPDefl<b>": "m", "IPDefl<b>": "m",
    "TipDxc<b>": "m", "TipDyc<b>": "m", "TipDzc<b>": "m", "TipDxb<b>": "m", "TipDyb<b>": "m",
    "PtfmSurge": "m", "PtfmPitch": "deg", "NacYaw": "deg", "BldPitch<b>": "deg",
    "RotThrust": "kN", "RotTorq": "kN-m", "LSShftTq": "kN-m", "HSShftTq": "kN-m", "HSShftPwr": "kW", "GenTq": "kN-m",
    "GenPwr": "kW", "RotPwr": "kW", "YawMom": "kN-m",
    "TwrBsMyt": "kN-m", "TwrBsMxt": "kN-m", "RootMyc<b>": "kN-m", "RootMxc<b>": "kN-m",
    "TwrBsMzt": "kN-m", "TwrBsFxt": "kN", "TwrBsFyt": "kN", "TwrBsFzt": "kN",
    "YawBrMxp": "kN-m", "YawBrMyp": "kN-m", "YawBrMzp": "kN-m", "YawBrFxp": "kN", "YawBrFyp": "kN", "YawBrFzp": "kN",
    "RootMzc<b>": "kN-m", "RootFxc<b>": "kN", "RootFyc<b>": "kN", "RootFzc<b>": "kN",
    "RootMxb<b>": "kN-m", "RootMyb<b>": "kN-m", "RootFxb<b>": "kN", "RootFyb<b>": "kN",
    "RtAeroFxh": "N", "RtAeroMxh": "N-m", "RtAeroPwr": "W", "RtAeroCp": "-", "RtAeroCq": "-", "RtAeroCt": "-",
    "RtSpeed": "rpm", "RtTSR": "-", "RtVAvgxh": "m/s", "RtSkew": "deg", "RtArea": "m^2",
    "RtAeroFyh": "N", "RtAeroFzh": "N", "RtAeroMyh": "N-m", "RtAeroMzh": "N-m",
    "YawBrTDxp": "m", "YawBrTDyp": "m", "YawBrTDzp": "m", "TipRDzc<b>": "deg",
    "YawBrTAxp": "m/s^2", "YawBrTAyp": "m/s^2", "YawBrTAzp": "m/s^2", "NcIMUTAxs": "m/s^2", "NcIMUTAys": "m/s^2",
    "NcIMUTAzs": "m/s^2", "NcIMUTAgxs": "m/s^2", "NcIMUTAgys": "m/s^2", "NcIMUTAgzs": "m/s^2",
    "NcIMUTVxs": "m/s", "NcIMUTVys": "m/s", "NcIMUTVzs": "m/s", "NcIMURVxs": "deg/s", "NcIMURVys": "deg/s",
    "NcIMURVzs": "deg/s", "NcIMURAxs": "deg/s^2", "NcIMURAys": "deg/s^2", "NcIMURAzs": "deg/s^2",
    "LSSTipAxa": "deg/s^2", "LSSGagAxa": "deg/s^2", "HSShftA": "deg/s^2",
    "LSShftFys": "kN", "LSShftFzs": "kN", "LSShftFya": "kN", "LSShftFza": "kN",
    "LSSTipMys": "kN-m", "LSSTipMzs": "kN-m", "LSSTipMya": "kN-m", "LSSTipMza": "kN-m",
    "LSSGagMys": "kN-m", "LSSGagMzs": "kN-m", "LSSGagMya": "kN-m", "LSSGagMza": "kN-m",
}


#: ElastoDyn's other names of the channels modesel computes: the entries of
#: its output list (ElastoDyn.f90 ValidParamAry) that share one output with
#: the key; OpenFAST writes a channel under the name the OutList gives it
CHANNEL_ALIASES = {
    "Azimuth": ("LSSTipP", "LSSTipPxa", "LSSTipPxs"), "RotSpeed": ("LSSTipV", "LSSTipVxa", "LSSTipVxs"),
    "GenSpeed": ("HSShftV",), "NacYaw": ("NacYawP", "YawPos", "YawPzn", "YawPzp"),
    "TTDspFA": ("YawBrTDxt",), "TTDspSS": ("YawBrTDyt",), "TTDspTwst": ("YawBrRDzt",),
    "OoPDefl<b>": ("TipDxc<b>",), "IPDefl<b>": ("TipDyc<b>",), "TipDzc<b>": ("TipDzb<b>",),
    "BldPitch<b>": ("BlPitch<b>", "PtchPMzb<b>", "PtchPMzc<b>"),
    "RootMxc<b>": ("RootMIP<b>",), "RootMyc<b>": ("RootMOoP<b>",),
    "RootMzc<b>": ("RootMzb<b>",), "RootFzc<b>": ("RootFzb<b>",),
    "RootMxb<b>": ("RootMEdg<b>",), "RootMyb<b>": ("RootMFlp<b>",),
    "YawBrFzp": ("YawBrFzn",), "YawBrMzp": ("YawBrMzn",), "TipRDzc<b>": ("TipRDzb<b>", "TwstDefl<b>"),
    "RotTorq": ("LSShftTq", "LSShftMxa", "LSShftMxs", "LSSGagMxa", "LSSGagMxs"),
    "RotThrust": ("LSShftFxa", "LSShftFxs", "LSSGagFxa", "LSSGagFxs"), "RotPwr": ("LSShftPwr",),
    "YawMom": ("YawMomCom",),
    # AeroDyn's older names of its rotor loads (AeroDyn_IO_Params.f90 ValidParamAry: RtFld* = RtAero*)
    "RtAeroCp": ("RtFldCp",), "RtAeroCq": ("RtFldCq",), "RtAeroCt": ("RtFldCt",), "RtAeroPwr": ("RtFldPwr",),
    "RtAeroFxh": ("RtFldFxh",), "RtAeroFyh": ("RtFldFyh",), "RtAeroFzh": ("RtFldFzh",),
    "RtAeroMxh": ("RtFldMxh",), "RtAeroMyh": ("RtFldMyh",), "RtAeroMzh": ("RtFldMzh",),
    "LSSTipAxa": ("LSSTipA", "LSSTipAxs", "RotAccel"), "LSSGagAxa": ("LSSGagA", "LSSGagAxs"),
    "HSShftA": ("GenAccel",), "TipRDxb<b>": ("RollDefl<b>",), "TipRDyb<b>": ("PtchDefl<b>",),
    "LSSGagPxa": ("LSSGagP", "LSSGagPxs"), "LSSGagVxa": ("LSSGagV", "LSSGagVxs"),
    "TipClrnc<b>": ("TwrClrnc<b>", "Tip2Twr<b>"),
    "LSShftFya": ("LSSGagFya",), "LSShftFza": ("LSSGagFza",), "LSShftFys": ("LSSGagFys",),
    "LSShftFzs": ("LSSGagFzs",),
    "PtfmSurge": ("PtfmTDxi",), "PtfmPitch": ("PtfmRDyi",),
}
_ALIAS_OF = {}
for _name, _aliases in CHANNEL_ALIASES.items():
    for _b in ("1", "2", "3") if "<b>" in _name else ("",):
        for _alias in _aliases:
            _ALIAS_OF[_alias.replace("<b>", _b).upper()] = _name.replace("<b>", _b)


#: the blade-root loads in the pitched frame b and their coned-frame (x, y) sources
PITCHED_ROOT_LOADS = {"RootMxb": ("RootMxc", "RootMyc"), "RootMyb": ("RootMxc", "RootMyc"),
                      "RootFxb": ("RootFxc", "RootFyc"), "RootFyb": ("RootFxc", "RootFyc")}
#: the low-speed shaft's loads in the rotating frame a and at the strain gauges, all
#: from the nonrotating loads at the shaft tip (`shaft_loads`)
SHAFT_LOAD_SOURCES = ("LSShftFys", "LSShftFzs", "LSSTipMys", "LSSTipMzs")
SHAFT_LOADS = ("LSShftFya", "LSShftFza", "LSSTipMya", "LSSTipMza", "LSSGagMya", "LSSGagMza", "LSSGagMys",
               "LSSGagMzs")
_FORCE_CHANNELS = re.compile(r"(TwrBs(F[xyz]|Mz)t|YawBr[FM][xyz]p|Root(F[xyz]|Mz)c\d|Root[MF][xy]b\d|"
                             r"LSShftF[yz][as]|LSS(Tip|Gag)M[yz][as]|TwHt\d(FL|ML|TD|RD|ALg|AL)[xyz]t)")


def needs_reaction_forces(wanted) -> bool:
    """Whether channels `wanted` (None: all) need the reaction coordinates of
    the forces and remaining moments (model/template.py `reaction_forces`)."""
    return wanted is None or any(_FORCE_CHANNELS.fullmatch(canonical_channel(c)) for c in wanted)


def pitched_root_loads(data: dict, pitch: float, wanted=None) -> dict:
    """RootMxb<b>, RootMyb<b>, RootFxb<b>, RootFyb<b> from the coned-frame
    loads in `data` (module doc; pitch [rad]), those in `wanted` unless None."""
    c, s = np.cos(pitch), np.sin(pitch)
    out = {}
    for name, (xc, yc) in PITCHED_ROOT_LOADS.items():
        for b in range(1, 10):
            x, y = data.get(f"{xc}{b}"), data.get(f"{yc}{b}")
            if x is None or y is None or (wanted is not None and f"{name}{b}" not in wanted):
                continue
            out[f"{name}{b}"] = c * x - s * y if name[-2] == "x" else s * x + c * y
    return out


def wind_channels(built, times, points, wanted=None) -> dict:
    """InflowWind's Wind<k>VelX/Y/Z [m/s]: the undisturbed wind of the scene's
    `wind` effect at the inertial points (x, y, z) [m] (k = 1, 2, ...) at each
    of `times` [s]; {} without the effect. wanted: None (all) or names."""
    from modesel.aero.wind import wind_velocity
    # the compiled function's Python source, evaluated by the interpreter: a few
    # hundred calls cost less than loading its compiled specialisation for Python
    velocity = getattr(wind_velocity, "py_func", wind_velocity)
    effect = built.effect("wind")
    names = [f"Wind{k}Vel{c}" for k in range(1, len(points) + 1) for c in "XYZ"]
    if effect is None or (wanted is not None and not set(names) & set(wanted)):
        return {}
    out = np.empty((len(times), len(points), 3))
    for i, t in enumerate(times):
        p = effect.field.params(float(t))
        for k, (x, y, z) in enumerate(points):
            out[i, k] = velocity(p, float(x), float(y), float(z))
    return {name: out[:, j // 3, j % 3].copy() for j, name in enumerate(names)}


def switched_off_dofs(requested, columns: dict, coordinates) -> dict:
    """Q_<dof> and QD_<dof> [m, m/s] of the elastic DOFs an OpenFAST case's
    ElastoDyn switches off (TwFADOF1 False: TFA1, ...) that its OutList
    `requested` names: 0 throughout, as ElastoDyn holds a switched-off DOF
    at 0 (ElastoDyn.f90 InitBlDefl and the tower's initial state) and
    OpenFAST writes it. Only names of elastic DOFs (vocabulary) absent from
    `coordinates` (the model's) and from `columns`; and DrTr (DrTrDOF False:
    ElastoDyn holds the drivetrain's twist at 0, modesel's rotor joint keeps
    the coordinate, fixed at 0), where `columns` lacks it."""
    n = len(columns["Time"])
    out = {}
    for name in requested:
        prefix, _, dof = name.partition("_")
        if prefix not in ("Q", "QD") or name in columns:
            continue
        if dof == "DrTr":
            out[name] = np.zeros(n)
            continue
        if dof in coordinates:
            continue
        try:
            elastic = parse_dof(dof).kind == "elastic" and parse_dof(dof).multiblade is None
        except ValueError:
            continue
        if elastic:
            out[name] = np.zeros(n)
    return out


def canonical_channel(name: str) -> str:
    """modesel's name of channel `name`: the channel an ElastoDyn alias
    names, or the channel itself as modesel spells it (ElastoDyn reads its
    OutList without case: 'rotspeed' is RotSpeed); a name modesel does not
    know comes back as given."""
    key = name.upper()
    found = _ALIAS_OF.get(key) or _SPELLING.get(key)
    if found is not None:
        return found
    for pattern, spell in _SPELLED_PATTERNS:
        if m := pattern.fullmatch(name):
            return spell(m)
    return name


def _spelled_dof(name: str) -> str:
    """A coordinate's name as the vocabulary spells it (`parse_dof`), from any letter case."""
    if m := re.fullmatch(r"(B[1-9]\d*)?(TFA|TSS|TTor|F|E)([1-9]\d*)", name, re.IGNORECASE):
        return f"{(m.group(1) or '').upper()}{_FIELD_PREFIXES[m.group(2).upper()]}{m.group(3)}"
    return _RIGID_DOFS.get(name.upper(), name)


_FIELD_PREFIXES = {p.upper(): p for p in FIELD_PREFIX.values()}
_RIGID_DOFS = {d.upper(): d for d in RIGID_DOFS}
#: channels by their upper-case names: CHANNEL_UNITS' with blades 1-9
_SPELLING = {n.replace("<b>", b).upper(): n.replace("<b>", b)
             for n in CHANNEL_UNITS for b in ("123456789" if "<b>" in n else "-")}
_QUANTITY = {q.upper(): q for q in GAUGE_UNITS}
#: the channel families modesel writes under any number, spelled from any letter case
_SPELLED_PATTERNS = (
    (re.compile(GAUGE_CHANNEL.pattern, re.IGNORECASE),
     lambda m: f"Spn{m.group(1)}{_QUANTITY[m.group(2).upper()]}{m.group(3).lower()}b{m.group(4)}"),
    (re.compile(TOWER_GAUGE_CHANNEL.pattern, re.IGNORECASE),
     lambda m: f"TwHt{m.group(1)}{_QUANTITY[m.group(2).upper()]}{m.group(3).lower()}t"),
    (re.compile(TIP_CHANNEL.pattern, re.IGNORECASE),
     lambda m: f"TipClrnc{m.group(4)}" if m.group(4) else
     f"Tip{_QUANTITY[m.group(1).upper()]}{m.group(2).lower()}b{m.group(3)}"),
    (re.compile(r"Wind([1-9])Vel([XYZ])", re.IGNORECASE), lambda m: f"Wind{m.group(1)}Vel{m.group(2).upper()}"),
    (re.compile(r"(QD?)_(\w+)", re.IGNORECASE), lambda m: f"{m.group(1).upper()}_{_spelled_dof(m.group(2))}"),
)


def requested_channels(names) -> set:
    """The channel names (modesel's) that computing `names` (an OpenFAST
    case's OutList, a search's channels) needs: each as given, as modesel
    spells it (`canonical_channel`), and without a sign prefix
    (`signed_channel`; both readings of a leading 'm', whose meaning depends
    on what is computed)."""
    out = set()
    for name in names:
        for n in (name, signed_channel(name)[1]):
            out |= {n, canonical_channel(n)}
    return out


def output_columns(columns) -> dict:
    """{upper-case modesel name of the output: the first of `columns` that
    names it}: the columns by output, whatever ElastoDyn name each goes by
    (matched without case, as ElastoDyn matches)."""
    index = {}
    for c in columns:
        index.setdefault(canonical_channel(str(c)).upper(), c)
    return index


def signed_channel(name: str, known=lambda n: False) -> tuple:
    """(sign, channel) of an OutList entry, as ElastoDyn's SetOutParam reads
    it: a leading '-' or '_' negates the channel after it; a leading 'm' or
    'M' does where the whole name is not a channel (`known`)."""
    if name[:1] in ("-", "_") and len(name) > 1:
        return -1.0, name[1:]
    if name[:1] in ("m", "M") and len(name) > 1 and not known(name):
        return -1.0, name[1:]
    return 1.0, name


def with_aliases(columns: dict, requested) -> dict:
    """`columns` plus, for each name in `requested` (an OpenFAST case's
    OutList) that is not a column under that exact spelling, the column of
    its output again under the name as typed, as OpenFAST writes it: another
    ElastoDyn name of the output (`output_columns`), other letter case, or
    a sign prefix (`signed_channel`: the values negated)."""
    by_output = output_columns(columns)

    def source(name):
        return by_output.get(canonical_channel(name).upper())

    out = dict(columns)
    for name in requested:
        if name in out:
            continue
        sign, base = signed_channel(name, lambda n: source(n) is not None)
        found = source(base)
        if found is not None:
            out[name] = columns[found] if sign > 0 else -columns[found]
    return out


def channel_unit(name: str) -> str | None:
    """Unit of a simulation output channel (OpenFAST's, also under an
    ElastoDyn alias), None if unknown."""
    unit = _unit(canonical_channel(name))
    if unit is None:            # a negated OutList entry (`signed_channel`)
        unit = _unit(canonical_channel(signed_channel(name)[1]))
    return unit


def _unit(name: str) -> str | None:
    if re.fullmatch(r"Wind[1-9]Vel[XYZ]", name):
        return "m/s"
    if m := (GAUGE_CHANNEL.fullmatch(name) or TOWER_GAUGE_CHANNEL.fullmatch(name)):
        return GAUGE_UNITS[m.group(2)]
    if m := TIP_CHANNEL.fullmatch(name):
        return "m" if m.group(4) else GAUGE_UNITS[m.group(1)]
    for prefix, rate in (("Q_", False), ("QD_", True)):
        if name.startswith(prefix):
            try:
                return dof_unit(name[len(prefix):], rate=rate)
            except ValueError:
                return None
    if name in CHANNEL_UNITS:
        return CHANNEL_UNITS[name]
    per_blade = re.fullmatch(r"(\D+)\d", name)
    return CHANNEL_UNITS.get(f"{per_blade.group(1)}<b>") if per_blade else None


def coordinate_history(model, integ, name, accelerations=None) -> tuple:
    """(q, qd, qdd) of coordinate `name` over the output times of `integ`:
    a free one's from the integration (qdd from `accelerations` {name:
    values} where given, else 0), a prescribed one's from its motion, a
    fixed one at its value (rates 0)."""
    t = integ.t
    free = list(model.system.free)
    if name in free:
        i = free.index(name)
        qdd = (accelerations or {}).get(name, np.zeros_like(t))
        return integ.q[:, i], integ.qd[:, i], qdd
    if name in model.system.prescribed:
        vals = np.array([model.system.prescribed[name](ti)[:3] for ti in t])
        return vals[:, 0], vals[:, 1], vals[:, 2]
    return np.full_like(t, model.system.fixed.get(name, 0.0)), np.zeros_like(t), np.zeros_like(t)


def channels(built, integ, wanted=None):
    """Channels of `built` (simulation.assembly.Built) along `integ`
    (integrate.Integration): {name: 1-D array over the output times}, 'Time'
    first. wanted: None (all), or the names needed: the effects' channels and
    reaction loads, which cost an evaluation per output time, are then left
    out unless named (the coordinates, speeds, deflections and shaft torque
    are always there)."""
    model = built.model
    names = list(model.system.free)
    idx = {n: i for i, n in enumerate(names)}
    t = integ.t
    data = {"Time": t}
    for i, n in enumerate(names):
        data[f"Q_{n}"] = integ.q[:, i]
    for i, n in enumerate(names):
        data[f"QD_{n}"] = integ.qd[:, i]

    def coord(name):
        """Value and rate of any coordinate (free, prescribed or fixed)."""
        return coordinate_history(model, integ, name)[:2]

    # the coordinates held at a value or turned at a constant speed (e.g. GeAz with
    # ElastoDyn's GenDOF off), which OpenFAST writes as well: Q_<dof>, QD_<dof>
    for n in [*model.system.prescribed, *model.system.fixed]:
        if parse_dof(n).kind != "reaction" and (wanted is None or {f"Q_{n}", f"QD_{n}"} & set(wanted)):
            data[f"Q_{n}"], data[f"QD_{n}"] = coord(n)
    if "Q_GeAz" in data:  # ElastoDyn's generator azimuth: 0 with blade 1 at -90 deg, in [0, 2 pi)
        data["Q_GeAz"] = np.mod(data["Q_GeAz"] - 0.5 * np.pi, 2.0 * np.pi)

    ge, ged = coord("GeAz")
    dt_, dtd = coord("DrTr")
    az = ge + dt_
    # ElastoDyn's Azimuth reads AzimB1Up when blade 1 points up (LSSTipPxa = GeAz + DrTr + AzimB1Up + 90 deg)
    b1_up = model.turbine.azimuth_b1_up
    data["Azimuth"] = np.mod(np.rad2deg(az + b1_up), 360.0)
    data["RotSpeed"] = (ged + dtd) * 30.0 / np.pi
    data["GenSpeed"] = ged * model.turbine.gearbox_ratio * 30.0 / np.pi
    # the shaft at its strain gauge, the generator's side of the drivetrain spring (ElastoDyn's
    # LSSGagPxa = GeAz + 90 deg, which modesel's GeAz includes; LSSGagVxa = GeAz')
    data["LSSGagPxa"] = np.mod(np.rad2deg(ge + b1_up), 360.0)
    data["LSSGagVxa"] = ged * 30.0 / np.pi
    fa = model.field_dofs.get("tower_fa", ())
    ss = model.field_dofs.get("tower_ss", ())
    tw = model.field_dofs.get("tower_torsion", ())
    data["TTDspFA"] = sum((coord(d)[0] for d in fa), np.zeros_like(t))
    data["TTDspSS"] = -sum((coord(d)[0] for d in ss), np.zeros_like(t))
    data["TTDspTwst"] = np.rad2deg(sum((coord(d)[0] for d in tw), np.zeros_like(t)))
    data.update(tip_deflections(model, coord, t))
    data.update(tower_top_deflection(model, coord, t))
    for b in range(1, model.turbine.num_blades + 1):
        data[f"BldPitch{b}"] = np.full_like(t, np.rad2deg(model.pitch))
    if "PtfmSurge" in idx or "PtfmSurge" in model.system.fixed:
        data["PtfmSurge"] = coord("PtfmSurge")[0]
    if "PtfmPitch" in idx or "PtfmPitch" in model.system.fixed:
        data["PtfmPitch"] = np.rad2deg(coord("PtfmPitch")[0])
    if "Yaw" in idx or "Yaw" in model.system.fixed:
        data["NacYaw"] = np.rad2deg(coord("Yaw")[0])
    data.update(shaft_torque(built, coord, data["RotSpeed"]))
    data.update(yaw_moment(built, coord))
    if wanted is not None:      # the coned-frame sources of the pitched-frame root loads, the shaft's
        wanted = set(wanted) | {f"{src}{n[-1]}" for n in wanted if n[:-1] in PITCHED_ROOT_LOADS
                                for src in PITCHED_ROOT_LOADS[n[:-1]]}
        if wanted & set(SHAFT_LOADS):
            wanted |= set(SHAFT_LOAD_SOURCES)
        if any(TOWER_GAUGE_CHANNEL.fullmatch(n) for n in wanted):
            wanted |= set(YAW_BEARING_LOADS)
    data.update(load_channels(built, integ, wanted))
    data.update(pitched_root_loads(data, model.pitch, wanted))
    data.update(shaft_loads(data, model.turbine, wanted))
    data.update(shaft_power(data, model.turbine))
    return data


def shaft_power(data: dict, turbine) -> dict:
    """Where RotTorq [kN m] came from a reaction (a rigid drivetrain, see
    `shaft_torque` for the spring): LSShftTq, RotPwr [kW] = RotTorq * rotor
    speed and HSShftTq = RotTorq / GBRatio [kN m] (less the gearbox losses,
    `_torque_channels`); and, with either, HSShftPwr [kW] = HSShftTq *
    generator speed (ElastoDyn.f90 CalcOutput)."""
    if "RotTorq" not in data:
        return {}
    out = {} if "RotPwr" in data else _torque_channels(data["RotTorq"], data["RotSpeed"], turbine)
    hss = out.get("HSShftTq", data.get("HSShftTq"))
    out["HSShftPwr"] = hss * data["GenSpeed"] * np.pi / 30.0
    return out


def shaft_loads(data: dict, turbine, wanted=None) -> dict:
    """ElastoDyn's low-speed shaft loads (ElastoDyn.f90 CalcOutput) from
    the nonrotating loads the rotor exerts at the apex in `data` (LSShftFys,
    LSShftFzs [kN], LSSTipMys, LSSTipMzs [kN m]; frame s: y_s to the left, z_s
    up, normal to the shaft), those in `wanted` unless None:
    - the shaft tip is a two-blader's teeter pin, UndSling downwind of the
      apex (rPQ = -UndSling c1): M_P = M_Q - UndSling c1 x F;
    - the rotating frame a turns with the rotor, y_a = cos(Azimuth) y_s +
      sin(Azimuth) z_s, z_a along blade 1's axis (Azimuth as output: 0 with
      blade 1 up): LSShftFya, LSShftFza, LSSTipMya, LSSTipMza;
    - at the strain gauges ShftGagL upwind of the tip: LSSGagMya = LSSTipMya
      + ShftGagL LSShftFza, LSSGagMza = LSSTipMza - ShftGagL LSShftFya, and
      the same in frame s."""
    if any(data.get(n) is None for n in SHAFT_LOAD_SOURCES) or "Azimuth" not in data:
        return {}
    fy, fz, my, mz = (data[n] for n in SHAFT_LOAD_SOURCES)
    my, mz = my + turbine.undersling * fz, mz - turbine.undersling * fy
    az = np.deg2rad(data["Azimuth"]) - turbine.azimuth_b1_up        # blade 1's azimuth from up
    c, s = np.cos(az), np.sin(az)
    out = {"LSSTipMys": my, "LSSTipMzs": mz, "LSShftFya": c * fy + s * fz, "LSShftFza": -s * fy + c * fz,
           "LSSTipMya": c * my + s * mz, "LSSTipMza": -s * my + c * mz}
    g = turbine.shaft_gage
    for frame, forces in (("a", (out["LSShftFya"], out["LSShftFza"])), ("s", (fy, fz))):
        out[f"LSSGagMy{frame}"] = out[f"LSSTipMy{frame}"] + g * forces[1]
        out[f"LSSGagMz{frame}"] = out[f"LSSTipMz{frame}"] - g * forces[0]
    return {k: v for k, v in out.items() if wanted is None or k in wanted or k in SHAFT_LOAD_SOURCES}


def tip_deflections(model, coord, t) -> dict:
    """ElastoDyn's blade-tip deflections [m] (ElastoDyn.f90, CalcOutput):
    the vector from the undeflected tip (root + blade length along the
    coned blade axis) to the deflected tip, in the coned frame i of each
    blade: TipDxc<b> (= OoPDefl<b>, out of plane, downwind), TipDyc<b>
    (= IPDefl<b>, in plane), TipDzc<b> (along the blade, the shortening).
    The tip displacement is the sum over the blade's coordinates of their
    tip displacement vectors (pitched blade frame) plus the axial
    shortening -1/2 q^T G q, turned by the pitch into the coned frame."""
    out = {}
    turn = elementary_rotation(2, -model.pitch)        # pitched blade frame -> coned frame
    for b in range(1, model.turbine.num_blades + 1):
        tip = model.tips.get(f"blade{b}")
        if not tip:
            continue
        disp = tip_displacement(tip, coord, len(t))     # 0 for a rigid blade, as OpenFAST writes it
        coned = disp @ turn.T
        out[f"TipDxb{b}"], out[f"TipDyb{b}"] = disp[:, 0], disp[:, 1]
        out[f"OoPDefl{b}"], out[f"IPDefl{b}"] = coned[:, 0], coned[:, 1]
        out[f"TipDxc{b}"], out[f"TipDyc{b}"], out[f"TipDzc{b}"] = coned[:, 0], coned[:, 1], coned[:, 2]
    return out


def tip_displacement(tip: dict, coord, n: int) -> np.ndarray:
    """(n, 3) displacement [m] of a flexible body's tip (`model.tips` entry)
    in the body's frame over the output times: the coordinates' tip
    displacement vectors plus the axial shortening -1/2 q^T G q along z.
    coord: name -> (values, rates) over the n times."""
    disp = np.zeros((n, 3))
    for d, vec in tip["displacement"].items():
        disp += np.outer(coord(d)[0], vec)
    if tip.get("shortening") is not None:
        dofs, G = tip["shortening"]
        q = np.column_stack([coord(d)[0] for d in dofs])
        disp[:, 2] -= 0.5 * np.einsum("ti,ij,tj->t", q, np.asarray(G), q)
    return disp


def tower_top_deflection(model, coord, t) -> dict:
    """ElastoDyn's YawBrTDxp, YawBrTDyp, YawBrTDzp [m] (ElastoDyn.f90,
    CalcOutput: rOPO on b1, -b3, b2): the vector from the undeflected to the
    deflected tower top (the modes' tip displacements and the axial
    shortening -1/2 q^T G q, in the tower-base frame) in the tower-top frame
    p, which the tip slopes and twist turn (`flexible_beam.tip_joint`: about
    y, then x, then z); and TipRDzc<b> [deg], the blade tips' torsion, 0:
    neither ElastoDyn nor modesel has a blade torsion DOF (ElastoDyn writes
    0 under TipRDzc, TipRDzb and TwstDefl, "always zero")."""
    out = {}
    blades = [b for b in range(1, model.turbine.num_blades + 1) if model.tips.get(f"blade{b}")]
    tip = model.tips.get("tower")
    n = len(t)
    if tip:                 # a rigid tower (no field) has none: 0, as OpenFAST writes it
        disp = tip_displacement(tip, coord, n)
        angle = {k: sum((coord(d)[0] * c for d, c in tip[k].items()), np.zeros(n))
                 for k in ("slope_y", "slope_x", "twist")}
        R = (elementary_rotation(1, angle["slope_y"]) @ elementary_rotation(0, angle["slope_x"])
             @ elementary_rotation(2, angle["twist"]))
        local = np.einsum("ti,tij->tj", disp, R)     # components on the tower-top axes (R's columns)
        out["YawBrTDxp"], out["YawBrTDyp"], out["YawBrTDzp"] = local[:, 0], local[:, 1], local[:, 2]
    for b in blades:
        out[f"TipRDzc{b}"] = np.zeros(n)
    return out


def shaft_torque(built, coord, rot_speed_rpm) -> dict:
    """ElastoDyn's low-speed shaft torque RotTorq = LSShftTq [kN m] (LSShftMxa:
    the moment about the shaft the rotor exerts on it, inertia included)
    where the ElastoDyn drivetrain spring carries it: with DrTr free, the
    rotor's equation makes it the spring-damper torque k DrTr + c DrTr'.
    RotPwr [kW] = RotTorq * rotor speed; HSShftTq [kN m] (`_torque_channels`)."""
    dt = built.effect("drivetrain")
    if dt is None or dt.options["model"] != "elastodyn":
        return {}
    q, qd = coord("DrTr")
    return _torque_channels((dt.k_lss * q + dt.c_lss * qd) / 1e3, rot_speed_rpm, built.model.turbine)


def _torque_channels(torque, rot_speed_rpm, turbine) -> dict:
    """RotTorq = LSShftTq [kN m], RotPwr [kW] = RotTorq * rotor speed, HSShftTq
    [kN m] = RotTorq eta^sign(RotTorq) / GBRatio (the gearbox efficiency eta:
    its losses, ElastoDyn's GBoxEffFac; `multibody.gearbox`), of the
    low-speed shaft torque `torque` [kN m]."""
    torque = np.asarray(torque, float)
    eta = turbine.gearbox_efficiency
    passed = torque * np.where(torque >= 0.0, eta, 1.0 / eta) if eta != 1.0 else torque
    return {"RotTorq": torque, "LSShftTq": torque, "RotPwr": torque * rot_speed_rpm * np.pi / 30.0,
            "HSShftTq": passed / turbine.gearbox_ratio}


def yaw_moment(built, coord) -> dict:
    """ServoDyn's YawMom (= YawMomCom) [kN m] where the `yaw` effect acts:
    the moment the yaw drive resists with, YawSpr (Yaw - YawNeut) + YawDamp
    Yaw' (ServoDyn_IO.f90: YawMomCom = -0.001 y%YawMom, y%YawMom the moment
    applied to the nacelle, Yaw_CalcOutput, YCMode 0)."""
    yaw = built.effect("yaw")
    if yaw is None:
        return {}
    q, qd = coord("Yaw")
    o = yaw.options
    return {"YawMom": (o["stiffness"] * (q - o["neutral_deg"]) + o["damping"] * qd) / 1e3}


def load_channels(built, integ, wanted=None) -> dict:
    """Effect channels, reaction loads and accelerations at every output
    time (empty when the scene has none of them), those in `wanted` unless
    it is None (an effect's channels come all together). Where every effect
    runs compiled, all come from one compiled pass over the output times,
    the effects' loads and channels inside it (`CompiledRHS.outputs`);
    otherwise the effect channels come from the effects' Python `__call__`
    and `channels` at each output time (`python_effect_channels`, the
    reference of the compiled ones). Accelerations: `tower_top_accelerations`."""
    with_channels = [e for e in built.acting if type(e).channels is not Effect.channels
                     and (wanted is None or set(e.CHANNELS) & set(wanted))]
    reactions = {k: v for k, v in built.model.reactions.items() if wanted is None or k in wanted}
    accel = _tower_top_coordinates(built) if wanted is None or set(ACCELERATION_CHANNELS) & set(wanted) else None
    gauges = wanted_gauges(built.model, wanted)
    tower_gauges = wanted_tower_gauges(built.model, wanted)
    tips = wanted_tips(built.model, wanted)
    rotor = [c for c in ("GeAz", "DrTr") if c in built.model.system.free] \
        if wanted is None or set(SHAFT_ACCELERATIONS) & set(wanted) else []
    if not (with_channels or reactions or accel is not None or gauges or tower_gauges or tips or rotor):
        return {}
    solved = (accel or []) + [c for c in rotor if c not in (accel or [])]   # the accelerations the pass returns
    if gauges or tower_gauges or tips:
        solved = solved + [n for n in built.model.system.free if n not in solved]
    names = [c for e in with_channels for c in e.CHANNELS]
    rhs = built.rhs(all_rows=True)
    if not all(c in getattr(rhs, "channels", {}) for c in names):
        out, qdd = _reaction_channels(built, integ, reactions, rhs, solved) if reactions or solved else ({}, {})
        out.update(python_effect_channels(built, integ, with_channels))
    else:
        rows = list(reactions.values())
        values = rhs.outputs(integ.t, integ.q, integ.qd, rows, names, solved)
        out = {n: values[:, k] / 1e3 for k, n in enumerate(reactions)}
        qdd = {c: values[:, len(rows) + k] for k, c in enumerate(solved)}
        out.update({n: values[:, len(rows) + len(solved) + k] for k, n in enumerate(names)})
    if accel is not None:
        out.update(tower_top_accelerations(built, integ, qdd))
    if wanted is None or set(SHAFT_ACCELERATIONS) & set(wanted):
        out.update(shaft_accelerations(built.model, integ, qdd))
    if not all(n in out for n in YAW_BEARING_LOADS):
        tower_gauges = []
    if gauges or tower_gauges or tips:
        out.update(gauge_loads(built, integ, qdd, gauges, tower_gauges, out, tips))
    return out


#: ElastoDyn's shaft accelerations [deg/s^2] (`shaft_accelerations`)
SHAFT_ACCELERATIONS = ("LSSTipAxa", "LSSGagAxa", "HSShftA")


def shaft_accelerations(model, integ, qdd) -> dict:
    """LSSTipAxa = (GeAz + DrTr)'' (the rotor's), LSSGagAxa = GeAz'' and
    HSShftA = GBRatio GeAz'' [deg/s^2] (ElastoDyn.f90 CalcOutput), from the
    solved accelerations `qdd` {coordinate: values} (a held or turned
    coordinate's from its motion)."""
    ge = coordinate_history(model, integ, "GeAz", qdd)[2]
    dt = coordinate_history(model, integ, "DrTr", qdd)[2]
    return {"LSSTipAxa": np.degrees(ge + dt), "LSSGagAxa": np.degrees(ge),
            "HSShftA": np.degrees(model.turbine.gearbox_ratio * ge)}


#: ElastoDyn's accelerations [m/s^2] modesel writes where the tower base is fixed
#: (`tower_top_accelerations`): the tower top's in frame p, the nacelle IMU's in the shaft frame
ACCELERATION_CHANNELS = ("YawBrTAxp", "YawBrTAyp", "YawBrTAzp", "NcIMUTAxs", "NcIMUTAys", "NcIMUTAzs",
                         "NcIMUTAgxs", "NcIMUTAgys", "NcIMUTAgzs", "NcIMUTVxs", "NcIMUTVys", "NcIMUTVzs",
                         "NcIMURVxs", "NcIMURVys", "NcIMURVzs", "NcIMURAxs", "NcIMURAys", "NcIMURAzs")


def _tower_top_coordinates(built) -> list | None:
    """The coordinates whose accelerations give the tower top's and the
    nacelle's motion: the tower tip's and Yaw (none for a rigid tower and a
    fixed yaw: the accelerations are 0, as OpenFAST writes them); None
    where the tower base moves (a platform coordinate), which this does not
    cover."""
    model = built.model
    tip = model.tips.get("tower")
    index = built.eq.index
    if not tip or any(d in index for d in ("PtfmSurge", "PtfmPitch")):
        return None
    names = set(tip["displacement"]) | set(tip["slope_x"]) | set(tip["slope_y"]) | set(tip["twist"])
    if tip.get("shortening") is not None:
        names |= set(tip["shortening"][0])
    return sorted(n for n in names if n in index) + (["Yaw"] if "Yaw" in index else [])


def tower_top_accelerations(built, integ, qdd) -> dict:
    """ElastoDyn's YawBrTAxp, YawBrTAyp, YawBrTAzp [m/s^2] (LinAccEO on b1,
    -b3, b2: the tower top's inertial acceleration in the tower-top frame p)
    and NcIMUTAxs, NcIMUTAys, NcIMUTAzs [m/s^2] (LinAccEIMU on c1, -c3, c2:
    the nacelle IMU's, at NcIMUxn, NcIMUyn, NcIMUzn from the tower top in
    the nacelle frame, in the shaft frame: tilted, yawed, not turning with
    the rotor), gravity excluded, on a fixed tower base. qdd: {coordinate:
    its accelerations at the output times} (`_tower_top_coordinates`).

    With the tower tip's displacement d = Phi q - 1/2 (q^T G q) e_z, its
    acceleration is Phi qdd - (qd^T G qd + q^T G qdd) e_z. The nacelle turns
    by Ry(a_y) Rx(a_x) Rz(a_z + yaw) (`flexible_beam.tip_joint`, the slopes
    and twist linear in q), so its angular velocity is
    w = a_y' e_y + Ry e_x a_x' + Ry Rx e_z c', c = a_z + yaw, and its angular
    acceleration alpha = a_y'' e_y + Ry e_x a_x'' + a_y' a_x' e_y x Ry e_x
    + Ry Rx e_z c'' + (a_y' e_y + a_x' Ry e_x) x Ry Rx e_z c'; the IMU at
    rho = R_n imu from the tower top: a = a_O + alpha x rho + w x (w x rho)."""
    model = built.model
    tip = model.tips["tower"]
    n = len(integ.t)

    def state(name):
        return coordinate_history(model, integ, name, qdd)

    acc = np.zeros((n, 3))
    vel = np.zeros((n, 3))
    for d, vec in tip["displacement"].items():
        acc += np.outer(state(d)[2], vec)
        vel += np.outer(state(d)[1], vec)
    if tip.get("shortening") is not None:
        dofs, G = tip["shortening"]
        G = np.asarray(G)
        q, qd, qdd_ = (np.column_stack([state(d)[k] for d in dofs]) for k in range(3))
        acc[:, 2] -= np.einsum("ti,ij,tj->t", qd, G, qd) + np.einsum("ti,ij,tj->t", q, G, qdd_)
        vel[:, 2] -= np.einsum("ti,ij,tj->t", qd, G, q)

    def angle(key, extra=()):
        parts = [(state(d), c) for d, c in tip[key].items()] + [(state(d), 1.0) for d in extra]
        return tuple(sum((st[k] * c for st, c in parts), np.zeros(n)) for k in range(3))

    ay, ax = angle("slope_y"), angle("slope_x")
    az = angle("twist", ["Yaw"] if "Yaw" in built.eq.index else [])
    Ry, Rx, Rz = elementary_rotation(1, ay[0]), elementary_rotation(0, ax[0]), elementary_rotation(2, az[0])
    R_p = Ry @ Rx @ elementary_rotation(2, angle("twist")[0])
    ey = np.array([0.0, 1.0, 0.0])
    x1 = Ry[:, :, 0]                                  # Ry e_x
    z2 = (Ry @ Rx)[:, :, 2]                           # Ry Rx e_z
    w_yx = ay[1][:, None] * ey + ax[1][:, None] * x1
    w = w_yx + az[1][:, None] * z2
    alpha = (ay[2][:, None] * ey + ax[2][:, None] * x1 + (ay[1] * ax[1])[:, None] * np.cross(ey, x1)
             + az[2][:, None] * z2 + az[1][:, None] * np.cross(w_yx, z2))
    local = np.einsum("ti,tij->tj", acc, R_p)
    out = {"YawBrTAxp": local[:, 0], "YawBrTAyp": local[:, 1], "YawBrTAzp": local[:, 2]}
    R_n = Ry @ Rx @ Rz
    rho = R_n @ np.asarray(model.turbine.nacelle_imu, float)
    a_imu = acc + np.cross(alpha, rho) + np.cross(w, np.cross(w, rho))
    v_imu = vel + np.cross(w, rho)
    shaft = R_n @ elementary_rotation(1, -model.turbine.shaft_tilt)
    gravity = np.array([0.0, 0.0, -model.turbine.gravity])
    # on the shaft frame's x, y (= -c3), z (= c2): translational (m/s, m/s^2; Ag: less
    # gravity's, an accelerometer's) and rotational (deg/s, deg/s^2) motions of the IMU
    for name, series, scale in (("TA", a_imu, 1.0), ("TAg", a_imu - gravity, 1.0), ("TV", v_imu, 1.0),
                                ("RV", w, np.degrees(1.0)), ("RA", alpha, np.degrees(1.0))):
        local = np.einsum("ti,tij->tj", series, shaft) * scale
        out.update({f"NcIMU{name}{a}s": local[:, k] for k, a in enumerate("xyz")})
    return out


def python_effect_channels(built, integ, effects) -> dict:
    """The output channels of `effects` at every output time of `integ`, from
    their Python `__call__` and `channels` (each sees the same state; their
    latched switches advance with the times)."""
    out = {}
    eq = built.eq
    gen = np.zeros(eq.n_all)
    for k, ti in enumerate(integ.t):
        q_all, qd_all, _ = eq.full_state(integ.q[k], integ.qd[k], ti)
        gen[:] = 0.0
        nodes = {}
        for e in effects:
            e(built, ti, q_all, qd_all, gen, nodes)
            for name, value in e.channels(built).items():
                if name not in out:
                    out[name] = np.full(len(integ.t), np.nan)
                out[name][k] = value
    return out


def _reaction_channels(built, integ, reactions, rhs, accelerations=()):
    """(reaction loads [kN, kN m] (module doc) of `reactions` {channel:
    coordinate}, {coordinate: acceleration} of `accelerations`) along
    `integ`; rhs: `built.rhs(all_rows=True)`."""
    names = list(reactions)
    rows = [reactions[n] for n in names]
    if hasattr(rhs, "outputs"):
        loads = rhs.outputs(integ.t, integ.q, integ.qd, rows, (), accelerations)
        return ({n: loads[:, k] / 1e3 for k, n in enumerate(names)},
                {c: loads[:, len(rows) + k] for k, c in enumerate(accelerations)})
    # an effect without a compiled form: the Python loads at each output time
    eq = built.eq
    index = [eq.index[r] for r in rows]
    fi, pi = eq.free_idx, eq.presc_idx
    loads = np.full((len(integ.t), len(rows) + len(accelerations)), np.nan)
    index += [eq.index[c] for c in accelerations]
    for k, ti in enumerate(integ.t):
        q_all, qd_all, qdd_p = eq.full_state(integ.q[k], integ.qd[k], ti)
        gen, nodes = built.loads(ti, q_all, qd_all)
        M, F = eq.evaluate_full(q_all, qd_all, nodes or None, gen)
        qdd = np.zeros(eq.n_all)
        qdd[pi] = qdd_p[pi]
        rhs_f = F[fi] - M[np.ix_(fi, pi)] @ qdd_p[pi] if len(pi) else F[fi]
        qdd[fi] = np.linalg.solve(M[np.ix_(fi, fi)], rhs_f)
        loads[k] = np.concatenate([F[index[:len(rows)]] - M[index[:len(rows)]] @ qdd, qdd[index[len(rows):]]])
    return ({n: loads[:, k] / 1e3 for k, n in enumerate(names)},
            {c: loads[:, len(rows) + k] for k, c in enumerate(accelerations)})
