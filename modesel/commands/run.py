"""`modesel run STUDY.toml --out DIR`: search the cheapest mode set meeting the
tolerance and write trials.csv, pareto.csv, best_modeset.json and report.html
into DIR.

Options override the study file: --n-trials, --timeout [s], --n-jobs
(parallel processes), --storage (SQLAlchemy URL shared with `modesel worker`;
default: an Optuna journal file in DIR), --seed. Running again with the same
--out resumes the study: finished trials are kept, interrupted ones are
queued again, and --n-trials more are run. Ctrl-C (SIGINT) or SIGTERM stops
the study gracefully: the finished trials stay in the storage and their
results (trials.csv, pareto.csv, best_modeset.json, report.html) are written
before the command exits (code 130 or 143) with one line.

A progress bar on stderr (trials done of --n-trials, best error so far in %,
failed trials, ETA) is drawn when stderr is a terminal; --quiet turns it and
the first-run compile notice off.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from modesel.commands._common import add_search_options, collector_paused, say
from modesel.errors import Interrupted, ModeselError

EPILOG = ("The study file (every table and key, type, default and unit, the metrics with "
          "their formulas and the families with their parameter ranges) is described in "
          "docs/study-file.md.")


def register(subparsers):
    p = subparsers.add_parser(
        "run", help="search the cheapest mode set meeting a tolerance",
        description=__doc__, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("study", help="study file (TOML; reference: docs/study-file.md)")
    p.add_argument("--quiet", action="store_true", help="no progress bar, no compile notice")
    p.add_argument("--out", required=True, help="output folder (created; reused to resume)")
    add_search_options(p, n_trials="trials to run now (default [budget].n_trials)",
                       n_jobs="parallel worker processes", seed="sampler seed")
    p.add_argument("--storage", help="SQLAlchemy URL of a shared study storage")
    p.set_defaults(func=run)


def prepare_out_dir(path) -> Path:
    out = Path(path)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ModeselError(f"cannot create output folder: {exc.strerror}", file=str(out)) from None
    if not out.is_dir() or not os.access(out, os.W_OK | os.X_OK):
        raise ModeselError("output folder is not writable", file=str(out))
    return out


def _interrupted(exc: KeyboardInterrupt, out: Path, engine) -> Interrupted:
    """Write the results of the finished trials (ignoring a second Ctrl-C)
    and return the one-line `Interrupted` error to raise."""
    from modesel.study.results import refresh
    signal_name = "SIGTERM" if type(exc).__name__ == "Terminated" else "SIGINT"
    try:
        summary = refresh(out, engine=engine)
        ranked = summary["ranked"]
        done = int((ranked["status"] == "COMPLETE").sum()) if not ranked.empty else 0
        kept = f"{done} evaluated mode sets kept, results written to {out}"
    except (ModeselError, KeyboardInterrupt) as problem:
        kept = f"finished trials kept in the storage (results not written: {problem or 'interrupted'})"
    return Interrupted(f"interrupted ({signal_name}): {kept}; run the same command again to resume",
                       signal_name=signal_name)


def trial_counts(outcome, ranked) -> str:
    """One sentence counting the trials once: distinct sets of this run and of the study."""
    n_sets = len(ranked)
    n_failed = int((ranked["status"] != "COMPLETE").sum()) if n_sets else 0
    text = f"this run evaluated {outcome.n_new} new mode sets"
    if outcome.n_repeats:
        text += f" (and served {outcome.n_repeats} repeated proposals from the record)"
    if outcome.requeued:
        text += f", {outcome.requeued} interrupted trials re-queued"
    total = len(outcome.optuna_study.get_trials(deepcopy=False))
    return text + f"; trials: {total} in the study, {n_sets} distinct sets ({n_failed} failed)"


def run(args, engine=None) -> int:
    with collector_paused() as started:
        return _run(args, engine, started)


def _run(args, engine, started) -> int:
    from modesel.study.results import refresh, write_run_info
    from modesel.study.search import default_storage, mask_url, run_search
    from modesel.study.spec import load_study

    study = load_study(args.study)
    started()
    out = prepare_out_dir(args.out)
    storage = args.storage or study.run.storage or default_storage(out)
    info = {"study_file": str(study.path), "study_toml": study.text, "study_name": study.name,
            "storage": storage}
    write_run_info(out, info)
    try:
        outcome = run_search(study, out_dir=out, storage=storage, n_trials=args.n_trials,
                             timeout=args.timeout, n_jobs=args.n_jobs, seed=args.seed, engine=engine,
                             log=say, progress=False if args.quiet else None)
    except KeyboardInterrupt as exc:   # keep what was done: results of the finished trials
        raise _interrupted(exc, out, engine) from None
    write_run_info(out, dict(info, reference_info={k: r.info for k, r in outcome.references.items()}))
    summary = refresh(out, engine=engine, log=say)
    print(f"{study.name}: {trial_counts(outcome, summary['ranked'])}"
          + (f"; {outcome.requeued} interrupted trials re-queued" if outcome.requeued else "")
          + f"; storage {mask_url(storage)}")
    for name, ref in outcome.references.items():
        if ref.info.get("kind") == "internal":
            counts = " ".join(f"{f}={ref.info['family']}:{n}" for f, n in ref.info["counts"].items())
            print(f"internal reference of scene '{name}': {counts} (converged to "
                  f"{ref.info['tolerance']:g})")
    for sentence in summary["sentences"]:
        print(sentence)
    best = summary["best"]
    print(f"best: {best.get('label', '-')} ({best['selection']})")
    print(f"wrote {out / 'trials.csv'}, pareto.csv, best_modeset.json, report.html")
    return 0
