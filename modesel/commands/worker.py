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

from modesel.commands._common import positive_float
from modesel.commands.run import _say, non_negative_int, positive_int


def register(subparsers):
    p = subparsers.add_parser(
        "worker", help="run trials of a study in a shared storage",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("study", help="study file (TOML)")
    p.add_argument("--storage", required=True, help="SQLAlchemy URL, e.g. postgresql://user@host/db")
    p.add_argument("--n-trials", type=positive_int, help="trials to run (default [budget].n_trials)")
    p.add_argument("--timeout", type=positive_float, help="stop starting trials after S seconds")
    p.add_argument("--n-jobs", type=positive_int, help="parallel processes on this machine")
    p.add_argument("--seed", type=non_negative_int, help="sampler seed (default: the study's)")
    p.add_argument("--cache", help="folder for the internal reference cache "
                                   "(default: .modesel/<study name> next to the study file)")
    p.set_defaults(func=run)


def run(args, engine=None) -> int:
    from modesel.study.search import mask_url, run_search
    from modesel.study.spec import load_study

    study = load_study(args.study)
    cache = Path(args.cache) if args.cache else study.path.parent / ".modesel" / study.name
    # salt the seed with host and process, so workers started together differ
    salt = zlib.crc32(f"{socket.gethostname()}:{os.getpid()}".encode())
    outcome = run_search(study, storage=args.storage, n_trials=args.n_trials, timeout=args.timeout,
                         n_jobs=args.n_jobs, seed=args.seed, engine=engine, cache_dir=cache, log=_say,
                         salt=salt)
    trials = outcome.optuna_study.get_trials(deepcopy=False)
    print(f"{study.name}: {outcome.n_new} trials run by this worker, {len(trials)} in the study "
          f"at {mask_url(outcome.storage_url)}")
    return 0
