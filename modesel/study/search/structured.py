"""The structured search (``[search] sampler = "fieldwise"``): the paper's
flowchart, automated.

It uses two properties of the problem: each output channel is governed
mainly by one field (the tower-top fore-aft deflection by tower_fa, the
blade-tip out-of-plane deflection by blade_flap, ...), and a set's error is
its worst channel. So one simulation in which only field f differs from a
base set tells how good f's choice is, and the error of a combination is
predicted from those one-field runs. The cost objective also has structure:
a field with more modes costs more (more DOFs, a stiffer highest mode), so
counts are tried in increasing order.

Level by level, loosest first:

1. **Sweep.** The base set is each field's first choice at its fewest
   modes. For count k = 1, 2, ...: for every field that does not meet the
   level yet, each choice (family, k modes) of that field with the other
   fields at the base. The channels of field f are those whose error varies
   most when only f varies (learned from these runs, nothing declared).
   Field f meets the level once one of its choices does (its error: the
   worst of its channels); more modes would only cost more.
2. **Combine.** The combinations whose predicted error (per field, the run
   in which only that field had that choice) meets the level with a 15 %
   margin, cheapest predicted first (predicted cost: the dearest of the
   one-field runs, then the number of modes). The level is settled once a
   simulated set meets it at a cost no higher than every unsimulated
   candidate's prediction. Then the next level.

After the last level the margin widens (50 %, 150 %), and at the end any set
not yet simulated is proposed.

The strategy sees only the records of simulated sets (the set, its error per
channel, its cost), as `modesel run` stores them; it is deterministic for a
given seed (which orders the fields and the families of one count) and
history. Continuous family parameters are held at the middle of their range.
"""
from __future__ import annotations

import itertools
import math

import numpy as np
import optuna

from modesel.modeset import FieldModes, ModeSet

MARGINS = (0.15, 0.5, 1.5)      # relative margin on the predicted error, widened in turn
COMBO_LIMIT = 8                 # cheapest feasible choices per field combined


class Record:
    """One simulated set: canonical `modeset`, per-channel `errors`, `error`, `cost`
    (error = inf for a failed set)."""

    __slots__ = ("modeset", "errors", "error", "cost")

    def __init__(self, modeset: ModeSet, errors: dict | None, error: float, cost: float):
        self.modeset, self.errors, self.error, self.cost = modeset, dict(errors or {}), float(error), float(cost)


class Fieldwise:
    """Proposes the next set to simulate from the records so far (see module docstring)."""

    def __init__(self, space, levels, seed: int = 0):
        self.space = space
        self.levels = tuple(sorted({float(v) for v in levels}, reverse=True))
        rng = np.random.default_rng(int(seed))
        fields = [s.field for s in space.spec.fields]
        self.fields = [fields[i] for i in rng.permutation(len(fields))]
        self.choices = {}
        for s in space.spec.fields:
            seen, out = set(), []
            for fam in s.families:
                for count in range(fam.min_count, fam.max_count + 1):
                    params = {p: 0.5 * (lo + hi) for p, (lo, hi) in fam.params.items()}
                    fm = self._canonical(s.field, FieldModes(fam.family, count, params))
                    if fm.label() not in seen:
                        seen.add(fm.label())
                        out.append(fm)
            # by count; the families of one count in a seeded order
            order = {fm.label(): i for i, fm in enumerate(out)}
            shuffle = {fm.label(): r for fm, r in zip(out, rng.random(len(out)))}
            self.choices[s.field] = sorted(out, key=lambda m: (m.count, shuffle[m.label()], order[m.label()]))
        self.base = {f: self.choices[f][0] for f in self.fields}

    def _canonical(self, field, fm):
        return self.space.canonical(ModeSet({field: fm}))[field]

    def _set(self, **changed) -> ModeSet:
        fields = dict(self.base)
        fields.update(changed)
        return ModeSet({f: fields[f] for f in (s.field for s in self.space.spec.fields)})

    # --- what the records tell -------------------------------------------------------------------
    def _one_field_runs(self, records: dict) -> dict:
        """{field: {choice label: Record}} of the simulated sets differing from the base in that
        field only (the base itself counts for every field)."""
        out = {f: {} for f in self.fields}
        for rec in records.values():
            differ = [f for f in self.fields if rec.modeset[f].label() != self.base[f].label()]
            if len(differ) <= 1:
                for f in (differ or self.fields):
                    out[f][rec.modeset[f].label()] = rec
        return out

    @staticmethod
    def _attribution(runs: dict) -> dict:
        """{channel: field}: the field whose one-field runs move that channel's error most
        (spread of log error)."""
        spread = {}
        for f, recs in runs.items():
            good = [r for r in recs.values() if math.isfinite(r.error) and r.errors]
            if len(good) < 2:
                continue
            for ch in good[0].errors:
                logs = np.log([max(r.errors.get(ch, np.nan), 1e-12) for r in good])
                spread.setdefault(ch, {})[f] = float(np.nanmax(logs) - np.nanmin(logs))
        return {ch: max(s, key=s.get) for ch, s in spread.items()}

    @staticmethod
    def _field_error(rec: Record, field: str, owner: dict) -> float:
        if not math.isfinite(rec.error):
            return math.inf
        mine = [e for ch, e in rec.errors.items() if owner.get(ch) == field]
        return max(mine) if mine else 0.0

    # --- the proposal ------------------------------------------------------------------------------
    def propose(self, records: dict, pending=()) -> ModeSet | None:
        """The next set to simulate. `records`: {label: Record} of the simulated sets;
        `pending`: labels being simulated. None when every set of the space was simulated.
        Level by level, loosest first: sweep until every field meets the level (or has no
        count left), then the combinations predicted to meet it; then wider margins."""
        taken = set(records) | set(pending)
        base = self._set()
        if base.label() not in taken:
            return base
        runs = self._one_field_runs(records)
        owner = self._attribution(runs)
        for level in self.levels:
            ms = self._sweep_next(runs, owner, taken, level)
            if ms is None:
                ms = self._combine_next(records, runs, owner, taken, level, MARGINS[0])
            if ms is not None:
                return ms
        for margin in MARGINS[1:]:
            for level in self.levels:
                ms = self._combine_next(records, runs, owner, taken, level, margin)
                if ms is not None:
                    return ms
        # every prediction settled: the rest of the space, fewest modes first, then by the
        # one-field runs' costs where known
        rest = []
        for combo in itertools.product(*(self.choices[f] for f in self.fields)):
            ms = self._set(**dict(zip(self.fields, combo)))
            if ms.label() not in taken:
                known = [runs[f][m.label()].cost for f, m in zip(self.fields, combo) if m.label() in runs[f]]
                rest.append((sum(m.count for m in combo), -len(known), max(known, default=0.0), ms.label(), ms))
        return min(rest, key=lambda r: r[:4])[4] if rest else None

    def _sweep_next(self, runs, owner, taken, level):
        """The next one-field run, fewest modes first, of a field none of whose choices with
        fewer modes met `level`."""
        counts = sorted({m.count for f in self.fields for m in self.choices[f]})
        for k in counts:
            for f in self.fields:
                if any(self._field_error(runs[f][m.label()], f, owner) <= level
                       for m in self.choices[f] if m.count < k and m.label() in runs[f]):
                    continue
                for m in self.choices[f]:
                    if m.count == k:
                        ms = self._set(**{f: m})
                        if ms.label() not in taken:
                            return ms
        return None

    def _predict(self, runs, owner, combo: dict) -> tuple:
        """(predicted error, predicted cost key) of `combo` {field: choice}: the worst of the
        fields' errors in their one-field runs; the dearest of those runs, then the number of
        modes, then the sum of their costs."""
        recs = {f: runs[f][m.label()] for f, m in combo.items()}
        error = max(self._field_error(rec, f, owner) for f, rec in recs.items())
        cost = max(r.cost for r in recs.values())
        return error, (cost, sum(m.count for m in combo.values()), sum(r.cost for r in recs.values()))

    def _combine_next(self, records, runs, owner, taken, level, margin):
        """The cheapest predicted combination meeting `level` with `margin` that is not
        simulated yet and could still be cheaper than the cheapest set known to meet it."""
        per_field = []
        for f in self.fields:
            ok = [m for m in self.choices[f] if m.label() in runs[f]
                  and self._field_error(runs[f][m.label()], f, owner) <= level * (1 + margin)]
            ok.sort(key=lambda m: (runs[f][m.label()].cost, m.count))
            per_field.append(ok[:COMBO_LIMIT])
        candidates = []
        for combo in itertools.product(*per_field):
            c = dict(zip(self.fields, combo))
            candidates.append((self._predict(runs, owner, c)[1], self._set(**c)))
        candidates.sort(key=lambda kc: kc[0])
        met = [r.cost for r in records.values() if r.error <= level]
        best = min(met) if met else math.inf
        for key, ms in candidates:
            if key[0] > best:
                break
            if ms.label() not in taken:
                return ms
        return None


def history(study, space, before: int | None = None) -> tuple:
    """({label: Record} of the simulated sets, [labels being simulated], number of running trials
    numbered below `before` whose set is not known yet) of an Optuna study, read from what the
    objective stores: user attributes modeset_json and errors of complete trials (a repeat,
    ``duplicate_of``, adds nothing), failed trials as error inf, and the parameters of running or
    queued trials."""
    records, pending, unknown = {}, [], 0
    states = optuna.trial.TrialState
    for t in study.get_trials(deepcopy=False):
        attrs = t.user_attrs
        if t.state == states.COMPLETE and "errors" in attrs and t.values is not None:
            ms = space.canonical(ModeSet.from_dict(attrs["modeset_json"]))
            records[ms.label()] = Record(ms, attrs["errors"], t.values[0], t.values[1])
        elif t.state == states.FAIL and "modeset_json" in attrs and "duplicate_of" not in attrs:
            ms = space.canonical(ModeSet.from_dict(attrs["modeset_json"]))
            records.setdefault(ms.label(), Record(ms, None, math.inf, math.inf))
        elif t.state in (states.RUNNING, states.WAITING):
            ms = space.from_params(t.params)
            if ms is not None:
                pending.append(space.canonical(ms).label())
            elif t.state == states.RUNNING and before is not None and t.number < before:
                unknown += 1
    return records, pending, unknown


class FieldwiseSampler(optuna.samplers.BaseSampler):
    """`Fieldwise` as an Optuna sampler (public `BaseSampler` interface): before
    each trial it reads the stored trials (`history`), asks the strategy for the
    next set and hands out that set's parameters; with nothing left to propose
    it samples at random. It keeps no state beyond the trial being sampled, so a
    study resumes, and several processes share one study (a set being simulated
    by another process is not proposed again)."""

    def __init__(self, study, seed: int = 0, space=None):
        from modesel.study.search.space import SearchSpace
        # the objective's space when given: it carries the family objects to worker processes
        self.space = space if space is not None else SearchSpace(study.search)
        # the strategy's order comes from the study's seed, the same in every worker and on
        # resume (one base set); the per-worker `seed` only drives the random fallback
        self.strategy = Fieldwise(self.space, study.compare.levels, seed=study.run.seed)
        self.fallback = optuna.samplers.RandomSampler(seed=seed)
        self.plan = {}

    def infer_relative_search_space(self, study, trial):
        return {}

    def sample_relative(self, study, trial, search_space):
        return {}

    def before_trial(self, study, trial):
        records, pending, unknown = history(study, self.space, before=trial.number)
        # earlier trials still choosing their set (workers started together) took the first
        # proposals: skip as many
        pending = list(pending)
        for _ in range(unknown + 1):
            modeset = self.strategy.propose(records, pending)
            if modeset is None:
                return
            pending.append(modeset.label())
        self.plan[trial.number] = self.space.params(modeset)

    def sample_independent(self, study, trial, param_name, param_distribution):
        plan = self.plan.get(trial.number, {})
        if param_name in plan:
            return plan[param_name]
        return self.fallback.sample_independent(study, trial, param_name, param_distribution)

    def after_trial(self, study, trial, state, values):
        self.plan.pop(trial.number, None)
