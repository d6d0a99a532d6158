"""Is the search intelligent? Fraction of the exhaustive simulations it needs.

Sub-space (stated): the tower free-decay study against OpenFAST
(`studies/tower_free_decay.toml`, 4 s, 3 DOFs + modes) with tower_fa and
tower_ss each searched over families clamped, cosine, polynomial and fem,
1-4 modes: 16 choices per field, 256 sets (`elastodyn` left out: the
reference is ElastoDyn's own 1-mode run, so elastodyn:1 wins every level at
once and the question would be trivial). The space is enumerated once (every set simulated, deterministic
model cost), which gives the true cheapest set for each tolerance level.
Then each strategy searches the same space with 5 seeds; a proposal of a
set already evaluated is answered from the record (as in `modesel run`) and
costs no simulation. Reported per seed and tolerance: the number of
distinct sets simulated until the true cheapest set of that level had been
evaluated, as a fraction of the 324.

Strategies:
- `tpe`: Optuna's TPE (multi-objective, error and cost), as `modesel run`.
- `fieldwise`: the structure of the problem (fields nearly separable):
  converge one field at a time with the others held at the most accurate
  choice found so far (every family/count of that field; two sweeps), then,
  per level, combine the 3 fewest-mode choices of each field that met the
  level with the others held.

    python3 benchmarks/bench_search_efficiency.py [--seeds 5] [--strategy tpe fieldwise]
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

STUDY = ROOT / "studies" / "tower_free_decay.toml"
FAMILIES = '["clamped", "cosine", "polynomial", "fem"]'
LEVELS = (0.035, 0.01, 0.005, 0.002, 0.001)


def sub_space_study():
    text = STUDY.read_text().replace('"relaxed_tipmass", ', "").replace('"elastodyn", ', "")
    text = text.replace("max_count = 2", "max_count = 4")
    assert FAMILIES in text
    return parse_study(text, STUDY)


def enumerate_space(study):
    engine = default_engine()
    scenes = load_scenes(study, engine)
    objective = Objective(study, scenes, prepare_references(study, scenes, engine), engine)
    objective.warm_up()
    sets = []
    per_field = [[FieldModes(f.family, c) for f in s.families for c in range(f.min_count, f.max_count + 1)]
                 for s in study.search.fields]
    for combo in itertools.product(*per_field):
        sets.append(ModeSet({s.field: fm for s, fm in zip(study.search.fields, combo)}))
    table, t0 = {}, time.perf_counter()
    for ms in sets:
        rec = objective.evaluate(ms)
        table[ms.label()] = (rec["error"], rec["cost"], rec["n_dofs"], rec["errors"])
    return table, time.perf_counter() - t0


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
    ap.add_argument("--calibrate", action="store_true")
    ap.add_argument("--table", help="JSON file caching the enumeration (written if absent)")
    args = ap.parse_args(argv)
    if args.calibrate:
        calibrate()
        return
    study = sub_space_study()
    cache = Path(args.table) if args.table else None
    if cache is not None and cache.exists():
        import json
        data = json.loads(cache.read_text())
        table, wall = {k: tuple(v) for k, v in data["table"].items()}, data["wall_s"]
    else:
        table, wall = enumerate_space(study)
        if cache is not None:
            import json
            cache.write_text(json.dumps({"table": table, "wall_s": wall}))
    n = len(table)
    print(f"sub-space: tower_fa x tower_ss, families {FAMILIES}, 1-4 modes: {n} sets; "
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
