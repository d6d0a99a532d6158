"""scipy's BLAS for numba, and the BLAS threads of one simulation.

numba's matrix products call the BLAS functions of scipy's Cython module
`scipy.linalg.cython_blas`; numba imports that module when its CPU target
first compiles or loads a function (`numba.np.linalg.ensure_blas`), which
imports the whole package `scipy.linalg` unless the module is loaded already.
`load_scipy_blas` loads it alone; `kernel` calls it before its first compiled
function (a given signature compiles, or loads from the cache, at import), so
that the simulate path never imports `scipy.linalg` (tests/test_fast_start.py).
`single_thread_blas` runs one simulation with one OpenBLAS thread.
"""
from __future__ import annotations

import functools


def load_scipy_blas():
    """scipy's BLAS module `scipy.linalg.cython_blas`, whose function pointers
    numba's matrix products call (numba imports it when it builds its target
    context, `numba.np.linalg.ensure_blas`). Where it is not loaded yet, it is
    loaded from its extension file alone and entered in `sys.modules` under
    its own name: the package `scipy.linalg` around it would cost a
    simulation about 0.15 s of start-up (its array-API layer clones numpy's
    namespace, which imports numpy.f2py) and the engine needs none of it.
    `import scipy.linalg` later still works; `import scipy.linalg.cython_blas`
    and `from scipy.linalg import cython_blas` (numba's and scipy's Cython
    modules import it so) give this module, only the attribute
    `scipy.linalg.cython_blas` stays unset. Where the file cannot be found or
    loaded, the package is imported as usual."""
    import importlib.machinery
    import importlib.util
    import os
    import sys

    name = "scipy.linalg.cython_blas"
    if name in sys.modules:
        return sys.modules[name]
    if "scipy.linalg" in sys.modules:         # the package is there already: the usual import is cheap
        import scipy.linalg.cython_blas
        return sys.modules[name]
    try:
        import scipy

        folder = os.path.join(os.path.dirname(scipy.__file__), "linalg")
        path = next(p for suffix in importlib.machinery.EXTENSION_SUFFIXES
                    if os.path.isfile(p := os.path.join(folder, "cython_blas" + suffix)))
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        return module
    except Exception:
        sys.modules.pop(name, None)
        import scipy.linalg.cython_blas
        return sys.modules[name]


@functools.lru_cache(maxsize=1)
def _blas_thread_controls():
    """(get, set) ctypes functions of each OpenBLAS loaded in this process
    (numpy's and scipy's; numba's matrix products call scipy's), found in
    /proc/self/maps once (after scipy's BLAS is loaded); empty where that
    does not exist."""
    import ctypes

    try:
        with open("/proc/self/maps") as fh:
            libs = sorted({ln.split()[-1] for ln in fh if "openblas" in ln.lower() and ".so" in ln})
    except OSError:
        return []
    out = []
    for path in libs:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for suffix in ("", "64_", "_64_"):
            names = [f"{pre}openblas_{{}}_num_threads{suffix}" for pre in ("scipy_", "")]
            found = [(getattr(lib, nm.format("get"), None), getattr(lib, nm.format("set"), None))
                     for nm in names]
            found = [(g, st) for g, st in found if g is not None and st is not None]
            if found:
                get, set_ = found[0]
                get.restype, get.argtypes = ctypes.c_int, []
                set_.restype, set_.argtypes = None, [ctypes.c_int]
                out.append((get, set_))
                break
    return out


class single_thread_blas:
    """Context manager: one OpenBLAS thread inside, the previous counts restored after.

    An OpenBLAS already at one thread is left alone: after a fork its pool
    of threads is gone, and setting any count starts it again (OpenBLAS
    `goto_set_num_threads`), workers that spin for about 0.1 s. In a forked
    child of a process whose OpenBLAS ran two threads (no
    OPENBLAS_NUM_THREADS=1, which `cli.main` sets for its own commands), they
    took the two cores' time from the child: its first simulation of
    steady_08 (one output step) ran 0.12-0.13 s instead of 0.06 s, with
    0.19-0.20 s of CPU; with `keep_one_thread` before the fork, 0.06 s."""

    def __enter__(self):
        load_scipy_blas()     # the BLAS numba's matrix products call, loaded before looking for it

        self._saved = [(count, set_) for get, set_ in _blas_thread_controls() if (count := get()) != 1]
        for _, set_ in self._saved:
            set_(1)
        return self

    def __exit__(self, *exc):
        for count, set_ in self._saved:
            set_(count)
        return False


def keep_one_thread() -> None:
    """One OpenBLAS thread from now on in this process, and in the processes
    it forks, which then start no pool of BLAS threads (`single_thread_blas`):
    `modesel serve` where the user set OPENBLAS_NUM_THREADS, and the
    benchmark of its children (`benchmarks/simulate_phases.py --warm`)."""
    load_scipy_blas()
    for _, set_ in _blas_thread_controls():
        set_(1)
