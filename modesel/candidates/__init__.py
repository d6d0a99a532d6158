"""Candidate library: families of assumed modes per flexible field.

Every family module (`base.FAMILY_MODULES`) registers itself with the
registry in `base` on the first look-up; use `mode_shapes` (re-exported
here from `base`) to evaluate one.
"""
from modesel.candidates.base import (  # noqa: F401
    FAMILY_MODULES, FieldContext, Family, Parameter, ShapeSet, families, get_family, mode_shapes,
)
