"""The search: an Optuna study over mode sets, holding no physics.

Pieces, each replaceable:

- `Engine` (load_scene, simulate): the physics, injected. The default is
  `modesel.simulation.api`; tests inject a fake. Both must be picklable
  (module-level functions) when trials run in parallel processes.
- `SearchSpace`: per searched field a categorical ``<field>.family`` from the
  allowed list, an integer ``<field>.<family>.count`` in the family's range
  (capped by the family's own maximum), and floats
  ``<field>.<family>.<param>`` for its continuous parameters; count and
  parameters are conditioned on the family.
- `Objective`: runs `simulate` on every scene of the load case, compares with
  the references and returns (error, cost): error = worst weighted channel
  (per channel, the weight-averaged error over the scenes, see
  `load_case_errors`), cost = wall seconds per simulated second (sum over the
  scenes), or the DOF count with ``[search] cost = "dofs"``. It records user
  attributes: modeset (label), modeset_json, errors {channel: error},
  scene_errors, error, worst_channel, meets_tolerance, n_dofs (max over
  scenes, a deterministic cost proxy), wall_time_s, simulated_time_s, speed,
  cost. A `ModeselError` (e.g. `SimulationDiverged`) marks the trial FAIL
  with user attribute fail_reason (and failed_scene) and the study goes on;
  Optuna samplers ignore failed trials. A set already evaluated is not
  simulated again: the trial gets the earlier values and user attributes
  modeset and duplicate_of (the earlier trial's number) only.
- Samplers (`SAMPLERS`: tpe, nsga2, random), seeded per worker and per number
  of trials already in the study, so a resumed study does not replay the
  first run's proposals.
- Storage (`open_storage`): by default an Optuna journal file
  ``study.journal`` in the output folder (safe for several processes; a
  study resumes from it without repeating finished trials, and trials an
  interruption cut short are queued again); or any SQLAlchemy URL
  (``sqlite:///x.db``, ``postgresql://user@host/db``) so several machines run
  `modesel worker` on one study.
- Callbacks: `modesel.study.metrics.StopWhenMet` stops when the criterion is
  met (after ``keep_searching_trials`` more).

`run_search` ties them together; with n_jobs > 1 it starts that many loky
processes (joblib), each optimising the same stored study.
"""
from __future__ import annotations

import logging
import math
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from modesel.study.metrics import StopWhenMet, metric
from modesel.errors import ModeselError, unknown_name
from modesel.modeset import FieldModes, ModeSet
from modesel.study.reference import internal_reference, load_reference

DIRECTIONS = ("minimize", "minimize")   # (error, cost)
JOURNAL_NAME = "study.journal"
INTERRUPTED = "interrupted"


# --------------------------------------------------------------------------- engine

@dataclass(frozen=True)
class Engine:
    """The physics the search drives: `load_scene(path) -> Scene`,
    `simulate(scene, modeset, tmax=, dt=) -> SimulationResult` and,
    optionally, `channel_unit(name) -> unit or None` (the unit of an output
    channel, so references in incompatible units are refused before the search)."""

    load_scene: Callable
    simulate: Callable
    channel_unit: Callable | None = None


def default_engine() -> Engine:
    from modesel.simulation import api
    return Engine(api.load_scene, api.simulate, api.channel_unit)


# --------------------------------------------------------------------------- search space

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


# --------------------------------------------------------------------------- objective

def load_case_errors(scene_errors: dict, weights: dict) -> dict:
    """Per channel, the weight-averaged error over the scenes:
    e_c = sum_s w_s e_sc / sum_s w_s (scene weights as occurrence weights)."""
    total = sum(weights[s] for s in scene_errors)
    channels = next(iter(scene_errors.values())).keys()
    return {ch: sum(weights[s] * scene_errors[s][ch] for s in scene_errors) / total for ch in channels}


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
        scene_errors, series = {}, {}
        n_dofs, wall, simulated = 0, 0.0, 0.0
        for spec in self.study.scenes:
            try:
                result = self.engine.simulate(self.scenes[spec.name], modeset, tmax=spec.tmax, dt=spec.dt)
                aligned = self.references[spec.name].align(result.outputs, channels,
                                                           file=f"simulation of scene '{spec.name}'")
                scene_errors[spec.name] = {
                    ch: metric(self.study.compare.metric, aligned.sim[ch], aligned.ref[ch], aligned.time,
                               channel=ch) for ch in channels}
            except ModeselError as exc:
                exc.scene = spec.name
                raise
            n_dofs = max(n_dofs, int(result.n_dofs))
            wall += float(result.wall_time_s)
            simulated += float(result.simulated_time_s)
            series[spec.name] = (aligned.time, aligned.sim)
        errors = load_case_errors(scene_errors, {s.name: s.weight for s in self.study.scenes})
        verdict = self.criterion.assess(errors)
        cost = wall / simulated if simulated > 0 else math.inf
        return {"modeset": modeset.label(), "modeset_json": modeset.to_dict(), "errors": errors,
                "scene_errors": scene_errors, "error": verdict.error,
                "worst_channel": verdict.worst_channel, "meets_tolerance": verdict.meets,
                "n_dofs": n_dofs, "wall_time_s": wall, "simulated_time_s": simulated,
                "speed": simulated / wall if wall > 0 else math.inf,
                "cost": float(n_dofs) if self.study.search.cost == "dofs" else cost,
                "_series": series}

    def warm_up(self) -> None:
        """Simulate a few steps of the first scene with its default set, untimed:
        the first simulation in a process pays one-off costs (imports, JIT
        compilation) that would otherwise inflate the first trial's cost."""
        spec = self.study.scenes[0]
        scene = self.scenes[spec.name]
        dt = spec.dt or getattr(scene, "dt", None)
        try:
            self.engine.simulate(scene, None, tmax=5 * dt if dt else None, dt=dt)
        except ModeselError:
            pass

    def _earlier(self, trial, label: str):
        """The trial that owns `label`: a finished one, or one that another
        worker is running and that was created before `trial` (the later
        trial always yields, so two workers never simulate the same set)."""
        import optuna
        TS = optuna.trial.TrialState
        for t in trial.study.get_trials(deepcopy=False, states=(TS.COMPLETE, TS.FAIL, TS.RUNNING)):
            if t.number == trial.number or t.user_attrs.get("modeset") != label \
                    or t.user_attrs.get("fail_reason") == INTERRUPTED \
                    or t.user_attrs.get("duplicate_of") is not None:
                continue
            if t.state != TS.RUNNING or t.number < trial.number:
                return t
        return None

    def _finished(self, trial, earlier, wait_s: float = 600.0, poll_s: float = 0.5):
        """`earlier` once it has finished (another worker may still be running
        it), or None if it has not finished within `wait_s`."""
        import time
        import optuna
        deadline = time.monotonic() + wait_s
        while earlier.state == optuna.trial.TrialState.RUNNING:
            if time.monotonic() > deadline:
                return None
            time.sleep(poll_s)
            earlier = next(t for t in trial.study.get_trials(deepcopy=False) if t.number == earlier.number)
        return earlier

    def __call__(self, trial):
        modeset = self.space.suggest(trial)
        label = modeset.label()
        trial.set_user_attr("modeset", label)          # claim the set before looking for owners
        earlier = self._earlier(trial, label)
        if earlier is not None:
            earlier = self._finished(trial, earlier)
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
        except KeyboardInterrupt:
            trial.set_user_attr("fail_reason", INTERRUPTED)
            raise
        except Exception as exc:  # a bug, not a user problem: record it, then stop the study
            trial.set_user_attr("fail_reason", f"internal error: {type(exc).__name__}: {exc}")
            raise
        series = record.pop("_series")
        for key, value in record.items():
            trial.set_user_attr(key, value)
        if self.series_dir is not None:
            from modesel.study.results import write_series
            write_series(self.series_dir, trial.number, series)
        return record["error"], record["cost"]


# --------------------------------------------------------------------------- samplers

def _tpe(seed, n_trials):
    import optuna
    return optuna.samplers.TPESampler(seed=seed, n_startup_trials=min(10, max(2, n_trials // 4)),
                                      constant_liar=True)


def _nsga2(seed, n_trials):
    import optuna
    return optuna.samplers.NSGAIISampler(seed=seed, population_size=int(min(50, max(8, n_trials // 5))))


def _random(seed, n_trials):
    import optuna
    return optuna.samplers.RandomSampler(seed=seed)


SAMPLERS = {"tpe": _tpe, "nsga2": _nsga2, "random": _random}


def make_sampler(name: str, seed: int, n_trials: int = 100):
    if name not in SAMPLERS:
        raise unknown_name("sampler", name, SAMPLERS, field="search.sampler")
    return SAMPLERS[name](int(seed), int(n_trials))


def worker_seed(seed: int, n_existing: int, worker: int, salt: int = 0) -> int:
    """Distinct, reproducible seed per (study seed, trials already done, worker
    index, salt); `modesel worker` salts with host and process id so workers
    started together on several machines do not propose the same sets."""
    return int(np.random.SeedSequence([int(seed), int(n_existing), int(worker), int(salt)])
               .generate_state(1)[0])


# --------------------------------------------------------------------------- storage

def mask_url(url: str) -> str:
    return re.sub(r"//([^:/@]+):[^@]*@", r"//\1:***@", str(url))


def default_storage(out_dir) -> str:
    return str(Path(out_dir).resolve() / JOURNAL_NAME)


def open_storage(url: str):
    """An Optuna storage for `url`: a SQLAlchemy URL ('scheme://...') gives an
    RDB storage (with heartbeats so trials of a dead worker are failed), any
    other string is a journal file path."""
    import optuna
    if isinstance(url, optuna.storages.BaseStorage):   # already open
        return url
    if "://" in url:
        import time
        import sqlalchemy.exc
        for attempt in range(5):
            try:
                return optuna.storages.RDBStorage(url, heartbeat_interval=60, grace_period=180)
            except sqlalchemy.exc.IntegrityError:
                # two workers creating the schema of an empty database at once:
                # one wins, the other retries and finds the tables made
                time.sleep(0.2 * (attempt + 1))
            except (ImportError, ValueError, sqlalchemy.exc.SQLAlchemyError, OSError) as exc:
                msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
                raise ModeselError(f"cannot open storage: {msg}", file=mask_url(url)) from None
        raise ModeselError("cannot open storage: schema creation kept conflicting", file=mask_url(url))
    path = Path(url)
    if not path.parent.is_dir():
        raise ModeselError("storage folder does not exist", file=url)
    try:
        from optuna.storages.journal import JournalFileBackend
        return optuna.storages.JournalStorage(JournalFileBackend(str(path)))
    except OSError as exc:
        raise ModeselError(f"cannot open storage: {exc.strerror}", file=url) from None


def open_study(study, storage_url, sampler=None, *, create: bool = True):
    """Create or load the Optuna study named after `study` in `storage_url`
    (a URL/path or an open storage) and check that it was made from the same
    study definition (`Study.fingerprint`)."""
    import optuna
    storage = open_storage(storage_url)
    storage_url = getattr(storage_url, "url", None) or str(storage_url)
    try:
        if create:
            opt = optuna.create_study(study_name=study.name, storage=storage, sampler=sampler,
                                      directions=list(DIRECTIONS), load_if_exists=True)
        else:
            opt = optuna.load_study(study_name=study.name, storage=storage, sampler=sampler)
    except KeyError:
        raise ModeselError(f"no study named '{study.name}' in this storage; start it with "
                           f"`modesel run` or `modesel worker`", file=mask_url(storage_url)) from None
    except ValueError as exc:
        raise ModeselError(f"cannot use study '{study.name}': {exc}", file=mask_url(storage_url)) from None
    if len(opt.directions) != len(DIRECTIONS):
        raise ModeselError(f"study '{study.name}' in this storage is not an (error, cost) study",
                           file=mask_url(storage_url))
    found = opt.user_attrs.get("fingerprint")
    if found is None and create:
        opt.set_user_attr("fingerprint", study.fingerprint())
        opt.set_user_attr("study_file", str(study.path))
        opt.set_user_attr("channels", list(study.compare.channels))
        opt.set_user_attr("metric", study.compare.metric)
    elif found is not None and found != study.fingerprint():
        raise ModeselError(
            f"study '{study.name}' in this storage was made from a different definition (scenes, "
            f"reference, channels, metric or search space changed); use another output folder, "
            f"storage or [study] name", file=mask_url(storage_url))
    return opt


def requeue_interrupted(opt, study, *, fail_running: bool) -> int:
    """Queue again the sets whose trials an interruption cut short. With
    `fail_running` (private storage: nothing else can be running) RUNNING
    trials are first marked FAIL 'interrupted'. Returns how many were queued."""
    import optuna
    TS = optuna.trial.TrialState
    storage = opt._storage
    if fail_running:
        for t in opt.get_trials(deepcopy=False, states=(TS.RUNNING,)):
            storage.set_trial_user_attr(t._trial_id, "fail_reason", INTERRUPTED)
            storage.set_trial_state_values(t._trial_id, TS.FAIL)
    retried = set(opt.user_attrs.get("requeued", []))
    queued = 0
    for t in opt.get_trials(deepcopy=False, states=(TS.FAIL,)):
        if t.user_attrs.get("fail_reason") == INTERRUPTED and t.number not in retried and t.params:
            opt.enqueue_trial(t.params, skip_if_exists=False)
            retried.add(t.number)
            queued += 1
    if queued:
        opt.set_user_attr("requeued", sorted(retried))
    return queued


def queue_baseline(opt, study, scenes: dict) -> bool:
    """On a new study, queue the first scene's default mode set (restricted to
    the searched fields) as trial 0 when it lies in the search space, so the
    results show what the default costs and how far off it is."""
    if opt.get_trials(deepcopy=False):
        return False
    default = getattr(scenes[study.scenes[0].name], "default_modeset", None)
    space = SearchSpace(study.search)
    if default is None or not space.contains(default):
        return False
    opt.enqueue_trial(space.params(default))
    return True


# --------------------------------------------------------------------------- preparation

def load_scenes(study, engine: Engine) -> dict:
    scenes = {}
    for spec in study.scenes:
        scenes[spec.name] = engine.load_scene(spec.path)
    active = set().union(*(set(getattr(s, "fields", ())) for s in scenes.values()))
    for space in study.search.fields:
        if space.field not in active:
            raise ModeselError(
                f"field '{space.field}' is not active in any scene (active: "
                f"{', '.join(sorted(active)) or 'none'}); searching it changes nothing",
                file=str(study.path), field=f"search.fields.{space.field}")
    return scenes


def prepare_references(study, scenes: dict, engine: Engine, cache_dir=None, log=None) -> dict:
    """{scene name: Reference} for every scene of the load case."""
    ref = study.reference
    channels = list(study.compare.channels)
    out = {}
    for spec in study.scenes:
        if ref.kind == "internal":
            out[spec.name] = internal_reference(
                scenes[spec.name], channels, engine.simulate, family=ref.family,
                tolerance=ref.tolerance, start_count=ref.start_count, max_count=ref.max_count,
                tmax=spec.tmax, dt=spec.dt, cache_dir=cache_dir, window=ref.window, name=spec.name,
                progress=log)
        else:
            out[spec.name] = load_reference(spec.reference, ref.kind, channels, mapping=ref.channels,
                                            time_offset=ref.time_offset, window=ref.window,
                                            scene=spec.name)
            check_reference_fits(out[spec.name], spec, scenes[spec.name], study, engine)
    return out


def check_reference_fits(reference, spec, scene, study, engine: Engine) -> None:
    """Refuse, before any trial, a reference that no simulation of the scene
    can be compared with: no time overlap with the scene's [0, tmax] (within
    the window), or a channel whose unit cannot be converted to the
    simulation's (every trial would fail the same way)."""
    from modesel.study.reference import unit_factor
    tmax = spec.tmax if spec.tmax is not None else getattr(scene, "tmax", None)
    if tmax is not None:
        lo, hi = max(0.0, reference.time[0]), min(float(tmax), reference.time[-1])
        window = reference.window
        if window is not None:
            lo, hi = max(lo, window[0]), min(hi, window[1])
        if not hi > lo:
            span = f"reference [{reference.time[0]:g}, {reference.time[-1]:g}] s"
            raise ModeselError(
                f"{span} (time_offset {study.reference.time_offset:g} s applied) and scene "
                f"'{spec.name}' [0, {float(tmax):g}] s" + (f" within window [{window[0]:g}, {window[1]:g}] s"
                                                            if window is not None else "")
                + " do not overlap", file=str(study.path),
                field="reference.window" if window is not None else "reference.time_offset")
    if engine.channel_unit is None:
        return
    for ch, unit in reference.units.items():
        sim_unit = engine.channel_unit(ch)
        if unit and sim_unit and unit_factor(unit, sim_unit) is None:
            raise ModeselError(f"reference unit '{unit}' cannot be converted to the simulation's "
                               f"'{sim_unit}'", file=reference.source, field=ch)


# --------------------------------------------------------------------------- running

def _quiet_optuna():
    import optuna
    optuna.logging.set_verbosity(logging.ERROR)
    import warnings
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)


class Budget:
    """Optuna callback: stop this process after `quota` evaluated sets (repeats
    of an evaluated set do not count) or when every set of a finite space has
    been evaluated.

    Samplers converge and then keep proposing sets already evaluated (TPE on a
    few dozen discrete sets does so most of the time). After `kick_after`
    repeats in a row, a random set not yet evaluated is queued (an
    exploration step, drawn with this worker's seed); if none is found in
    `draws` draws, or after `max_streak` repeats in a row, the process stops.
    """

    def __init__(self, objective: Objective, quota: int, seed: int = 0, kick_after: int = 3,
                 max_streak: int = 50, draws: int = 2000):
        self.objective = objective
        self.quota = quota
        self.kick_after = kick_after
        self.max_streak = max_streak
        self.draws = draws
        self.space_size = objective.space.size()
        self.rng = np.random.default_rng(seed)

    def exhausted(self, study) -> bool:
        if math.isinf(self.space_size):
            return False
        return len(distinct_sets(study)) >= self.space_size

    def __call__(self, study, trial) -> None:
        obj = self.objective
        if obj.evaluated >= self.quota or obj.duplicate_streak >= self.max_streak or self.exhausted(study):
            study.stop()
        elif obj.duplicate_streak >= self.kick_after:
            seen = distinct_sets(study)
            for _ in range(self.draws):
                candidate = obj.space.random_set(self.rng)
                if candidate.label() not in seen:
                    study.enqueue_trial(obj.space.params(candidate))
                    obj.duplicate_streak = 0
                    return
            study.stop()


def distinct_sets(study) -> set:
    """Labels of the mode sets evaluated so far (interrupted trials excluded)."""
    import optuna
    TS = optuna.trial.TrialState
    return {t.user_attrs["modeset"] for t in study.get_trials(deepcopy=False, states=(TS.COMPLETE, TS.FAIL))
            if "modeset" in t.user_attrs and t.user_attrs.get("fail_reason") != INTERRUPTED}


def optimize_worker(objective: Objective, storage_url, study, sampler_name: str,
                    seed: int, n_trials: int, timeout: float | None, callbacks: list,
                    progress=None) -> str | None:
    """Evaluate `n_trials` new sets of the stored study in this process. Returns
    None, or the one-line text of a ModeselError (errors cross process
    boundaries as text)."""
    _quiet_optuna()
    try:
        sampler = make_sampler(sampler_name, seed, n_trials)
        opt = open_study(study, storage_url, sampler, create=False)
        budget = Budget(objective, n_trials, seed)
        if budget.exhausted(opt):
            return None
        objective.warm_up()
        cbs = [budget] + list(callbacks) + ([progress] if progress else [])
        opt.optimize(objective, n_trials=None, timeout=timeout, callbacks=cbs, catch=(ModeselError,))
    except ModeselError as exc:
        return str(exc)
    return None


class _Progress:
    """tqdm bar on stderr when it is a terminal; updated per finished trial."""

    def __init__(self, total: int, name: str, enabled: bool | None = None):
        enabled = sys.stderr.isatty() if enabled is None else enabled
        self.bar = None
        if enabled:
            from tqdm import tqdm
            self.bar = tqdm(total=total, desc=name, unit="trial", file=sys.stderr, leave=True)
        self.done = 0

    def set(self, done: int, best: float | None = None, failed: int = 0):
        if self.bar is None:
            return
        self.bar.update(max(0, done - self.done))
        self.done = max(self.done, done)
        self.bar.set_postfix_str((f"best error {best:.3g}" if best is not None else "") +
                                 (f" failed {failed}" if failed else ""))

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _counts(opt, since: int, criterion):
    import optuna
    TS = optuna.trial.TrialState
    done = [t for t in opt.get_trials(deepcopy=False, states=(TS.COMPLETE, TS.FAIL))
            if t.number >= since and "duplicate_of" not in t.user_attrs]
    errors = [criterion.assess(t.user_attrs["errors"]).error for t in opt.get_trials(
        deepcopy=False, states=(TS.COMPLETE,)) if t.user_attrs.get("errors")]
    return len(done), (min(errors) if errors else None), sum(1 for t in done if t.state == TS.FAIL)


@dataclass
class SearchOutcome:
    """`n_new`: sets evaluated by this run; `n_repeats`: proposals of sets
    already evaluated (served from the record); `requeued`: interrupted
    trials queued again; `baseline`: the scene's default set was queued."""

    optuna_study: object
    storage_url: str
    n_new: int
    n_repeats: int
    requeued: int
    already_met: bool
    references: dict
    baseline: bool = False


def run_search(study, *, out_dir=None, storage: str | None = None, n_trials: int | None = None,
               timeout: float | None = None, n_jobs: int | None = None, seed: int | None = None,
               engine: Engine | None = None, cache_dir=None, progress: bool | None = None,
               log: Callable | None = None, salt: int = 0) -> SearchOutcome:
    """Run (or resume) the search of `study`; CLI options override the study's
    [budget]/[run] values. Without `storage` the journal file in `out_dir` is
    used. Trial time series go to `out_dir` when given."""
    _quiet_optuna()
    engine = engine or default_engine()
    log = log or (lambda msg: None)
    n_trials = study.budget.n_trials if n_trials is None else int(n_trials)
    timeout = study.budget.timeout_s if timeout is None else float(timeout)
    n_jobs = study.run.n_jobs if n_jobs is None else int(n_jobs)
    seed = study.run.seed if seed is None else int(seed)
    if n_trials < 1 or n_jobs < 1:
        raise ModeselError("--n-trials and --n-jobs must be >= 1")
    storage = storage or study.run.storage
    if storage is None:
        if out_dir is None:
            raise ModeselError("no storage: give an output folder or --storage URL")
        storage = default_storage(out_dir)
    # the output folder's own journal belongs to this run (and its child
    # processes): a RUNNING trial found there was cut short by an interruption
    private = out_dir is not None and isinstance(storage, str) and "://" not in storage \
        and Path(storage).resolve() == Path(default_storage(out_dir))
    if cache_dir is None and out_dir is not None:
        cache_dir = Path(out_dir) / "reference"

    scenes = load_scenes(study, engine)
    references = prepare_references(study, scenes, engine, cache_dir, log)
    if out_dir is not None:
        from modesel.study.results import write_series
        write_series(out_dir, "reference", {name: (r.time, r.channels) for name, r in references.items()})

    opt = open_study(study, storage, create=True)
    n_before = len(opt.get_trials(deepcopy=False))
    requeued = requeue_interrupted(opt, study, fail_running=private)
    baseline = queue_baseline(opt, study, scenes)
    stop = StopWhenMet(study.criterion(), study.budget.keep_searching_trials) \
        if study.budget.stop_when_met else None
    callbacks = [stop] if stop else []
    if stop and stop.is_satisfied(opt):
        log("the tolerance is already met and keep_searching_trials done; no new trial "
            "(set [budget] stop_when_met = false or raise keep_searching_trials to search on)")
        return SearchOutcome(opt, storage, 0, 0, requeued, True, references)

    objective = Objective(study, scenes, references, engine,
                          None if out_dir is None else Path(out_dir).resolve())
    since = n_before
    n_jobs = min(n_jobs, n_trials)
    shares = [n_trials // n_jobs + (1 if i < n_trials % n_jobs else 0) for i in range(n_jobs)]
    bar = _Progress(n_trials, study.name, progress)
    criterion = study.criterion()
    try:
        if n_jobs == 1:
            def tick(s, t):
                bar.set(*_counts(s, since, criterion))
            error = optimize_worker(objective, opt._storage, study, study.search.sampler,
                                    worker_seed(seed, n_before, 0, salt), n_trials, timeout, callbacks,
                                    tick if bar.bar is not None else None)
            errors = [error] if error else []
        else:
            seeds = [worker_seed(seed, n_before, i, salt) for i in range(n_jobs)]
            errors = _run_parallel(objective, storage, study, seeds, shares, timeout, callbacks,
                                   lambda: bar.set(*_counts(opt, since, criterion)))
    finally:
        bar.close()
    if errors:
        raise ModeselError(errors[0])   # already "file: field: message" text from the worker
    new = opt.get_trials(deepcopy=False)[n_before:]
    repeats = sum(1 for t in new if "duplicate_of" in t.user_attrs)
    return SearchOutcome(opt, storage, len(new) - repeats, repeats, requeued, False, references, baseline)


def _run_parallel(objective, storage, study, seeds, shares, timeout, callbacks, poll):
    from concurrent.futures import FIRST_COMPLETED, wait

    from joblib.externals.loky import get_reusable_executor
    executor = get_reusable_executor(max_workers=len(shares), reuse=False)
    futures = [executor.submit(optimize_worker, objective, storage, study, study.search.sampler,
                               worker_seed_i, share, timeout, callbacks)
               for worker_seed_i, share in zip(seeds, shares)]
    try:
        pending = set(futures)
        while pending:
            _, pending = wait(pending, timeout=0.5, return_when=FIRST_COMPLETED)
            poll()
    except KeyboardInterrupt:
        # stop the workers and wait until they are gone, so that no trial
        # finishes after the results of the finished trials have been written
        executor.shutdown(wait=True, kill_workers=True)
        raise
    return [f.result() for f in futures if f.result()]
