"""`CompiledRHS`: the Python front of the compiled kernel (`kernel.py`) for
one `KaneEquations`, built from its public attributes: the packed arrays
(`packed_full`, `packed_free`), the coordinate indices and the prescribed
motion. `integrate` takes it as the right-hand side of the method
"compiled-DOP853" and "compiled-RK45" (`kernel.runge_kutta`) and
"compiled-Radau" (`implicit.radau5`), and of scipy's methods through
`accelerations`.
"""
from __future__ import annotations

import numpy as np

from modesel.multibody import implicit, kernel, rk45_tableau
from modesel.multibody.watch import run_watched


#: output rows per compiled pass of `CompiledRHS.outputs` (one system evaluation
#: each: about 0.1 s for steady_08), so that a signal (Ctrl-C) waits at most that
#: long; the rows are taken in order, the effects' latched state carried across
OUTPUT_ROWS = 2048


def spring_dampers(linear) -> list:
    """Generalised spring-dampers (row, column, k, c[, neutral]) as 5-tuples,
    the neutral position 0 where a term leaves it out (`CompiledRHS`)."""
    return [tuple(term) + (0.0,) * (5 - len(term)) for term in linear]


class CompiledRHS:
    """A `KaneEquations` packed for the compiled kernel, with its free,
    prescribed and fixed coordinates.

    linear: iterable of (row, column, stiffness, damping[, neutral]) over
    coordinate names: generalised spring-dampers gen[row] -= k (q[column] -
    neutral) + c qd[column] [N/m, N s/m or N m/rad, N m s/rad; neutral in
    the coordinate's unit, default 0] (e.g. the drivetrain, ElastoDyn
    DTTorSpr/DTTorDmp; ServoDyn's yaw spring about YawNeut). Callable as
    (t, q, qd) -> (M, F) of the free coordinates like `Built.M_F`; `accelerations(t, q, qd)` solves inside the
    kernel; `dop853`, `rk45` and `radau` integrate entirely compiled, which need every
    prescribed coordinate to be polynomial in t (`compilable`). `full`
    evaluates all coordinates: every row with all_rows=True, else only the
    rows of free and prescribed coordinates (the others are zero);
    `reactions` (all_rows) gives the reaction loads of fixed coordinates at
    many output times in one compiled call.

    loads: None (no effects: `no_loads.NO_LOADS` runs in their place, so
    that one compiled specialisation of the kernel's loops serves every
    problem), or (numba cfunc of `kernel.LOADS_SIG`, ints, floats, state):
    the effects' loads evaluated inside the kernel at every right-hand side
    (`modesel.model.effects.compiled` packs them); state is modified in place
    (scratch and latched switches). channels: {output channel: (state index,
    scale)}: the effects' output channels, state[index] * scale after an
    evaluation with state[channel_flag] set (`outputs`). packed: the arrays
    of the kernel (default `eq.packed_full` or `eq.packed_free`; e.g.
    `eq.pack_free(invariants=False)` to compile the kernel without loading
    the invariant route, `simulation.first_run`)."""

    def __init__(self, eq, linear=(), *, all_rows=False, loads=None, channels=None, channel_flag=-1, packed=None):
        self.eq = eq
        self.channels = dict(channels or {})
        self.channel_flag = int(channel_flag)
        if self.channels and (loads is None or self.channel_flag < 0):
            raise ValueError("output channels need loads and the index of their channel flag")
        if packed is None:
            packed = eq.packed_full if all_rows else eq.packed_free
        self.packed = packed
        n, nf = eq.n_all, len(eq.free_idx)
        lin = spring_dampers(linear)
        lin_idx = np.array([[eq.index[r], eq.index[c]] for r, c, _, _, _ in lin], np.int64).reshape(-1, 2)
        lin_kc = np.array([[k, c, k * q0] for _, _, k, c, q0 in lin], float).reshape(-1, 3)
        poly = eq.prescribed_polynomials
        self.compilable = poly is not None
        pcoef = np.zeros((len(eq.presc_idx), 3)) if poly is None else poly
        #: whether effects' loads act inside the kernel
        self.has_loads = loads is not None
        self.prob = (eq.free_idx.astype(np.int64), eq.presc_idx.astype(np.int64), pcoef,
                     eq.fixed_values.astype(float), eq.gravity.astype(float), lin_idx, lin_kc,
                     np.zeros((packed.n_rows, 6)), np.zeros(eq.n_bodies, np.int64),
                     _loads_tuple(_no_loads() if loads is None else loads))
        self.rwork = (np.zeros((4, n)), np.zeros((n, n)), np.zeros(n), np.zeros((nf, nf)), np.zeros(nf))
        self.n_free = nf
        self._x = np.zeros(2 * nf)
        self._out = np.zeros(2 * nf)
        self._no_bounds = np.full(nf, np.inf)
        self._call = None                   # `call_system`'s compiled entry point for this instance's arguments

    def _problem_at(self, t):
        """(time passed to the kernel, prob): prescribed callables are
        evaluated here and passed as a constant-acceleration polynomial at 0."""
        if self.compilable:
            return float(t), self.prob
        return 0.0, self.prob[:2] + (self.eq.prescribed_state(t),) + self.prob[3:]

    def _free(self, t, q, qd, solve):
        x = self._x
        x[:self.n_free] = q
        x[self.n_free:] = qd
        tk, prob = self._problem_at(t)
        p = self.packed
        args = (_system(), tk, x, self._out, solve, self._no_bounds, prob, self.rwork, p.data, p.work)
        if self._call is not None:
            return self._call(*args)[0]
        code = kernel.call_system(*args)[0]
        if self.compilable:
            self._call = _entry_point(kernel.call_system, args)
        return code

    def __call__(self, t, q, qd):
        self._free(t, q, qd, kernel.NO_SOLVE)
        return self.rwork[3].copy(), self.rwork[4].copy()

    def accelerations(self, t, q, qd):
        """(qdd, status) at the free coordinates; status OK, SINGULAR or NON_FINITE_ACC
        (the state itself is checked by the caller)."""
        code = self._free(t, q, qd, kernel.SOLVE)
        return self._out[self.n_free:].copy(), code

    def full(self, q_all, qd_all, generalized=None, node_forces=None):
        """M (n_all x n_all) and F (n_all) at all coordinates; node_forces
        {flexible body name: (N, 3) inertial forces [N], or (N, 6) forces and
        moments [N m] (`KaneEquations`)}; not for a body whose loads the
        packing takes at load points (`packing.with_load_points`)."""
        n = self.eq.n_all
        gen = np.zeros(n) if generalized is None else np.asarray(generalized, float)
        fnodes, flag = np.zeros_like(self.prob[7]), np.zeros_like(self.prob[8])
        if node_forces:
            fnodes, flag = np.zeros_like(fnodes), np.zeros_like(flag)
            for name, f in node_forces.items():
                first, count = self.packed.node_rows(name)
                fnodes[first:first + count, :np.shape(f)[1]] = f
                flag[self.eq.body_index[name]] = 1
        M, F = np.empty((n, n)), np.empty(n)
        p = self.packed
        kernel.assemble(np.asarray(q_all, float), np.asarray(qd_all, float), self.prob[4], fnodes, flag, gen,
                        p.data, p.work, M, F)
        return M, F

    def linear_model(self, t, q, qd, rel_step):
        """(M, C, K) of the free coordinates at (t, q, qd) by the central
        differences of `linearize.linearize`, with its steps and in its order,
        the 4 n states evaluated in one compiled call (`kernel.reaction_loads`
        with NO_SOLVE on the free rows: F_f at each; each call from Python
        costs numba about 1 ms to type the arguments); NaN where an
        evaluation fails. None for a prescribed coordinate given as a Python
        function."""
        if not self.compilable:
            return None
        n = self.n_free
        x = np.concatenate([np.asarray(q, float), np.asarray(qd, float)])
        M = self(t, x[:n], x[n:])[0]
        X = np.repeat(x[None, :], 4 * n, axis=0)
        h = np.empty(2 * n)
        for j in range(n):
            for c, col in enumerate((j, n + j)):        # q_j, then qd_j (`linearize`'s order)
                h[col] = rel_step * max(1.0, abs(x[col]))
                X[4 * j + 2 * c, col] = x[col] + h[col]
                X[4 * j + 2 * c + 1, col] = x[col] - h[col]
        F = np.zeros((4 * n, n))
        p = self.packed
        # argument types: `first_run.loop_signatures`, which the first run compiles
        code = kernel.reaction_loads(_system(), kernel.NO_SOLVE, np.full(4 * n, float(t)), X,
                                     self.eq.free_idx.astype(np.int64), np.zeros(0, np.int64), self.prob,
                                     self.rwork, p.data, p.work, F)
        if code != kernel.OK:
            return np.full((n, n), np.nan), np.full((n, n), np.nan), np.full((n, n), np.nan)
        K, C = np.zeros((n, n)), np.zeros((n, n))
        for j in range(n):
            K[:, j] = -(F[4 * j] - F[4 * j + 1]) / (2 * h[j])
            C[:, j] = -(F[4 * j + 2] - F[4 * j + 3]) / (2 * h[n + j])
        return M, C, K

    def reactions(self, t, q, qd, rows):
        """Reaction loads F_r - M_r qdd [N or N m] of coordinates `rows`
        (names, e.g. the models' reaction coordinates) at times t (n_t,) and
        free states q, qd (n_t, n_free): (n_t, len(rows)). Needs all_rows."""
        return self.outputs(t, q, qd, rows)

    def outputs(self, t, q, qd, rows=(), channels=(), accelerations=()):
        """Reaction loads of coordinates `rows` (as `reactions`), the
        accelerations of coordinates `accelerations` (names; free: solved,
        prescribed: their own, fixed: 0) [m/s^2 or rad/s^2] and the effects'
        output `channels` (names in `self.channels`, scaled) at times t (n_t,)
        and free states q, qd (n_t, n_free), in one compiled pass over the
        times: (n_t, len(rows) + len(accelerations) + len(channels)), NaN
        throughout where an evaluation fails. The effects' latched switches
        advance with the times, as in an integration. Compiled: in passes of
        OUTPUT_ROWS rows, between which Python handles signals. Needs all_rows."""
        if not self.packed.data[12].all():         # the active mask: every row
            raise ValueError("reactions need a CompiledRHS packed with all_rows=True")
        t = np.array(t, float, ndmin=1)        # a writable copy: the one type the first run compiles for
        X = np.ascontiguousarray(np.hstack([np.atleast_2d(q), np.atleast_2d(qd)]), float)
        idx = np.array([self.eq.index[r] for r in rows] + [-1 - self.eq.index[c] for c in accelerations], np.int64)
        slots = np.array([self.channels[c][0] for c in channels], np.int64)
        out = np.zeros((len(t), len(idx) + len(slots)))
        state = self.prob[9][3]
        if len(slots):
            state[self.channel_flag] = 1.0
        try:
            if self.compilable:          # in slices of OUTPUT_ROWS: Ctrl-C is handled between them
                code = kernel.OK
                for a in range(0, len(t), OUTPUT_ROWS):
                    b = a + OUTPUT_ROWS
                    code = kernel.reaction_loads(_system(), kernel.SOLVE, t[a:b], X[a:b], idx, slots, self.prob,
                                                 self.rwork, self.packed.data, self.packed.work, out[a:b])
                    if code != kernel.OK:
                        break
            else:
                code = kernel.OK
                for k, tk in enumerate(t):
                    tk0, prob = self._problem_at(tk)
                    code = kernel.reaction_loads(_system(), kernel.SOLVE, np.array([tk0]), X[k:k + 1], idx, slots,
                                                 prob, self.rwork, self.packed.data, self.packed.work,
                                                 out[k:k + 1])
                    if code != kernel.OK:
                        break
        finally:
            if len(slots):
                state[self.channel_flag] = 0.0
        if code != kernel.OK:
            out[:] = np.nan
        out[:, len(idx):] *= np.array([self.channels[c][1] for c in channels])
        return out

    def dop853(self, x0, t_eval, tmax, rtol, atol, max_step, bounds, table, progress=None):
        """Integrate from x0 = [q, qd] over [0, tmax] with DOP853
        (`kernel.runge_kutta`, `table` of `dop853_tableau`):
        (status, time, n_rhs, index, outputs Y (n_out x 2n) at t_eval).
        The loop runs in a thread that this one watches (`watch.run_watched`:
        progress(t, tmax) about every quarter second, Ctrl-C)."""
        return self._explicit(kernel.DOP853_KIND, x0, t_eval, tmax, rtol, atol, max_step, bounds, table, progress)

    def rk45(self, x0, t_eval, tmax, rtol, atol, max_step, bounds, progress=None):
        """As `dop853`, with Dormand-Prince 5(4) (`rk45_tableau`)."""
        return self._explicit(kernel.RK45_KIND, x0, t_eval, tmax, rtol, atol, max_step, bounds,
                              rk45_tableau.TABLE, progress)

    def _explicit(self, kind, x0, t_eval, tmax, rtol, atol, max_step, bounds, table, progress):
        if not self.compilable:
            raise ValueError("a prescribed coordinate is a Python function: use scipy")
        Y = np.zeros((len(t_eval), len(x0)))
        p = self.packed
        # argument types: `first_run.loop_signatures`, which the first run compiles
        args = (_system(), np.array(x0, float), np.asarray(t_eval, float), float(tmax), float(rtol),
                np.asarray(atol, float), float(max_step), np.asarray(bounds, float), tuple(table), kind,
                self.prob, self.rwork, p.data, p.work, Y)
        code, t_stop, nfev, n_out, idx = run_watched(kernel.runge_kutta, args, tmax, progress)
        return code, t_stop, nfev, idx, Y[:n_out]

    def jacobian(self, t, q, qd, held=False):
        """(dqdd/dq, dqdd/dqd) of the free coordinates at (t, q, qd) by the
        compiled forward differences of `implicit.jacobian` (n_free x n_free
        each); held: with the BEM loads and the tower drag held at their
        values at (q, qd), as `implicit.radau5` forms it."""
        tk, prob = self._problem_at(t)
        n = self.n_free
        x = np.concatenate([q, qd]).astype(float)
        f = np.zeros(2 * n)
        p = self.packed
        code, _ = kernel.call_system(_system(), tk, x, f, kernel.SOLVE, self._no_bounds, prob, self.rwork, p.data,
                                     p.work)
        A, B = np.zeros((n, n)), np.zeros((n, n))
        if code == kernel.OK:
            code = implicit.jacobian(_system(), bool(held), tk, x, f, A, B, np.zeros(2 * n), np.zeros(2 * n),
                                     np.zeros(2 * n), self._no_bounds, prob, self.rwork, p.data, p.work,
                                     np.zeros(2, np.int64))
        if code != kernel.OK:
            A[:], B[:] = np.nan, np.nan
        return A, B

    def radau(self, x0, t_eval, tmax, rtol, atol, max_step, bounds, progress=None):
        """Radau IIA (order 5) entirely compiled (`implicit.radau5`), with the
        Jacobian by compiled finite differences: (status, time, n_rhs, index,
        outputs Y (n_out x 2n) at t_eval, {"n_jac", "n_lu", "n_steps"}),
        watched as `dop853`."""
        if not self.compilable:
            raise ValueError("a prescribed coordinate is a Python function: use scipy")
        Y = np.zeros((len(t_eval), len(x0)))
        p = self.packed
        args = (_system(), np.array(x0, float), np.asarray(t_eval, float), float(tmax), float(rtol),
                np.asarray(atol, float), float(max_step), np.asarray(bounds, float), implicit.TABLE, self.prob,
                self.rwork, p.data, p.work, Y)
        code, t_stop, nfev, n_out, idx, n_jac, n_lu, n_steps = run_watched(implicit.radau5, args, tmax, progress)
        return code, t_stop, nfev, idx, Y[:n_out], {"n_jac": int(n_jac), "n_lu": int(n_lu),
                                                      "n_steps": int(n_steps)}


def _system():
    """`system_function.FREE_SYSTEM`, the right-hand side's cfunc, imported
    (so compiled or loaded from numba's cache) on first use."""
    from modesel.multibody.system_function import FREE_SYSTEM
    return FREE_SYSTEM


def _no_loads():
    """`no_loads.NO_LOADS`, imported on first use (loading its cfunc from
    numba's cache costs about 0.1 s, which a scene with effects never needs)."""
    from modesel.multibody.no_loads import NO_LOADS
    return NO_LOADS


def _loads_tuple(loads):
    """(cfunc, ints, floats, state) with the kernel's dtypes."""
    fn, ints, floats, state = loads
    return (fn, np.ascontiguousarray(ints, np.int64), np.ascontiguousarray(floats, float),
            np.ascontiguousarray(state, float))


def _entry_point(dispatcher, args):
    """The compiled entry point of `dispatcher` for the types of `args`, or
    None. numba types every argument at every call through the dispatcher;
    tuples holding first-class functions (the loads and the invariant
    route) fall back to its Python `typeof`, about 0.8 ms per call of the
    right-hand side from Python (static equilibrium, scipy's methods), six
    times the 38-DOF right-hand side itself. A `CompiledRHS` passes the
    same arrays (same dtypes and layouts) at every call, so the overload its
    first call took serves the later ones (`Dispatcher.get_overload`)."""
    try:
        return dispatcher.get_overload(tuple(dispatcher.typeof_pyval(a) for a in args))
    except (KeyError, TypeError, AttributeError):
        return None
