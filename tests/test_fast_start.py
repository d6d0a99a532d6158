"""Fast start of `modesel simulate` (issue 12): the simulate path imports no
search, plotting or symbolic package, parsed decks are cached, and the first
run compiles the loads in a child process that never outlives the command."""
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from test_interrupt import terminal_sigint

ROOT = Path(__file__).resolve().parents[1]
DECAY = ROOT / "studies/data/openfast_free_decay/tower_fa_ss_shaft/Spar_ED_ForED.dat"
#: packages `modesel simulate` must not import (search, plotting, symbolic, the
#: candidate-family command; scipy's integrators and splines, 0.17 s together,
#: which a compiled run of the deck's shapes does not use; pandas, 0.17 s: the
#: CSV is written from the result's columns; the package scipy.linalg, 0.15 s:
#: numba's BLAS module is loaded alone, `blas.load_scipy_blas`)
NOT_ON_SIMULATE_PATH = ("optuna", "matplotlib", "sympy", "pandas", "modesel.commands.candidates",
                        "modesel.commands.run", "modesel.multibody.symbolic",
                        "scipy.integrate", "scipy.interpolate", "scipy.linalg")


def test_simulate_imports_no_optuna_matplotlib_or_sympy(tmp_path):
    out = tmp_path / "decay.csv"
    code = (
        "import json, sys\n"
        "from modesel.cli import main\n"
        f"rc = main(['simulate', {str(DECAY)!r}, '--tmax', '0.05', '--out', {str(out)!r}])\n"
        f"print(json.dumps([rc, [m for m in {NOT_ON_SIMULATE_PATH!r} if m in sys.modules]]))\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
               MODESEL_CACHE_DIR=str(tmp_path / "cache"))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                          cwd=tmp_path, timeout=900)
    assert done.returncode == 0, done.stderr
    rc, imported = json.loads(done.stdout.strip().splitlines()[-1])
    assert rc == 0 and out.is_file()
    assert imported == []


def test_simulate_ends_at_once_with_its_output_and_exit_code(tmp_path):
    """`python -m modesel simulate` (`cli.entry`) ends the process without
    Python's shutdown once the command returns: what it printed arrives
    whole through a pipe, a reader that closes the pipe after one line gets
    no traceback, and the exit codes stay (0; 2 with one line for an error)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    command = [sys.executable, "-m", "modesel", "simulate", str(DECAY), "--tmax", "0.05", "--out"]
    done = subprocess.run(command + [str(tmp_path / "a.csv")], capture_output=True, text=True, env=env)
    assert done.returncode == 0 and (tmp_path / "a.csv").is_file()
    lines = done.stdout.splitlines()
    assert lines[0].startswith("Spar_ED_ForED: ") and any(line.endswith(f"-> {tmp_path / 'a.csv'}") for line in lines)
    proc = subprocess.Popen(command + [str(tmp_path / "b.csv")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env=env, text=True)
    proc.stdout.readline()
    proc.stdout.close()                 # as `| head -1`
    err = proc.stderr.read()
    assert proc.wait() in (0, -signal.SIGPIPE) and "Traceback" not in err, err
    bad = subprocess.run(command[:4] + [str(tmp_path / "none.fst"), "--out", str(tmp_path / "c.csv")],
                         capture_output=True, text=True, env=env)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1 and "none.fst" in bad.stderr


def test_scipy_blas_loaded_alone_serves_numba_and_scipy():
    """`load_scipy_blas` loads scipy's BLAS module without the package
    scipy.linalg; numba's matrix product then runs on it (against numpy's),
    and scipy.linalg imported afterwards works and hands out the same module."""
    code = (
        "import sys, numpy as np, numba\n"
        "from modesel.multibody.blas import load_scipy_blas\n"
        "blas = load_scipy_blas()\n"
        "alone = 'scipy.linalg' not in sys.modules\n"
        "dot = numba.njit(lambda a, b: np.dot(a, b))\n"
        "a, b = np.random.default_rng(1).random((2, 40, 40))\n"
        "same = bool(np.allclose(dot(a, b), a @ b, rtol=1e-13, atol=0))\n"
        "import scipy.linalg\n"
        "from scipy.linalg import cython_blas\n"
        "lam = scipy.linalg.eigh(a @ a.T + np.eye(40), eigvals_only=True)\n"
        "print(alone, same, cython_blas is blas, bool(np.allclose(lam, np.linalg.eigvalsh(a @ a.T + np.eye(40)))))\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["True"] * 4


def test_forked_child_of_a_one_thread_blas_starts_no_blas_threads():
    """After a fork OpenBLAS starts its pool of threads again when its count
    is set (they spin about 0.1 s, taking a 2-core machine's time from the
    simulation): `single_thread_blas` leaves a BLAS already at one thread
    alone, so a child of a process that keeps one thread (`keep_one_thread`,
    `modesel serve`) runs with its one thread, while setting the count in a
    child of a two-thread BLAS starts the pool (the case it avoids)."""
    code = textwrap.dedent("""
        import os
        from modesel.multibody import blas
        def threads_in_child(action):
            pid = os.fork()
            if pid == 0:
                action()
                os._exit(len(os.listdir("/proc/self/task")))
            return os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
        def simulate_like():
            with blas.single_thread_blas():
                pass
        def set_one():
            for _, set_ in blas._blas_thread_controls():
                set_(1)
        blas.load_scipy_blas()
        assert blas._blas_thread_controls()
        started = threads_in_child(set_one)
        blas.keep_one_thread()
        print(started, threads_in_child(simulate_like))
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                          env=dict(os.environ, OPENBLAS_NUM_THREADS="2"))
    assert done.returncode == 0, done.stderr
    started, kept = map(int, done.stdout.split())
    assert started > 1 and kept == 1


def test_collector_paused_while_importing_then_restored():
    """`modesel simulate` imports with the garbage collector off; `started()`
    freezes what that made and turns the collector on; on leaving (also on an
    error) nothing stays frozen and the collector is as it was."""
    import gc

    from modesel.commands._common import collector_paused
    try:
        for enabled in (True, False):
            (gc.enable if enabled else gc.disable)()
            with collector_paused() as started:
                assert not gc.isenabled()
                started()
                assert gc.isenabled() is enabled and gc.get_freeze_count() > 0
            assert gc.isenabled() is enabled and gc.get_freeze_count() == 0
        gc.enable()
        with pytest.raises(ValueError), collector_paused():
            raise ValueError("a bad input while reading")
        assert gc.isenabled() and gc.get_freeze_count() == 0
        with collector_paused() as started:
            started()
            gc.collect()
            cycle = [[]]
            cycle[0].append(cycle)
            del cycle
            assert gc.collect() >= 2            # made after started(): collected
    finally:
        gc.unfreeze()
        gc.enable()


@pytest.mark.parametrize("argv, command", [
    (["simulate", "x.fst"], "simulate"), (["--debug", "simulate", "x"], "simulate"),
    (["--help"], None), ([], None), (["simulat", "x"], None), (["--", "simulate"], None)])
def test_cli_builds_only_the_named_command(argv, command):
    from modesel import cli
    assert cli.command_of(argv) == command


def test_parsed_decks_are_cached_and_reread_when_a_file_changes(tmp_path, monkeypatch):
    import shutil

    from modesel.turbine import deck_cache
    from modesel.turbine.elastodyn import read_elastodyn
    monkeypatch.setenv("MODESEL_CACHE_DIR", str(tmp_path / "cache"))
    case = tmp_path / "case"
    shutil.copytree(DECAY.parent, case, ignore=shutil.ignore_patterns("*.outb"))
    main = case / DECAY.name
    first = read_elastodyn(main)
    entries = sorted((tmp_path / "cache" / "decks").glob("*.pickle"))
    assert len(entries) == 3            # main, blade and tower decks, one entry each
    stamps = [e.stat().st_mtime_ns for e in entries]
    again = read_elastodyn(main)        # from the cache: entries not rewritten
    assert [e.stat().st_mtime_ns for e in entries] == stamps
    assert again.tip_radius == first.tip_radius == 63.0
    # a changed deck (other size and time) is read again
    text = main.read_text().replace("63   TipRad", "64.5   TipRad")
    assert text != main.read_text()
    main.write_text(text)
    os.utime(main, ns=(main.stat().st_atime_ns, main.stat().st_mtime_ns + 10**9))
    assert read_elastodyn(main).tip_radius == 64.5
    # switched off: no entries written
    monkeypatch.setenv("MODESEL_CACHE_DIR", "off")
    assert deck_cache.cache_dir() is None


def test_aero_deck_kept_in_the_process_is_read_again_when_a_file_changes(tmp_path, monkeypatch):
    """The aero effects take their AeroDyn deck from `aerodyn.shared_aerodyn`
    (`effects.aero.aerodyn_deck`):
    the same object while its files are unchanged, and the deck as it now
    is after an edit of the main file or of an airfoil file (it was kept by
    path alone, so a warm server's commands ran the deck of its first run)."""
    import shutil

    from modesel.turbine.aerodyn import shared_aerodyn
    monkeypatch.setenv("MODESEL_CACHE_DIR", str(tmp_path / "cache"))
    common = tmp_path / "common"
    shutil.copytree(ROOT / "studies/data/openfast/common", common)
    main = common / "NREL5MW_AD_v5.dat"
    first = shared_aerodyn(main)
    assert shared_aerodyn(main) is first and first.bem.tip_loss
    main.write_text(main.read_text().replace("True          TipLoss", "False         TipLoss"))
    os.utime(main, ns=(main.stat().st_atime_ns, main.stat().st_mtime_ns + 10**9))
    edited = shared_aerodyn(main)
    assert edited is not first and not edited.bem.tip_loss
    polar = Path(sorted(p.name for b in edited.blades for p in b.polars.polars)[-1])
    polar = polar if polar.is_absolute() else common / polar
    cl_before = edited.blades[0].polars.arrays[1].copy()
    lines = polar.read_text().splitlines()
    row = next(i for i, line in enumerate(lines) if line.split()[:1] == ["0.00"])  # alpha 0 deg
    cols = lines[row].split()
    cols[1] = f"{float(cols[1]) + 0.05:.4f}"
    lines[row] = "  ".join(cols)
    polar.write_text("\n".join(lines) + "\n")
    os.utime(polar, ns=(polar.stat().st_atime_ns, polar.stat().st_mtime_ns + 10**9))
    again = shared_aerodyn(main)
    assert again is not edited and not np.array_equal(again.blades[0].polars.arrays[1], cl_before)


def test_deck_cache_keeps_at_most_max_entries(tmp_path, monkeypatch):
    from modesel.turbine import deck_cache
    monkeypatch.setenv("MODESEL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(deck_cache, "MAX_ENTRIES", 4)
    reads = []
    for k in range(6):
        deck = tmp_path / f"deck{k}.dat"
        deck.write_text(f"value {k}\n")
        assert deck_cache.cached(lambda p: reads.append(p) or Path(p).read_text(), deck) == f"value {k}\n"
    assert len(reads) == 6
    assert 2 <= len(list((tmp_path / "cache" / "decks").glob("*.pickle"))) <= 4


def test_deck_cache_is_skipped_while_its_code_changed_after_import(tmp_path, monkeypatch):
    """A reader module whose source is newer than the process's import of
    the cache (an upgrade or an edit while a search runs): its values are
    neither taken from the cache nor written to it, so no entry pickled by
    the older code is stamped with the newer source."""
    import importlib
    import time

    from modesel.turbine import deck_cache
    monkeypatch.setenv("MODESEL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.syspath_prepend(str(tmp_path))
    source = tmp_path / "modesel_test_reader.py"
    source.write_text("FORMAT = 1\n")
    importlib.import_module("modesel_test_reader")
    past = deck_cache._IMPORTED_NS - 10**9
    os.utime(source, ns=(past, past))                     # installed before this process started
    deck = tmp_path / "deck.dat"
    deck.write_text("value\n")
    reads = []

    def reader(p):
        reads.append(p)
        return Path(p).read_text()
    for _ in range(2):
        assert deck_cache.cached(reader, deck, code=("modesel_test_reader",)) == "value\n"
    entries = list((tmp_path / "cache" / "decks").glob("*.pickle"))
    assert len(reads) == 1 and len(entries) == 1
    written = entries[0].stat().st_mtime_ns
    later = time.time_ns() + 10**9
    os.utime(source, ns=(later, later))                   # the source changes under the running process
    for _ in range(2):
        assert deck_cache.cached(reader, deck, code=("modesel_test_reader",)) == "value\n"
    assert len(reads) == 3                                # read each time, the entry not taken
    assert [e.stat().st_mtime_ns for e in entries] == [written]     # nor rewritten
    assert len(list((tmp_path / "cache" / "decks").glob("*"))) == 1


STEADY_08 = ROOT / "studies/data/openfast/steady_08/steady_08.fst"


def _cold_simulate(tmp_path, out, site=None):
    """`modesel simulate` of steady_08 (BEM loads) with an empty numba cache,
    in a subprocess (with `site`'s sitecustomize.py when given)."""
    path = [str(site)] if site else []
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(path + [str(ROOT), os.environ.get("PYTHONPATH", "")]),
               NUMBA_CACHE_DIR=str(tmp_path / "numba"), MODESEL_CACHE_DIR=str(tmp_path / "cache"))
    return subprocess.Popen([sys.executable, "-m", "modesel", "simulate", str(STEADY_08), "--tmax", "0.2",
                             "--out", str(out)], env=env, cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=terminal_sigint)


def _children(pid: int) -> list:
    """(pid, command line) of the live children of `pid` (Linux /proc)."""
    out = []
    for status in Path("/proc").glob("[0-9]*/status"):
        try:
            fields = dict(line.split(":\t", 1) for line in status.read_text().splitlines() if ":\t" in line)
            if int(fields.get("PPid", "0")) == pid and not fields.get("State", "").startswith("Z"):
                cmd = (status.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
                out.append((int(status.parent.name), cmd))
        except (OSError, ValueError):
            continue
    return out


def _alive(pid: int) -> bool:
    """Whether process `pid` runs (a zombie does not)."""
    try:
        state = Path(f"/proc/{pid}/status").read_text().split("State:\t", 1)[1]
    except (OSError, IndexError):
        return False
    return not state.startswith("Z")


@pytest.mark.skipif(not Path("/proc/self/status").is_file(), reason="needs Linux /proc to see the child")
def test_first_run_child_compiling_the_loads_never_outlives_the_command(tmp_path):
    """First run of a scene with BEM loads (empty numba cache): a child process
    compiles the effects' loads while the command compiles the kernel
    (`simulation.first_run`); Ctrl-C meanwhile stops the command with its
    one line and exit code 130, and the child is gone with it."""
    proc = _cold_simulate(tmp_path, tmp_path / "out.csv")
    deadline = time.monotonic() + 120
    child = []
    while not child:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no child compiling the loads"
        child = [pid for pid, cmd in _children(proc.pid) if "modesel.model.effects.compiled" in cmd]
        time.sleep(0.1)
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == "modesel: interrupted (SIGINT)" and "Traceback" not in err
    assert not _alive(child[0])


# Makes every call of llvmlite's object-cache callback (ctypes, run while numba
# compiles) last 0.3 s and mark itself with a file named after its process (the
# child that compiles the loads has callbacks of its own), so that a signal can
# be sent to the command while the callback runs.
SLOW_CALLBACK = """
import os, time
from llvmlite.binding import executionengine

_set = executionengine.ExecutionEngine.set_object_cache
_MARK = {mark!r} + "." + str(os.getpid())


def set_object_cache(self, notify_func=None, getbuffer_func=None):
    def slow_notify(module, buf):
        open(_MARK, "w").close()
        try:
            time.sleep(0.3)
        finally:
            os.remove(_MARK)
        return notify_func(module, buf)
    return _set(self, slow_notify if notify_func else None, getbuffer_func)


executionengine.ExecutionEngine.set_object_cache = set_object_cache
"""


def test_ctrl_c_while_numba_runs_a_ctypes_callback_still_stops_the_command(tmp_path):
    """The CI failure of stop 17: Ctrl-C landed in llvmlite's object-cache
    callback, which ctypes runs and where a raised exception is printed and
    dropped; the compiler, left half-done, then failed ("no compiled object
    yet", exit code 1 with a traceback), or the Ctrl-C was lost and the
    command ran to the end (exit code 0). The handler now delivers the signal
    again outside the callback (modesel.cli doc): one line, exit code 130."""
    from llvmlite.binding import executionengine
    if not hasattr(executionengine.ExecutionEngine, "set_object_cache"):
        pytest.skip("this llvmlite has no ExecutionEngine.set_object_cache to slow down")
    site = tmp_path / "site"
    site.mkdir()
    mark = tmp_path / "in_callback"
    (site / "sitecustomize.py").write_text(SLOW_CALLBACK.format(mark=str(mark)))
    proc = _cold_simulate(tmp_path, tmp_path / "out.csv", site=site)
    mark = tmp_path / f"in_callback.{proc.pid}"
    deadline = time.monotonic() + 120
    while not mark.exists():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "numba's object-cache callback never ran"
        time.sleep(0.005)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == "modesel: interrupted (SIGINT)" and "Traceback" not in err
    assert not (tmp_path / "out.csv").exists()


def test_cold_cache_is_told_apart_for_modules_of_one_name(tmp_path):
    """`first_run.is_cold` finds a module's numba index in the folder numba
    names after that module's source folder: with `pkg_a/compiled.py` cached,
    `pkg_b/compiled.py` is still cold, under NUMBA_CACHE_DIR and beside the
    sources (modesel has `effects/compiled.py`, the loads the first run
    compiles in a child, and `multibody/compiled.py`; the two were confused
    once the latter held a cfunc, and a first run compiled all in one
    process)."""
    for pkg in ("pkg_a", "pkg_b"):
        (tmp_path / pkg).mkdir()
        (tmp_path / pkg / "__init__.py").write_text("")
        (tmp_path / pkg / "compiled.py").write_text(
            "from numba import njit\n\n@njit(cache=True)\ndef f(x):\n    return x + 1\n")
    code = ("import json, pkg_a.compiled\n"
            "pkg_a.compiled.f(1)\n"
            "from modesel.simulation.first_run import is_cold\n"
            "print(json.dumps([is_cold('pkg_a.compiled'), is_cold('pkg_b.compiled')]))\n")
    path = os.pathsep.join([str(tmp_path), str(ROOT), os.environ.get("PYTHONPATH", "")])
    for cache in (str(tmp_path / "numba"), None):
        env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
        env.update(PYTHONPATH=path, **({"NUMBA_CACHE_DIR": cache} if cache else {}))
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                              timeout=600, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        assert json.loads(done.stdout.strip().splitlines()[-1]) == [False, True], cache


#: a small rigid scene (no invariant route, no effects but gravity)
SMALL_RIGID = {"turbine": "nrel5mw", "modes": {}, "dofs": {"free": ["GeAz"]}, "initial": {"RotSpeed": 9.0},
               "effects": {"gravity": True}}


def test_kernel_argument_types_do_not_depend_on_the_model():
    """The first run compiles the right-hand side on the scene's own
    equations without its loads or invariant route, and the loops for
    their argument types alone (`first_run.loop_signatures`): numba's types
    of the kernel's arguments (problem, work arrays, packed equations) are
    `kernel.PROB_T`, `RWORK_T`, `DATA_T`, `WORK_T` for a small rigid scene,
    an OpenFAST case with BEM (its packed loads), a tower-only scene
    (`no_loads.NO_LOADS`) and the turbine scene, whose flexible bodies take
    the invariant route (`invariant_sums`), so the compiled loops serve
    them all."""
    from numba import typeof, types

    from modesel.multibody import kernel
    from modesel.multibody.compiled import CompiledRHS
    from modesel.simulation import first_run
    from modesel.simulation.api import build, load_scene
    from modesel.simulation.scene import scene_from_dict
    scenes = [scene_from_dict(SMALL_RIGID), load_scene(str(STEADY_08)),
              load_scene(str(ROOT / "studies" / "scenes" / "paper_3dof_land.toml")),
              load_scene(str(ROOT / "studies" / "scenes" / "turbine_wind_11p4.toml"))]
    builts = [build(s, reactions=True) for s in scenes]
    kinds = set()
    for b in builts:
        for rhs in (b.rhs(all_rows=True), CompiledRHS(b.eq, b.linear, all_rows=True)):
            kinds.add(typeof((rhs.prob, rhs.rwork, rhs.packed.data, rhs.packed.work)))
    assert builts[1].rhs().has_loads and not builts[2].rhs().has_loads
    # the OpenFAST case's bodies take the node sums (the invariant route's
    # stand-in), the turbine scene's the invariants (its cfunc): one type
    routes = [first_run.uses_invariants(b.eq) for b in builts]
    assert routes[1] is False and routes[3] is True
    assert kinds == {types.Tuple((kernel.PROB_T, kernel.RWORK_T, kernel.DATA_T, kernel.WORK_T))}


def test_loops_are_called_with_the_types_the_first_run_compiles():
    """The integration loop and the reaction loads (also the linear model's),
    run as a simulation runs them, take exactly the argument types `first_run.compile_loops` compiles
    them for (else the first run would have compiled them for nothing), and
    the right-hand side's cfunc is of `kernel.SYSTEM_SIG`."""
    from numba import typeof, types

    from modesel.multibody import kernel
    from modesel.multibody.system_function import FREE_SYSTEM
    from modesel.simulation import first_run
    from modesel.simulation.api import build, load_scene
    assert typeof(FREE_SYSTEM) == types.FunctionType(kernel.SYSTEM_SIG)
    built = build(load_scene(str(STEADY_08)), reactions=True)
    rhs = built.rhs(all_rows=True)
    x0 = np.concatenate([built.q0, built.qd0]).astype(float)
    n = rhs.n_free
    code, *_ = rhs.rk45(x0, np.array([0.0, 0.01]), 0.01, 1e-5, np.full(2 * n, 1e-6), np.inf, np.full(n, np.inf))
    assert code == kernel.OK
    rhs.outputs(np.array([0.0]), np.asarray(built.q0, float)[None, :], np.asarray(built.qd0, float)[None, :],
                rows=list(built.model.reactions.values())[:1])
    rhs.linear_model(0.0, built.q0, built.qd0, 1e-6)
    expected = first_run.loop_signatures()
    assert [tuple(s) for s in kernel.runge_kutta.signatures] == [expected["runge_kutta"]]
    assert [tuple(s) for s in kernel.reaction_loads.signatures] == [expected["reaction_loads"]]


@pytest.mark.slow
def test_first_run_compiled_in_parallel_gives_the_warm_run(tmp_path):
    """The cold run (loads compiled by the child, the kernel against a stand-in
    of the loads' type) writes the child's cache, all the warm run needs, and
    the outputs of a warm run,
    to the integration tolerance: freshly compiled and cache-loaded code round
    differently in the last digits (fastmath reassociation in the node sums),
    which moves the adaptive steps (rtol 1e-5 of an OpenFAST case)."""
    cold = tmp_path / "cold.csv"
    proc = _cold_simulate(tmp_path, cold)
    _, err = proc.communicate(timeout=900)
    assert proc.returncode == 0, err
    assert (tmp_path / "numba").is_dir() and list((tmp_path / "numba").glob("**/compiled.effect_loads*.nbi"))
    compiled = sorted((tmp_path / "numba").glob("**/*.nbc"))
    warm = tmp_path / "warm.csv"
    proc = _cold_simulate(tmp_path, warm)
    _, err = proc.communicate(timeout=900)
    assert proc.returncode == 0, err
    # the warm run compiled nothing: the first run compiled what it needs, for its types
    assert sorted((tmp_path / "numba").glob("**/*.nbc")) == compiled
    from modesel.files import read_unit_csv
    a, b = read_unit_csv(cold), read_unit_csv(warm)
    assert list(a.columns) == list(b.columns) and len(a) == len(b) > 2
    for c in a.columns:
        x, y = a[c].to_numpy(float), b[c].to_numpy(float)
        assert np.all(np.abs(x - y) <= 1e-3 * (np.ptp(y) + np.abs(y).max()) + 1e-9), c


def test_node_sums_alone_load_no_invariant_route():
    """A system whose flexible bodies all take the node sums runs the kernel
    with the invariant route's stand-in (`packing.invariant_function`): in a
    fresh interpreter, before any numba cfunc exists, numba types it (its
    typeof is registered by `packing`) and the invariant route's cfunc is
    never loaded (about 35 ms saved)."""
    code = ("import sys\n"
            "import numpy as np\n"
            "from modesel.model.template import build_turbine\n"
            "from modesel.modeset import FieldModes, ModeSet\n"
            "from modesel.multibody import kernel, packing\n"
            "from modesel.multibody.kane import KaneEquations\n"
            "from modesel.turbine.elastodyn import load_turbine\n"
            "system = build_turbine(load_turbine('nrel5mw'), ModeSet({'tower_fa': FieldModes('elastodyn', 1)}),\n"
            "                       free=('GeAz',)).system\n"
            "eq = KaneEquations(system)\n"
            "p = packing.pack(eq, invariants=False)\n"
            "kernel.kinematics(np.zeros(eq.n_all), np.zeros(eq.n_all), p.data, p.work)\n"
            "print('modesel.multibody.invariant_sums' in sys.modules)\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1] == "False"


def test_first_run_of_a_scene_without_effects_leaves_the_loads(tmp_path, monkeypatch):
    """`first_run.compile_in_parallel` on an empty cache: a scene without
    effects compiles the right-hand side here and the loops in the child,
    not the effects' loads it never calls (28 s of one core, which made
    paper_3dof_land's first run 43-48 s instead of 26-32 s); a scene with
    BEM loads has the child compile them (the one variant of the loads it
    runs: with the tower's influence for a scene with it, and not the loads
    without). It is decided by the cache of the
    right-hand side's cfunc, which numba keeps under `kernel.free_system`,
    and it spawns nothing once that is there (a child per warm run cost a
    warm paper_3dof_land 1 s)."""
    from modesel.simulation import first_run
    from modesel.simulation.api import build, load_scene
    from modesel.simulation.scene import scene_from_dict

    spawned = []

    class Child:
        def __init__(self, args, **kwargs):
            spawned.append(args[-1])

        def wait(self):
            return 0

        def poll(self):
            return 0

    monkeypatch.setattr(first_run.subprocess, "Popen", Child)
    monkeypatch.setattr(first_run, "_compile_system", lambda built: None)
    monkeypatch.setattr(first_run, "compile_loops", lambda names: spawned.append(("here", tuple(names))))
    cached = set()
    monkeypatch.setattr(first_run, "is_cold", lambda module, function=None: (module, function) not in cached)
    bare = build(scene_from_dict(SMALL_RIGID))
    windy = build(load_scene(ROOT / "studies" / "data" / "openfast" / "steady_08" / "steady_08.fst"))
    monkeypatch.delitem(sys.modules, first_run.SYSTEM_MODULE, raising=False)
    monkeypatch.delitem(sys.modules, first_run.LOADS_MODULE, raising=False)
    assert first_run.compile_in_parallel(bare)
    code, here = spawned
    assert first_run.LOADS_MODULE not in code and "compile_loops(('runge_kutta', 'reaction_loads'))" in code
    assert here == ("here", ())
    spawned.clear()
    cached.add(first_run.SYSTEM_CACHE)
    assert not first_run.compile_in_parallel(bare) and not spawned
    assert first_run.compile_in_parallel(windy)
    assert f"import {first_run.LOADS_MODULE}; {first_run.LOADS_MODULE}.loads_function(False, False);" in spawned[0]
    assert spawned[1] == ("here", ("runge_kutta",))
    # AeroDyn's tower influence: its loads (a second cfunc) compile in the child instead of
    # the loads without it, and only for a scene that has it, also once those are cached
    tower = build(load_scene(ROOT / "tests" / "data" / "openfast_more" / "tower_potential" / "tower_potential.fst"))
    spawned.clear()
    assert first_run.compile_in_parallel(tower)
    assert f"import {first_run.LOADS_MODULE}; {first_run.LOADS_MODULE}.loads_function(True, False);" in spawned[0]
    assert "loads_function(False, False)" not in spawned[0]
    cached.add((first_run.LOADS_MODULE, first_run.LOADS_VARIANTS[False, False]))
    spawned.clear()
    assert not first_run.compile_in_parallel(windy) and not spawned
    assert first_run.compile_in_parallel(tower) and "loads_function(True, False)" in spawned[0]
    cached.add((first_run.LOADS_MODULE, first_run.LOADS_VARIANTS[True, False]))
    spawned.clear()
    assert not first_run.compile_in_parallel(tower) and not spawned
    # the child is told, and the cache searched for, the functions the variants compile
    # (a name that drifted would find no cache, so every warm run would spawn a child)
    from modesel.model.effects import compiled
    assert {key: f.__name__ for key, f in compiled._VARIANTS.items()} == first_run.LOADS_VARIANTS
    # the right-hand side's cfunc is cached under the function it compiles (numba's naming)
    from modesel.multibody import system_function
    index = system_function.FREE_SYSTEM._cache._cache_file._index_name
    module, function = first_run.SYSTEM_CACHE
    assert index.startswith(f"{module.rsplit('.', 1)[1]}.{function}-"), index
