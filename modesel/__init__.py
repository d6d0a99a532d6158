"""modesel: choose assumed-mode sets for reduced-order wind-turbine models.

SI units everywhere (m, kg, s, N, rad) unless a name says otherwise
(`_deg`, `_rpm`, `_hz`). Output channels use OpenFAST names.
"""

__version__ = "0.1.0"

# numba does not see a change of a function compiled into another module's
# cached code: drop the engine's cache when its sources changed (engine_cache)
from modesel import engine_cache  # noqa: E402

engine_cache.discard_stale()
