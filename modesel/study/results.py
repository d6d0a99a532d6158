"""Results of a study, written to the output folder (every file atomically:
written to a temporary file in the same folder, then `os.replace`d).

Every CSV has a second header row of units in parentheses, as OpenFAST text
outputs do (``pandas.read_csv(path, header=[0, 1])`` reads it with its units;
`modesel.files.read_unit_csv` gives a flat table with ``attrs["units"]``).

- ``trials.csv``: one row per evaluated mode set, ranked. Sets meeting the
  tolerance come first, cheapest first (cost, then DOF count, then error);
  then the others, most accurate first; failed trials last; the column
  ``rank_group`` says which of the three groups a row is in and its order.
  Columns: rank, rank_group, trial, modeset (e.g.
  ``tower_fa=clamped:2 blade_flap=fem:3``), ``<field>_family``,
  ``<field>_count`` (and ``<field>_<param>``) per searched field, n_dofs,
  error_pct (worst weighted channel, %), worst_channel,
  ``error_pct_<channel>`` per compared channel (%), wall_time_s (s),
  simulated_time_s (s), speed_x_real_time (simulated s per wall s), the cost
  (``cost_wall_s_per_sim_s``, wall s per simulated s, ``cost_model_s_per_sim_s``, the
  deterministic cost model's s per simulated s, or ``cost_n_dofs`` with
  ``[search] cost = "dofs"``), meets_tolerance, status (COMPLETE/FAIL) and
  reason. A trial that proposed a set already evaluated is served from that
  trial's record (user attribute ``duplicate_of``) and is not listed again.
- ``pareto.csv``: the completed sets no other set beats on both error and
  cost, ranked cheapest first (column ``rank``), same columns.
- ``best_modeset.json``: the cheapest set meeting the tolerance, or the most
  accurate one if none does; ``selection`` says which.
- ``timeseries/``: the compared channels of featured trials (and the
  reference) so `modesel report` can redraw the overlays
  (`modesel.study.timeseries`).
- ``run.json``: the study text, storage and study name `modesel report` needs.
- ``report.html``: the page `modesel.study.report` renders.

`refresh(out_dir)` rebuilds all of them from the study's storage. The
tables come from `modesel.study.ranking` (errors recomputed with the study's
current criterion, so a changed tolerance re-ranks without re-simulating).
A featured trial without stored series (run by a remote worker, or pruned)
is simulated again when the engine is available.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from modesel.errors import ModeselError
from modesel.files import atomic_write_text, unit_csv_text
from modesel.modeset import ModeSet
from modesel.study import report
from modesel.study.ranking import best_modeset, featured_trials, file_table, pareto, rank, trial_table
from modesel.study.search import Objective, load_scenes, mask_url, open_study, prepare_references
from modesel.study.search import engine as engines
from modesel.study.spec import parse_study
from modesel.study.timeseries import prune_series, read_series, write_series

RUN_INFO = "run.json"
KEEP_SERIES_TOP = 10


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


def write_csv(path, df: pd.DataFrame, units: dict) -> None:
    """CSV with a second header row of units (`modesel.files.unit_csv_text`)."""
    atomic_write_text(path, unit_csv_text(df, units))


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


# --------------------------------------------------------------------------- tables

def write_results(out_dir, optuna_study, study) -> dict:
    """Write trials.csv, pareto.csv and best_modeset.json; return the tables."""
    out_dir = Path(out_dir)
    trials = optuna_study.get_trials(deepcopy=False)
    table = trial_table(trials, study)
    ranked = rank(table)
    front = pareto(table)
    write_csv(out_dir / "trials.csv", *file_table(ranked, study))
    front_ranked = front.copy()
    if not front_ranked.empty:
        front_ranked.insert(0, "rank", np.arange(1, len(front_ranked) + 1))
    write_csv(out_dir / "pareto.csv", *file_table(front_ranked, study, groups=False))
    best = best_modeset(ranked, study, {t.number: t for t in trials})
    write_json(out_dir / "best_modeset.json", best)
    return {"table": table, "ranked": ranked, "pareto": front, "best": best,
            "featured": featured_trials(ranked, study)}


# --------------------------------------------------------------------------- refresh

def resimulate_series(out_dir, study, missing: dict, engine, notes: list) -> None:
    """Simulate again the sets {trial number: ModeSet} whose series are not
    stored and store them; a problem becomes a note."""
    try:
        scenes = load_scenes(study, engine)
        refs = prepare_references(study, scenes, engine, Path(out_dir) / "reference")
        objective = Objective(study, scenes, refs, engine)
        for number, modeset in missing.items():
            write_series(out_dir, number, objective.evaluate(modeset)["_series"])
    except (ModeselError, ImportError) as exc:
        notes.append(f"time series of trials {sorted(missing)} not drawn: {exc}")


def refresh(out_dir, *, storage: str | None = None, engine=None, log=None) -> dict:
    """Rewrite trials.csv, pareto.csv, best_modeset.json, the featured time
    series and report.html of `out_dir` from its storage (or `storage`).
    Returns the summary with the tolerance sentences under 'sentences'."""
    out_dir = Path(out_dir)
    info = read_run_info(out_dir)
    study = parse_study(info["study_toml"], info["study_file"])
    storage = storage or info["storage"]
    opt = open_study(study, storage, create=False)
    summary = write_results(out_dir, opt, study)
    ranked, featured = summary["ranked"], summary["featured"]
    trials = {t.number: t for t in opt.get_trials(deepcopy=False)}
    notes = []

    missing = {n: ModeSet.from_dict(trials[n].user_attrs["modeset_json"])
               for n in set(featured.values()) if read_series(out_dir, n) is None}
    try:
        engine = engines.resolve(engine)
    except ImportError as exc:
        engine = None
        notes.append(f"simulator not available: {exc}")
    if missing and engine is not None:
        if log:
            log(f"simulating again trials {sorted(missing)} for the report time series")
        resimulate_series(out_dir, study, missing, engine, notes)
    keep = set(featured.values()) | set(ranked["trial"].head(KEEP_SERIES_TOP).astype(int)) \
        if not ranked.empty else set()
    prune_series(out_dir, keep)
    summary["reference_info"] = info.get("reference_info", {})

    chosen, scene = None, None          # the selected set (best_modeset.json), drawn with its turbine
    if "trial" in summary["best"]:
        chosen = ModeSet.from_dict(trials[summary["best"]["trial"]].user_attrs["modeset_json"])
        if engine is not None:
            try:
                scene = engine.load_scene(study.scenes[0].path)
            except (ModeselError, OSError) as exc:
                notes.append(f"shapes drawn without the scene's turbine: {exc}")
    sentences = report.tolerance_sentences(ranked, study)
    page = report.render(out_dir, study, summary, sentences, chosen, scene, notes,
                         dict(info, storage_display=mask_url(storage)), engine=engine)
    atomic_write_text(out_dir / "report.html", page)
    summary["sentences"] = sentences
    summary["notes"] = notes
    return summary
