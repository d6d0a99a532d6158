"""The structured search (``[search] sampler = "fieldwise"``): the paper's
flowchart, automated.

It uses two properties of the problem: the fields are nearly separable (each
output channel is moved by few fields: the tower-top fore-aft deflection by
tower_fa, the blade-tip in-plane deflection by blade_edge AND blade_flap),
and a set's error is its worst channel. The cost objective also has
structure: a field with more modes costs more, so counts are tried in
increasing order.

Level by level, loosest first:

1. **Descent** (coordinate descent, Gauss-Seidel). The base set starts at
   each field's first choice with its fewest modes. For count k = 1, 2, ...:
   each field that moves a channel the base set misses (a field not varied
   yet counts as moving every channel) is swept: each choice (family, k modes) of that field
   with the other fields at the base. The base then takes that field's best
   choice (mean log error over the channels, then the worst channel), and
   the next field is swept from the new base, so a poor base choice of one
   field does not spoil the other's sweep. A channel belongs to every field
   whose change alone moved its error by more than 25 % (learned from the
   simulated sets, nothing declared). The descent stops when the base set
   meets the level; the next level continues from there (a field's sweep at
   k modes is done once).
2. **Combine.** Per channel, an additive model of the error over the
   fields' choices, e = sum_f u_f(choice), fitted by least squares on every
   simulated set, predicts each combination of simulated choices. The
   combinations predicted to meet the level with a 15 % margin are proposed
   cheapest predicted first (predicted cost: the dearest of the choices'
   cost bounds, a choice's bound being the cheapest simulated set holding
   it; then the number of modes). The level is settled once a simulated set
   meets it at a cost no higher than every unsimulated candidate's bound.
   Then the next level.

After the last level the margin widens (50 %, 150 %), and at the end any set
not yet simulated is proposed.

The strategy sees only the records of simulated sets (the set, its error per
channel, its cost), as `modesel run` stores them; it keeps no state (the
descent is replayed from the records at each proposal) and is deterministic
for a given seed (which orders the fields and the families of one count) and
history. In `modesel run` (`FieldwiseSampler`) the sets are proposed in rounds
of `ROUND` trials: each round's proposals come from the records of the earlier
rounds only (a worker waits for the previous round to end), so the sets and
their order do not depend on the number of workers or on which trial finished
first. Continuous family parameters are
held at the middle of their range.
"""
from __future__ import annotations

import itertools
import math
import time

import numpy as np
import optuna

from modesel.modeset import FieldModes, ModeSet

MARGINS = (0.15, 0.5, 1.5)      # relative margin on the predicted error, widened in turn
ROUND = 4                       # sets proposed per round from the records of the earlier rounds
POLL_S = 0.2                    # how often a worker looks whether the previous round has finished
MOVED = 1.25                    # a field owns a channel whose error its change alone moved by this factor


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

    def _set_of(self, fields: dict) -> ModeSet:
        return ModeSet({f: fields[f] for f in (s.field for s in self.space.spec.fields)})

    def _set(self, **changed) -> ModeSet:
        fields = dict(self.base)
        fields.update(changed)
        return self._set_of(fields)

    # --- what the records tell -------------------------------------------------------------------
    def _owners(self, records: dict) -> tuple:
        """({channel: set of fields}, varied): every field whose change alone moved that
        channel's error by more than `MOVED` (pairs of simulated sets that differ in that field
        only); `varied`, the fields such a pair exists for. A field not varied yet may move
        any channel."""
        good = [r for r in records.values() if math.isfinite(r.error) and r.errors]
        owners, varied = {}, set()
        for f in self.fields:
            groups = {}
            for r in good:
                key = tuple(r.modeset[g].label() for g in self.fields if g != f)
                groups.setdefault(key, []).append(r)
            for group in groups.values():
                if len(group) < 2:
                    continue
                varied.add(f)
                for ch in group[0].errors:
                    e = [max(r.errors.get(ch, 0.0), 1e-12) for r in group]
                    if max(e) > MOVED * min(e):
                        owners.setdefault(ch, set()).add(f)
        return owners, varied

    @staticmethod
    def _score(rec: Record) -> tuple:
        """Descent order of simulated sets: mean log error over the channels (every channel
        counts, so a field is judged by what it moves even when another field's channel is
        the worst), then the worst channel."""
        if not math.isfinite(rec.error) or not rec.errors:
            return (math.inf, math.inf)
        return (float(np.mean(np.log([max(e, 1e-12) for e in rec.errors.values()]))), rec.error)

    def _descend(self, records: dict, taken: set, level: float, state: dict):
        """Coordinate descent towards `level`, replayed from the records: for k = 1, 2, ...,
        each field that moves a channel the base set misses (a field not varied yet: any
        channel) is swept at k modes with the other fields at the base; then the base takes that
        field's best choice (`_score`) and the next field is swept from there. Stops once the
        base set meets `level`. `state` ({"base", "done"}) carries over from looser levels.
        Returns the next sweep set to simulate, or None when this level's descent is over."""
        owners, varied = self._owners(records)
        unknown = set(self.fields) - varied
        counts = sorted({m.count for f in self.fields for m in self.choices[f]})
        for k in counts:
            for f in self.fields:
                base = self._set_of(state["base"])
                rec = records.get(base.label())
                if rec is not None and rec.error <= level:
                    return None
                if (f, k) in state["done"]:
                    continue
                sweep = [self._set_of({**state["base"], f: m}) for m in self.choices[f] if m.count == k]
                started = any(ms.label() in taken for ms in sweep if ms.label() != base.label())
                if rec is not None and rec.errors and not started:
                    # a channel nobody moved yet may belong to any field
                    failing = [ch for ch, e in rec.errors.items() if e > level]
                    if not any(f in (owners.get(ch) or set(self.fields)) | unknown for ch in failing):
                        continue
                for ms in sweep:
                    if ms.label() not in taken:
                        return ms
                # all simulated (or being simulated: judged on those known): re-base on the best
                known = [records[ms.label()] for ms in sweep + [base] if ms.label() in records]
                if known:
                    best = min(known, key=lambda r: (self._score(r), r.cost, r.modeset.label()))
                    state["base"][f] = best.modeset[f]
                state["done"].add((f, k))
        return None

    def _predict(self, records: dict):
        """Per channel, an additive model of the error over the fields' choices,
        e(set) = sum_f u_f(choice), fitted (least squares) on every simulated set; and a
        cost bound per choice (cheapest simulated set holding it). Returns
        ({field: [choices]}, {field: error arrays [choice, channel]}, {field: cost array}, channels)."""
        good = [r for r in records.values() if math.isfinite(r.error) and r.errors]
        if not good:
            return None
        channels = sorted(good[0].errors)
        index, known = {}, {}
        for f in self.fields:
            labels = {r.modeset[f].label(): r.modeset[f] for r in good}
            known[f] = [m for m in self.choices[f] if m.label() in labels]
            for m in known[f]:
                index[(f, m.label())] = len(index)
        A = np.zeros((len(good), len(index)))
        for i, r in enumerate(good):
            for f in self.fields:
                A[i, index[(f, r.modeset[f].label())]] = 1.0
        E = np.array([[r.errors.get(ch, np.nan) for ch in channels] for r in good])
        E = np.where(np.isfinite(E), E, np.nanmax(np.where(np.isfinite(E), E, 0.0)))
        u = np.linalg.lstsq(A, E, rcond=None)[0]
        err = {f: np.array([u[index[(f, m.label())]] for m in known[f]]) for f in self.fields}
        cost = {f: np.array([min(r.cost for r in good if r.modeset[f].label() == m.label()) for m in known[f]])
                for f in self.fields}
        return known, err, cost, channels

    def _combine_next(self, records, model, taken, level, margin):
        """The cheapest combination of simulated choices whose predicted error (`_predict`)
        meets `level` with `margin`, not simulated yet, that could still be cheaper than the
        cheapest simulated set meeting it. Predicted cost: the dearest of the choices' cost
        bounds, then the number of modes."""
        if model is None:
            return None
        known, err, cost, _ = model
        shape = [len(known[f]) for f in self.fields]
        total = np.zeros(shape + [err[self.fields[0]].shape[1]])
        worst_cost = np.zeros(shape)
        modes = np.zeros(shape)
        for i, f in enumerate(self.fields):
            axes = [1] * len(self.fields)
            axes[i] = shape[i]
            total = total + err[f].reshape(axes + [-1])
            worst_cost = np.maximum(worst_cost, cost[f].reshape(axes))
            modes = modes + np.array([m.count for m in known[f]], float).reshape(axes)
        predicted = total.max(axis=-1)
        met = [r.cost for r in records.values() if r.error <= level]
        best = min(met) if met else math.inf
        ok = np.argwhere((predicted <= level * (1 + margin)) & (worst_cost <= best))
        order = sorted(ok.tolist(), key=lambda ix: (worst_cost[tuple(ix)], modes[tuple(ix)], predicted[tuple(ix)], ix))
        for ix in order:
            ms = self._set_of({f: known[f][j] for f, j in zip(self.fields, ix)})
            if ms.label() not in taken:
                return ms
        return None

    # --- the proposal ------------------------------------------------------------------------------
    def propose(self, records: dict, pending=()) -> ModeSet | None:
        """The next set to simulate. `records`: {label: Record} of the simulated sets;
        `pending`: labels being simulated. None when every set of the space was simulated.
        Level by level, loosest first: the descent until the base set meets the level, then
        the combinations predicted to meet it; then wider margins; then the rest."""
        taken = set(records) | set(pending)
        model = self._predict(records)
        state = {"base": dict(self.base), "done": set()}
        for level in self.levels:
            ms = self._descend(records, taken, level, state)
            if ms is None:
                ms = self._combine_next(records, model, taken, level, MARGINS[0])
            if ms is not None:
                return ms
        for margin in MARGINS[1:]:
            for level in self.levels:
                ms = self._combine_next(records, model, taken, level, margin)
                if ms is not None:
                    return ms
        # every prediction settled: the rest of the space, fewest modes first, then by the
        # choices' cost bounds where known
        bound = {}
        if model is not None:
            for f in self.fields:
                for m, c in zip(model[0][f], model[2][f]):
                    bound[(f, m.label())] = c
        rest = []
        for combo in itertools.product(*(self.choices[f] for f in self.fields)):
            ms = self._set(**dict(zip(self.fields, combo)))
            if ms.label() not in taken:
                known = [bound[(f, m.label())] for f, m in zip(self.fields, combo) if (f, m.label()) in bound]
                rest.append((sum(m.count for m in combo), -len(known), max(known, default=0.0), ms.label(), ms))
        return min(rest, key=lambda r: r[:4])[4] if rest else None


def finished_before(study, number: int) -> bool:
    """True when every trial numbered below `number` has ended (complete, failed or pruned)."""
    live = (optuna.trial.TrialState.RUNNING, optuna.trial.TrialState.WAITING)
    return all(t.state not in live for t in study.get_trials(deepcopy=False) if t.number < number)


def history(study, space, below: int) -> dict:
    """{label: Record} of the sets simulated by the trials numbered below `below` of an Optuna
    study, read from what the objective stores: user attributes modeset_json and errors of
    complete trials (a repeat, ``duplicate_of``, adds nothing), failed trials as error inf."""
    records = {}
    states = optuna.trial.TrialState
    for t in study.get_trials(deepcopy=False):
        if t.number >= below:
            continue
        attrs = t.user_attrs
        if t.state == states.COMPLETE and "errors" in attrs and t.values is not None:
            ms = space.canonical(ModeSet.from_dict(attrs["modeset_json"]))
            records[ms.label()] = Record(ms, attrs["errors"], t.values[0], t.values[1])
        elif t.state == states.FAIL and "modeset_json" in attrs and "duplicate_of" not in attrs:
            ms = space.canonical(ModeSet.from_dict(attrs["modeset_json"]))
            records.setdefault(ms.label(), Record(ms, None, math.inf, math.inf))
    return records


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
        # Rounds of ROUND trials by number: the proposals of a round come from the records of
        # the earlier rounds only, the i-th trial of the round taking the i-th proposal. So the
        # sets, and their order, depend neither on the number of workers nor on which trial
        # happened to finish first: same seed, same study, same results. A worker waits for
        # the previous round to end (it never waits on its own round).
        start = trial.number - trial.number % ROUND
        while not finished_before(study, start):
            time.sleep(POLL_S)
        records = history(study, self.space, below=start)
        pending = []
        for _ in range(trial.number - start + 1):
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
