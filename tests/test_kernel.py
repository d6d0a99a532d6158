"""The compiled kernel (kernel.py) against the numpy reference of the Kane
equations (kane.py): M and F equal to 1e-10 relative at random states,
and the compiled DOP853 loop against scipy's solve_ivp on the same equations.

The first run compiles the kernel (numba, cached on disk afterwards)."""
from types import SimpleNamespace

import numpy as np
import pytest

from modesel.errors import ModeselError, SimulationDiverged
from modesel.modeset import FieldModes, ModeSet
from modesel.multibody import body_integrals, kernel, packing
from modesel.multibody.bodies import FlexibleBody, Joint, RigidBody, Rotation, Shortening
from modesel.turbine.elastodyn import load_turbine
from modesel.multibody.kane import KaneEquations
from modesel.multibody.integrate import integrate
from modesel.model.template import build_turbine
from modesel.multibody.system import Prescribed, System

REL = 1e-10


def assert_equal_rel(a, b, what):
    scale = np.abs(b).max()
    assert scale > 0, what
    err = np.abs(a - b).max() / scale
    assert err <= REL, (what, err)


def pendulum_chain() -> System:
    """A rigid chain exercising every joint feature (prismatic + revolute,
    rotation sequences with summed and offset angles, axial shortening),
    rigid-distributed bodies with node polar inertia (0 elastic DOFs, one of
    them and a rigid body on constant joints, which the kernel lumps into
    their parent) and a flexible body with shapes, shortening, torsion and
    polar inertia."""
    rng = np.random.default_rng(7)
    link1 = RigidBody("link1", Joint(None, np.array([0.1, 0.0, 2.0]), translation={"d": np.array([1.0, 0.0, 0.0])},
                                     rotations=[Rotation(1, {"th1": 1.0})]),
                      3.0, np.array([0.0, 0.0, -1.0]), np.diag([0.4, 0.5, 0.1]))
    pre = Rotation(0, {}, 0.2)
    j2 = Joint("link1", np.array([0.0, 0.1, -2.0]), np.eye(3), {"th2": np.array([0.0, 0.3, 0.0])},
               Shortening(np.array([0.0, 0.0, 1.0]), ("d", "th2"), np.array([[0.2, 0.05], [0.05, 0.1]])),
               [pre, Rotation(0, {"th2": 1.0}), Rotation(2, {"th1": 0.5, "th2": 1.0, "psi": 1.0}, 0.3),
                Rotation(1, {"phi": 1.0})])
    link2 = RigidBody("link2", j2, 2.0, np.array([0.1, 0.0, -1.5]),
                      np.array([[0.3, 0.01, 0.0], [0.01, 0.2, 0.02], [0.0, 0.02, 0.1]]))
    N = 12
    nodes = np.column_stack([rng.normal(size=N) * 0.1, rng.normal(size=N) * 0.1, -np.linspace(0.1, 1.5, N)])
    bob = FlexibleBody("bob", Joint("link2", np.array([0.0, 0.0, -1.5]), rotations=[Rotation(2, {"psi": 2.0})]),
                       nodes, rng.uniform(0.5, 1.5, N), np.array([0.0, 0.0, -1.0]),
                       node_polar_inertia=rng.uniform(0.01, 0.1, N))
    ne = 2
    shapes = rng.normal(size=(N, 3, ne)) * 0.3
    S = rng.normal(size=(N, ne, ne)) * 0.1
    S = S + S.transpose(0, 2, 1)
    K = np.array([[50.0, 5.0], [5.0, 80.0]])
    arm = FlexibleBody("arm", Joint("link1", np.array([0.0, 0.0, -2.0]), rotations=[Rotation(0, {"th2": -1.0})]),
                       nodes * 0.8, rng.uniform(0.5, 1.5, N), np.array([0.0, 0.0, -1.0]), ("e1", "e2"),
                       shapes, S, rng.normal(size=(N, ne)) * 0.2, rng.uniform(0.01, 0.1, N), K, 0.01 * K)
    # rigid bodies on constant joints, lumped into link2 by the kernel
    quarter_turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    fin = FlexibleBody("fin", Joint("link2", np.array([0.2, -0.1, -0.7]), quarter_turn,
                                    rotations=[Rotation(1, {}, 0.4)]),
                       nodes * 0.5, rng.uniform(0.5, 1.5, N), np.array([1.0, 0.0, 0.0]),
                       node_polar_inertia=rng.uniform(0.01, 0.1, N))
    cap = RigidBody("cap", Joint("fin", np.array([0.0, 0.3, 0.2]), rotations=[Rotation(2, {}, -0.8)]),
                    0.7, np.array([0.05, 0.0, 0.1]), np.diag([0.02, 0.03, 0.01]))
    return System([link1, link2, bob, arm, fin, cap], ["th1", "th2", "d", "e1", "e2"], {"phi": 0.2},
                  {"psi": Prescribed(0.1, 0.7, 0.3)})


@pytest.fixture(scope="module")
def turbine():
    return load_turbine("nrel5mw")


def turbine_system(turbine, case) -> System:
    ed = lambda n: FieldModes("elastodyn", n)            # noqa: E731
    if case == "land_3dof":
        return build_turbine(turbine, ModeSet({"tower_fa": ed(1), "tower_ss": ed(1)}), free=("GeAz",)).system
    blades = ModeSet({"tower_fa": ed(1), "tower_ss": ed(1), "tower_torsion": FieldModes("linear", 1),
                      "blade_flap": ed(2), "blade_edge": ed(1)})
    if case == "flexible_blades":
        return build_turbine(turbine, blades, free=("GeAz", "DrTr"), fixed={"Yaw": 0.05}).system
    if case == "prescribed_rotor":
        return build_turbine(turbine, blades, prescribed={"GeAz": Prescribed(0.4, 1.27, 0.05)}).system
    raise KeyError(case)


def random_states(eq, rng, count=3):
    for _ in range(count):
        q = rng.normal(size=eq.n_all) * 0.5
        qd = rng.normal(size=eq.n_all)
        for name in ("GeAz", "DrTr", "Yaw", "th1", "th2", "psi", "phi"):
            if name in eq.index:
                q[eq.index[name]] = rng.uniform(-np.pi, np.pi)
        yield q, qd


def node_forces(system, rng):
    return {b.name: rng.normal(size=(len(b.node_mass), 3)) * 1e3 for b in system.flexible_bodies()}


def check_against_reference(system, rng):
    eq = KaneEquations(system)
    for q, qd in random_states(eq, rng):
        gen = rng.normal(size=eq.n_all) * 1e3
        nf = node_forces(system, rng)
        M, F = eq.evaluate_full(q, qd, nf, gen)
        Mr, Fr = eq.evaluate_full_reference(q, qd, nf, gen)
        assert_equal_rel(M, Mr, "M (all coordinates)")
        assert_equal_rel(F, Fr, "F (all coordinates)")
        assert np.allclose(M, M.T, rtol=0, atol=1e-12 * np.abs(M).max())
        t = rng.uniform(0, 10)
        qf, qdf = q[eq.free_idx], qd[eq.free_idx]
        M, F = eq.evaluate(qf, qdf, t)
        Mr, Fr = eq.evaluate_reference(qf, qdf, t)
        assert_equal_rel(M, Mr, "M (free)")
        assert_equal_rel(F, Fr, "F (free)")
    return eq


def test_pendulum_chain_matches_reference():
    eq = check_against_reference(pendulum_chain(), np.random.default_rng(1))
    kinds = eq.packed_full.data[0][:, 1]
    assert list(kinds[-2:]) == [kernel.LUMPED, kernel.LUMPED]      # fin and cap lumped into link2


def assemble_by_route(eq, invariants, q, qd, forces, gen):
    """M, F of all coordinates with every flexible body forced onto one
    route of the kernel (node sums or invariants, `body_integrals`)."""
    p = packing.pack(eq, invariants=invariants)
    fnodes = np.zeros((p.data[8].shape[0], 6))
    flag = np.zeros(eq.n_bodies, np.int64)
    for name, f in forces.items():
        first, count = p.node_start[name]
        fnodes[first:first + count, :f.shape[1]] = f
        flag[eq.body_index[name]] = 1
    M, F = np.empty((eq.n_all, eq.n_all)), np.empty(eq.n_all)
    kernel.assemble(q, qd, eq.gravity.astype(float), fnodes, flag, gen, p.data, p.work, M, F)
    return M, F, p


def fem_turbine(turbine, count=3):
    fields = ("tower_fa", "tower_ss", "tower_torsion", "blade_flap", "blade_edge")
    return build_turbine(turbine, ModeSet({f: FieldModes("fem", count) for f in fields}),
                         free=("GeAz", "DrTr")).system


@pytest.mark.parametrize("case", ["pendulum_chain", "fem_turbine"])
def test_invariant_route_equals_node_sums_and_reference(turbine, case):
    """The invariants of a flexible body (`body_integrals`: node sums
    expanded in q_e, qd_e at pack time) give the node sums' M and F to
    round-off, with node forces and moments on every flexible body. The
    chain's flexible arm has shapes with axial components, a full
    shortening matrix, torsion and polar inertia; the fem turbine's tower
    has torsion modes without shortening (ns < ne)."""
    system = pendulum_chain() if case == "pendulum_chain" else fem_turbine(turbine)
    eq = KaneEquations(system)
    rng = np.random.default_rng(11)
    for q, qd in random_states(eq, rng):
        gen = rng.normal(size=eq.n_all) * 1e3
        forces = {b.name: rng.normal(size=(len(b.node_mass), 6)) * 1e3 for b in system.flexible_bodies()}
        M_node, F_node, p_node = assemble_by_route(eq, False, q, qd, forces, gen)
        M_inv, F_inv, p_inv = assemble_by_route(eq, True, q, qd, forces, gen)
        Mr, Fr = eq.evaluate_full_reference(q, qd, forces, gen)
        assert_equal_rel(M_inv, M_node, "M: invariants against node sums")
        assert_equal_rel(F_inv, F_node, "F: invariants against node sums")
        assert_equal_rel(M_inv, Mr, "M: invariants against the reference")
        assert_equal_rel(F_inv, Fr, "F: invariants against the reference")
    used = p_inv.data[0][:, kernel.INV0]
    assert np.all(p_node.data[0][:, kernel.INV0] == 0)
    flexible = p_inv.data[0][:, kernel.KIND] == kernel.FLEX
    assert flexible.any() and np.all(used[flexible] > 0)
    if case == "fem_turbine":
        tower = eq.body_index["tower"]
        assert 0 < p_inv.data[0][tower, kernel.NS] < p_inv.data[0][tower, kernel.NE]


def test_load_points_give_the_sums_of_their_node_loads(turbine):
    """Node loads f_k = sum_a T_ka g_a (forces and moments) of a transfer T
    (N nodes, P < N points) on each blade give the same M and F at the
    blades' load points (`packing.with_load_points`: the T-weighted mean
    geometry, loads w_a g_a) as at the nodes, and as the numpy reference;
    so does the tower, whose node moments also work through its torsion
    shapes (the points carry their T-weighted mean); a transfer with P >= N
    keeps the nodes."""
    eq = KaneEquations(fem_turbine(turbine))
    rng = np.random.default_rng(5)
    blades = [b.name for b in eq.system.flexible_bodies() if b.name.startswith("blade")]
    N = len(eq.system.body("blade1").node_mass)
    P = 9
    assert np.any(eq.system.body("tower").torsion)                 # torsion shapes
    counts = dict.fromkeys(blades, P) | {"tower": 5}
    transfers = {}
    for name, p in counts.items():
        n = len(eq.system.body(name).node_mass)
        T = np.zeros((n, p))
        for k in range(n):
            a = rng.integers(0, p - 1)
            T[k, a:a + 2] = rng.uniform(0.0, 1.0, 2)
        transfers[name] = T
    base = packing.pack(eq, invariants=True)
    pts = packing.with_load_points(base, eq, transfers)
    assert sorted(pts.load_points) == sorted(counts)
    assert not packing.with_load_points(base, eq, {"blade1": np.ones((N, N))}).load_points
    assert pts.n_rows == base.n_rows + sum(counts.values())
    blades_only = packing.with_load_points(base, eq, {name: transfers[name] for name in blades})
    assert blades_only.node_rows("tower") == base.node_start["tower"]
    with pytest.raises(ValueError, match="load points"):     # its node rows are not read: no effect may load them
        pts.node_rows("blade1")
    for q, qd in random_states(eq, rng):
        gen = rng.normal(size=eq.n_all) * 1e3
        g = {name: rng.normal(size=(p, 6)) * 1e3 for name, p in counts.items()}
        nodes = {name: transfers[name] @ g[name] for name in counts}
        M_node, F_node, _ = assemble_by_route(eq, True, q, qd, nodes, gen)
        fnodes = np.zeros((pts.n_rows, 6))
        flag = np.zeros(eq.n_bodies, np.int64)
        for name, p in counts.items():
            lp = pts.load_points[name]
            fnodes[lp.first:lp.first + p] = lp.weights[:, None] * g[name]
            flag[eq.body_index[name]] = 1
        M, F = np.empty((eq.n_all, eq.n_all)), np.empty(eq.n_all)
        kernel.assemble(q, qd, eq.gravity.astype(float), fnodes, flag, gen, pts.data, pts.work, M, F)
        Mr, Fr = eq.evaluate_full_reference(q, qd, nodes, gen)
        assert_equal_rel(M, M_node, "M: load points against nodes")
        assert_equal_rel(F, F_node, "F: load points against nodes")
        assert_equal_rel(F, Fr, "F: load points against the reference")
        F0 = eq.evaluate_full_reference(q, qd, None, gen)[1]       # the loads' own part, on its own scale
        scale = np.abs(Fr - F0).max()
        assert scale > 0 and np.abs((F - F0) - (Fr - F0)).max() <= 1e-8 * scale


def test_route_choice_by_cost(turbine):
    """The packer takes the invariants where they are the cheaper: the
    blades of the 214-node fem beam with 3 modes per field, not a blade of
    17 nodes with 3 modes (an OpenFAST deck's), nor one whose S-S tensor
    would exceed `MAX_ENTRIES` entries."""
    eq = KaneEquations(fem_turbine(turbine))
    blade = next(f for b, _, f in eq.bodies if b.name == "blade1")
    assert len(blade.m) > 200 and body_integrals.choose_invariants(blade)

    def body(n_nodes, ne):
        S = np.ones((n_nodes, ne, ne))
        return SimpleNamespace(idx=np.arange(ne), m=np.ones(n_nodes), S=S, eta=None)

    assert not body_integrals.choose_invariants(body(17, 3))
    assert body_integrals.choose_invariants(body(214, 8))
    big = int(body_integrals.MAX_ENTRIES ** 0.25) + 1
    assert not body_integrals.choose_invariants(body(2000, big))


def test_pendulum_chain_analytic():
    """Single pendulum through the kernel: M = m L^2 + I, F = -m g L sin(th)."""
    L, m, g = 2.0, 3.0, 9.80665
    bob = RigidBody("bob", Joint(None, rotations=[Rotation(1, {"th": 1.0})]), m, np.array([0, 0, -L]),
                    np.diag([0.0, 0.5, 0.0]))
    rhs = KaneEquations(System([bob], ["th"], gravity=g)).compiled_rhs()
    for th in (0.1, 1.0, 2.5):
        M, F = rhs(0.0, np.array([th]), np.array([0.7]))
        assert M[0, 0] == pytest.approx(m * L * L + 0.5, rel=1e-12)
        assert F[0] == pytest.approx(-m * g * L * np.sin(th), rel=1e-12)


@pytest.mark.parametrize("case", ["land_3dof", "flexible_blades", "prescribed_rotor"])
def test_turbine_matches_reference(turbine, case):
    check_against_reference(turbine_system(turbine, case), np.random.default_rng(2))


def test_compiled_rhs_matches_evaluate(turbine):
    """CompiledRHS (free rows, drivetrain spring-damper, solve in the kernel)
    equals the reference equations plus the same generalised force."""
    system = turbine_system(turbine, "flexible_blades")
    eq = KaneEquations(system)
    k, c = 8.7e8, 6.2e6
    rhs = eq.compiled_rhs([("DrTr", "DrTr", k, c)])
    i = eq.index["DrTr"]
    for q, qd in random_states(eq, np.random.default_rng(3)):
        qf, qdf = q[eq.free_idx], qd[eq.free_idx]
        gen = np.zeros(eq.n_all)
        gen[i] = -(k * q[i] + c * qd[i])
        Mr, Fr = eq.evaluate_reference(qf, qdf, 1.3, generalized=gen)
        M, F = rhs(1.3, qf, qdf)
        assert_equal_rel(M, Mr, "M")
        assert_equal_rel(F, Fr, "F")
        qdd, status = rhs.accelerations(1.3, qf, qdf)
        assert status == 0
        assert_equal_rel(qdd, np.linalg.solve(Mr, Fr), "qdd")
        # a first call goes through numba's dispatcher, the later ones through the entry point it
        # resolved (`compiled._entry_point`): the same compiled code, bit for bit
        fresh = eq.compiled_rhs([("DrTr", "DrTr", k, c)])
        M1, F1 = fresh(1.3, qf, qdf)
        assert np.array_equal(M1, M) and np.array_equal(F1, F)
    assert rhs._call is not None


def test_dop853_tableau_is_scipys():
    """compiled-DOP853's tableau (numbers in `dop853_tableau`, so a compiled run
    does not import scipy.integrate) equals scipy's DOP853 class attributes bit for bit."""
    from scipy.integrate import DOP853

    from modesel.multibody.dop853_tableau import A, B, C, D, E3, E5
    n = DOP853.n_stages
    assert np.array_equal(A[:n, :n], DOP853.A) and np.array_equal(A[n, :n], DOP853.B)
    assert np.array_equal(A[n + 1:], DOP853.A_EXTRA) and not A[:n + 1, n:].any()
    assert np.array_equal(C, np.concatenate([DOP853.C, [1.0], DOP853.C_EXTRA]))
    for ours, theirs in ((B, DOP853.B), (E3, DOP853.E3), (E5, DOP853.E5), (D, DOP853.D)):
        assert ours.shape == theirs.shape and np.array_equal(ours, theirs)


def test_compiled_dop853_equals_solve_ivp(turbine):
    """The compiled loop reproduces scipy's DOP853 (same steps, same outputs)."""
    system = build_turbine(turbine, ModeSet({"tower_fa": FieldModes("elastodyn", 1),
                                             "tower_ss": FieldModes("elastodyn", 1)}), free=("GeAz",)).system
    eq = KaneEquations(system)
    rhs = eq.compiled_rhs()
    q0, qd0 = np.array([1.0, 0.5, 0.0]), np.array([0.0, 0.0, 1.27])
    compiled = integrate(rhs, q0, qd0, 5.0, 0.01, method="compiled-DOP853")
    scipy_run = integrate(lambda t, q, qd: eq.evaluate_reference(q, qd, t), q0, qd0, 5.0, 0.01, method="DOP853")
    assert compiled.n_rhs == scipy_run.n_rhs
    assert np.array_equal(compiled.t, scipy_run.t)
    assert np.abs(compiled.q - scipy_run.q).max() < 1e-9
    assert np.abs(compiled.qd - scipy_run.qd).max() < 1e-9
    assert np.ptp(compiled.q[:, 0]) > 1.5                      # it did vibrate


def test_rk45_tableau_is_scipys():
    """compiled-RK45's tableau (numbers in `rk45_tableau`) equals scipy's RK45
    class attributes bit for bit."""
    from scipy.integrate import RK45

    from modesel.multibody.rk45_tableau import A, B, C, E, P, TABLE
    for ours, theirs in ((A, RK45.A), (B, RK45.B), (C, RK45.C), (E, RK45.E), (P, RK45.P)):
        assert ours.shape == theirs.shape and np.array_equal(ours, theirs)
    assert all(x is y for x, y in zip(TABLE, (A, B, C, E, E, P)))


def test_compiled_rk45_equals_solve_ivp(turbine):
    """The compiled Dormand-Prince 5(4) loop reproduces scipy's RK45 (same
    steps and right-hand sides, same outputs), and agrees with DOP853 to the
    tolerance."""
    system = build_turbine(turbine, ModeSet({"tower_fa": FieldModes("elastodyn", 1),
                                             "tower_ss": FieldModes("elastodyn", 1)}), free=("GeAz",)).system
    eq = KaneEquations(system)
    rhs = eq.compiled_rhs()
    q0, qd0 = np.array([1.0, 0.5, 0.0]), np.array([0.0, 0.0, 1.27])
    compiled = integrate(rhs, q0, qd0, 5.0, 0.01, method="compiled-RK45", rtol=1e-6, atol=1e-8)
    scipy_run = integrate(lambda t, q, qd: eq.evaluate_reference(q, qd, t), q0, qd0, 5.0, 0.01, method="RK45",
                          rtol=1e-6, atol=1e-8)
    assert compiled.method == "compiled-RK45"
    assert compiled.n_rhs == scipy_run.n_rhs
    assert np.array_equal(compiled.t, scipy_run.t)
    assert np.abs(compiled.q - scipy_run.q).max() < 1e-9
    assert np.abs(compiled.qd - scipy_run.qd).max() < 1e-9
    assert np.ptp(compiled.q[:, 0]) > 1.5                      # it did vibrate
    exact = integrate(rhs, q0, qd0, 5.0, 0.01, method="compiled-DOP853", rtol=1e-11, atol=1e-12)
    assert np.abs(compiled.q - exact.q).max() < 1e-4 * np.ptp(exact.q[:, 0])


@pytest.mark.parametrize("method", ["compiled-DOP853", "compiled-RK45"])
def test_compiled_divergence_detected(turbine, method):
    """Buckling tower (gravity x 1e4) and a tight bound stop with SimulationDiverged."""
    ms = ModeSet({"tower_fa": FieldModes("elastodyn", 1)})
    model = build_turbine(turbine, ms)
    model.system.gravity *= 1e4
    rhs = KaneEquations(model.system).compiled_rhs()
    with pytest.raises(SimulationDiverged) as info:
        integrate(rhs, np.array([0.1]), np.array([0.0]), 20.0, 0.01, bounds=np.array([40.0]), method=method)
    assert 0.0 < info.value.time < 20.0
    rhs = KaneEquations(build_turbine(turbine, ms).system).compiled_rhs()
    with pytest.raises(SimulationDiverged) as info:
        integrate(rhs, np.array([1.0]), np.array([0.0]), 5.0, 0.01, bounds=np.array([0.5]), method=method)
    assert "beyond its physical bound" in str(info.value)


def test_linear_solvers():
    """Cholesky for the (SPD) mass matrix; Gaussian elimination for any other
    non-singular matrix; an exactly singular one is reported."""
    rng = np.random.default_rng(4)
    A = rng.normal(size=(6, 6))
    b = rng.normal(size=6)
    spd = A @ A.T + np.eye(6)
    x = b.copy()
    assert kernel.cholesky_solve(spd.copy(), x)
    assert np.allclose(spd @ x, b, rtol=0, atol=1e-12)
    indefinite = A + A.T
    assert not kernel.cholesky_solve(indefinite.copy(), b.copy())
    x = b.copy()
    assert kernel.lu_solve(indefinite.copy(), x)
    assert np.allclose(indefinite @ x, b, rtol=0, atol=1e-10)
    singular = A.copy()
    singular[3] = 0.0
    assert not kernel.lu_solve(singular, b.copy())


def test_reaction_loads_match_reference(turbine):
    """Batch reaction loads (tower base and blade roots) equal F_r - M_r qdd
    of the reference equations, with the drivetrain spring-damper."""
    ms = ModeSet({"tower_fa": FieldModes("elastodyn", 1), "blade_flap": FieldModes("elastodyn", 1)})
    model = build_turbine(turbine, ms, free=("GeAz", "DrTr"), reactions=True)
    eq = KaneEquations(model.system)
    k, c = 8.7e8, 6.2e6
    rows = list(model.reactions.values())
    rhs = eq.compiled_rhs([("DrTr", "DrTr", k, c)], all_rows=True)
    rng = np.random.default_rng(5)
    nf = len(eq.free_idx)
    t = rng.uniform(0, 5, 4)
    q, qd = rng.normal(size=(4, nf)) * 0.3, rng.normal(size=(4, nf))
    loads = rhs.reactions(t, q, qd, rows)
    i = eq.index["DrTr"]
    for j in range(4):
        q_all, qd_all, _ = eq.full_state(q[j], qd[j], t[j])
        gen = np.zeros(eq.n_all)
        gen[i] = -(k * q_all[i] + c * qd_all[i])
        M, F = eq.evaluate_full_reference(q_all, qd_all, generalized=gen)
        qdd = np.zeros(eq.n_all)
        fi = eq.free_idx
        qdd[fi] = np.linalg.solve(M[np.ix_(fi, fi)], F[fi])
        expected = np.array([F[eq.index[r]] - M[eq.index[r]] @ qdd for r in rows])
        assert_equal_rel(loads[j], expected, "reactions")


def test_scipy_paths_of_the_compiled_rhs(turbine):
    """A rotor speed prescribed by a Python function (scipy path, kernel
    accelerations) and by the equivalent polynomial (compiled loop) give the
    same motion; Radau agrees with DOP853 to its tolerance."""
    ms = ModeSet({"tower_fa": FieldModes("elastodyn", 1), "tower_ss": FieldModes("elastodyn", 1)})
    poly = Prescribed(0.3, 1.27, 0.02)
    runs = {}
    for name, presc in (("poly", poly), ("function", Prescribed(function=poly.__call__))):
        rhs = KaneEquations(build_turbine(turbine, ms, prescribed={"GeAz": presc}).system).compiled_rhs()
        assert rhs.compilable == (name == "poly")
        method = "compiled-DOP853" if rhs.compilable else "DOP853"
        runs[name] = integrate(rhs, np.array([1.0, -0.5]), np.zeros(2), 3.0, 0.01, method=method)
    assert np.abs(runs["poly"].q - runs["function"].q).max() < 1e-9
    radau = integrate(rhs, np.array([1.0, -0.5]), np.zeros(2), 3.0, 0.01, method="Radau")
    assert np.abs(radau.q - runs["poly"].q).max() < 1e-5
    for method in ("compiled-DOP853", "compiled-RK45", "compiled-Radau"):   # a Python function: a user error
        with pytest.raises(ModeselError, match=f"{method} needs a compiled right-hand side"):
            integrate(rhs, np.array([1.0, -0.5]), np.zeros(2), 3.0, 0.01, method=method)


def test_lumping_keeps_frames_or_whole_subtrees():
    """lumping.lump: ground <- a (moving) <- b (constant) <- c (moving) and
    b <- d (constant). Keeping frames (the kernel), b and d join a; lumping
    whole subtrees only (the symbolic reduction), only d joins b. The lumped
    part has the total mass and the centre of mass of its members."""
    from modesel.multibody.lumping import RigidPart, lump
    rng = np.random.default_rng(8)
    parents = [-1, 0, 1, 1]
    parts = []
    for m in (2.0, 1.0, 3.0, 0.5):
        A = rng.normal(size=(3, 3))
        parts.append(RigidPart(m, rng.normal(size=3), A @ A.T))
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    placements = [None, (turn, np.array([0.0, 0.0, 1.0])), None, (np.eye(3), np.array([0.5, 0.0, 0.0]))]
    joins = [False, True, False, True]
    frames = lump(parents, parts, placements, joins, whole_subtrees=False)
    assert frames.target == [0, 0, 2, 0] and frames.lumped_into(0) == [1, 3]
    cm_d = turn @ (np.array([0.5, 0.0, 0.0]) + parts[3].cm) + np.array([0.0, 0.0, 1.0])
    cm_b = turn @ parts[1].cm + np.array([0.0, 0.0, 1.0])
    expected = (2.0 * parts[0].cm + 1.0 * cm_b + 0.5 * cm_d) / 3.5
    assert frames.parts[0].mass == 3.5 and np.allclose(frames.parts[0].cm, expected, rtol=0, atol=1e-14)
    subtrees = lump(parents, parts, placements, joins, whole_subtrees=True)
    assert subtrees.target == [0, 1, 2, 1] and list(subtrees.parts) == [1]


def test_linear_model_in_one_compiled_call_equals_the_numpy_differences():
    """`linearize` on a compiled right-hand side evaluates its central
    differences' states in one compiled call (`CompiledRHS.linear_model`,
    through `kernel.reaction_loads`); the numpy loop over the
    same right-hand side, called from Python 4 n + 1 times, gives the same
    M, C and K (the turbine with BEM, tower drag and generator: 11 DOFs, at a
    deflected, moving state, to 1e-9 of each matrix's largest entry: the BEM's
    iteration starts from the previous call's roots)."""
    from modesel.multibody.linearize import linearize
    from modesel.simulation.api import build, load_scene
    b = build(load_scene("studies/scenes/turbine_wind_11p4.toml"))
    rhs = b.rhs()
    names = list(b.model.system.free)
    rng = np.random.default_rng(5)
    q = np.asarray(b.q0, float) + 0.01 * rng.standard_normal(len(names))
    qd = np.asarray(b.qd0, float) + 0.05 * rng.standard_normal(len(names))
    compiled = linearize(rhs, q, qd, names, t=1.0)
    numpy_loop = linearize(lambda t, qq, vv: rhs(t, qq, vv), q, qd, names, t=1.0)
    for a, ref in ((compiled.M, numpy_loop.M), (compiled.C, numpy_loop.C), (compiled.K, numpy_loop.K)):
        assert np.all(np.isfinite(a)) and np.max(np.abs(ref)) > 0
        assert np.max(np.abs(a - ref)) <= 1e-9 * np.max(np.abs(ref))


def test_elementary_rotation_of_an_array_stacks_the_matrices():
    """`rotations.elementary_rotation` of n angles (the tower-top frame at every
    output time, `model.outputs`) is the stack of its matrices one angle at a time."""
    from modesel.multibody.rotations import elementary_rotation
    angles = np.array([0.3, -1.2, 2.0, 0.0])
    for axis in range(3):
        expected = np.array([elementary_rotation(axis, float(a)) for a in angles])
        stacked = elementary_rotation(axis, angles)
        assert stacked.shape == (4, 3, 3)
        assert np.allclose(stacked, expected, rtol=0, atol=1e-15), axis


def test_frames_along_a_history_equal_the_reference_kinematics():
    """`FrameKinematics.along` (the outputs' pass: the frames at every output
    time in one compiled call, `kernel.kinematics_along`) gives at each state
    the frames of the numpy reference (`KaneEquations.kinematics`: R, r, v,
    w) and of the one-state call, on the chain exercising every joint feature."""
    from modesel.multibody.kinematics import FrameKinematics
    eq = KaneEquations(pendulum_chain())
    states = list(random_states(eq, np.random.default_rng(3)))
    Q, QD = np.array([q for q, _ in states]), np.array([qd for _, qd in states])
    frames = FrameKinematics(eq)
    R, vec = frames.along(Q, QD)
    assert R.shape[0] == vec.shape[0] == len(states) >= 3
    for k, (q, qd) in enumerate(states):
        R1, vec1 = frames(q, qd)
        np.testing.assert_array_equal(R[k], R1)
        np.testing.assert_array_equal(vec[k], vec1)
        for b, ref in enumerate(eq.kinematics(q, qd)):
            assert_equal_rel(R[k, b], ref.R, "R")
            for i, x in enumerate((ref.r, ref.v, ref.w)):
                assert_equal_rel(vec[k, b, i], x, ("r", "v", "w")[i])


def test_small_rotation_of_arrays_is_the_stack_of_the_scalar_ones():
    """ElastoDyn's SmllRotTrans (`rotations.small_rotation`) of arrays of
    angles (the gauge channels over all output times at once) is the stack
    of the matrices of each time's angles; each is orthonormal to the
    rounding of its O(t^4) terms and is the identity at zero."""
    from modesel.multibody.rotations import small_rotation
    rng = np.random.default_rng(5)
    t = rng.normal(scale=0.05, size=(3, 7))
    stack = small_rotation(*t)
    assert stack.shape == (7, 3, 3)
    for k in range(7):
        np.testing.assert_array_equal(stack[k], small_rotation(*t[:, k]))
        assert np.abs(stack[k] @ stack[k].T - np.eye(3)).max() < 1e-5
    np.testing.assert_array_equal(small_rotation(np.zeros(2), 0.0)[1], np.eye(3))
