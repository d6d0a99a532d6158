"""The search: an Optuna study over mode sets, holding no physics.

Pieces, each replaceable, one module each:

- `engine`: the physics, injected (`Engine`: load_scene, simulate,
  channel_unit); the default is `modesel.simulation.api`.
- `space`: `SearchSpace`, Optuna trial parameters <-> a `ModeSet`.
- `objective`: `Objective`, one mode set evaluated on the load case ->
  (error, cost), its record kept as trial user attributes.
- `claims`: which trial simulates a set that several trials propose (each
  set is simulated once; the others take its record).
- `samplers`: tpe, nsga2, random, seeded per worker and per trials done.
- `storage`: the journal file or SQLAlchemy URL the trials are kept in;
  interrupted trials queued again; the scene's default set as trial 0.
- `load_case`: the scenes and their references, checked before any trial.
- `runner`: `run_search`, budget, progress and worker processes.
"""
from modesel.study.search.claims import INTERRUPTED, distinct_sets
from modesel.study.search.engine import Engine, default_engine
from modesel.study.search.load_case import check_reference_fits, load_scenes, prepare_references
from modesel.study.search.objective import Objective, load_case_errors
from modesel.study.search.runner import Budget, SearchOutcome, optimize_worker, run_search
from modesel.study.search.samplers import SAMPLERS, make_sampler, worker_seed
from modesel.study.search.space import SearchSpace
from modesel.study.search.storage import (DIRECTIONS, JOURNAL_NAME, default_storage, mask_url, open_storage,
                                          open_study, queue_baseline, requeue_interrupted)

__all__ = ["Budget", "DIRECTIONS", "Engine", "INTERRUPTED", "JOURNAL_NAME", "Objective", "SAMPLERS",
           "SearchOutcome", "SearchSpace", "check_reference_fits", "default_engine", "default_storage",
           "distinct_sets", "load_case_errors", "load_scenes", "make_sampler", "mask_url", "open_storage",
           "open_study", "optimize_worker", "prepare_references", "queue_baseline", "requeue_interrupted",
           "run_search", "worker_seed"]
