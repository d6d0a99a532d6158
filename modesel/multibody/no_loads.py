"""Loads that add nothing, for a problem without effects.

The kernel's loops take the effects' loads as a first-class function of
`kernel.LOADS_SIG` (`model.effects.compiled` packs them). A problem without
effects runs the same loops with `no_loads`, so that scenes with and without
effects share one compiled specialisation of each loop: one first-run
compile and one cache entry for every scene. Its own module, imported on
first use (`compiled.CompiledRHS`): numba compiles or loads the cfunc when
the module is imported.
"""
from __future__ import annotations

import numpy as np
from numba import cfunc

from modesel.multibody.kernel import LOADS_SIG


@cfunc(LOADS_SIG, cache=True)
def no_loads(t, q_all, qd_all, R, vec, gen, fnodes, fflag, ints, floats, state, held):
    """Adds no load (`kernel.LOADS_SIG`); returns the kernel's OK."""
    return 0


#: the kernel's loads argument (cfunc, ints, floats, state) of a problem without effects
NO_LOADS = (no_loads, np.zeros(1, np.int64), np.zeros(1), np.zeros(1))
