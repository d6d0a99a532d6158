"""Time-domain simulation of a scene: `simulate`."""
from __future__ import annotations

import re
import time

import numpy as np

from modesel.errors import ModeselError, SimulationDiverged
from modesel.modeset import ModeSet
from modesel.model.outputs import (channel_unit, channels, needs_reaction_forces, requested_channels,
                                   switched_off_dofs, wind_channels, with_aliases)
from modesel.multibody.blas import single_thread_blas
from modesel.multibody.integrate import choose_method, default_tolerances, integrate
from modesel.multibody.linearize import eigenvalues, linearize, spectrum
from modesel.simulation import first_run
from modesel.simulation.assembly import Built, build
from modesel.simulation.results import SimulationResult
from modesel.simulation.scene import Scene, check_time_grid
from modesel.simulation.stability import check_static_stability, coordinate_fields
from modesel.vocabulary import is_blade_field, is_translation, parse_dof

#: |q| bound of a rigid-body translation [m] and of the other rigid and
#: drivetrain coordinates [rad] for divergence detection
TRANSLATION_BOUND = 1e3
ANGLE_BOUND = 1e6
#: memory budget of one simulation's history [bytes]: float64 columns per
#: output row, about 6 per DOF (q, qd, qdd and their channels) plus 60 others
MAX_HISTORY_BYTES = 4 * 2**30
HISTORY_COLUMNS_PER_DOF = 6
HISTORY_COLUMNS = 60


def divergence_bounds(built: Built) -> np.ndarray:
    """Physical bounds of |q| for divergence detection: half the beam
    length [m] for elastic tip-normalised coordinates, pi for tower torsion,
    TRANSLATION_BOUND and ANGLE_BOUND for the others."""
    t = built.model.turbine
    out = []
    for n in built.model.system.free:
        d = parse_dof(n)
        if d.kind == "elastic":
            beam = t.blade if is_blade_field(d.field) else t.tower
            out.append(np.pi if d.field == "tower_torsion" else 0.5 * beam.length)
        else:
            out.append(TRANSLATION_BOUND if is_translation(n) else ANGLE_BOUND)
    return np.array(out)


def simulate(scene: Scene, modeset: ModeSet | None = None, *, tmax: float | None = None,
             dt: float | None = None, progress=None, channels=None) -> SimulationResult:
    """Integrate `scene` (with `modeset` overriding its shapes) over tmax [s]
    with outputs every dt [s] (default: the scene's) and return outputs.
    The integrator is chosen by the stiffness ratio of the scene linearised
    at rest (`integrate.choose_method`), after the static stability check;
    tolerances are the scene's, else the method's defaults
    (`integrate.default_tolerances`).
    progress: optional progress(t, tmax) hook of the integrator.
    channels: None (every output channel), or the names needed (a search's
    compared channels, an OpenFAST case's OutList: any letter case, sign
    prefixes, ElastoDyn's other names; `outputs.requested_channels`):
    effect channels, reaction loads, gauges and tip motions not named are
    left out (`outputs.channels`; about one right-hand side per output time).
    Runs with one BLAS thread (`blas.single_thread_blas`)."""
    with single_thread_blas():
        return _simulate(scene, modeset, tmax, dt, progress, channels)


def _simulate(scene, modeset, tmax, dt, progress, wanted=None) -> SimulationResult:
    tmax = scene.tmax if tmax is None else float(tmax)
    dt = scene.dt if dt is None else float(dt)
    if not (tmax > 0 and dt > 0 and np.isfinite(tmax) and np.isfinite(dt)):
        raise ModeselError(f"tmax and dt must be positive finite numbers, got tmax = {tmax:g} s, "
                           f"dt = {dt:g} s (give --tmax / --dt)", file=scene.path, field="tmax/dt")
    rows = check_time_grid(tmax, dt, file=scene.path)
    if scene.output_start > tmax:
        raise ModeselError(f"the outputs start at {scene.output_start:g} s, after tmax = {tmax:g} s: no output "
                           f"row", file=scene.path, field="TStart")
    asked = list(wanted or ())
    wanted = None if wanted is None else requested_channels(asked)
    t0 = time.perf_counter()
    built = build(scene, modeset, reactions=True, reaction_forces=needs_reaction_forces(wanted))
    first_run.compile_in_parallel(built)    # first run with compiled loads: loads and kernel at once
    requested = scene.solver.get("method", "auto")
    names = list(built.model.system.free)
    n = len(names)
    if n == 0:
        raise ModeselError("the scene has no free degree of freedom", file=scene.path, field="dofs")
    need = rows * (HISTORY_COLUMNS_PER_DOF * n + HISTORY_COLUMNS) * 8
    if need > MAX_HISTORY_BYTES:
        raise ModeselError(f"tmax / dt = {tmax:g} s / {dt:g} s with {n} DOFs needs about "
                           f"{need / 2**30:.1f} GiB for the state history and outputs, more than "
                           f"{MAX_HISTORY_BYTES / 2**30:.0f} GiB; shorten tmax or raise dt",
                           file=scene.path, field="tmax/dt")
    rhs = built.rhs()       # compiled (M, F) with the effects' loads, as Built.M_F
    lin = linearize(rhs, built.q0 * 0, built.qd0, names)
    if not all(np.all(np.isfinite(a)) for a in (lin.M, lin.C, lin.K)):
        raise ModeselError("the equations are not finite at the initial state (check the turbine's "
                           "properties and the scene's parameters)", file=scene.path)
    lam = eigenvalues(lin)
    if scene.solver.get("stability_check", True):
        check_static_stability(lin, file=scene.path, fields=coordinate_fields(names), lam=lam)
    # oscillatory modes set the ratio (a free rotor's slow speed mode is real, not stiff) ...
    modes = spectrum(lin, lam=lam)
    omegas = np.array([2 * np.pi * f for f, zeta in modes if abs(zeta) < 1.0])
    # ... and a decaying real mode faster than all of them is stiff too (an overdamped
    # drivetrain: GBRatio 1, |lambda| 1.2e4 1/s, which compiled-RK45 crawled through at 0.8x real time)
    fastest = max((2 * np.pi * f for f, zeta in modes if zeta >= 1.0), default=0.0)
    if len(omegas) and fastest > omegas.max():
        omegas = np.append(omegas, fastest)
    method, ratio = choose_method(omegas if len(omegas) else np.array([1.0]), requested, rhs,
                                  scene.solver.get("rtol"), kinked=built.kinked)
    rtol, atol = default_tolerances(method)
    wind = built.effect("wind")
    if wind is not None:            # a full field: the rotor and tmax inside it
        wind.check_covers(built, tmax)
    try:
        integ = integrate(rhs, built.q0, built.qd0, tmax, dt, method=method,
                          rtol=float(scene.solver.get("rtol", rtol)), atol=scene.solver.get("atol", atol),
                          max_step=float(scene.solver.get("max_step", np.inf)), bounds=divergence_bounds(built),
                          stiffness_ratio=ratio, progress=progress)
    except SimulationDiverged as exc:     # name the coordinate and the scene
        reason = re.sub(r"coordinate (\d+) ", lambda m: f"coordinate {_name(names, m.group(1))} ", exc.reason)
        raise SimulationDiverged(reason, exc.time, file=scene.path) from None
    wall = time.perf_counter() - t0
    columns = channels(built, integ, wanted)
    start = scene.output_start
    if start > 0.0:     # an OpenFAST case's TStart: simulated from 0, output from TStart on
        keep = columns["Time"] >= start - 1e-9 * dt
        columns = {c: v[keep] for c, v in columns.items()}
    if scene.wind_points:           # an OpenFAST case's InflowWind output points
        columns.update(wind_channels(built, columns["Time"], scene.wind_points, wanted))
    if scene.out_list and modeset is None:      # the case's own DOFs: those it switches off
        columns.update(switched_off_dofs(scene.out_list, columns, built.eq.index))
    if scene.out_list or asked:     # an OpenFAST case's OutList, a search's channels: ElastoDyn's other names
        columns = with_aliases(columns, list(scene.out_list) + asked)
    units = {c: u for c in columns if (u := channel_unit(c)) is not None}
    return SimulationResult(columns, n, wall, float(integ.t[-1]), names, integ.method, ratio, integ.n_rhs, units)


def _name(names, index: str) -> str:
    """Name of free coordinate number `index` (the integrator's message), or the number."""
    i = int(index)
    return names[i] if 0 <= i < len(names) else index
