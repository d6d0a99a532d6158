"""Is the search intelligent? Fraction of the exhaustive simulations it needs.

Sub-spaces (stated), each 4 families (clamped, cosine, polynomial, fem) x
1-4 modes per field, 16 choices per field, 256 sets:
- `tower` (default): the tower free-decay study against OpenFAST
  (`studies/tower_free_decay.toml`, 4 s), tower_fa x tower_ss;
- `blade`: the rotating-blade study (`studies/blade_rotating.toml`, 10 s,
  reference the converged fem model), blade_flap x blade_edge.
`elastodyn` is left out (in the tower study the reference is ElastoDyn's
own 1-mode run, so elastodyn:1 would win every level at once). The space is
enumerated once (every set simulated, deterministic model cost), which gives
the true cheapest set for each tolerance level (cost, then DOFs, then
error). Then each strategy searches the same space with 5 seeds. Every
distinct set simulated counts once; a proposal of a set already simulated is
answered from the record (as in `modesel run`) and costs no simulation. A
strategy sees only what it simulated (the set, its error per channel, its
cost), never the enumeration. Reported per seed and tolerance level: the
number of distinct sets simulated until the true cheapest set of that level
had been simulated, as a fraction of the 256 (a miss counts as 1).

Strategies:
- `tpe`: Optuna's TPE (multi-objective, error and cost), as `modesel run`.
- `fieldwise`: `modesel.study.search.structured.Fieldwise`, the one
  ``[search] sampler = "fieldwise"`` runs: coordinate descent, counts in
  increasing order, one field at a time from the best set found so far (the
  base takes each field's best choice before the next field is swept), a
  channel belonging to every field that moves it; then the combinations an
  additive per-channel error model (fitted on every simulated set) predicts
  to meet each level, cheapest predicted first.
  It is given the levels 3.5, 1, 0.5, 0.2 and 0.1 %.

    python3 benchmarks/bench_search_efficiency.py [--subspace tower|blade] [--seeds 5] [--strategy tpe fieldwise] [--table CACHE.json]
    python3 benchmarks/bench_search_efficiency.py --calibrate   # unit cost per RHS evaluation
"""
from __future__ import annotations

import argparse
import itertools
import logging
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from modesel.modeset import FieldModes, ModeSet  # noqa: E402
from modesel.study.search import Objective, SearchSpace, default_engine, load_scenes, prepare_references  # noqa: E402
from modesel.study.spec import parse_study  # noqa: E402

FAMILIES = '["clamped", "cosine", "polynomial", "fem"]'
LEVELS = (0.035, 0.01, 0.005, 0.002, 0.001)
# sub-space -> (study file, what is searched)
SUBSPACES = {"tower": ("tower_free_decay.toml", "tower_fa x tower_ss (tower free decay against OpenFAST)"),
             "blade": ("blade_rotating.toml", "blade_flap x blade_edge (rotating blades against the "
                       "converged fem reference)")}


def sub_space_study(name="tower"):
    """The study file with families clamped, cosine, polynomial and fem, 1-4 modes per field."""
    path = ROOT / "studies" / SUBSPACES[name][0]
    text = path.read_text().replace('"relaxed_tipmass", ', "").replace('"elastodyn", ', "")
    text = text.replace("max_count = 2\n", "max_count = 4\n").replace("max_count = 3\n", "max_count = 4\n")
    assert text.count(FAMILIES) == 2
    return parse_study(text, path)


def enumerate_space(study, partial=None):
    """{label: (error, cost, n_dofs, {channel: error})} of every set, and the wall time [s];
    `partial` (a JSON path) is written as it goes and resumed from."""
    import json
    engine = default_engine()
    scenes = load_scenes(study, engine)
    objective = Objective(study, scenes, prepare_references(study, scenes, engine), engine)
    objective.warm_up()
    sets = []
    per_field = [[FieldModes(f.family, c) for f in s.families for c in range(f.min_count, f.max_count + 1)]
                 for s in study.search.fields]
    for combo in itertools.product(*per_field):
        sets.append(ModeSet({s.field: fm for s, fm in zip(study.search.fields, combo)}))
    table, wall = {}, 0.0
    if partial is not None and Path(partial).exists():
        data = json.loads(Path(partial).read_text())
        table, wall = {k: tuple(v) for k, v in data["table"].items()}, data["wall_s"]
    for ms in sets:
        if ms.label() in table:
            continue
        t0 = time.perf_counter()
        rec = objective.evaluate(ms)
        wall += time.perf_counter() - t0
        table[ms.label()] = (rec["error"], rec["cost"], rec["n_dofs"], rec["errors"])
        if partial is not None:
            Path(partial).write_text(json.dumps({"table": table, "wall_s": wall}))
    return table, wall


def truths(table):
    """{level: label of the cheapest set meeting it (cost, then DOFs, then error)}."""
    out = {}
    for level in LEVELS:
        ok = [(c, n, e, k) for k, (e, c, n, *_) in table.items() if e <= level]
        if ok:
            out[level] = min(ok)[3]
    return out


def run_tpe(study, table, seed, limit, wanted=()):
    import optuna
    optuna.logging.set_verbosity(logging.ERROR)
    space = SearchSpace(study.search)
    sampler = optuna.samplers.TPESampler(seed=seed, n_startup_trials=10, multivariate=True)
    opt = optuna.create_study(directions=["minimize", "minimize"], sampler=sampler)
    order, seen = [], set()
    stall = 0
    while len(order) < limit and stall < 500 and not set(wanted) <= seen:
        trial = opt.ask()
        label = space.canonical(space.suggest(trial)).label()
        error, cost = table[label][:2]
        opt.tell(trial, (error, cost))
        if label not in seen:
            seen.add(label)
            order.append(label)
            stall = 0
        else:
            stall += 1
    return order


def run_fieldwise(study, table, seed, limit, wanted=()):
    """`modesel.study.search.structured.Fieldwise` (``sampler = "fieldwise"``), driven
    set by set: it sees only the records of the sets simulated so far."""
    from modesel.study.search.structured import Fieldwise, Record
    space = SearchSpace(study.search)
    strategy = Fieldwise(space, LEVELS, seed=seed)
    records, order = {}, []
    while len(order) < limit and not set(wanted) <= set(order):
        ms = strategy.propose(records)
        if ms is None:
            break
        label = space.canonical(ms).label()
        if label in records:
            raise RuntimeError(f"fieldwise proposed {label} twice")
        error, cost, _, errors = table[label]
        records[label] = Record(ms, errors, error, cost)
        order.append(label)
    return order


STRATEGIES = {"tpe": run_tpe, "fieldwise": run_fieldwise}


def calibrate():
    """Unit cost of one right-hand-side evaluation [s] per DOF count and effect set
    (`modesel.study.search.objective.UNIT_COST_S`)."""
    from modesel.simulation.api import load_scene, simulate
    cases = {"structure": ROOT / "tests/data/openfast_turbine/parked_release/parked_release.fst",
             "aero": ROOT / "studies/data/openfast/steady_11p4/steady_11p4.fst"}
    for effects, path in cases.items():
        scene = load_scene(path)
        simulate(scene, None, tmax=0.2)
        points = []
        for n in (1, 2, 3, 4):
            ms = ModeSet({f: FieldModes("clamped", n) for f in ("tower_fa", "tower_ss", "blade_flap", "blade_edge")})
            runs = {T: min((simulate(scene, ms, tmax=T) for _ in range(2)), key=lambda r: r.wall_time_s)
                    for T in (1.0, 4.0)}
            u = (runs[4.0].wall_time_s - runs[1.0].wall_time_s) / (runs[4.0].n_rhs - runs[1.0].n_rhs)
            points.append((runs[4.0].n_dofs, u))
            print(f"{effects:<9} {runs[4.0].n_dofs:>3} DOFs: {u * 1e6:8.1f} us per RHS evaluation", flush=True)
        b, a = np.polyfit(*zip(*points), 1)
        print(f"{effects}: u(n) = {a:.3g} s + {b:.3g} s * n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--strategy", nargs="+", default=list(STRATEGIES), choices=list(STRATEGIES))
    ap.add_argument("--subspace", default="tower", choices=list(SUBSPACES))
    ap.add_argument("--calibrate", action="store_true")
    ap.add_argument("--table", help="JSON file caching the enumeration (written if absent)")
    args = ap.parse_args(argv)
    if args.calibrate:
        calibrate()
        return
    study = sub_space_study(args.subspace)
    cache = Path(args.table) if args.table else None
    if cache is not None and cache.exists() and not Path(str(cache) + ".partial").exists():
        import json
        data = json.loads(cache.read_text())
        table, wall = {k: tuple(v) for k, v in data["table"].items()}, data["wall_s"]
    else:
        partial = Path(str(cache) + ".partial") if cache is not None else None
        table, wall = enumerate_space(study, partial)
        if cache is not None:
            import json
            cache.write_text(json.dumps({"table": table, "wall_s": wall}))
            partial.unlink()
    n = len(table)
    print(f"sub-space: {SUBSPACES[args.subspace][1]}, families {FAMILIES}, 1-4 modes: {n} sets; "
          f"enumerated in {wall:.1f} s wall")
    truth = truths(table)
    for level, label in truth.items():
        e, c, d = table[label][:3]
        print(f"  true cheapest within {level:.3g}: {label} (error {e:.4g}, cost {c:.4g} model s per "
              f"simulated s, {d} DOFs)")
    for name in args.strategy:
        print(f"strategy {name}: fraction of the {n} exhaustive simulations needed to find the true "
              "cheapest set")
        print("  seed  " + "  ".join(f"{lv:>7.3g}" for lv in truth))
        fractions = {lv: [] for lv in truth}
        for seed in range(args.seeds):
            order = STRATEGIES[name](study, table, seed, n, wanted=set(truth.values()))
            row = []
            for level, label in truth.items():
                k = order.index(label) + 1 if label in order else None
                frac = k / n if k else 1.0      # not found: counted as the whole enumeration
                fractions[level].append(frac)
                row.append(f"{frac:7.3f}" if k else "   miss")
            print(f"  {seed:>4}  " + "  ".join(row), flush=True)
        print("  mean  " + "  ".join(f"{np.mean(v):7.3f}" for v in fractions.values()))


if __name__ == "__main__":
    main()
