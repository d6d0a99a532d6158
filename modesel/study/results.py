"""Results of a study, written to the output folder (every file atomically:
written to a temporary file in the same folder, then `os.replace`d).

- ``trials.csv``: one row per evaluated mode set, ranked. Sets meeting the
  tolerance come first, cheapest first (cost, then DOF count, then error);
  then the others, most accurate first; failed trials last. Columns: rank,
  trial, modeset (e.g. ``tower_fa=clamped:2 blade_flap=fem:3``),
  ``<field>_family``, ``<field>_count`` (and ``<field>_<param>``) per searched
  field, n_dofs, error (worst weighted channel), worst_channel,
  ``error_<channel>`` per compared channel, wall_time_s, simulated_time_s,
  speed (simulated s per wall s), cost, meets_tolerance, status
  (COMPLETE/FAIL) and reason. A trial that proposed a set already evaluated
  is served from that trial's record (user attribute ``duplicate_of``) and
  is not listed again.
- ``pareto.csv``: the completed sets no other set beats on both error and
  cost, cheapest first.
- ``best_modeset.json``: the cheapest set meeting the tolerance, or the most
  accurate one if none does; ``selection`` says which.
- ``timeseries/``: the compared channels of featured trials (and the
  reference) so `modesel report` can redraw the overlays.
- ``run.json``: the study text, storage and study name `modesel report` needs.

Errors are recomputed from each trial's per-channel errors with the study's
current criterion, so a changed tolerance re-ranks without re-simulating.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from modesel.errors import ModeselError
from modesel.files import atomic_write_text  # noqa: F401  (re-exported)
from modesel.modeset import ModeSet

RUN_INFO = "run.json"
SERIES_DIR = "timeseries"


def write_json(path, data) -> None:
    atomic_write_text(path, json.dumps(data, indent=2, sort_keys=True, default=_json_default) + "\n")


def _json_default(obj):
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating,)):
        return float(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    return str(obj)


def write_csv(path, df: pd.DataFrame) -> None:
    atomic_write_text(path, df.to_csv(index=False, float_format="%.9g"))


# --------------------------------------------------------------------------- run metadata

def write_run_info(out_dir, info: dict) -> None:
    write_json(Path(out_dir) / RUN_INFO, info)


def read_run_info(out_dir) -> dict:
    """run.json of an output folder, with the keys `modesel report` needs checked."""
    path = Path(out_dir) / RUN_INFO
    try:
        info = json.loads(path.read_text())
    except (FileNotFoundError, NotADirectoryError):
        raise ModeselError(f"not a modesel output folder (no {RUN_INFO})", file=str(out_dir)) from None
    except json.JSONDecodeError as exc:
        raise ModeselError(f"not valid JSON ({exc.msg} at line {exc.lineno})", file=str(path)) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ModeselError(f"cannot read: {exc}", file=str(path)) from None
    for key in ("study_toml", "study_file", "storage"):
        if not isinstance(info, dict) or not isinstance(info.get(key), str):
            raise ModeselError("missing or not a string (the file is damaged; run `modesel run` "
                               "again with the same --out)", file=str(path), field=key)
    return info


# --------------------------------------------------------------------------- time series

def series_path(out_dir, trial: int | str) -> Path:
    name = "reference" if trial == "reference" else f"trial_{int(trial):05d}"
    return Path(out_dir) / SERIES_DIR / f"{name}.csv"


def write_series(out_dir, trial: int | str, by_scene: dict) -> None:
    """Store {scene: (time, {channel: values})} as one long CSV (column `scene`)."""
    frames = []
    for scene, (time, channels) in by_scene.items():
        frames.append(pd.DataFrame({"scene": scene, "Time": time, **channels}))
    path = series_path(out_dir, trial)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_csv(path, pd.concat(frames, ignore_index=True))


def read_series(out_dir, trial: int | str) -> dict | None:
    """{scene: DataFrame(Time, channels...)} or None when not stored."""
    path = series_path(out_dir, trial)
    if not path.exists():
        return None
    df = pd.read_csv(path)
    return {str(s): g.drop(columns="scene").reset_index(drop=True) for s, g in df.groupby("scene", sort=False)}


def prune_series(out_dir, keep) -> None:
    """Delete stored trial series except those of trial numbers in `keep`."""
    folder = Path(out_dir) / SERIES_DIR
    keep = {series_path(out_dir, k).name for k in keep}
    for path in folder.glob("trial_*.csv"):
        if path.name not in keep:
            path.unlink(missing_ok=True)


# --------------------------------------------------------------------------- tables

def trial_table(trials, study) -> pd.DataFrame:
    """One row per finished trial (COMPLETE or FAIL) with recomputed errors."""
    import optuna
    criterion = study.criterion()
    channels = list(study.compare.channels)
    rows = []
    by_number = {t.number: t for t in trials}
    for t in trials:
        if t.state not in (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.FAIL):
            continue
        a = t.user_attrs
        if a.get("duplicate_of") in by_number:   # a repeat: the record is the earlier trial's
            a = dict(by_number[a["duplicate_of"]].user_attrs, duplicate_of=a["duplicate_of"])
        row = {"trial": t.number, "modeset": a.get("modeset", "")}
        ms = a.get("modeset_json")
        ms = ModeSet.from_dict(ms) if ms else None
        for space in study.search.fields:
            fm = ms.get(space.field) if ms else None
            row[f"{space.field}_family"] = fm.family if fm else None
            row[f"{space.field}_count"] = fm.count if fm else None
            for fam in space.families:
                for p in fam.params:
                    if f"{space.field}_{p}" not in row:
                        row[f"{space.field}_{p}"] = None
                    if fm and fm.family == fam.family and p in fm.params:
                        row[f"{space.field}_{p}"] = fm.params[p]
        row["n_dofs"] = a.get("n_dofs")
        complete = t.state == optuna.trial.TrialState.COMPLETE and bool(a.get("errors"))
        if complete:
            verdict = criterion.assess(a["errors"])
            row.update(error=verdict.error, worst_channel=verdict.worst_channel)
        else:
            row.update(error=math.nan, worst_channel=None)
        for ch in channels:
            row[f"error_{ch}"] = a.get("errors", {}).get(ch, math.nan) if complete else math.nan
        row.update(wall_time_s=a.get("wall_time_s", math.nan),
                   simulated_time_s=a.get("simulated_time_s", math.nan),
                   speed=a.get("speed", math.nan), cost=a.get("cost", math.nan),
                   meets_tolerance=bool(complete and verdict.meets),
                   status="COMPLETE" if complete else "FAIL",
                   reason=a.get("fail_reason", "") if not complete else "",
                   duplicate_of=a.get("duplicate_of"))
        rows.append(row)
    df = pd.DataFrame(rows)
    if df.empty:
        return df
    for col in df.columns:
        if col.endswith("_count") or col in ("n_dofs", "duplicate_of"):
            df[col] = df[col].astype("Int64")
    return df


def rank(df: pd.DataFrame) -> pd.DataFrame:
    """Distinct mode sets, best first, with a 1-based `rank` column first."""
    if df.empty:
        return df.assign(rank=pd.Series(dtype=int))
    df = df[df["duplicate_of"].isna()].copy()
    group = np.where(df["status"] != "COMPLETE", 2, np.where(df["meets_tolerance"], 0, 1))
    df["_group"] = group
    df["_k1"] = np.where(group == 0, df["cost"], np.where(group == 1, df["error"], df["trial"]))
    df["_k2"] = np.where(group == 0, df["n_dofs"].astype(float), df["cost"])
    df["_k3"] = np.where(group == 0, df["error"], df["trial"])
    df = df.sort_values(["_group", "_k1", "_k2", "_k3", "trial"], na_position="last")
    df = df.drop(columns=["_group", "_k1", "_k2", "_k3"])
    df.insert(0, "rank", np.arange(1, len(df) + 1))
    return df.reset_index(drop=True)


def pareto(df: pd.DataFrame) -> pd.DataFrame:
    """Completed distinct sets not dominated in (error, cost), cheapest first."""
    if df.empty:
        return df
    done = df[(df["status"] == "COMPLETE") & df["duplicate_of"].isna()]
    done = done.sort_values(["cost", "error", "n_dofs", "trial"])
    keep, best_error = [], math.inf
    for idx, row in done.iterrows():
        if row["error"] < best_error:
            keep.append(idx)
            best_error = row["error"]
    return done.loc[keep].reset_index(drop=True)


def choose(ranked: pd.DataFrame, tolerance: float | None = None, criterion=None):
    """Cheapest completed set whose error <= tolerance (row), else None."""
    if ranked.empty:
        return None
    done = ranked[ranked["status"] == "COMPLETE"]
    ok = done[done["error"] <= tolerance] if tolerance is not None else done[done["meets_tolerance"]]
    if ok.empty:
        return None
    return ok.sort_values(["cost", "n_dofs", "error", "trial"]).iloc[0]


def most_accurate(ranked: pd.DataFrame):
    done = ranked[ranked["status"] == "COMPLETE"] if not ranked.empty else ranked
    if done.empty:
        return None
    return done.sort_values(["error", "cost", "trial"]).iloc[0]


def best_modeset(ranked: pd.DataFrame, study, trials_by_number: dict) -> dict:
    """Content of best_modeset.json."""
    row = choose(ranked, study.compare.tolerance)
    selection = "cheapest set meeting the tolerance"
    if row is None:
        row = most_accurate(ranked)
        selection = "most accurate set (none met the tolerance)"
    if row is None:
        return {"study": study.name, "selection": "none (no trial completed)", "fields": {},
                "tolerance": study.compare.tolerance}
    attrs = trials_by_number[int(row["trial"])].user_attrs
    data = ModeSet.from_dict(attrs["modeset_json"]).to_dict()
    data.update(study=study.name, selection=selection, label=row["modeset"], trial=int(row["trial"]),
                meets_tolerance=bool(row["meets_tolerance"]), tolerance=study.compare.tolerance,
                metric=study.compare.metric, error=float(row["error"]),
                worst_channel=row["worst_channel"], errors=dict(attrs["errors"]),
                n_dofs=None if pd.isna(row["n_dofs"]) else int(row["n_dofs"]),
                wall_time_s=float(row["wall_time_s"]), speed=float(row["speed"]),
                cost=float(row["cost"]), cost_measure=study.search.cost)
    return data


def featured_trials(ranked: pd.DataFrame, study) -> dict:
    """{description: trial number}: chosen set per tolerance level and the most accurate."""
    out = {}
    for level in study.compare.levels:
        row = choose(ranked, level)
        if row is not None:
            out[f"cheapest within {level:.3g}"] = int(row["trial"])
    row = most_accurate(ranked)
    if row is not None:
        out["most accurate"] = int(row["trial"])
    return out


def write_results(out_dir, optuna_study, study) -> dict:
    """Write trials.csv, pareto.csv and best_modeset.json; return the tables."""
    out_dir = Path(out_dir)
    trials = optuna_study.get_trials(deepcopy=False)
    table = trial_table(trials, study)
    ranked = rank(table)
    front = pareto(table)
    drop = ["duplicate_of"]
    write_csv(out_dir / "trials.csv", ranked.drop(columns=drop, errors="ignore"))
    write_csv(out_dir / "pareto.csv", front.drop(columns=drop, errors="ignore"))
    best = best_modeset(ranked, study, {t.number: t for t in trials})
    write_json(out_dir / "best_modeset.json", best)
    return {"table": table, "ranked": ranked, "pareto": front, "best": best,
            "featured": featured_trials(ranked, study)}
