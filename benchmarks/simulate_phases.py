"""Where one `modesel simulate` spends its time, phase by phase, in a fresh
process (numba's cache warm): imports, loading the scene, each step of
`simulate` (build, linearisation, eigenvalues, stability check, integration,
channels) and writing the CSV as the command does (with Python's garbage
collector paused until the scene is read, as the command does).

Run: python3 benchmarks/simulate_phases.py [--tmax 20] [--all-channels] [--warm] [SCENE]
     (default SCENE: the OpenFAST case steady_08 with BEM)

--warm times the phases as `modesel serve` runs them: the scene is first
simulated for one output step (the server's warm-up, `server.WARM_TMAX_S`),
then a forked child does the timed run (imports none: the client's own
start, about 0.05 s, is not in these figures).

The steps are timed by wrapping the functions `simulation.transient` calls;
"simulate" is the whole call, so it also holds what no step names (numba
loading the compiled functions from its cache on their first call).
"""
import time

T0 = time.perf_counter()
import gc  # noqa: E402

gc.disable()          # as `modesel simulate` (commands._common.collector_paused) until the scene is read
import argparse  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from modesel.commands.simulate import written_channels, written_columns  # noqa: E402
from modesel.files import columns_csv_text  # noqa: E402
from modesel.simulation import transient  # noqa: E402
from modesel.simulation.api import load_scene, simulate  # noqa: E402

T1 = time.perf_counter()
STEPS = ("build", "linearize", "eigenvalues", "check_static_stability", "integrate", "channels")
spent = {}


def timed(name):
    f = getattr(transient, name)

    def wrapper(*args, **kwargs):
        t = time.perf_counter()
        try:
            return f(*args, **kwargs)
        finally:
            spent[name] = spent.get(name, 0.0) + time.perf_counter() - t
    return wrapper


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", nargs="?", default=str(REPO / "studies/data/openfast/steady_08/steady_08.fst"))
    p.add_argument("--tmax", type=float, default=20.0, help="simulated time [s]")
    p.add_argument("--all-channels", action="store_true", help="every channel, as `modesel simulate --all-channels`")
    p.add_argument("--warm", action="store_true", help="as `modesel serve`'s forked child, after its warm-up")
    a = p.parse_args()
    global T0, T1
    if a.warm:
        import os

        from modesel.multibody.blas import keep_one_thread
        from modesel.server import WARM_TMAX_S
        keep_one_thread()               # as the server (`Server.serve_forever`)
        warm = load_scene(a.scene)
        simulate(warm, tmax=WARM_TMAX_S, dt=WARM_TMAX_S, channels=written_channels(warm, a.all_channels))
        gc.freeze()
        pid = os.fork()
        if pid:
            os.waitpid(pid, 0)
            return
        T0 = T1 = time.perf_counter()
    for name in STEPS:
        setattr(transient, name, timed(name))
    t2 = time.perf_counter()
    scene = load_scene(a.scene)
    gc.freeze()
    gc.enable()
    t3 = time.perf_counter()
    outlist = written_channels(scene, a.all_channels)       # as the command
    result = simulate(scene, tmax=a.tmax, channels=outlist)
    t4 = time.perf_counter()
    units = dict(result.units, Time="s")
    columns = written_columns(result, outlist)
    columns_csv_text(columns, {c: units.get(c, "?") for c in columns})
    t5 = time.perf_counter()
    print(f"{Path(a.scene).name}, {a.tmax:g} s simulated ({result.n_dofs} DOFs, {result.method}, "
          f"{result.n_rhs} right-hand sides)")
    print(f"  imports      {T1 - T0:6.3f} s")
    print(f"  load_scene   {t3 - t2:6.3f} s")
    print(f"  simulate     {t4 - t3:6.3f} s, of which:")
    for name in STEPS:
        print(f"    {name:<24} {spent.get(name, 0.0):6.3f} s")
    print(f"  CSV text     {t5 - t4:6.3f} s")
    print(f"  total        {t5 - T0:6.3f} s (" + ("the forked child, after the warm-up)" if a.warm else
                                               "this process, after the interpreter's own start)"))


if __name__ == "__main__":
    main()
