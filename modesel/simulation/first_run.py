"""The first simulation after install (or after a source change), when numba
compiles the engine into its on-disk cache.

The engine has three independent parts to compile: the flexible bodies'
invariant route (`multibody.invariant_sums`, a cfunc), the effects' loads
(`model.effects.compiled`: the cfunc `effect_loads` and the BEM, kinematics
and load-distribution functions it calls) and the integration loop
(`multibody.kernel`: the right-hand side, DOP853, the reaction loads), which
needs only the *types* of the other two, first-class functions of
`kernel.INVARIANT_SIG` and `kernel.LOADS_SIG`; a scene without effects runs
the same loops with loads that add nothing (`multibody.no_loads`), and one
whose bodies all take the node sums with a stand-in for the invariant route
(`packing.invariant_function`), so one compile serves every scene.
`compile_in_parallel` compiles the invariant route (where the scene uses
it) and the loads in a child process while this process compiles the
right-hand side against `NO_LOADS` and the stand-in; the child then
compiles the reaction loads over the output times on a small stand-in problem
(the kernel's argument types do not depend on the model), while this process
compiles DOP853. All land in numba's cache, from which the simulation then
loads them. On the 2-core machine this takes the first run of `steady_08` from
about 57 s to about 30 s of wall time (README, Benchmarks).

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
#: the module of the flexible bodies' invariant route (compiled by the child first)
INVARIANT_MODULE = "modesel.multibody.invariant_sums"


def index_files(module: str) -> list:
    """numba cache index files (*.nbi) of `module` in the places numba looks
    (`engine_cache.cache_places`: NUMBA_CACHE_DIR, else __pycache__ beside
    the source, then the user-wide cache)."""
    spec = importlib.util.find_spec(module)
    if spec is None or not spec.origin:
        return []
    source = Path(os.path.abspath(spec.origin))
    for place in cache_places(source.parent):
        found = list(place.glob(f"{source.stem}.*.nbi")) if place.is_dir() else []
        if found:
            return found
    return []


def is_cold(module: str) -> bool:
    """True when `module`'s compiled functions have no numba cache yet."""
    try:
        return not index_files(module)
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
    """Compile the invariant route (where `built` uses it), the effects' loads
    and then the kernel's reaction loads in a child process and the kernel's
    right-hand side and its explicit Runge-Kutta loop (one for DOP853 and
    RK45) here, at once,
    when the loads have no numba cache yet (module doc), also for a scene
    without effects (a later one with effects finds them compiled). Returns
    True when it ran. The child is waited for, and killed if this process is
    interrupted, so no process outlives the call; if it fails, the simulation
    compiles what it lacks itself, as without this step. Cheap when there is
    nothing to do (loads in Python, or the loads' module already imported)."""
    acting = getattr(built, "acting", None)
    if acting is None or not all(hasattr(e, "compile_loads") for e in acting):
        return False                # loads in Python: scipy's integrators, not the kernel's loops
    if LOADS_MODULE in sys.modules or not is_cold(LOADS_MODULE):
        return False
    package_root = str(Path(__file__).resolve().parents[2])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (package_root, os.environ.get("PYTHONPATH"))
                                                        if p))
    first = f"import {INVARIANT_MODULE}; " if uses_invariants(built.eq) else ""
    code = f"{first}import {LOADS_MODULE}; from {__name__} import compile_reactions; compile_reactions()"
    child = subprocess.Popen([sys.executable, "-c", code], env=env,
                             stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             preexec_fn=die_with_parent_signal if sys.platform.startswith("linux") else None)

    def right_hand_side_cached():
        """Tell the child (a line on its stdin, then end of file)."""
        try:
            child.stdin.write(b"\n")
            child.stdin.close()
        except OSError:         # the child has ended: the simulation compiles what it lacks
            pass
    try:
        _compile_kernel(built, right_hand_side_cached)
        child.wait()
    finally:
        if not child.stdin.closed:
            right_hand_side_cached()
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


def _compile_kernel(built, rhs_done) -> None:
    """Compile (or load) the kernel's right-hand side and its explicit
    Runge-Kutta loop (`kernel.runge_kutta`, run here as DOP853: the same
    compiled specialisation serves RK45) for
    `built`'s equations with `NO_LOADS`: the argument types of the
    simulation's own, with or without effects; `rhs_done()` once the
    right-hand side is compiled (and in numba's cache)."""
    from modesel.multibody.compiled import CompiledRHS
    from modesel.multibody.dop853_tableau import TABLE
    # NO_LOADS: the loads' type; node sums only: the invariant route's type
    # without its cfunc, which the child compiles meanwhile
    rhs = CompiledRHS(built.eq, built.linear, packed=built.eq.pack_free(invariants=False))
    q0, qd0 = np.asarray(built.q0, float), np.asarray(built.qd0, float)
    rhs(0.0, q0, qd0)
    rhs_done()
    if rhs.compilable:
        n = len(q0)
        x0 = np.concatenate([q0, qd0])
        rhs.dop853(x0, np.array([0.0, 1e-4]), 1e-4, 1e-6, np.full(2 * n, 1e-6), np.inf, np.full(n, np.inf),
                   TABLE)


#: the stand-in problem `compile_reactions` compiles on: the kernel's argument
#: types do not depend on the model (tests/test_fast_start.py checks it);
#: rigid, so that building it loads no invariant route (`packing.invariant_function`)
STAND_IN_SCENE = {"turbine": "nrel5mw", "modes": {},
                  "dofs": {"free": ["GeAz"]}, "initial": {"RotSpeed": 9.0}, "effects": {"gravity": True}}


def compile_reactions() -> None:
    """Compile (or load) the kernel's reaction loads (`CompiledRHS.outputs`)
    on the small `STAND_IN_SCENE` (`compile_in_parallel`'s child, after the
    loads). It first waits for a line or the end of file on stdin: the parent
    writes it once the right-hand side, which the reaction loads call, is in
    numba's cache, so that this process loads it from there instead of
    compiling it a second time."""
    from modesel.multibody.compiled import CompiledRHS
    from modesel.simulation.assembly import build
    from modesel.simulation.scene import scene_from_dict
    built = build(scene_from_dict(STAND_IN_SCENE), reactions=True)
    sys.stdin.readline()
    full = CompiledRHS(built.eq, built.linear, all_rows=True)
    q0, qd0 = np.asarray(built.q0, float), np.asarray(built.qd0, float)
    full.reactions(np.array([0.0]), q0[None, :], qd0[None, :], list(built.model.reactions.values())[:1])
