"""The kernel's right-hand side, `kernel.free_system`, compiled once as a
numba cfunc of `kernel.SYSTEM_SIG`, which every compiled loop (the explicit
Runge-Kutta pairs, Radau, the reaction loads) takes as its first argument
and calls through a pointer, and Python through `kernel.call_system`.

Why a pointer: numba links the code of each jitted function a function calls
into that function's own library and optimises and emits the whole again
(numba's `CPUCodeLibrary.finalize`). Each loop that called `free_system`
directly compiled the whole right-hand side once more: `runge_kutta` 7.2 s,
`reaction_loads` 3.9 s of a first run's compile (numba's compile events,
steady_08, one process). Through the pointer each loop compiles only its
own code, and its cache holds no copy of the right-hand side. The loops
compile against the type alone (`simulation.first_run`), beside it.

Its own module, imported on first use (`compiled.CompiledRHS`): numba
compiles or loads the cfunc when the module is imported. error_model
"numpy": a division by zero gives inf or NaN, which the loops report as a
divergence, where a cfunc could not pass an exception on.
"""
from __future__ import annotations

from numba import cfunc

from modesel.multibody.kernel import SYSTEM_SIG, free_system

#: `kernel.free_system` compiled (numba cfunc of `kernel.SYSTEM_SIG`)
FREE_SYSTEM = cfunc(SYSTEM_SIG, cache=True, error_model="numpy")(free_system)
