"""References: the response a mode set must reproduce.

Three kinds (study file `[reference] kind`):

- ``openfast``: an OpenFAST output file (.out text or .outb binary), read by
  `modesel.turbine.openfast_output.read_openfast_output`.
- ``csv``: a CSV table with a ``Time`` column [s] and one column per
  channel; a header may carry units as ``TTDspFA [m]`` or ``TTDspFA (m)``.
- ``internal``: a converged response of the same engine, obtained by
  raising the mode count of one family (default ``fem``) per active field
  until one more mode changes the response (worst nrmse over the compared
  channels between successive counts) by less than a tolerance (default
  0.1 %); the convergence loop of the second paper's mode-selection
  flowchart (Dai et al., section 5, Fig. 12), which also found that adding
  modal terms improves agreement at a cost growing with their number. Fields are converged one at a time in `FIELDS` order, each keeping
  the count reached, in a single sweep. The result is cached in the output
  folder under a hash of the scene file, time span and settings, so a
  resumed study does not recompute it (editing files the scene points to,
  e.g. a blade file, does not change the hash: delete the cache to redo it).

Every file reference is checked on load: ``Time`` present, finite, strictly
increasing (no duplicate, no step back), every compared channel present
(did-you-mean on a typo) and finite. `Reference.align` resamples it onto
the simulation time grid by linear interpolation within the window where
both overlap, and converts units when both sides state them (deg/rad,
rpm/rad/s, kN/N, kN-m/N-m...) or refuses incompatible ones. Every problem is
a one-line `ModeselError` naming the file and the channel.
"""
from __future__ import annotations

import csv
import hashlib
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from modesel.errors import ModeselError, unknown_name
from modesel.files import atomic_write_text, read_unit_csv, unit_csv_text
from modesel.modeset import FIELDS, FieldModes, ModeSet

CACHE_VERSION = 1

# unit -> (SI unit, factor to SI); names normalised by `_normalise_unit`
_UNITS = {
    "s": ("s", 1.0), "sec": ("s", 1.0),
    "m": ("m", 1.0), "mm": ("m", 1e-3), "cm": ("m", 1e-2),
    "rad": ("rad", 1.0), "deg": ("rad", math.pi / 180.0),
    "rad/s": ("rad/s", 1.0), "deg/s": ("rad/s", math.pi / 180.0), "rpm": ("rad/s", math.pi / 30.0),
    "rad/s^2": ("rad/s^2", 1.0), "deg/s^2": ("rad/s^2", math.pi / 180.0),
    "m/s": ("m/s", 1.0), "m/s^2": ("m/s^2", 1.0),
    "n": ("n", 1.0), "kn": ("n", 1e3), "mn": ("n", 1e6),
    "n-m": ("n-m", 1.0), "kn-m": ("n-m", 1e3), "mn-m": ("n-m", 1e6),
    "w": ("w", 1.0), "kw": ("w", 1e3), "mw": ("w", 1e6),
    "-": ("-", 1.0), "": ("-", 1.0),
}


def _normalise_unit(unit: str) -> str:
    u = str(unit).strip().strip("[]()").strip().lower().replace(" ", "")
    u = u.replace("·", "-").replace("*", "-").replace("²", "^2").replace("s2", "s^2")
    u = re.sub(r"^(k|m)?nm$", lambda m: f"{m.group(1) or ''}n-m", u)
    return {"degrees": "deg", "radians": "rad", "(-)": "-", "none": "-"}.get(u, u)


def unit_factor(from_unit: str, to_unit: str) -> float | None:
    """Factor turning a value in `from_unit` into `to_unit`; None if incompatible/unknown."""
    a, b = _normalise_unit(from_unit), _normalise_unit(to_unit)
    if a == b:
        return 1.0
    if a in _UNITS and b in _UNITS and _UNITS[a][0] == _UNITS[b][0]:
        return _UNITS[a][1] / _UNITS[b][1]
    return None


# --------------------------------------------------------------------------- reading tables

_HEADER_UNIT = re.compile(r"^\s*(?P<name>[^\[\(]+?)\s*[\[\(](?P<unit>[^\]\)]*)[\]\)]\s*$")


def _read_csv(path: Path) -> pd.DataFrame:
    try:
        df = read_unit_csv(path)        # a second header row of units "(s),(m)" is read as units
    except FileNotFoundError:
        raise ModeselError("reference file not found", file=str(path)) from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, OSError) as exc:
        raise ModeselError(f"cannot read CSV: {str(exc).splitlines()[0]}", file=str(path)) from None
    with open(path, newline="", errors="replace") as fh:     # pandas renames repeated columns (X.1)
        header = next(csv.reader(fh), [])
    seen = set()
    for col in header:
        if col.strip() in seen:
            raise ModeselError("column appears twice", file=str(path), field=col.strip())
        seen.add(col.strip())
    names, units = [], {}
    for col in df.columns:
        m = _HEADER_UNIT.match(str(col))
        name = m.group("name") if m else str(col).strip()
        if m:
            units[name] = m.group("unit").strip()
        names.append(name)
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise ModeselError("column appears twice", file=str(path), field=dup)
    units.update(df.attrs.get("units", {}))
    df.columns = names
    df.attrs["units"] = units
    return df


def _read_openfast(path: Path) -> pd.DataFrame:
    from modesel.turbine.openfast_output import read_openfast_output
    return read_openfast_output(path)


READERS = {"csv": _read_csv, "openfast": _read_openfast}


def read_reference_table(path: str | Path, kind: str) -> pd.DataFrame:
    """'Time' + channel columns of a reference file (units in df.attrs['units'])."""
    if kind not in READERS:
        raise unknown_name("reference kind", kind, READERS, file=str(path))
    return READERS[kind](Path(path))


def _check_time(time: np.ndarray, file: str) -> None:
    if len(time) < 2:
        raise ModeselError(f"needs at least 2 time samples, has {len(time)}", file=file, field="Time")
    if not np.all(np.isfinite(time)):
        row = int(np.flatnonzero(~np.isfinite(time))[0])
        raise ModeselError(f"NaN or infinite time at row {row}", file=file, field="Time")
    step = np.diff(time)
    if np.any(step == 0.0):
        row = int(np.flatnonzero(step == 0.0)[0]) + 1
        raise ModeselError(f"duplicated time {time[row]:g} s at row {row}", file=file, field="Time")
    if np.any(step < 0.0):
        row = int(np.flatnonzero(step < 0.0)[0]) + 1
        raise ModeselError(f"time is not increasing: {time[row - 1]:g} s then {time[row]:g} s "
                           f"at row {row}", file=file, field="Time")


def _column(df: pd.DataFrame, name: str, file: str, what: str = "channel") -> np.ndarray:
    if name not in df.columns:
        raise unknown_name(what, name, [c for c in df.columns], file=file, field=name)
    values = pd.to_numeric(df[name], errors="coerce").to_numpy(dtype=float)
    if not np.all(np.isfinite(values)):
        row = int(np.flatnonzero(~np.isfinite(values))[0])
        raise ModeselError(f"NaN, infinite or non-numeric value at row {row}", file=file, field=name)
    return values


# --------------------------------------------------------------------------- Reference

@dataclass
class Aligned:
    """Simulation and reference on the same time grid [s], keyed by simulation channel."""

    time: np.ndarray
    sim: dict
    ref: dict
    azimuth_sim: np.ndarray | None = None   # rotor azimuth [rad], unwrapped (when both sides have it)
    azimuth_ref: np.ndarray | None = None


@dataclass
class Reference:
    """Reference response of one scene.

    `time` [s] (time offset applied) and `channels` {simulation name: values};
    `units` {simulation name: unit} where the source states them; `source` the
    file (or "internal"); `info` how it was obtained (internal: counts used).
    """

    scene: str
    source: str
    time: np.ndarray
    channels: dict
    units: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)
    window: tuple | None = None
    azimuth: np.ndarray | None = None   # rotor azimuth [rad], unwrapped, when the file has 'Azimuth'

    def align(self, outputs: pd.DataFrame, channels, *, file: str | None = None) -> Aligned:
        """Both series on one time grid: the simulation's (`outputs['Time']`)
        samples inside the overlap of both time spans (and the comparison
        window), with the reference linearly interpolated at them; or, where
        the reference has fewer samples in that span (a coarser output step),
        the reference's own samples there, with the simulation interpolated at
        them. Interpolating the coarser series onto the finer grid would count
        its interpolation error as the model's (a 0.1-s reference against
        0.05-s outputs: the deck's own modes scored 0.87 % instead of 0.08 %).
        `file` names the simulation in errors.
        """
        where = file or f"simulation of scene '{self.scene}'"
        if "Time" not in outputs.columns:
            raise ModeselError("simulation outputs have no 'Time' column", file=where, field="Time")
        t_sim = outputs["Time"].to_numpy(dtype=float)
        _check_time(t_sim, where)
        lo = max(t_sim[0], self.time[0])
        hi = min(t_sim[-1], self.time[-1])
        if self.window is not None:
            lo, hi = max(lo, self.window[0]), min(hi, self.window[1])
        eps = 1e-9 * max(1.0, abs(hi))
        keep = (t_sim >= lo - eps) & (t_sim <= hi + eps)
        if keep.sum() < 2:
            raise ModeselError(
                f"simulation [{t_sim[0]:g}, {t_sim[-1]:g}] s and reference [{self.time[0]:g}, "
                f"{self.time[-1]:g}] s" + (f" within window [{self.window[0]:g}, {self.window[1]:g}] s"
                                           if self.window else "") + " share fewer than 2 samples",
                file=self.source, field="Time")
        in_ref = (self.time >= lo - eps) & (self.time <= hi + eps)
        on_reference = 2 <= in_ref.sum() < keep.sum()      # the reference is the coarser grid
        t = self.time[in_ref] if on_reference else t_sim[keep]

        def on_grid(values):        # a simulation series on the common grid
            return np.interp(t, t_sim, values) if on_reference else values[keep]

        sim_units = outputs.attrs.get("units", {}) or {}
        sim, ref = {}, {}
        for ch in channels:
            if ch not in outputs.columns:
                raise unknown_name("simulation channel", ch, [c for c in outputs.columns if c != "Time"],
                                   file=where, field=ch)
            if ch not in self.channels:
                raise unknown_name("reference channel", ch, self.channels, file=self.source, field=ch)
            factor = 1.0
            if ch in sim_units and self.units.get(ch):
                factor = unit_factor(self.units[ch], sim_units[ch])
                if factor is None:
                    raise ModeselError(f"reference unit '{self.units[ch]}' does not match the "
                                       f"simulation unit '{sim_units[ch]}'", file=self.source, field=ch)
            sim[ch] = on_grid(outputs[ch].to_numpy(dtype=float))
            ref[ch] = factor * (self.channels[ch][in_ref] if on_reference else np.interp(t, self.time, self.channels[ch]))
        az_sim = az_ref = None
        if self.azimuth is not None and "Azimuth" in outputs.columns:
            # both unwrapped before resampling, so that 360 -> 0 deg is no jump
            az_sim = on_grid(unwrapped_azimuth(outputs["Azimuth"].to_numpy(dtype=float),
                                               sim_units.get("Azimuth", "deg"), where))
            az_ref = self.azimuth[in_ref] if on_reference else np.interp(t, self.time, self.azimuth)
        return Aligned(t, sim, ref, az_sim, az_ref)

    def frame(self) -> pd.DataFrame:
        return pd.DataFrame({"Time": self.time, **self.channels})


def unwrapped_azimuth(values, unit: str, file: str) -> np.ndarray:
    """Rotor azimuth [rad], continuous (2 pi added at each wrap)."""
    factor = unit_factor(unit or "deg", "rad")
    if factor is None:
        raise ModeselError(f"azimuth unit '{unit}' is not an angle", file=file, field="Azimuth")
    return np.unwrap(factor * np.asarray(values, dtype=float))


def load_reference(path: str | Path, kind: str, channels, *, mapping: dict | None = None,
                   time_offset: float = 0.0, window=None, scene: str = "") -> Reference:
    """Read and check a reference file; `mapping` {sim name: file name} renames
    channels; a compared channel the file lacks is read from its column under
    another of ElastoDyn's names of the same output (OpenFAST writes the name
    its OutList gives), if it has one."""
    mapping = mapping or {}
    file = str(path)
    df = read_reference_table(path, kind)
    if "Time" not in df.columns:
        raise unknown_name("time column", "Time", list(df.columns), file=file, field="Time")
    time = _column(df, "Time", file, "time column")
    _check_time(time, file)
    units_in_file = df.attrs.get("units", {}) or {}
    values, units = {}, {}
    used = {}
    by_output = None
    for ch in channels:
        name = mapping.get(ch, ch)
        sign = 1.0
        if name.startswith("-"):          # "-Q_TSS1": the file's channel, negated
            sign, name = -1.0, name[1:]
        if ch not in mapping and name not in df.columns:    # under another of ElastoDyn's names (RootMxb1 for RootMEdg1)
            from modesel.model.outputs import canonical_channel, output_columns
            by_output = by_output or output_columns(df.columns)
            name = by_output.get(canonical_channel(name).upper(), name)
        used[ch] = ("-" if sign < 0 else "") + name
        values[ch] = sign * _column(df, name, file)
        if units_in_file.get(name):
            units[ch] = units_in_file[name]
    azimuth = None
    if "Azimuth" in df.columns:      # for metrics compared against azimuth (periodic)
        azimuth = unwrapped_azimuth(_column(df, "Azimuth", file), units_in_file.get("Azimuth", "deg"), file)
    return Reference(scene, file, time + float(time_offset), values, units,
                     {"kind": kind, "channels": used},
                     None if window is None else tuple(window), azimuth)


# --------------------------------------------------------------------------- internal reference

def _change(new: Aligned, old: Aligned) -> float:
    """Worst channel nrmse of `old` against `new` (0 when both are identically flat)."""
    from modesel.study.metrics import nrmse
    worst = 0.0
    for ch, ref in new.sim.items():
        try:
            change = nrmse(old.sim[ch], ref, new.time)
        except ModeselError:  # flat channel: no change if the old one is identical
            change = 0.0 if np.array_equal(old.sim[ch], ref) else math.inf
        worst = max(worst, change)
    return worst


def _cache_key(scene_path, settings: dict) -> str:
    h = hashlib.sha256()
    h.update(json.dumps(settings, sort_keys=True, default=str).encode())
    try:
        h.update(Path(scene_path).read_bytes())
    except (OSError, TypeError):
        h.update(str(scene_path).encode())
    return h.hexdigest()[:16]


def internal_reference(scene, channels, simulate, *, family: str = "fem", tolerance: float = 1e-3,
                       start_count: int = 1, max_count: int = 10, tmax=None, dt=None,
                       cache_dir: str | Path | None = None, window=None, name: str | None = None,
                       progress=None) -> Reference:
    """Converged reference of `scene` from `simulate` with `family` modes.

    For each active field (scene.fields) in turn, raise its count from
    `start_count` until one more mode changes the response by less than
    `tolerance` (worst nrmse over `channels`); raise ModeselError if
    `max_count` (or the family's own maximum) is reached first. `info`
    reports the counts used and every change measured.
    """
    from modesel.candidates.base import get_family
    name = name or getattr(scene, "name", "scene")
    channels = list(channels)
    fields = [f for f in FIELDS if f in tuple(scene.fields)]
    if not fields:
        raise ModeselError("the scene has no active flexible field to converge", file=scene.path)
    fam = get_family(family)
    top = max_count if fam.max_count is None else min(max_count, fam.max_count)
    settings = {"version": CACHE_VERSION, "family": family, "tolerance": tolerance,
                "start_count": start_count, "max_count": top, "tmax": tmax, "dt": dt,
                "channels": sorted(channels), "fields": fields, "scene": name}
    cache = None
    if cache_dir is not None:
        key = _cache_key(getattr(scene, "path", None), settings)
        stem = f"internal_{re.sub(r'[^A-Za-z0-9_-]', '_', name)[:100]}_{key}"   # no separator, no '..'
        folder = Path(cache_dir).resolve()
        csv, meta = folder / f"{stem}.csv", folder / f"{stem}.json"
        cache = folder / stem
        if csv.parent != folder:        # the cache stays inside its folder whatever the name
            raise ModeselError(f"scene name {name!r} cannot name a cache file", field="scene.name")
        if csv.exists() and meta.exists():
            df = read_unit_csv(csv)
            info = json.loads(meta.read_text())
            return Reference(name, "internal", df["Time"].to_numpy(float),
                             {ch: df[ch].to_numpy(float) for ch in channels}, {}, info,
                             None if window is None else tuple(window))

    counts = {f: start_count for f in fields}

    def run():
        ms = ModeSet({f: FieldModes(family, counts[f]) for f in fields})
        if progress:
            progress(f"internal reference '{name}': {ms.label()}")
        out = simulate(scene, ms, tmax=tmax, dt=dt).outputs
        t = out["Time"].to_numpy(float)
        missing = [ch for ch in channels if ch not in out.columns]
        if missing:
            raise unknown_name("simulation channel", missing[0], [c for c in out.columns if c != "Time"],
                               file=getattr(scene, "path", None), field=missing[0])
        return out, Aligned(t, {ch: out[ch].to_numpy(float) for ch in channels}, {})

    out, current = run()
    history = []
    for f in fields:
        while True:
            if counts[f] >= top:
                raise ModeselError(
                    f"internal reference did not converge: {family}:{counts[f]} still changes the "
                    f"response by {history[-1]['change']:.3g} (tolerance {tolerance:g}); raise "
                    f"[reference].max_count or the tolerance" if history and history[-1]["field"] == f
                    else f"internal reference cannot raise {f} beyond {family}:{top} modes",
                    file=getattr(scene, "path", None), field=f)
            counts[f] += 1
            out, new = run()
            change = _change(new, current)
            history.append({"field": f, "count": counts[f], "change": change})
            current = new
            if change < tolerance:
                break
    info = {"kind": "internal", "family": family, "counts": dict(counts), "tolerance": tolerance,
            "changes": history}
    ref = Reference(name, "internal", current.time, dict(current.sim), {}, info,
                    None if window is None else tuple(window))
    if cache is not None:
        from modesel.study.timeseries import series_units
        Path(cache_dir).mkdir(parents=True, exist_ok=True)
        frame = ref.frame()
        atomic_write_text(cache.with_suffix(".csv"),
                          unit_csv_text(frame, series_units(frame.columns), float_format="%.17g"))
        atomic_write_text(cache.with_suffix(".json"), json.dumps(info, indent=2, sort_keys=True) + "\n")
    return ref
