"""Candidate library: families of assumed modes per flexible field.

Importing this package registers every family; use
`modesel.candidates.base.mode_shapes` (re-exported here) to evaluate one.
"""
from modesel.candidates.base import (  # noqa: F401
    FieldContext, Family, Parameter, ShapeSet, families, get_family, mode_shapes,
)

# Family modules register themselves on import (add yours here).
FAMILY_MODULES = ("polynomial", "cosine", "clamped", "relaxed_root", "relaxed_tipmass",
                  "elastodyn", "linear", "sine", "fem")

for _name in FAMILY_MODULES:
    __import__(f"modesel.candidates.{_name}")
