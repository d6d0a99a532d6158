"""InflowWind input files (OpenFAST `modules/inflowwind`): the main file as
the options of modesel's `wind` effect, and uniform wind files.

Supported: WindType 1 (steady wind: HWindSpeed at RefHt with power-law
exponent PLExp), WindType 2 (uniform wind file, linear interpolation in
time: VelInterpCubic = False), with PropagationDir (a rotation of the flow
about the vertical; with a uniform file only where its linear horizontal
shear is zero), and WindType 3 (a TurbSim binary full field, FileName_BTS,
`aero.full_field`; PropagationDir turns it about the vertical through the hub,
`aero.wind`), with InflowWind's upflow VFlowAng on a
uniform wind whose PropagationDir is 0 (`aero.wind`, `upflow_deg`). Anything
else (Bladed or HAWC full fields, cubic interpolation, lidar) is a
`ModeselError` naming the file and the input.

Uniform wind file (InflowWind_IO.f90, IfW_UniformWind_Init): comment lines
start with '!'; each data row holds time [s], horizontal speed [m/s],
direction [deg], vertical speed [m/s], linear horizontal shear [-],
power-law shear exponent [-], linear vertical shear [-], gust speed [m/s]
and optionally the upflow angle [deg]; times strictly increase. Directions
are made continuous (no jump of more than 180 deg between rows) as
InflowWind does.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from modesel.errors import ModeselError
from modesel.turbine.openfast_inputs import InputFile


def read_inflowwind(path, tmax: float | None = None) -> dict:
    """Options of the `wind` effect for an InflowWind main file (paths absolute)."""
    f = InputFile(path, "InflowWind")
    wind_type = f.integer("WindType")
    if wind_type not in (1, 2, 3):
        raise f.unsupported("WindType", "only 1 = steady, 2 = uniform wind file and 3 = TurbSim full field "
                                        "are modelled")
    if "SensorType" in f and f.integer("SensorType") != 0:
        raise f.unsupported("SensorType", "lidar")
    direction = -f.number("PropagationDir")     # InflowWind: positive rotates the flow towards -y
    upflow = f.number("VFlowAng")               # [deg], the field tilted about the hub point (`aero.wind`)
    if upflow != 0.0 and (direction != 0.0 or wind_type == 3):
        raise f.unsupported("VFlowAng", "an upflow angle with PropagationDir or a full field")
    extra = {"upflow_deg": upflow} if upflow != 0.0 else {}
    if wind_type == 1:
        ref = f.number("RefHt")
        if ref <= 0:
            raise f.error(f"must be > 0, got {ref:g}", "RefHt")
        speed = f.number("HWindSpeed")
        if not speed > 0:       # as InflowWind (InflowWind_Subs.f90): a wind from behind is PropagationDir 180
            raise f.error(f"must be > 0 m/s for a steady wind, as InflowWind requires, got {speed:g} "
                          f"(a wind from behind is PropagationDir = 180)", "HWindSpeed")
        return {"speed": speed, "shear": f.number("PLexp", "PLExp"),
                "reference_height": ref, "direction_deg": direction, **extra}
    if f.flag("VelInterpCubic", default=False):
        raise f.unsupported("VelInterpCubic", "cubic interpolation in time")
    if wind_type == 3:
        bts = f.referenced("FileName_BTS")
        if bts is None:
            raise f.error("WindType = 3 needs a TurbSim binary file", "FileName_BTS")
        return {"full_field": str(bts), **({"direction_deg": direction} if direction != 0.0 else {})}
    wind_file = f.referenced("FileName_Uni", )
    if wind_file is None:
        raise f.error("WindType = 2 needs a uniform wind file", "FileName_Uni")
    ref, length = f.number("RefHt_Uni"), f.number("RefLength")
    if ref <= 0 or length <= 0:
        raise f.error("must be > 0", "RefHt_Uni" if ref <= 0 else "RefLength")
    table = read_uniform_wind(wind_file)
    if direction != 0.0 and np.any(table[:, 4] != 0.0):
        raise f.unsupported("PropagationDir", "a rotated field with linear horizontal shear")
    if direction != 0.0:
        raise f.unsupported("PropagationDir", "give the direction in the uniform wind file's column instead")
    return {"file": str(wind_file), "reference_height": ref, "reference_length": length, **extra}


def read_uniform_wind(path) -> np.ndarray:
    """(N, 9) table of a uniform wind file in `aero.wind.COLUMNS` order, angles in rad."""
    path = Path(path)
    try:
        lines = path.read_text(errors="replace").splitlines()
    except OSError as exc:
        raise ModeselError(f"cannot read the uniform wind file: {exc.strerror}", file=str(path)) from None
    rows, ncol = [], None
    for k, line in enumerate(lines, start=1):
        text = line.strip()
        if not text or text.startswith(("!", "#")):
            continue
        try:
            values = [float(v) for v in text.replace(",", " ").split()]
        except ValueError:
            raise ModeselError(f"line {k}: expected numbers, got {text[:40]!r}", file=str(path),
                               field="uniform wind data") from None
        if len(values) < 8:
            raise ModeselError(f"line {k}: needs at least 8 columns (time, speed, direction, vertical "
                               f"speed, horizontal shear, shear exponent, vertical shear, gust), got "
                               f"{len(values)}", file=str(path), field="uniform wind data")
        values = values[:9]
        if ncol is None:
            ncol = len(values)
        rows.append(values[:ncol] + [0.0] * (9 - ncol))
    if not rows:
        raise ModeselError("no data rows", file=str(path), field="uniform wind data")
    table = np.array(rows, float)
    if not np.all(np.isfinite(table)):
        raise ModeselError("non-finite values", file=str(path), field="uniform wind data")
    if np.any(np.diff(table[:, 0]) <= 0):
        raise ModeselError("times must strictly increase", file=str(path), field="uniform wind data")
    table[:, 2] = np.deg2rad(table[:, 2])
    table[:, 8] = np.deg2rad(table[:, 8])
    for i in range(1, len(table)):           # continuous direction, as InflowWind
        while table[i, 2] - table[i - 1, 2] > np.pi:
            table[i, 2] -= 2 * np.pi
        while table[i, 2] - table[i - 1, 2] < -np.pi:
            table[i, 2] += 2 * np.pi
    return table
