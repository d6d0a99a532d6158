"""The first simulation after install (or after a source change), when numba
compiles the engine into its on-disk cache.

The engine has four independent parts to compile: the flexible bodies'
invariant route (`multibody.invariant_sums`, a cfunc), the effects' loads
(`model.effects.compiled`: the one cfunc of `loads_function(tower, field)`
the scene runs, `effect_loads` or its variant with AeroDyn's tower influence
and/or a full-field wind, and the BEM, kinematics and load-distribution
functions it calls), the right-hand side
(`multibody.system_function`: the cfunc of `kernel.free_system`) and the
loops that call it through a pointer (`kernel.runge_kutta` for DOP853 and
RK45, `kernel.reaction_loads`). Each needs only the *types* of the others
(first-class functions of `kernel.INVARIANT_SIG`, `kernel.LOADS_SIG` and
`kernel.SYSTEM_SIG`); a scene without effects runs the same loops with loads
that add nothing (`multibody.no_loads`), and one whose bodies all take the
node sums with a stand-in for the invariant route
(`packing.invariant_function`), so one compile serves every scene.
`compile_in_parallel` compiles the invariant route (where the scene uses
it), the loads and then the reaction loads (for their argument types alone)
in a child process, while this process compiles the right-hand side against
`NO_LOADS` and the stand-in, and then the Runge-Kutta loop (where the scene
uses the invariant route, whose compile lengthens the child's share, this
process compiles the reaction loads too). A scene without effects does not
compile the loads (28 s of one core, which it never calls; the first scene
with effects compiles them beside loading the rest): the child compiles the
invariant route (where used) and the loops, this process the right-hand
side. A scene with gearbox losses has this process compile their cfunc
(`multibody.gearbox_loss`) too, when its right-hand side is packed (the
child's share, the loads, is the longer). All land in numba's cache, from
which the simulation then loads them. Timings: docs/benchmarks.md.

`index_files` and `is_cold` tell whether a module's compiled functions are
in numba's cache yet (`simulation.progress` uses them for its notice).
"""
from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from modesel.engine_cache import cache_places

#: the module of the effects' compiled loads (compiled by the child)
LOADS_MODULE = "modesel.model.effects.compiled"
#: the cfuncs of the loads in LOADS_MODULE, without and with AeroDyn's tower
#: influence and/or a full-field wind, {(tower, field): function}
#: (`loads_function(tower, field)`): the child compiles the one a scene runs
LOADS_VARIANTS = {(False, False): "effect_loads", (True, False): "_loads_tower", (False, True): "_loads_field",
                  (True, True): "_loads_tower_field"}
#: the module of the flexible bodies' invariant route (compiled by the child first)
INVARIANT_MODULE = "modesel.multibody.invariant_sums"
#: the module whose import compiles the right-hand side's cfunc (by this process), and
#: where numba caches it: under the module and name of the function it compiles
SYSTEM_MODULE = "modesel.multibody.system_function"
SYSTEM_CACHE = ("modesel.multibody.kernel", "free_system")


def index_files(module: str, function: str | None = None) -> list:
    """numba cache index files (*.nbi) of `module` (of its `function` alone
    if given) in the places numba looks (`engine_cache.cache_places`:
    NUMBA_CACHE_DIR, else __pycache__ beside the source, then the user-wide
    cache)."""
    spec = importlib.util.find_spec(module)
    if spec is None or not spec.origin:
        return []
    source = Path(os.path.abspath(spec.origin))
    for place in cache_places(source.parent):
        pattern = f"{source.stem}.{function}-*.nbi" if function else f"{source.stem}.*.nbi"
        found = list(place.glob(pattern)) if place.is_dir() else []
        if found:
            return found
    return []


def is_cold(module: str, function: str | None = None) -> bool:
    """True when `module`'s compiled functions (its `function` if given) have
    no numba cache yet."""
    try:
        return not index_files(module, function)
    except OSError:
        return False


def die_with_parent_signal() -> None:
    """Linux: this process gets SIGKILL when its parent dies (PR_SET_PDEATHSIG);
    elsewhere nothing. Run in a child (here before exec; the search's workers,
    `study.search.runner.die_with_parent`)."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes
        import signal
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):
        pass


def compile_in_parallel(built) -> bool:
    """Compile the parts of the engine (module doc) in a child process and
    here at once: for a scene with effects when the loads have no numba
    cache yet, for one without when the right-hand side has none. Returns
    True when it ran. The child is waited for, and killed if this process is
    interrupted, so no process outlives the call; if it fails, the simulation
    compiles what it lacks itself, as without this step. Cheap when there is
    nothing to do (loads in Python, or the loads' module already imported)."""
    acting = getattr(built, "acting", None)
    if acting is None or not all(hasattr(e, "compile_loads") for e in acting):
        return False                # loads in Python: scipy's integrators, not the kernel's loops
    with_loads = len(acting) > 0
    tower = with_loads and any(getattr(e, "tower_influence", False) for e in acting)
    wind = built.effect("wind") if with_loads else None
    field = getattr(wind, "full_field", None) is not None
    module = LOADS_MODULE if with_loads else SYSTEM_MODULE
    cache = (LOADS_MODULE, LOADS_VARIANTS[tower, field]) if with_loads else SYSTEM_CACHE
    if module in sys.modules or not is_cold(*cache):
        return False
    package_root = str(Path(__file__).resolve().parents[2])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (package_root, os.environ.get("PYTHONPATH"))
                                                        if p))
    invariants = uses_invariants(built.eq)
    first = f"import {INVARIANT_MODULE}; " if invariants else ""
    if with_loads:
        loops = () if invariants else ("reaction_loads",)
        here = ("runge_kutta",) + (("reaction_loads",) if invariants else ())
        first += f"import {LOADS_MODULE}; {LOADS_MODULE}.loads_function({tower}, {field}); "
    else:
        loops, here = ("runge_kutta", "reaction_loads"), ()
    code = f"{first}from {__name__} import compile_loops; compile_loops({loops!r})"
    child = subprocess.Popen([sys.executable, "-c", code], env=env,
                             stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             preexec_fn=die_with_parent_signal if sys.platform.startswith("linux") else None)
    try:
        _compile_system(built)
        compile_loops(here)
        child.wait()
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    return True


def uses_invariants(eq) -> bool:
    """Whether a flexible body of `eq` (`KaneEquations`) takes the invariant
    route (`body_integrals.choose_invariants`), whose cfunc the child then
    compiles first."""
    from modesel.multibody.body_integrals import choose_invariants
    return any(f is not None and choose_invariants(f) for _, _, f in eq.bodies)


def _compile_system(built) -> None:
    """Compile (or load) the right-hand side's cfunc (`system_function`) and
    its Python front (`kernel.call_system`) for `built`'s equations with
    `NO_LOADS` and the node sums only: the argument types of the
    simulation's own, with or without effects or the invariant route (whose
    cfunc the child compiles meanwhile)."""
    from modesel.multibody.compiled import CompiledRHS
    rhs = CompiledRHS(built.eq, built.linear, packed=built.eq.pack_free(invariants=False))
    rhs(0.0, np.asarray(built.q0, float), np.asarray(built.qd0, float))


def loop_signatures() -> dict:
    """{name: numba argument types} of the kernel's loops `runge_kutta` and
    `reaction_loads` (also the linear model's) as `compiled.CompiledRHS`
    calls them: the right-hand
    side as a first-class function of `kernel.SYSTEM_SIG`, the problem's
    arrays of `kernel.PROB_T`, `RWORK_T`, `DATA_T`, `WORK_T` (the types of
    every scene: tests/test_fast_start.py), the tableau of DOP853 (RK45's
    has the same types)."""
    from numba import typeof, types

    from modesel.multibody import kernel
    from modesel.multibody.dop853_tableau import TABLE
    system = types.FunctionType(kernel.SYSTEM_SIG)
    f1, f2, i1 = typeof(np.zeros(1)), typeof(np.zeros((1, 1))), typeof(np.zeros(1, np.int64))
    problem = (kernel.PROB_T, kernel.RWORK_T, kernel.DATA_T, kernel.WORK_T)
    return {"runge_kutta": (system, f1, f1, typeof(1.0), typeof(1.0), f1, typeof(1.0), f1, typeof(tuple(TABLE)),
                            typeof(kernel.DOP853_KIND)) + problem + (f2, f1),
            "reaction_loads": (system, typeof(kernel.SOLVE), f1, f2, i1, i1) + problem + (f2,)}


def compile_loops(names) -> None:
    """Compile (or load) the kernel's loops `names` (of `loop_signatures`)
    for their argument types, without running them: they call the
    right-hand side through a pointer, so they need its type, not its code."""
    from modesel.multibody import kernel
    signatures = loop_signatures()
    for name in names:
        getattr(kernel, name).compile(signatures[name])
