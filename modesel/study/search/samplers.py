"""Optuna samplers of the search, seeded per worker and per number of trials
already in the study, so that a resumed study does not replay the first
run's proposals."""
from __future__ import annotations

import numpy as np

from modesel.errors import unknown_name


def _tpe(seed, n_trials):
    import optuna
    return optuna.samplers.TPESampler(seed=seed, n_startup_trials=min(10, max(2, n_trials // 4)),
                                      constant_liar=True)


def _nsga2(seed, n_trials):
    import optuna
    return optuna.samplers.NSGAIISampler(seed=seed, population_size=int(min(50, max(8, n_trials // 5))))


def _random(seed, n_trials):
    import optuna
    return optuna.samplers.RandomSampler(seed=seed)


def _fieldwise(seed, n_trials, study=None, space=None):
    from modesel.study.search.structured import FieldwiseSampler
    return FieldwiseSampler(study, seed, space)


SAMPLERS = {"tpe": _tpe, "nsga2": _nsga2, "random": _random, "fieldwise": _fieldwise}


def make_sampler(name: str, seed: int, n_trials: int = 100, study=None, space=None):
    """The Optuna sampler `name` (`SAMPLERS`); `study` (the parsed study file) is needed by
    the structured one, ``fieldwise``, and `space` (the objective's `SearchSpace`) is used by
    it when given."""
    if name not in SAMPLERS:
        raise unknown_name("sampler", name, SAMPLERS, field="search.sampler")
    if name == "fieldwise":
        return _fieldwise(int(seed), int(n_trials), study, space)
    return SAMPLERS[name](int(seed), int(n_trials))


def worker_seed(seed: int, n_existing: int, worker: int, salt: int = 0) -> int:
    """Distinct, reproducible seed per (study seed, trials already done, worker
    index, salt); `modesel worker` salts with host and process id so workers
    started together on several machines do not propose the same sets."""
    return int(np.random.SeedSequence([int(seed), int(n_existing), int(worker), int(salt)])
               .generate_state(1)[0])
