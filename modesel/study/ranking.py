"""Ranking the evaluated mode sets of a study (tables, no files).

One row per evaluated set (`trial_table`); sets meeting the tolerance
first, cheapest first (cost, then DOF count, then error), then the others,
most accurate first, failed trials last (`rank`); the sets no other beats on
both error and cost (`pareto`); the cheapest set within a tolerance
(`choose`), the most accurate one, and the set `best_modeset.json` holds.
Errors are recomputed from each trial's per-channel errors with the study's
current criterion, so a changed tolerance re-ranks without re-simulating.
A trial that proposed a set already evaluated (user attribute
``duplicate_of``) takes that trial's record and is not ranked again.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from modesel.modeset import ModeSet


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
        if "modeset" not in a and t.state != optuna.trial.TrialState.COMPLETE:
            continue        # stopped (interrupt, dead worker) before it proposed a set: nothing to report
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
                   reason=(a.get("fail_reason") or "interrupted (its worker stopped)") if not complete else "",
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
    data.update(study=study.name, scenes=[str(s.path) for s in study.scenes],
                selection=selection, label=row["modeset"], trial=int(row["trial"]),
                meets_tolerance=bool(row["meets_tolerance"]), tolerance=study.compare.tolerance,
                metric=study.compare.metric, error=float(row["error"]),
                error_pct=100.0 * float(row["error"]), tolerance_pct=100.0 * study.compare.tolerance,
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
            out[f"cheapest within {100.0 * level:.3g} %"] = int(row["trial"])
    row = most_accurate(ranked)
    if row is not None:
        out["most accurate"] = int(row["trial"])
    return out


# --------------------------------------------------------------------------- files (with units)

RANKING_GROUPS = ("meets tolerance: cheapest first (cost, DOFs, error)",
                  "misses tolerance: most accurate first (error, cost)",
                  "failed: by trial number")


def cost_column(study) -> tuple[str, str]:
    """(file column name, unit) of the cost objective of `study`."""
    if study.search.cost == "dofs":
        return "cost_n_dofs", "-"
    if study.search.cost == "model":
        return "cost_model_s_per_sim_s", "s/s"
    return "cost_wall_s_per_sim_s", "s/s"


def file_table(df: pd.DataFrame, study, groups: bool = True) -> tuple[pd.DataFrame, dict]:
    """The table as written to trials.csv/pareto.csv and its units: errors in
    % (``error_pct``, ``error_pct_<channel>``), speed and cost named with their
    units, with `groups` a `rank_group` column after `rank` saying how the rows
    are ranked, `duplicate_of` dropped."""
    if df.empty:
        return df, {}
    out = df.drop(columns=["duplicate_of"], errors="ignore").copy()
    cost_name, cost_unit = cost_column(study)
    channels = list(study.compare.channels)
    rename = {"error": "error_pct", "speed": "speed_x_real_time", "cost": cost_name}
    rename.update({f"error_{ch}": f"error_pct_{ch}" for ch in channels})
    for col in ["error"] + [f"error_{ch}" for ch in channels]:
        if col in out:
            out[col] = 100.0 * pd.to_numeric(out[col], errors="coerce")
    out = out.rename(columns=rename)
    if groups and "rank" in out:
        group = np.where(out["status"] != "COMPLETE", 2, np.where(out["meets_tolerance"], 0, 1))
        out.insert(1, "rank_group", [RANKING_GROUPS[g] for g in group])
    units = {c: "-" for c in out.columns}
    units.update({c: "%" for c in out.columns if c.startswith("error_pct")})
    units.update(wall_time_s="s", simulated_time_s="s", speed_x_real_time="sim s/wall s")
    units[cost_name] = cost_unit
    return out, units
