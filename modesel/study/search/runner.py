"""Running the search: budget, progress and worker processes.

`run_search` ties the pieces together: it loads the load case
(`load_case`), opens the stored study (`storage`), queues interrupted trials
again and, on a new study, the scene's default set, and optimises the
`Objective` with the study's sampler. With n_jobs > 1 it starts that many
loky processes (joblib), each optimising the same stored study; a worker
process ignores SIGINT (its parent stops it) and kills itself when its parent
dies (`die_with_parent`), and every trial names its process (user attribute
``owner``) so that a rerun queues again only the trials of dead processes
(`storage.requeue_interrupted`). Callbacks:
`Budget` (this process's share of new sets; forked workers take theirs
from one `SharedQuota`) and
`modesel.study.metrics.StopWhenMet` (stop when the criterion is met, after
``keep_searching_trials`` more).
"""
from __future__ import annotations

import gc
import math
import os
import signal
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from modesel.errors import ModeselError
from modesel.simulation.first_run import die_with_parent_signal
from modesel.simulation.progress import CompileProgress
from modesel.study.metrics import StopWhenMet
from modesel.study.search import engine as engines
from modesel.study.search.claims import abandoned, distinct_sets
from modesel.study.search.engine import Engine
from modesel.study.search.load_case import load_scenes, prepare_references
from modesel.study.search.objective import Objective
from modesel.study.search.progress import Progress, counts
from modesel.study.search.samplers import make_sampler, worker_seed
from modesel.study.search.owners import OWNER, process_owner
from modesel.study.search.storage import (check_against_results, default_storage, note_lost_trials, open_storage,
                                          open_study, queue_baseline, quiet_optuna, requeue_interrupted)
from modesel.study.timeseries import write_series

_quiet_optuna = quiet_optuna


def die_with_parent(parent: int, poll_s: float = 0.1) -> None:
    """In a worker process: exit at once (SIGKILL to itself) when the process
    `parent` is gone, even when it was killed with SIGKILL and had no chance
    to stop its workers. Linux: also PR_SET_PDEATHSIG; everywhere: a daemon
    thread polling the parent pid every `poll_s` seconds."""
    die_with_parent_signal()

    def watch():
        while True:
            if os.getppid() != parent:
                os.kill(os.getpid(), signal.SIGKILL)
            time.sleep(poll_s)

    if os.getppid() != parent:
        os.kill(os.getpid(), signal.SIGKILL)
    threading.Thread(target=watch, name="modesel-parent-watch", daemon=True).start()


_WATCHED = []


def worker_init(parent: int) -> None:
    """Start of a worker process (loky initializer, run once per process
    before any task): ignore SIGINT (the study process stops its workers)
    and die with the study process `parent`."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if parent not in _WATCHED:
        _WATCHED.append(parent)
        die_with_parent(parent)


class Owned:
    """The objective, with the trial's process recorded first (user attribute
    ``owner``, `owners.process_owner`)."""

    def __init__(self, objective: Objective):
        import uuid
        self.objective = objective
        self.owner = process_owner(run=uuid.uuid4().hex[:12])

    def __call__(self, trial):
        trial.set_user_attr(OWNER, self.owner)
        return self.objective(trial)


#: longest wait [s] for the shared quota's lock (`SharedQuota.take`), held for microseconds
LOCK_WAIT_S = 10.0


class SharedQuota:
    """The new sets the forked workers of one `modesel run` evaluate
    together (`total`): a worker takes a slot before each new set it may
    evaluate (`take`), so the workers stop together when the slots are gone
    instead of each after a fixed share, which left a worker whose share
    ran faster (cheaper sets, more repeats) idle while another finished
    (tower study, 2 jobs: one worker done 0.67 s before the other in a 3.5-s
    search). A counter in shared memory, made before the workers are forked."""

    def __init__(self, total: int):
        import multiprocessing
        self.total = total
        self.taken = multiprocessing.get_context("fork").Value("i", 0)

    def take(self) -> bool:
        """A slot for one more new set; False when all `total` are taken (or
        when the counter's lock stays held, by a worker killed while taking:
        this worker then stops rather than wait for it)."""
        lock = self.taken.get_lock()
        if not lock.acquire(timeout=LOCK_WAIT_S):
            return False
        try:
            if self.taken.value >= self.total:
                return False
            self.taken.value += 1
            return True
        finally:
            lock.release()


class Budget:
    """Optuna callback: stop this process after `quota` evaluated sets (repeats
    of an evaluated set do not count) or when every set of a finite space has
    been evaluated. With a `SharedQuota` the process holds one slot for its
    next new set and takes another once it has spent it, stopping when none
    is left (the quota is then the workers' together).

    Samplers converge and then keep proposing sets already evaluated (TPE on a
    few dozen discrete sets does so most of the time). After `kick_after`
    repeats in a row, a random set not yet evaluated is queued (an
    exploration step, drawn with this worker's seed); if none is found in
    `draws` draws, or after `max_streak` repeats in a row, the process stops.
    """

    def __init__(self, objective: Objective, quota: int, seed: int = 0, kick_after: int = 3,
                 max_streak: int = 50, draws: int = 2000, shared: SharedQuota | None = None):
        self.objective = objective
        self.quota = quota
        self.shared = shared
        self.spent = objective.evaluated         # new sets evaluated when the held slot was taken
        self.kick_after = kick_after
        self.max_streak = max_streak
        self.draws = draws
        self.space_size = objective.space.size()
        self.rng = np.random.default_rng(seed)

    def exhausted(self, study) -> bool:
        if math.isinf(self.space_size):
            return False
        return len(distinct_sets(study)) >= self.space_size

    def quota_left(self) -> bool:
        """Whether this process may evaluate another new set: its own quota,
        or a slot of the shared one (taken once the held slot is spent)."""
        obj = self.objective
        if self.shared is None:
            return obj.evaluated < self.quota
        if obj.evaluated > self.spent:
            self.spent = obj.evaluated
            return self.shared.take()
        return True

    def __call__(self, study, trial) -> None:
        obj = self.objective
        # the space is exhausted only when proposals repeat: checked after a
        # repeat only, since reading every trial costs O(trials) on an RDB storage
        if not self.quota_left() or obj.duplicate_streak >= self.max_streak or \
                (obj.duplicate_streak > 0 and self.exhausted(study)):
            study.stop()
        elif obj.duplicate_streak >= self.kick_after:
            seen = distinct_sets(study)
            for _ in range(self.draws):
                candidate = obj.space.random_set(self.rng)
                if obj.space.canonical(candidate).label() not in seen:
                    study.enqueue_trial(obj.space.params(candidate))
                    obj.duplicate_streak = 0
                    return
            study.stop()


def optimize_worker(objective: Objective, storage_url, study, sampler_name: str,
                    seed: int, n_trials: int, timeout: float | None, callbacks: list,
                    progress=None, parent: int | None = None, shared: SharedQuota | None = None) -> tuple:
    """Evaluate `n_trials` new sets of the stored study in this process (with
    `shared`, as many as the slots it takes of that quota, `Budget`).
    Returns (error, owner): None or the one-line text of a ModeselError
    (errors cross process boundaries as text), and the ``owner`` this
    process gave its trials. `parent`: the pid of the study process when
    this runs in a worker process (it then ignores SIGINT and dies with its
    parent)."""
    _quiet_optuna()
    if parent is not None:
        worker_init(parent)
    owned = Owned(objective)
    try:
        sampler = make_sampler(sampler_name, seed, n_trials, study=objective.study,
                               space=objective.space)
        opt = open_study(study, storage_url, sampler, create=False)
        budget = Budget(objective, n_trials, seed, shared=shared)
        if budget.exhausted(opt) or (shared is not None and not shared.take()):
            return None, owned.owner
        objective.warm_up()
        cbs = [budget] + list(callbacks) + ([progress] if progress else [])
        opt.optimize(owned, n_trials=None, timeout=timeout, callbacks=cbs, catch=(ModeselError,))
    except ModeselError as exc:
        return str(exc), owned.owner
    return None, owned.owner


def tally(trials, owners) -> tuple:
    """(sets evaluated, repeats) among `trials` run by the processes `owners`:
    a set is evaluated by the trial that simulated it (user attribute
    ``modeset_json``, not interrupted); a repeat took an earlier record."""
    mine = [t for t in trials if t.user_attrs.get(OWNER) in owners]
    repeats = sum(1 for t in mine if "duplicate_of" in t.user_attrs)
    evaluated = sum(1 for t in mine if "modeset_json" in t.user_attrs and "duplicate_of" not in t.user_attrs
                    and t.state.is_finished() and not abandoned(t))
    return evaluated, repeats


def check_time_grids(study, scenes: dict) -> None:
    """Each [[scene]]'s tmax/dt (or the scene file's) within the simulation's
    memory budget and dt <= tmax, before any trial (one-line error naming the
    study file and scene[i].tmax/dt)."""
    from modesel.simulation.scene import check_time_grid
    for i, spec in enumerate(study.scenes):
        scene = scenes.get(spec.name)
        tmax = spec.tmax if spec.tmax is not None else getattr(scene, "tmax", None)
        dt = spec.dt if spec.dt is not None else getattr(scene, "dt", None)
        if isinstance(tmax, (int, float)) and isinstance(dt, (int, float)):
            check_time_grid(float(tmax), float(dt), file=str(study.path), where=f"scene[{i}].")


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
    engine = engines.resolve(engine)
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
    # the output folder's own journal: trials.csv beside it tells whether records were lost
    private = out_dir is not None and isinstance(storage, str) and "://" not in storage \
        and Path(storage).resolve() == Path(default_storage(out_dir))
    if cache_dir is None and out_dir is not None:
        cache_dir = Path(out_dir) / "reference"

    scenes = load_scenes(study, engine)
    check_time_grids(study, scenes)
    references = prepare_references(study, scenes, engine, cache_dir, log)
    if out_dir is not None:
        write_series(out_dir, "reference", {name: (r.time, r.channels) for name, r in references.items()})

    if private:
        check_against_results(storage, out_dir)
    store = open_storage(storage, log=log)
    opt = open_study(study, storage, create=True, storage=store)
    if private:
        note_lost_trials(opt, out_dir, log)
    n_before = len(opt.get_trials(deepcopy=False))
    requeued = requeue_interrupted(opt, store, private=private)
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
    criterion = study.criterion()
    workers, bar = None, None
    forking = n_jobs > 1 and _can_fork()
    freezing = forking or n_jobs == 1
    caller_froze = gc.get_freeze_count() > 0
    try:
        if freezing:
            with CompileProgress(quiet=progress is False):
                objective.warm_up()
            # what the warm-up loaded (modules, compiled engine, decks,
            # references) stays to the end: frozen out of the garbage
            # collector's sight while the search runs, so that its collections
            # walk only the trials' objects and, in forked workers, never write
            # to the pages they share with this process (gc.freeze: "call
            # gc.freeze() right before fork()"); unfrozen after it unless the
            # caller had frozen objects itself (the commands: to their end)
            gc.freeze()
        if forking:
            # persistent workers forked from this process after the warm-up:
            # each starts with the compiled engine, the decks and the
            # references loaded (a spawned worker paid seconds of imports and
            # numba cache loading); forked before the progress bar starts its thread
            seeds = [worker_seed(seed, n_before, i, salt) for i in range(n_jobs)]
            workers = _fork_workers(objective, storage, study, seeds, shares, timeout, callbacks)
        bar = Progress(n_trials, study.name, progress)
        poll = (lambda: bar.set(*counts(opt, since, criterion))) if bar.bar is not None else (lambda: None)
        if workers is not None:
            results = _wait_workers(workers, poll)
        elif n_jobs == 1:
            def tick(s, t):
                bar.set(*counts(s, since, criterion))
            results = [optimize_worker(objective, store, study, study.search.sampler,
                                       worker_seed(seed, n_before, 0, salt), n_trials, timeout, callbacks,
                                       tick if bar.bar is not None else None)]
        else:
            seeds = [worker_seed(seed, n_before, i, salt) for i in range(n_jobs)]
            results = _run_parallel(objective, storage, study, seeds, shares, timeout, callbacks, poll)
    except BaseException:
        if workers is not None:
            _stop_workers(workers)
        if bar is not None:
            bar.close(clear=True)
        raise
    finally:
        if freezing and not caller_froze:
            gc.unfreeze()
    for error, text in results:
        if error == _INTERNAL:      # a bug in a forked worker: its traceback, not a one-line error
            bar.close(clear=True)
            raise RuntimeError(f"{_INTERNAL}:\n{text}")
    errors = [error for error, _ in results if error]
    bar.close(clear=bool(errors))
    if errors:
        raise ModeselError(errors[0])   # already "file: field: message" text from the worker
    new, repeats = tally(opt.get_trials(deepcopy=False), {owner for _, owner in results})
    return SearchOutcome(opt, storage, new, repeats, requeued, False, references, baseline)


_INTERNAL = "internal error in a worker process"


def _can_fork() -> bool:
    """Whether worker processes can be forked (POSIX with the fork start
    method; elsewhere the search spawns loky workers)."""
    import multiprocessing
    return hasattr(os, "fork") and "fork" in multiprocessing.get_all_start_methods() \
        and sys.platform.startswith("linux")


@dataclass
class _Worker:
    process: object
    conn: object
    result: tuple | None = None


def _forked_worker(conn, objective, storage, study, seed, share, timeout, callbacks, parent, shared) -> None:
    """Body of a forked worker process: run `optimize_worker` and send its
    (error, owner) back through `conn`; a bug is sent as its traceback."""
    import traceback
    try:
        result = optimize_worker(objective, storage, study, study.search.sampler, seed, share, timeout,
                                 callbacks, None, parent, shared)
    except BaseException:   # noqa: BLE001 (the parent reports it)
        result = (_INTERNAL, traceback.format_exc().rstrip())
    conn.send(result)
    conn.close()


def _fork_workers(objective, storage, study, seeds, shares, timeout, callbacks) -> list:
    """Fork one worker process per share, the shares' sets one quota they
    take from together (`SharedQuota`). SIGINT and SIGTERM are blocked
    around the fork, so that a Ctrl-C cannot reach a worker before it ignores
    SIGINT (`worker_init`: the study process stops its workers) and restores
    the default SIGTERM (the parent's handler raises in the main thread)."""
    import multiprocessing
    ctx = multiprocessing.get_context("fork")
    parent = os.getpid()
    workers = []
    shared = SharedQuota(sum(shares))
    blocked = {signal.SIGINT, signal.SIGTERM}
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, blocked)
    try:
        try:
            for seed_i, share in zip(seeds, shares):
                mine, theirs = ctx.Pipe(duplex=False)
                proc = ctx.Process(target=_forked_main, name="modesel-worker", daemon=True,
                                   args=(theirs, previous, objective, storage, study, seed_i, share,
                                         timeout, callbacks, parent, shared))
                proc.start()
                theirs.close()
                workers.append(_Worker(proc, mine))
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)   # a pending Ctrl-C is raised here
    except BaseException:
        _stop_workers(workers)
        raise
    return workers


def _forked_main(conn, mask, *args) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    _forked_worker(conn, *args)


def _wait_workers(workers: list, poll) -> list:
    """Wait for the forked workers (calling `poll` every 0.5 s); returns their
    (error, owner). A worker that died without a word (killed) is an error."""
    from multiprocessing.connection import wait
    pending = {w.conn: w for w in workers}
    while pending:
        for conn in wait(list(pending), timeout=0.5):
            w = pending.pop(conn)
            try:
                w.result = conn.recv()
            except (EOFError, OSError):
                w.process.join()
                code = w.process.exitcode
                how = f"was killed by signal {-code}" if code is not None and code < 0 else f"exited ({code})"
                w.result = (f"a worker process (pid {w.process.pid}) {how}; its running trial is queued "
                            f"again when the study is resumed", None)
        poll()
    for w in workers:
        w.process.join()
    return [w.result for w in workers]


def _stop_workers(workers: list) -> None:
    """Kill the worker processes and wait until they are gone, so that no
    trial finishes after the results of the finished trials have been
    written."""
    for w in workers:
        if w.process.is_alive():
            try:
                os.kill(w.process.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
    for w in workers:
        w.process.join()
        w.conn.close()


def _run_parallel(objective, storage, study, seeds, shares, timeout, callbacks, poll):
    from concurrent.futures import FIRST_COMPLETED, wait

    from joblib.externals.loky import get_reusable_executor
    parent = os.getpid()
    executor = get_reusable_executor(max_workers=len(shares), reuse=False, initializer=worker_init,
                                     initargs=(parent,))
    futures = [executor.submit(optimize_worker, objective, storage, study, study.search.sampler,
                               worker_seed_i, share, timeout, callbacks, None, parent)
               for worker_seed_i, share in zip(seeds, shares)]
    try:
        pending = set(futures)
        while pending:
            _, pending = wait(pending, timeout=0.5, return_when=FIRST_COMPLETED)
            poll()
        results = [f.result() for f in futures]
    except BaseException:
        # stop the workers and wait until they are gone, so that no trial
        # finishes after the results of the finished trials have been written
        executor.shutdown(wait=True, kill_workers=True)
        raise
    executor.shutdown(wait=True)        # no idle worker outlives the search
    return results
