"""`modesel report DIR`: rebuild trials.csv, pareto.csv, best_modeset.json and
report.html in an output folder of `modesel run` from its study storage
(e.g. after more trials were run by `modesel worker`). --storage overrides
the storage recorded in DIR/run.json.
"""
from __future__ import annotations

import argparse

from modesel.commands._common import say


def register(subparsers):
    p = subparsers.add_parser(
        "report", help="re-render the results and report.html of a study folder",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("dir", help="output folder of `modesel run`")
    p.add_argument("--storage", help="storage URL (default: the one recorded in DIR/run.json)")
    p.set_defaults(func=run)


def run(args, engine=None) -> int:
    from pathlib import Path

    from modesel.study.results import refresh
    summary = refresh(args.dir, storage=args.storage, engine=engine, log=say)
    for sentence in summary["sentences"]:
        print(sentence)
    print(f"wrote {Path(args.dir) / 'report.html'}")
    return 0
