"""Per-trial account of a search worker: exclusive wall and CPU time [ms per
trial] in the sampler, the storage, the claims (and their waits), owners,
the objective (simulate + metric), the time series written, callbacks and
the rest (Optuna), per worker process. The search machinery of
`modesel.study.search.runner.optimize_worker` runs as in `modesel run` (one
forked process per worker on one journal, or on a SQLAlchemy URL), with its
storage, sampler and objective methods wrapped by timers.

Run: python3 benchmarks/search_account.py STUDY.toml N_SETS N_JOBS [STORAGE_URL]
(``[budget] stop_when_met`` is turned off; ACCT_CACHE=folder keeps an
internal reference between runs). Used for the table in docs/benchmarks.md, search
throughput paragraph."""
import dataclasses, functools, os, sys, tempfile, time
import multiprocessing as mp

STACK = []           # [bucket, start, child]
TOT = {}
CNT = {}
CPU = {}

def add(bucket, dt):
    TOT[bucket] = TOT.get(bucket, 0.0) + dt

def wrap(obj, name, bucket):
    f = getattr(obj, name)
    @functools.wraps(f)
    def g(*a, **k):
        STACK.append([bucket, time.perf_counter(), 0.0, time.process_time(), 0.0])
        try:
            return f(*a, **k)
        finally:
            b, t0, child, c0, cchild = STACK.pop()
            el = time.perf_counter() - t0
            cel = time.process_time() - c0
            add(b, el - child)
            CPU[b] = CPU.get(b, 0.0) + cel - cchild
            CNT[b] = CNT.get(b, 0) + 1
            if STACK:
                STACK[-1][2] += el
                STACK[-1][4] += cel
    setattr(obj, name, g)

def patch():
    import optuna
    from optuna.storages import JournalStorage, BaseStorage
    from optuna.storages.journal import JournalFileBackend
    import modesel.study.search.claims as claims, modesel.study.search.objective as objective
    import modesel.study.search.owners as owners, modesel.study.search.runner as runner
    import modesel.study.metrics as metrics
    for m in [m for m in dir(BaseStorage) if not m.startswith("_")] + ["_sync_with_backend"]:
        if hasattr(JournalStorage, m) and callable(getattr(JournalStorage, m)):
            wrap(JournalStorage, m, "storage")
    from optuna.storages import RDBStorage
    for m in [m for m in dir(BaseStorage) if not m.startswith("_")]:
        if hasattr(RDBStorage, m) and callable(getattr(RDBStorage, m)):
            wrap(RDBStorage, m, "storage")
    wrap(JournalFileBackend, "append_logs", "storage write (lock+fsync)")   # Optuna's own backend only
    for cls in (optuna.samplers.TPESampler, optuna.samplers.NSGAIISampler, optuna.samplers.RandomSampler):
        for m in ("sample_relative", "sample_independent", "infer_relative_search_space", "before_trial", "after_trial"):
            wrap(cls, m, "sampler")
    wrap(claims, "claim", "claims")
    objective.claim = claims.claim
    wrap(claims.time, "sleep", "claims wait (sleep)")   # time.sleep: only claims sleep in a worker
    wrap(owners, "owner_alive", "owners")
    wrap(owners, "process_owner", "owners")
    runner.process_owner = owners.process_owner
    wrap(objective.Objective, "evaluate", "objective (simulate+metric)")
    wrap(objective.Objective, "warm_up", "start-up (warm_up)")
    wrap(objective, "write_series", "result writing (series)")
    wrap(runner.Budget, "__call__", "callbacks (budget)")
    wrap(metrics.StopWhenMet, "__call__", "callbacks (stop)")
    wrap(optuna.study.Study, "optimize", "optuna other")

def worker(q, objective, storage, study, seed, n, parent, shared):
    patch()
    import modesel.study.search.runner as runner
    c0 = time.process_time(); t0 = time.perf_counter()
    err, owner = runner.optimize_worker(objective, storage, study, study.search.sampler, seed, n, None, [], None, None,
                                        shared)
    q.put(dict(TOT=TOT, CNT=CNT, CPU=CPU, wall=time.perf_counter()-t0, cpu=time.process_time()-c0, err=err, owner=owner))

def main(study_file, n_trials, n_jobs, storage=None):
    from modesel.study.spec import load_study
    from modesel.study.search import engine as engines
    from modesel.study.search.load_case import load_scenes, prepare_references
    from modesel.study.search.objective import Objective
    from modesel.study.search.storage import open_storage, open_study, queue_baseline, default_storage
    from modesel.study.search.samplers import worker_seed
    from modesel.study.search.runner import tally
    study = load_study(study_file)
    study = dataclasses.replace(study, budget=dataclasses.replace(study.budget, stop_when_met=False))
    engine = engines.resolve(None)
    out = tempfile.mkdtemp(prefix="acct-")
    storage = storage or default_storage(out)
    scenes = load_scenes(study, engine)
    refs = prepare_references(study, scenes, engine, os.environ.get("ACCT_CACHE", os.path.join(out, "reference")), None)
    store = open_storage(storage)
    opt = open_study(study, storage, create=True, storage=store)
    queue_baseline(opt, study, scenes)
    objective = Objective(study, scenes, refs, engine, out)
    shares = [n_trials // n_jobs + (1 if i < n_trials % n_jobs else 0) for i in range(n_jobs)]
    ctx = mp.get_context("fork")
    q = ctx.Queue()
    t0 = time.perf_counter()
    from modesel.study.search.runner import SharedQuota
    shared = SharedQuota(n_trials) if n_jobs > 1 else None       # as `modesel run`'s forked workers
    ps = [ctx.Process(target=worker, args=(q, objective, storage, study, worker_seed(0, 0, i), s, os.getpid(), shared))
          for i, s in enumerate(shares)]
    for p in ps: p.start()
    res = [q.get() for _ in ps]
    for p in ps: p.join()
    wall = time.perf_counter() - t0
    trials = opt.get_trials(deepcopy=False)
    new, rep = tally(trials, {r["owner"] for r in res})
    print(f"== {os.path.basename(study_file)} n_jobs={n_jobs}: {len(trials)} trials ({new} simulated, {rep} repeats) in {wall:.1f} s wall: {len(trials)/wall*60:.0f} trials/min")
    buckets = sorted({b for r in res for b in r["TOT"]})
    for r in res:
        other = r["wall"] - sum(r["TOT"].values())
        r["TOT"]["unaccounted (optuna, python)"] = other
        r["CPU"]["unaccounted (optuna, python)"] = r["cpu"] - sum(r["CPU"].values())
    buckets.append("unaccounted (optuna, python)")
    print(f"{'bucket':32s} " + " ".join(f"{'w%d wall/cpu ms' % i:>18s}" for i in range(len(res))) + "   calls")
    per_worker_trials = [sum(1 for t in trials if t.user_attrs.get('owner') == r['owner']) for r in res]
    for b in buckets:
        print(f"{b:32s} " + " ".join(f"{1e3*r['TOT'].get(b,0)/max(1,k):9.1f}/{1e3*r['CPU'].get(b,0)/max(1,k):<8.1f}" for r, k in zip(res, per_worker_trials))
              + "   " + " ".join(str(r['CNT'].get(b, '')) for r in res))
    print(f"{'total wall':32s} " + " ".join(f"{1e3*r['wall']/max(1,k):14.1f}" for r, k in zip(res, per_worker_trials)))
    print(f"{'cpu':32s} " + " ".join(f"{1e3*r['cpu']/max(1,k):14.1f}" for r, k in zip(res, per_worker_trials)))
    print("trials per worker", per_worker_trials)

if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4] if len(sys.argv) > 4 else None)
