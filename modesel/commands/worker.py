"""`modesel worker STUDY.toml --storage URL [--n-trials N]`: run trials of a
study kept in a shared storage (e.g. PostgreSQL), so several machines can
work on one study. Start it with `modesel run ... --storage URL` or with a
worker (the first one creates it); `modesel run` or `modesel report` then
writes the results. The study file must define the same scenes, reference,
channels and search space as the stored study. Trial time series are not
kept by workers; `modesel report` simulates the featured sets again.
"""
from __future__ import annotations

import argparse
import os
import socket
import zlib
from pathlib import Path

from modesel.commands._common import add_search_options, collector_paused, say


def register(subparsers):
    p = subparsers.add_parser(
        "worker", help="run trials of a study in a shared storage",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("study", help="study file (TOML)")
    p.add_argument("--storage", required=True, help="SQLAlchemy URL, e.g. postgresql://user@host/db")
    add_search_options(p, n_trials="trials to run (default [budget].n_trials)",
                       n_jobs="parallel processes on this machine", seed="sampler seed (default: the study's)")
    p.add_argument("--quiet", action="store_true", help="no progress bar, no compile notice")
    p.add_argument("--cache", help="folder for the internal reference cache "
                                   "(default: .modesel/<study name> next to the study file)")
    p.set_defaults(func=run)


def run(args, engine=None) -> int:
    with collector_paused() as started:
        return _run(args, engine, started)


def _run(args, engine, started) -> int:
    from modesel.study.search import mask_url, run_search
    from modesel.study.spec import load_study

    study = load_study(args.study)
    started()
    cache = Path(args.cache) if args.cache else study.path.parent / ".modesel" / study.name
    # salt the seed with host and process, so workers started together differ
    salt = zlib.crc32(f"{socket.gethostname()}:{os.getpid()}".encode())
    outcome = run_search(study, storage=args.storage, n_trials=args.n_trials, timeout=args.timeout,
                         n_jobs=args.n_jobs, seed=args.seed, engine=engine, cache_dir=cache, log=say,
                         salt=salt, progress=False if args.quiet else None)
    trials = outcome.optuna_study.get_trials(deepcopy=False)
    print(f"{study.name}: this worker evaluated {outcome.n_new} new mode sets"
          + (f" (and served {outcome.n_repeats} repeated proposals from the record)" if outcome.n_repeats else "")
          + f"; the study holds {len(trials)} trials at {mask_url(outcome.storage_url)}")
    return 0
