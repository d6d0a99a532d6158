"""The objective: one mode set evaluated on the load case.

`Objective` runs `simulate` on every scene of the load case, compares with
the references and returns (error, cost): error = worst weighted channel
(per channel, the weight-averaged error over the scenes, see
`load_case_errors`). The cost (``[search] cost``) is

- ``model`` (deterministic): the right-hand-side evaluations the integrator
  made times the calibrated unit cost of one evaluation for that DOF count
  and effect set (`unit_cost`), per simulated second, summed over the
  scenes: the same set on the same scene always costs the same, so the
  ranking and the Pareto front do not move with timing noise;
- ``wall_time``: measured wall seconds per simulated second (noisy: two runs
  of the same study rank sets of equal size differently);
- ``dofs``: the DOF count.

It records user attributes: modeset (label), modeset_json, errors {channel:
error}, scene_errors, error, worst_channel, meets_tolerance, n_dofs (max
over scenes), n_rhs (sum over scenes), wall_time_s, simulated_time_s, speed
(measured, for information), cost. The set simulated is the canonical form
of the proposal (`SearchSpace.canonical`: the same shapes described once,
e.g. `relaxed_tipmass` with zero ratios is `clamped`); a proposal written
differently keeps its own text in user attribute ``proposed``. A
`ModeselError` (e.g. `SimulationDiverged`) marks the trial FAIL with user
attribute fail_reason (and failed_scene) and the study goes on; Optuna
samplers ignore failed trials. A set already evaluated is not simulated
again (`modesel.study.search.claims`): the trial gets the earlier values and
user attributes modeset and duplicate_of (the earlier trial's number) only.
"""
from __future__ import annotations

import math
import weakref
from pathlib import Path

from modesel.errors import ModeselError
from modesel.modeset import ModeSet
from modesel.study.metrics import AZIMUTH_METRICS, metric
from modesel.study.search.claims import INTERRUPTED, claim
from modesel.study.search.engine import Engine
from modesel.study.search.space import SearchSpace
from modesel.study.timeseries import write_series


# Unit cost of one right-hand-side evaluation [s] for n DOFs, u(n) = a + b n,
# per effect set, calibrated once on the reference machine class (the 2-core
# development machine: x86-64, numba kernel, DOP853) with
# `python3 benchmarks/bench_search_efficiency.py --calibrate`: NREL 5-MW
# parked release (structure only) and steady 11.4 m/s (BEM aero, InflowWind,
# tower drag) scenes with 1-4 clamped modes per field, each simulated for 1 s
# and 4 s (best of 2); u = difference of wall times / difference of
# evaluations, so the set-up time cancels; a, b the least-squares line.
UNIT_COST_S = {"structure": (7.1e-5, 2.3e-6), "aero": (4.5e-4, 2.3e-6)}


def effect_set(scene) -> str:
    """'aero' when the scene computes aerodynamic loads, else 'structure'."""
    effects = getattr(scene, "effects", None) or {}
    return "aero" if effects.get("aero") else "structure"


def unit_cost(n_dofs: int, effects: str = "structure") -> float:
    """Calibrated cost [s] of one right-hand-side evaluation with `n_dofs` DOFs."""
    a, b = UNIT_COST_S[effects]
    return a + b * float(n_dofs)


def load_case_errors(scene_errors: dict, weights: dict) -> dict:
    """Per channel, the weight-averaged error over the scenes:
    e_c = sum_s w_s e_sc / sum_s w_s (scene weights as occurrence weights)."""
    total = sum(weights[s] for s in scene_errors)
    channels = next(iter(scene_errors.values())).keys()
    return {ch: sum(weights[s] * scene_errors[s][ch] for s in scene_errors) / total for ch in channels}


#: the objectives warmed up in this process (`Objective.warm_up`); a forked
#: worker inherits the set with the warmed objects, a spawned one starts empty.
#: Weak references, not ids: an id is reused once its object is collected, and
#: a new objective at that address was taken for warmed (tests/test_search.py)
_WARMED: weakref.WeakSet = weakref.WeakSet()


class Objective:
    """Evaluates one mode set on the load case; an Optuna objective."""

    def __init__(self, study, scenes: dict, references: dict, engine: Engine,
                 series_dir: Path | None = None):
        self.study = study
        self.scenes = scenes                 # scene name -> Scene
        self.references = references         # scene name -> Reference
        self.engine = engine
        self.series_dir = series_dir
        self.space = SearchSpace(study.search)
        self.criterion = study.criterion()
        self.evaluated = 0          # sets simulated by this process (duplicates excluded)
        self.duplicate_streak = 0   # consecutive proposals of already evaluated sets

    def evaluate(self, modeset: ModeSet) -> dict:
        """Simulate every scene with `modeset` and compare; returns the record."""
        channels = list(self.study.compare.channels)
        # only the compared channels: the others (rotor aerodynamics, generator,
        # reaction loads) would cost an evaluation per output time
        only = {"channels": channels} if self.engine.selects_channels else {}
        scene_errors, series = {}, {}
        n_dofs, wall, simulated, n_rhs, modelled = 0, 0.0, 0.0, 0, 0.0
        for spec in self.study.scenes:
            try:
                result = self.engine.simulate(self.scenes[spec.name], modeset, tmax=spec.tmax, dt=spec.dt,
                                              **only)
                aligned = self.references[spec.name].align(result.outputs, channels,
                                                           file=f"simulation of scene '{spec.name}'")
                options = self.metric_options(aligned)
                scene_errors[spec.name] = {
                    ch: metric(self.study.compare.metric, aligned.sim[ch], aligned.ref[ch], aligned.time,
                               channel=ch, **options) for ch in channels}
            except ModeselError as exc:
                exc.scene = spec.name
                raise
            n_dofs = max(n_dofs, int(result.n_dofs))
            rhs = int(getattr(result, "n_rhs", 0) or 0)
            if self.study.search.cost == "model" and rhs <= 0:
                raise ModeselError("the engine reports no right-hand-side evaluations; the cost "
                                   "model needs them (use [search] cost = \"wall_time\")",
                                   field="search.cost")
            n_rhs += rhs
            modelled += rhs * unit_cost(int(result.n_dofs), effect_set(self.scenes[spec.name]))
            wall += float(result.wall_time_s)
            simulated += float(result.simulated_time_s)
            series[spec.name] = (aligned.time, aligned.sim)
        errors = load_case_errors(scene_errors, {s.name: s.weight for s in self.study.scenes})
        verdict = self.criterion.assess(errors)
        per_s = (lambda x: x / simulated if simulated > 0 else math.inf)
        cost = {"dofs": float(n_dofs), "model": per_s(modelled),
                "wall_time": per_s(wall)}[self.study.search.cost]
        return {"modeset": modeset.label(), "modeset_json": modeset.to_dict(), "errors": errors,
                "scene_errors": scene_errors, "error": verdict.error,
                "worst_channel": verdict.worst_channel, "meets_tolerance": verdict.meets,
                "n_dofs": n_dofs, "n_rhs": n_rhs, "wall_time_s": wall, "simulated_time_s": simulated,
                "speed": simulated / wall if wall > 0 else math.inf, "cost": cost,
                "_series": series}

    def metric_options(self, aligned) -> dict:
        """Keyword options of the study's metric (periodic: the azimuths and its parameters)."""
        options = dict(self.study.compare.metric_params)
        if self.study.compare.metric in AZIMUTH_METRICS:
            options.update(azimuth_sim=aligned.azimuth_sim, azimuth_ref=aligned.azimuth_ref)
        return options

    def warm_up(self) -> None:
        """Simulate a few steps of each scene with its default set, untimed:
        the first simulation in a process pays one-off costs (imports, JIT
        compilation) that would otherwise inflate the first trial's cost.
        A compared channel that a scene's simulation does not compute (e.g.
        a reaction force modesel has no coordinate for) fails every trial:
        it is a one-line error here, before the search starts. Other errors
        are left to the trials, which record them.

        Then a few steps of each scene with one set per family of the space
        (`SearchSpace.family_sets`): a family's first use imports what it
        needs (scipy.optimize for the cantilever roots of `clamped` and
        `relaxed_tipmass`, 0.3-0.6 s) and the largest bodies load the
        compiled invariant route (`multibody.invariant_sums`, 0.1-0.2 s).
        `modesel run` warms up before it forks its workers, so they inherit
        all this; before, each worker paid it inside its first trials, a
        fixed cost per worker that took the tower study's 2-job speed-up
        from 2x to 1.6-1.7x (`benchmarks/bench_search.py`). Once per process
        and objective: a forked worker finds it done."""
        if self in _WARMED:
            return
        from modesel.model.outputs import canonical_channel
        compared = list(self.study.compare.channels)

        def few_steps(spec, modeset, **options):
            scene = self.scenes[spec.name]
            dt = spec.dt or getattr(scene, "dt", None)
            return self.engine.simulate(scene, modeset, tmax=5 * dt if dt else None, dt=dt, **options)

        for spec in self.study.scenes:
            try:
                result = few_steps(spec, None)
            except ModeselError:
                continue
            columns = getattr(result, "columns", None) or {}
            # a trial asks for its channels by name, also by one of ElastoDyn's other names
            missing = [ch for ch in compared if columns and ch not in columns and canonical_channel(ch) not in columns]
            if missing:
                raise ModeselError(
                    f"scene '{spec.name}' does not compute the compared channel{'s' if len(missing) > 1 else ''} "
                    f"{', '.join(missing)}; it computes: {', '.join(c for c in columns if c != 'Time')}",
                    file=str(self.study.path), field="compare.channels")
        only = {"channels": compared} if self.engine.selects_channels else {}
        for modeset in self.space.family_sets():
            for spec in self.study.scenes:
                try:
                    few_steps(spec, modeset, **only)
                except ModeselError:        # a set the scene cannot build: its trials will say so
                    continue
        _WARMED.add(self)

    def __call__(self, trial):
        try:
            return self._run(trial)
        except KeyboardInterrupt:       # while waiting for a claim or simulating
            trial.set_user_attr("fail_reason", INTERRUPTED)
            raise

    def _run(self, trial):
        proposed = self.space.suggest(trial)
        modeset = self.space.canonical(proposed)
        if modeset.label() != proposed.label():
            trial.set_user_attr("proposed", proposed.label())
        earlier = claim(trial, modeset.label())
        if earlier is not None:   # the record stays with the earlier trial
            self.duplicate_streak += 1
            trial.set_user_attr("duplicate_of", earlier.number)
            if earlier.values is None:
                raise ModeselError(earlier.user_attrs.get("fail_reason", "failed"))
            return tuple(earlier.values)
        self.duplicate_streak = 0
        self.evaluated += 1
        trial.set_user_attr("modeset_json", modeset.to_dict())
        try:
            record = self.evaluate(modeset)
        except ModeselError as exc:
            trial.set_user_attr("fail_reason", str(exc))
            if getattr(exc, "scene", None):
                trial.set_user_attr("failed_scene", exc.scene)
            if getattr(exc, "time", None) is not None:
                trial.set_user_attr("failed_at_s", exc.time)
            raise
        except Exception as exc:  # a bug, not a user problem: record it, then stop the study
            trial.set_user_attr("fail_reason", f"internal error: {type(exc).__name__}: {exc}")
            raise
        series = record.pop("_series")
        for key, value in record.items():
            trial.set_user_attr(key, value)
        if self.series_dir is not None:
            write_series(self.series_dir, trial.number, series)
        return record["error"], record["cost"]
