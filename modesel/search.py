"""Front of the search (design-card name): the Optuna study over mode sets.

The code lives in `modesel/study/search/`; this module re-exports its public
front so that `from modesel.search import run_search` keeps working.
"""
from modesel.study.search import (Engine, Objective, SearchOutcome, SearchSpace,  # noqa: F401
                                  default_engine, run_search)

__all__ = ["Engine", "Objective", "SearchOutcome", "SearchSpace", "default_engine", "run_search"]
