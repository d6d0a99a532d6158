"""The load case of a study, made ready before the first trial: its scenes
loaded and checked, and one reference per scene (read, or computed by the
internal converged model)."""
from __future__ import annotations

from modesel.errors import ModeselError
from modesel.study.reference import internal_reference, load_reference, unit_factor
from modesel.study.search.engine import Engine


def load_scenes(study, engine: Engine) -> dict:
    """{scene name: Scene}; every searched field must be active in some scene."""
    scenes = {}
    for spec in study.scenes:
        scenes[spec.name] = engine.load_scene(spec.path)
    active = set().union(*(set(getattr(s, "fields", ())) for s in scenes.values()))
    for space in study.search.fields:
        if space.field not in active:
            raise ModeselError(
                f"field '{space.field}' is not active in any scene (active: "
                f"{', '.join(sorted(active)) or 'none'}); searching it changes nothing",
                file=str(study.path), field=f"search.fields.{space.field}")
    return scenes


def prepare_references(study, scenes: dict, engine: Engine, cache_dir=None, log=None) -> dict:
    """{scene name: Reference} for every scene of the load case."""
    ref = study.reference
    channels = list(study.compare.channels)
    out = {}
    for spec in study.scenes:
        if ref.kind == "internal":
            out[spec.name] = internal_reference(
                scenes[spec.name], channels, engine.simulate, family=ref.family,
                tolerance=ref.tolerance, start_count=ref.start_count, max_count=ref.max_count,
                tmax=spec.tmax, dt=spec.dt, cache_dir=cache_dir, window=ref.window, name=spec.name,
                progress=log)
        else:
            out[spec.name] = load_reference(spec.reference, ref.kind, channels, mapping=ref.channels,
                                            time_offset=ref.time_offset, window=ref.window,
                                            scene=spec.name)
            check_reference_fits(out[spec.name], spec, scenes[spec.name], study, engine)
    return out


def check_reference_fits(reference, spec, scene, study, engine: Engine) -> None:
    """Refuse, before any trial, a reference that no simulation of the scene
    can be compared with: no time overlap with the scene's [0, tmax] (within
    the window), or a channel whose unit cannot be converted to the
    simulation's (every trial would fail the same way)."""
    tmax = spec.tmax if spec.tmax is not None else getattr(scene, "tmax", None)
    if tmax is not None:
        lo, hi = max(0.0, reference.time[0]), min(float(tmax), reference.time[-1])
        window = reference.window
        if window is not None:
            lo, hi = max(lo, window[0]), min(hi, window[1])
        if not hi > lo:
            span = f"reference [{reference.time[0]:g}, {reference.time[-1]:g}] s"
            raise ModeselError(
                f"{span} (time_offset {study.reference.time_offset:g} s applied) and scene "
                f"'{spec.name}' [0, {float(tmax):g}] s" + (f" within window [{window[0]:g}, {window[1]:g}] s"
                                                            if window is not None else "")
                + " do not overlap", file=str(study.path),
                field="reference.window" if window is not None else "reference.time_offset")
    if engine.channel_unit is None:
        return
    for ch, unit in reference.units.items():
        sim_unit = engine.channel_unit(ch)
        if unit and sim_unit and unit_factor(unit, sim_unit) is None:
            raise ModeselError(f"reference unit '{unit}' cannot be converted to the simulation's "
                               f"'{sim_unit}'", file=reference.source, field=ch)
