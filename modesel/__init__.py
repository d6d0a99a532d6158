"""modesel: choose assumed-mode sets for reduced-order wind-turbine models.

SI units everywhere (m, kg, s, N, rad) unless a name says otherwise
(`_deg`, `_rpm`, `_hz`). Output channels use OpenFAST names.
"""

__version__ = "0.1.0"
