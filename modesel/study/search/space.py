"""The search space: Optuna trial parameters <-> a `ModeSet` of the searched fields.

Per searched field a categorical ``<field>.family`` from the allowed list, an
integer ``<field>.<family>.count`` in the family's range (capped by the
family's own maximum), and floats ``<field>.<family>.<param>`` for its
continuous parameters; count and parameters are conditioned on the family.

Counts are capped per field and family by the study file's validator
(`Family.max_count_for`: e.g. `elastodyn` 2 tower, 2 flap, 1 edge mode), so
no trial asks a family for more shapes than it has. Choices that describe
the same shapes (same family after defaults, same parameters, or a declared
equivalence such as `relaxed_tipmass` with zero ratios = `clamped`) have one
`canonical` form; the objective evaluates that form, so identical shapes are
simulated once and later proposals take the stored record.
"""
from __future__ import annotations

import math

from modesel.candidates.base import canonical_modes, get_family
from modesel.modeset import FieldModes, ModeSet


class SearchSpace:
    """Maps Optuna trial parameters to a `ModeSet` of the searched fields."""

    def __init__(self, spec):
        self.spec = spec
        # the family objects, held (and pickled to worker processes) with the space
        self.families = {f.family: get_family(f.family) for space in spec.fields for f in space.families}

    def _family(self, name: str):
        return self.families[name] if name in self.families else get_family(name)

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

    def canonical(self, modeset: ModeSet) -> ModeSet:
        """The simplest description of the same shapes, field by field
        (`modesel.candidates.base.canonical_modes`); fields outside the
        space are canonicalised too."""
        out = {}
        for name, fm in modeset.fields.items():
            family, count, params = canonical_modes(name, fm.family, fm.count, fm.params,
                                                    lookup=self._family)
            out[name] = FieldModes(family, count, params)
        return ModeSet(out)

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

    def family_sets(self) -> list:
        """One set per family the space allows (in the order the fields name
        them): the first field that allows the family takes it at its largest
        count, every other field its first family at its smallest count;
        continuous parameters at mid-range; sets with the same canonical form
        once. Between them they use every family, each at its largest count
        (`Objective.warm_up`)."""
        def first(space):
            fam = space.families[0]
            return FieldModes(fam.family, fam.min_count, {p: 0.5 * (lo + hi) for p, (lo, hi) in fam.params.items()})

        sets, seen = [], set()
        for space in self.spec.fields:
            for fam in space.families:
                if fam.family in seen:
                    continue
                seen.add(fam.family)
                fields = {other.field: first(other) for other in self.spec.fields}
                fields[space.field] = FieldModes(fam.family, fam.max_count,
                                                 {p: 0.5 * (lo + hi) for p, (lo, hi) in fam.params.items()})
                modeset = self.canonical(ModeSet(fields))
                if all(modeset.label() != other.label() for other in sets):
                    sets.append(modeset)
        return sets

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
        """Number of distinct discrete sets, counted on their canonical forms
        (inf with continuous parameters)."""
        total = 1.0
        for space in self.spec.fields:
            if any(fam.params for fam in space.families):
                return math.inf
            forms = set()
            for fam in space.families:
                for count in range(fam.min_count, fam.max_count + 1):
                    family, n, params = canonical_modes(space.field, fam.family, count,
                                                        lookup=self._family)
                    forms.add((family, n, tuple(sorted(params.items()))))
            total *= len(forms)
        return total
