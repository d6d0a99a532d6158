"""Helpers shared by the command modules."""
from __future__ import annotations

import argparse
import contextlib
import gc
import sys

from modesel.files import atomic_write_text  # noqa: F401  (shared by the commands)


@contextlib.contextmanager
def collector_paused():
    """Python's cyclic garbage collector off while a command imports what it
    needs and reads its inputs; the `started()` this yields then freezes the
    objects made so far (modules, functions, numba's dispatchers, the parsed
    decks: kept to the end) out of the collector's sight (`gc.freeze`) and
    turns it back on. On leaving, they are unfrozen and the collector is as
    it was. The imports of `modesel simulate` allocate about 90,000 such
    objects, and the collector, triggered every 700 allocations, walked them
    119 times: about 65 ms of a 1.1-s command. Imports and parsing make
    little garbage."""
    was_enabled = gc.isenabled()
    gc.disable()

    def started():
        gc.freeze()
        if was_enabled:
            gc.enable()
    try:
        yield started
    finally:
        gc.unfreeze()
        if was_enabled:
            gc.enable()


def load_modeset(path):
    """ModeSet from a JSON file (families, counts and parameters checked,
    errors naming the file and field), or None."""
    if path is None:
        return None
    from modesel.candidates.base import check_field_modes
    from modesel.modeset import ModeSet
    modeset = ModeSet.from_json(path)
    for field, fm in modeset.fields.items():
        check_field_modes(field, fm.family, fm.count, fm.params, file=str(path), where=f"fields.{field}")
    return modeset


def say(msg: str) -> None:
    """One line on stderr, prefixed 'modesel: '."""
    print(f"modesel: {msg}", file=sys.stderr)


# --------------------------------------------------------------------------- argument types

def number_type(kind: type, lowest, *, strict: bool = False):
    """An argparse `type`: text -> `kind` (int or float) that is >= `lowest`
    (> `lowest` with `strict`), else a one-line argparse error."""
    noun = "an integer" if kind is int else "a number"
    bound = ("positive" if lowest == 0 else f"> {lowest}") if strict else f">= {lowest}"

    def convert(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not {noun}: {text!r}") from None
        if not (value > lowest if strict else value >= lowest):
            raise argparse.ArgumentTypeError(f"must be {bound}, got {text}")
        return value

    return convert


positive_float = number_type(float, 0.0, strict=True)
positive_int = number_type(int, 1)
non_negative_int = number_type(int, 0)


def add_search_options(p, *, n_trials: str, n_jobs: str, seed: str) -> None:
    """--n-trials, --timeout, --n-jobs and --seed of the commands that run
    trials (`modesel run`, `modesel worker`); the help texts say what each
    means for the command."""
    p.add_argument("--n-trials", type=positive_int, help=n_trials)
    p.add_argument("--timeout", type=positive_float, help="stop starting trials after S seconds")
    p.add_argument("--n-jobs", type=positive_int, help=n_jobs)
    p.add_argument("--seed", type=non_negative_int, help=seed)
