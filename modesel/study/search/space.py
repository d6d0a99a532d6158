"""The search space: Optuna trial parameters <-> a `ModeSet` of the searched fields.

Per searched field a categorical ``<field>.family`` from the allowed list, an
integer ``<field>.<family>.count`` in the family's range (capped by the
family's own maximum), and floats ``<field>.<family>.<param>`` for its
continuous parameters; count and parameters are conditioned on the family.
"""
from __future__ import annotations

import math

from modesel.modeset import FieldModes, ModeSet


class SearchSpace:
    """Maps Optuna trial parameters to a `ModeSet` of the searched fields."""

    def __init__(self, spec):
        self.spec = spec

    def suggest(self, trial) -> ModeSet:
        fields = {}
        for space in self.spec.fields:
            names = [f.family for f in space.families]
            family = trial.suggest_categorical(f"{space.field}.family", names)
            fam = space.family(family)
            count = trial.suggest_int(f"{space.field}.{family}.count", fam.min_count, fam.max_count)
            params = {p: trial.suggest_float(f"{space.field}.{family}.{p}", low, high)
                      for p, (low, high) in fam.params.items()}
            fields[space.field] = FieldModes(family, count, params)
        return ModeSet(fields)

    def params(self, modeset: ModeSet) -> dict:
        """Trial parameters that reproduce `modeset` (for `study.enqueue_trial`)."""
        out = {}
        for space in self.spec.fields:
            fm = modeset[space.field]
            out[f"{space.field}.family"] = fm.family
            out[f"{space.field}.{fm.family}.count"] = fm.count
            for p, value in fm.params.items():
                out[f"{space.field}.{fm.family}.{p}"] = value
        return out

    def random_set(self, rng) -> ModeSet:
        """A uniformly drawn family, count and parameters per field."""
        fields = {}
        for space in self.spec.fields:
            fam = space.families[int(rng.integers(len(space.families)))]
            count = int(rng.integers(fam.min_count, fam.max_count + 1))
            params = {p: float(rng.uniform(lo, hi)) for p, (lo, hi) in fam.params.items()}
            fields[space.field] = FieldModes(fam.family, count, params)
        return ModeSet(fields)

    def contains(self, modeset: ModeSet) -> bool:
        """Whether `modeset` has every searched field with an allowed family,
        count and parameters."""
        for space in self.spec.fields:
            fm = modeset.get(space.field)
            if fm is None or fm.family not in [f.family for f in space.families]:
                return False
            fam = space.family(fm.family)
            if not fam.min_count <= fm.count <= fam.max_count:
                return False
            if set(fm.params) != set(fam.params) or any(
                    not lo <= fm.params[p] <= hi for p, (lo, hi) in fam.params.items()):
                return False
        return True

    def size(self) -> float:
        """Number of distinct discrete sets (inf with continuous parameters)."""
        total = 1.0
        for space in self.spec.fields:
            n = 0.0
            for fam in space.families:
                n += math.inf if fam.params else fam.max_count - fam.min_count + 1
            total *= n
        return total
