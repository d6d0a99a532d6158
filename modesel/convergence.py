"""Front of the convergence criterion (design-card name).

The metrics and the criterion live in `modesel/study/metrics.py`; this module
re-exports them so that `from modesel.convergence import Criterion` keeps working.
"""
from modesel.study.metrics import (METRICS, Assessment, Criterion, Metric,  # noqa: F401
                                   StopWhenMet, metric)

__all__ = ["METRICS", "Assessment", "Criterion", "Metric", "StopWhenMet", "metric"]
