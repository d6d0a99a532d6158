"""Every twin of the code base, checked against its other half.

A twin is one formula implemented twice: a numpy reference and a compiled
(numba) loop that the time integrator calls at every right-hand side, or the
numeric engine and its exact SymPy derivation. Each entry of `TWINS` names
both halves and returns (what, reference, twin) triples at random inputs;
one parametrised test holds every pair equal to `REL`, relative to the
largest reference value (exactly where the reference is all zeros), or to
the scale a triple gives as its fourth item (a component of a vector: the
vector's magnitude, `vector_scale`).
Formulas that share their code, like the BEM model ufuncs `prandtl_factor`,
`axial_induction` and `pitt_peters`, are no twins.

The multibody twins are reached through the public front only
(`modesel.simulation.api.build`, `KaneEquations`, `Built.frames`).
"""
import functools
import importlib.util
import tempfile
from pathlib import Path

import numpy as np
import pytest

from modesel.aero import BemOptions, BemSolver, Wind, skew_angles
from modesel.turbine.aerodyn import read_aerodyn
from modesel.aero.tower_drag import drag_forces
from modesel.aero.wind import COLUMNS, N_PARAMS, wind_params, wind_velocity
from modesel.model.effects.aero import inflow, section_reference
from modesel.multibody.kane import KaneEquations
from modesel.multibody.kernel import LOSS_K
from modesel.multibody.kinematics import PointSet
from modesel.simulation.api import build, load_scene
from modesel.simulation.scene import scene_from_dict

ROOT = Path(__file__).resolve().parents[1]
AD_FILE = ROOT / "modesel" / "turbine" / "data" / "nrel5mw" / "NREL5MW_AD.dat"
SCENES = ROOT / "studies" / "scenes"
REL = 1e-10
TWINS = {}


def twin(name):
    """Register a check `rng -> [(what, reference, twin), ...]` under `name`;
    its docstring names the two halves."""
    def register(check):
        TWINS[name] = check
        return check
    return register


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


# ----------------------------------------------------------------------------- aerodynamics

@twin("wind_profile")
def wind_profile(rng):
    """InflowWind's uniform wind: aero.wind.Wind.vector (numpy) / wind_velocity (numba),
    every column of the table in play (shears, direction, upflow, gust, time); its
    parameters in time: Wind.params (numpy) / wind_params (numba)."""
    n = 200
    z = np.concatenate([[0.0, -3.0], rng.uniform(-10.0, 200.0, n)])
    x, y = rng.uniform(-10.0, 10.0, n + 2), rng.uniform(-70.0, 70.0, n + 2)
    table = np.column_stack([[0.0, 5.0, 12.0], rng.uniform(3.0, 25.0, 3), rng.uniform(-0.5, 0.5, 3),
                             rng.uniform(-1.0, 1.0, 3), rng.uniform(-0.2, 0.2, 3), rng.uniform(-0.1, 0.4, 3),
                             rng.uniform(-0.2, 0.2, 3), rng.uniform(-2.0, 2.0, 3), rng.uniform(-0.1, 0.1, 3)])
    assert table.shape[1] == len(COLUMNS)
    wind = Wind(table=table, reference_height=rng.uniform(20.0, 150.0), reference_length=rng.uniform(50.0, 150.0),
                upflow=rng.uniform(-0.15, 0.15))
    out = []
    for t in (0.0, 3.3, 20.0):
        p = wind.params(t)
        compiled = np.array([wind_velocity(p, xk, yk, zk) for xk, yk, zk in zip(x, y, z)])
        out.append((f"V(t={t})", wind.vector(z, t, x, y), compiled))
    for t in (-1.0, 0.0, 2.7, 5.0, 9.9, 12.0, 30.0):
        p = np.zeros(N_PARAMS)
        p[N_PARAMS - 2:] = np.cos(wind.upflow), np.sin(wind.upflow)        # set by the packing, left by wind_params
        wind_params(wind.table, wind.reference_height, wind.reference_length, t, p)
        out.append((f"params(t={t})", wind.params(t), p))
    return out


def random_full_field(rng, periodic=False):
    """A TurbSim field of random velocities (11 x 9 points, 3 tower points, 60 steps), written and read back."""
    from modesel.aero.full_field import read_turbsim, write_turbsim
    nt, nz, ny = 60, 9, 11
    grid = rng.normal(0.0, 1.0, (nt, nz, ny, 3)) + [10.0, 0.0, 0.0]
    tower = rng.normal(0.0, 1.0, (nt, 3, 3)) + [8.0, 0.0, 0.0]
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "field.bts"
        write_turbsim(path, grid, tower, 14.0, 15.0, 0.3, 10.0, 90.0, 30.0, periodic=periodic)
        return read_turbsim(path)


@twin("full_field")
def full_field(rng):
    """InflowWind's TurbSim full field: aero.full_field.FullField.velocity (numpy) /
    grid_velocity through wind_velocity (numba), in the grid, on the tower points, from
    them to the ground and across a periodic file's wrap, turned about the vertical (PropagationDir);
    the tower drag in it: aero.TowerDrag.load of Wind.vector (numpy) / drag_forces (numba)."""
    out = []
    for periodic, turn in ((False, 0.0), (True, 0.0), (False, 0.2)):
        field = random_full_field(rng, periodic)
        wind = Wind(full_field=field, direction=turn)
        n = 300
        x = rng.uniform(-10.0, 10.0, n)
        y = rng.uniform(-field.half_width, field.half_width, n) * np.cos(turn) * 0.9
        z = np.concatenate([rng.uniform(field.grid_base, field.top, n - 60), rng.uniform(-5.0, field.grid_base, 60)])
        for t in (0.0, 2.1) + ((9.35,) if not turn else ()) + ((12.5, 17.9) if periodic else ()):
            p = wind.params(t)
            compiled = np.array([wind_velocity(p, xk, yk, zk) for xk, yk, zk in zip(x, y, z)])
            out.append((f"V(t={t}, periodic={periodic}, turn={turn})", wind.vector(z, t, x, y), compiled))
    drag = read_aerodyn(AD_FILE).tower
    m, rho = 40, 1.225
    pos = np.column_stack([rng.normal(0.0, 0.5, (m, 2)), rng.uniform(-2.0, 95.0, m)])
    vel = rng.normal(0.0, 3.0, (m, 3))
    reference = drag.load(pos[:, 2], wind.vector(pos[:, 2], 1.7, pos[:, 0], pos[:, 1]), vel, rho)
    forces = np.empty((m, 3))
    drag_forces(pos, vel, wind.params(1.7), drag.coefficient(pos[:, 2], rho), forces, True)
    out.append(("tower drag in the full field", reference, forces))
    return out


@twin("tower_drag")
def tower_drag(rng):
    """Eq. 51 with shear: aero.TowerDrag.load (numpy) / aero.tower_drag.drag_forces (numba)."""
    drag = read_aerodyn(AD_FILE).tower
    n, rho = 60, 1.225
    wind = Wind(rng.uniform(3.0, 25.0), rng.uniform(0.0, 0.4), rng.uniform(60.0, 120.0),
                direction=rng.uniform(-np.pi, np.pi))
    pos = np.column_stack([rng.normal(0.0, 0.5, (n, 2)), rng.uniform(-2.0, 95.0, n)])
    vel = rng.normal(0.0, 3.0, (n, 3))
    length = rng.uniform(0.5, 2.0, n)                   # node weights [m]
    reference = drag.load(pos[:, 2], wind.vector(pos[:, 2], 0.0, pos[:, 0], pos[:, 1]), vel, rho) * length[:, None]
    out = np.empty((n, 3))
    drag_forces(pos, vel, wind.params(0.0), drag.coefficient(pos[:, 2], rho) * length, out)
    return [("node forces", reference, out)]


@twin("polar_lookup")
def polar_lookup(rng):
    """aero.Polar.coefficients (np.interp, raw table) / PolarSet.coefficients (numba, common grid)."""
    polars = read_aerodyn(AD_FILE).blade.polars
    alpha = rng.uniform(-3 * np.pi, 3 * np.pi, 500)
    out = []
    for k, polar in enumerate(polars.polars):
        out += [(f"polar {k} {name}", ref, got) for name, ref, got in
                zip(("cl", "cd", "cm"), polar.coefficients(alpha), polars.coefficients(alpha, k))]
    return out


@twin("bem_elements")
def bem_elements(rng):
    """BemSolver.solve (numba, Chandrupatla) / the scalar reference of tests/test_aero.py
    (classic residual, brentq), both solved to round-off."""
    from test_aero import random_elements, scalar_solutions
    deck = read_aerodyn(AD_FILE)
    span, r, vn, vt, pitch, skew, psi = random_elements(rng, 60)
    solver = BemSolver.from_blade(deck.blade, span, num_blades=3, hub_radius=1.5,
                                  air_density=deck.air_density,
                                  options=BemOptions.from_deck(deck, tolerance=1e-15))
    res = solver.solve(r, vn, vt, pitch, skew, psi)
    reference = scalar_solutions(deck, solver, r, vn, vt, pitch, skew, psi)
    assert len(reference) > 0.9 * r.size
    idx = list(reference)
    ref = np.array(list(reference.values()))
    return [(name, ref[:, j], getattr(res, name)[idx])
            for j, name in enumerate(("a", "a_prime", "phi", "f_n", "f_t"))]


@twin("blade_point_loads")
def blade_point_loads(rng):
    """The blade loads summed per station: the node loads of distribute and node_moments
    (numba, the Python effect's) summed over the nodes / point_loads at one load point per
    station (effects/aero.py, the compiled loop's): total force, total moment about the
    blade origin at deflected positions (the load points at the T-weighted mean of the
    nodes, packing.LoadPoints), and the elastic generalised forces, with ElastoDyn-like
    moment points (a lumping other than the transfer, nearest nodes, offsets)."""
    from modesel.model.effects.aero import distribute, moment_points, node_moments, point_loads, row_bands
    B, M, N, K, ne = 3, 7, 23, 11, 4
    out = []
    for _ in range(2):
        T = np.zeros((N, M))                       # a band of two stations per node
        for i in range(N):
            a = rng.integers(0, M - 1)
            T[i, a:a + 2] = rng.uniform(0.1, 1.0, 2)
        L = np.zeros((K, M))
        for p in range(K):
            a = rng.integers(0, M - 2)
            L[p, a:a + 3] = rng.uniform(0.1, 1.0, 3)
        near = rng.integers(0, N, K).astype(np.int64)
        offset = rng.normal(size=(K, 3))
        slopes = rng.normal(size=(N, 3, ne))
        fn, ft, fm = rng.normal(size=(3, B, M)) * 1e3
        en, et = unit(rng.normal(size=(B, M, 3))), unit(rng.normal(size=(B, M, 3)))
        R = np.stack([random_rotation(rng) for _ in range(B + 1)])
        blades = np.arange(1, B + 1, dtype=np.int64)
        elastic = np.arange(B * ne, dtype=np.int64).reshape(B, ne)
        gen0 = rng.normal(size=B * ne)
        nodes = np.zeros((B, N, 6))
        gen_nodes = gen0.copy()
        distribute(fn, ft, en, et, *row_bands(T), nodes)
        node_moments(fn, ft, fm, 1.0, en, et, R, blades, *row_bands(L), near, offset, slopes, elastic, nodes,
                     gen_nodes)
        w = T.sum(axis=0)
        points = np.zeros((B, M, 6))
        gen_points = gen0.copy()
        point_loads(fn, ft, fm, 1.0, en, et, R, blades, w, *moment_points(L, near, offset, slopes), elastic,
                    points, gen_points)
        x = rng.normal(size=(N, 3)) * 10.0             # deflected node positions in the blade frame
        xp = (T / w).T @ x
        for b in range(B):
            pos, pos_p = x @ R[blades[b]].T, xp @ R[blades[b]].T
            out += [(f"blade {b} force", nodes[b, :, :3].sum(0), points[b, :, :3].sum(0)),
                    (f"blade {b} moment", (np.cross(pos, nodes[b, :, :3]) + nodes[b, :, 3:]).sum(0),
                     (np.cross(pos_p, points[b, :, :3]) + points[b, :, 3:]).sum(0))]
        out.append(("elastic generalised forces", gen_nodes, gen_points))
    return out


@twin("blade_inflow")
def blade_inflow(rng):
    """model.effects.aero.inflow (numba) / Wind.vector, aero.skew_angles, AeroDyn's TSR, the
    annulus frame of AeroDyn's NoSweepPitchTwist projection and its
    EulerExtract of the deflected section (numpy, scipy Rotation: the
    section's rotation from Euler parameters (w, theta/2), ElastoDyn's
    SmllRotTrans, and the 1-2-3 Euler angles of AeroDyn's orientation)."""
    from scipy.spatial.transform import Rotation
    B, M = 3, 9
    R = np.stack([random_rotation(rng) for _ in range(B + 1)])
    vec = rng.normal(0.0, 1.0, (B + 1, 5, 3))
    vec[0, 0, 2] = rng.uniform(60.0, 120.0)             # apex height [m]
    pos = vec[0, 0] + rng.normal(0.0, 40.0, (B, M, 3))
    vel = rng.normal(0.0, 20.0, (B, M, 3))
    rotation = rng.normal(0.0, 0.15, (B, M, 3))
    crv, tw, pitch = rng.normal(0.0, 0.05, M), rng.uniform(-0.1, 0.3, M), rng.uniform(-0.1, 0.5)
    A = section_reference(crv, tw, pitch)
    wind = Wind(rng.uniform(3.0, 25.0), rng.uniform(0.0, 0.4), rng.uniform(60.0, 120.0),
                direction=rng.uniform(-0.5, 0.5))
    vn, vt, skew, psi, theta, r_local, ratio = (np.empty((B, M)) for _ in range(7))
    en, et, vrel = np.empty((B, M, 3)), np.empty((B, M, 3)), np.empty(3)
    dist = rng.normal(0.0, 1.0, (B, M, 3))                           # the tower's influence [m/s]
    tsr = inflow(R, vec, 0, np.arange(1, B + 1), pos, vel, rotation, A, wind.params(0.0), dist, vn, vt, skew,
                 psi, en, et, theta, r_local, ratio, vrel)
    xs, zb = R[0, :, 0], R[1:, :, 2]
    e_c = unit(xs - (zb @ xs)[:, None] * zb)                       # coned normal
    e_t = np.cross(e_c, zb)
    coned = np.stack([e_c, np.cross(zb, e_c), zb], axis=1)         # (B, 3 axes, 3)
    euler = np.empty((B, M, 3))
    for b in range(B):
        for k in range(M):
            th = coned[b] @ rotation[b, k]
            quat = np.append(th / 2, np.sqrt(1 - th @ th / 4))
            ref = (Rotation.from_euler("XYZ", [0.0, crv[k], -tw[k]]).as_matrix().T
                   @ Rotation.from_euler("XYZ", [0.0, 0.0, -pitch]).as_matrix().T)
            section = ref @ Rotation.from_quat(quat).as_matrix().T          # change of basis, rows: axes
            euler[b, k] = Rotation.from_matrix(section.T).as_euler("XYZ")
    e_n = np.cos(euler[..., 1])[..., None] * e_c[:, None, :] - np.sin(euler[..., 1])[..., None] * zb[:, None, :]
    v_rel = wind.vector(pos[..., 2], 0.0, pos[..., 0], pos[..., 1]) + dist - vel
    radial = unit(zb - (zb @ xs)[:, None] * xs)
    disk = v_rel.reshape(-1, 3).mean(axis=0)
    chi0, psi_ref = skew_angles(disk, xs, radial)
    p = pos - vec[0, 0]
    r_ref = np.linalg.norm(p - (p @ xs)[..., None] * xs, axis=-1)
    return [("disk-averaged v_rel", disk, vrel),
            ("V_n", np.einsum("bki,bki->bk", v_rel, e_n), vn),
            ("V_t", -np.einsum("bki,bi->bk", v_rel, e_t), vt),
            ("annulus normal", e_n, en),
            ("section pitch + twist", -euler[..., 2], theta),
            ("r_local", r_ref, r_local),
            ("tip ratio", r_ref / r_ref.max(axis=1, keepdims=True), ratio),
            ("chi_0", np.broadcast_to(chi0, (B, M)), skew),
            ("psi", np.broadcast_to(psi_ref[:, None], (B, M)), psi),
            # AeroDyn's TSR (SetInputsForBEMT): hub spin about the shaft x max rLocal / V_dot_x
            ("tip-speed ratio", (vec[0, 2] @ xs) * r_ref.max() / (disk @ xs), tsr)]


# ----------------------------------------------------------------------------- multibody

def pendulum_chain_equations():
    """The kernel test's chain exercising every joint feature (tests/test_kernel.py)."""
    from test_kernel import pendulum_chain
    return KaneEquations(pendulum_chain())


@functools.lru_cache(maxsize=1)
def turbine_built():
    """NREL 5-MW with every flexible field, the rotor prescribed (all from the scene front)."""
    d = {"turbine": "nrel5mw",
         "modes": {"tower_fa": {"family": "elastodyn", "count": 2},
                   "tower_ss": {"family": "elastodyn", "count": 1},
                   "tower_torsion": {"family": "linear", "count": 1},
                   "blade_flap": {"family": "elastodyn", "count": 2},
                   "blade_edge": {"family": "elastodyn", "count": 1}},
         "dofs": {"free": ["DrTr"], "constant_speed": {"GeAz": 12.1}},
         "effects": {"gravity": True}}
    return build(scene_from_dict(d))


def random_state(eq, rng):
    q = rng.normal(size=eq.n_all) * 0.5
    qd = rng.normal(size=eq.n_all)
    return q, qd


def kane_pairs(eq, rng, what):
    out = []
    for k in range(2):
        q, qd = random_state(eq, rng)
        gen = rng.normal(size=eq.n_all) * 1e3
        # node forces [N]; at the second state node moments [N m] too (columns 3-5)
        nodes = {b.name: rng.normal(size=(len(b.node_mass), 3 * (k + 1))) * 1e3
                 for b in eq.system.flexible_bodies()}
        M, F = eq.evaluate_full(q, qd, nodes, gen)
        Mr, Fr = eq.evaluate_full_reference(q, qd, nodes, gen)
        t = rng.uniform(0.0, 10.0)
        qf, qdf = q[eq.free_idx], qd[eq.free_idx]
        Mf, Ff = eq.evaluate(qf, qdf, t)
        Mfr, Ffr = eq.evaluate_reference(qf, qdf, t)
        out += [(f"{what} M (all) #{k}", Mr, M), (f"{what} F (all) #{k}", Fr, F),
                (f"{what} M (free) #{k}", Mfr, Mf), (f"{what} F (free) #{k}", Ffr, Ff)]
    return out


@twin("kane")
def kane(rng):
    """M, F: KaneEquations.evaluate(_full) (numba kernel) / evaluate(_full)_reference (numpy)."""
    return (kane_pairs(pendulum_chain_equations(), rng, "pendulum chain")
            + kane_pairs(turbine_built().eq, rng, "NREL 5-MW"))


@twin("kinematics")
def kinematics(rng):
    """Frames and nodes: Built.frames, PointSet.kinematics (numba) / KaneEquations.kinematics,
    node_kinematics (numpy)."""
    b = turbine_built()
    eq = b.eq
    q, qd = random_state(eq, rng)
    R, vec = b.frames(q, qd)
    ref = eq.kinematics(q, qd)
    out = []
    for i, st in enumerate(ref):
        out += [(f"R {i}", st.R, R[i]), (f"r {i}", st.r, vec[i, 0]), (f"v {i}", st.v, vec[i, 1]),
                (f"w {i}", st.w, vec[i, 2])]
    for name in ("tower", "blade1", "blade3"):
        pos, vel = PointSet.of_body(eq, name).kinematics((R, vec), q, qd)
        p_ref, v_ref, _ = eq.node_kinematics(name, ref[eq.body_index[name]], q, qd)
        out += [(f"{name} positions", p_ref, pos), (f"{name} velocities", v_ref, vel)]
    return out


@twin("symbolic")
def symbolic(rng):
    """M, F of the first paper's 2-DOF model: SymPy derivation and its generated module
    (multibody.symbolic.write_python) / numpy engine / numba kernel."""
    from modesel.multibody.symbolic import write_python
    from modesel.simulation.symbolic import derive_scene
    scene = load_scene(SCENES / "paper_2dof_tower_shaft.toml")
    built, model = build(scene), derive_scene(scene)
    with tempfile.TemporaryDirectory() as folder:
        spec = importlib.util.spec_from_file_location("eom_2dof", write_python(model, Path(folder) / "eom.py"))
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    out = []
    for k in range(3):
        q = np.array([rng.normal(0.0, 0.7) if n != "GeAz" else rng.uniform(0, 2 * np.pi)
                      for n in model.coordinates])
        qd = rng.normal(0.0, 0.7, len(q))
        t = rng.uniform(0.0, 10.0)
        M_sym, F_sym = model.evaluate(q, qd, t)
        M_num, F_num = built.eq.evaluate_reference(q, qd, t)
        M_ker, F_ker = built.M_F(t, q, qd)
        out += [(f"M numpy #{k}", M_num, M_sym), (f"F numpy #{k}", F_num, F_sym),
                (f"M kernel #{k}", M_ker, M_sym), (f"F kernel #{k}", F_ker, F_sym),
                (f"M module #{k}", M_sym, module.mass_matrix(q, qd, t=t)),
                (f"F module #{k}", F_sym, module.forcing(q, qd, t=t))]
    return out


# ----------------------------------------------------------------------------- compiled loads

def turbine_with(effects, free=("GeAz", "DrTr"), modes=None):
    """NREL 5-MW with `effects` (the scene front), rotor free."""
    d = {"turbine": "nrel5mw",
         "modes": modes or {"tower_fa": {"family": "elastodyn", "count": 2},
                            "tower_ss": {"family": "elastodyn", "count": 1},
                            "tower_torsion": {"family": "linear", "count": 1},
                            "blade_flap": {"family": "elastodyn", "count": 2},
                            "blade_edge": {"family": "elastodyn", "count": 1}},
         "dofs": {"free": list(free)}, "initial": {"RotSpeed": 9.0},
         "effects": {"gravity": True, **effects}}
    return build(scene_from_dict(d), reactions=True)


def rhs_pairs(built, rng, what, n=3, speeds=(0.3, 1.6)):
    """(M, F) of the compiled right-hand side (`Built.rhs`, every effect's loads
    inside the kernel) / the reference: the effects' Python `__call__` with the
    numpy Kane equations (`KaneEquations.evaluate_reference`) and with the
    kernel (`Built.M_F`), in the same sequence of calls (latched switches)."""
    rhs = built.rhs()
    assert rhs.has_loads, "the effects' loads must run inside the kernel"
    names = list(built.model.system.free)
    out = []
    for k in range(n):
        q = built.q0 + rng.normal(size=len(names)) * 0.05
        qd = rng.normal(size=len(names)) * 0.05
        if "GeAz" in names:
            q[names.index("GeAz")] = rng.uniform(0.0, 2 * np.pi)
            qd[names.index("GeAz")] = rng.uniform(*speeds)
        t = rng.uniform(0.0, 30.0)
        M, F = rhs(t, q, qd)
        q_all, qd_all, _ = built.eq.full_state(q, qd, t)
        gen, nodes = built.loads(t, q_all, qd_all)
        Mr, Fr = built.eq.evaluate_reference(q, qd, t, node_forces=nodes or None, generalized=gen)
        Mk, Fk = built.M_F(t, q, qd)          # the same loads again (latches already set)
        out += [(f"{what} M #{k}", Mr, M), (f"{what} F #{k}", Fr, F), (f"{what} F kernel #{k}", Fk, F)]
    return out


#: the scenes of the compiled-loads twins: (label, effects, modes or None (turbine_with's),
#: states per check, rotor speeds drawn [rad/s]): every load effect and generator law
LOAD_SCENES = [
    ("aero+drag+VS", {"wind": {"speed": 8.0, "shear": 0.2}, "aero": True, "tower_drag": True,
                      "generator": {"mode": "variable_speed"}}, None, 3, (0.3, 1.6)),
    ("series wind, skew, rigid edge",
     {"wind": {"time_series": [[0.0, 6.0], [10.0, 14.0], [20.0, 9.0]], "direction_deg": 8.0},
      "aero": {"skew": True}, "tower_drag": True, "generator": {"mode": "constant", "torque": 3.0e4}},
     {"tower_fa": {"family": "elastodyn", "count": 1}, "blade_flap": {"family": "elastodyn", "count": 1}},
     3, (0.3, 1.6)),
    ("ElastoDyn blade nodes (aero's generalised-force correction)",
     {"wind": {"speed": 10.0, "shear": 0.2}, "aero": True, "elastodyn_nodes": True,
      "generator": {"mode": "variable_speed"}}, None, 3, (0.3, 1.6)),
    ("tower influence (Bak's potential flow, Eames' shadow)",
     {"wind": {"speed": 9.0, "shear": 0.14}, "aero": {"tower_potential": "bak", "tower_shadow": "eames"},
      "generator": {"mode": "variable_speed"}}, None, 3, (0.3, 1.6)),
    ("ServoDyn VSContrl 1", {"generator": {"mode": "simple_variable_speed", "rated_speed_rpm": 1161.963,
                                           "rated_torque": 43093.55, "region2_k": 0.0255764,
                                           "slip_percent": 10.0, "on_speed_rpm": 900.0}}, None, 6, (0.5, 1.5)),
    ("ServoDyn induction", {"generator": {"mode": "induction", "sync_speed_rpm": 1200.0, "rated_torque": 4.0e4,
                                          "slip_percent": 1.0, "pullout_ratio": 2.0, "off_time": 20.0,
                                          "off_when_no_power": True}}, None, 6, (1.1, 1.4)),
]


@twin("compiled_loads")
def compiled_loads(rng):
    """The whole right-hand side with every load effect: Built.rhs (loads packed into the
    kernel, model/effects/compiled.py) / the effects' Python __call__ + KaneEquations
    (numpy reference and kernel): wind (steady with shear; time series; an InflowWind
    table), BEM aero (ElastoDyn blade nodes too; the tower's influence on its wind), tower drag, generator laws (NREL 5-MW, constant, ServoDyn
    simple variable-speed and induction with their switches)."""
    return [pair for what, effects, modes, n, speeds in LOAD_SCENES
            for pair in rhs_pairs(turbine_with(effects, modes=modes), rng, what, n=n, speeds=speeds)]


@twin("yaw_spring")
def yaw_spring(rng):
    """The right-hand side with ServoDyn's yaw spring and damper about a neutral
    yaw of 3 deg on a free yaw (`effects.yaw`, a linear term with its neutral
    position: packed into the kernel) and a generator law / the Python effects
    + KaneEquations (numpy reference and kernel)."""
    built = turbine_with({"yaw": {"stiffness": 9.02832e9, "damping": 1.916e7, "neutral_deg": 3.0},
                          "generator": {"mode": "variable_speed"}}, free=("GeAz", "DrTr", "Yaw"))
    assert built.linear[-1][:2] == ("Yaw", "Yaw") and built.linear[-1][4] == pytest.approx(np.radians(3.0))
    return rhs_pairs(built, rng, "yaw spring")


@twin("tower_drag_nodes")
def tower_drag_nodes(rng):
    """The right-hand side with the tower drag carried to the tower's nodes by the transfer's bands
    (a tower that keeps its nodes; the scenes above take the drag at the tower's load points) / the
    Python effect + KaneEquations (numpy reference and kernel)."""
    built = turbine_with({"wind": {"speed": 9.0, "shear": 0.2}, "tower_drag": True})
    built.effect("tower_drag").load_points = lambda built: {}           # no load points offered
    assert not built.rhs().packed.load_points
    return rhs_pairs(built, rng, "tower drag at the nodes")


@twin("gearbox_losses")
def gearbox_losses(rng):
    """A lossy gearbox (ElastoDyn's GBoxEff 95 %, committed OpenFAST case gearbox_losses): the
    compiled right-hand side's accelerations (gearbox_loss.gearbox_loss, the loss factor decided by the
    shaft torque's sign) and its M, F at the factor it decided (held by the next NO_SOLVE call) /
    the Python effects + KaneEquations.evaluate_reference (multibody/gearbox.py), at states
    whose drivetrain twist drives the generator and states where it is driven (both factors)."""
    built = build(load_scene(ROOT / "tests/data/openfast_more/gearbox_losses/gearbox_losses.fst"))
    eq, rhs = built.eq, built.rhs()
    k, g, eta = eq.loss
    names = list(built.model.system.free)
    i_drtr = names.index("DrTr")
    out, factors = [], set()
    for n in range(6):
        q = built.q0 + rng.normal(size=len(names)) * 0.01
        qd = rng.normal(size=len(names)) * 0.01
        qd[names.index("GeAz")] = rng.uniform(0.8, 1.2)
        q[i_drtr] = (1.0 if n % 2 else -1.0) * rng.uniform(1e-4, 1e-3)     # the shaft torque's sign
        t = rng.uniform(0.0, 30.0)
        acc, code = rhs.accelerations(t, q, qd)
        assert code == 0
        M, F = rhs(t, q, qd)
        q_all, qd_all, _ = eq.full_state(q, qd, t)
        gen, nodes = built.loads(t, q_all, qd_all)
        Mr, Fr = eq.evaluate_reference(q, qd, t, node_forces=nodes or None, generalized=gen)
        factors.add(round(float(rhs.packed.data[1][k, LOSS_K]), 12))     # the factor it decided
        out += [(f"accelerations #{n}", np.linalg.solve(Mr, Fr), acc), (f"M #{n}", Mr, M), (f"F #{n}", Fr, F)]
    assert factors == {round(1.0 / eta, 12), round(eta, 12)}, factors
    return out


def channel_pairs(built, rng, what, n=6, speeds=(0.3, 1.6)):
    """The effects' output channels at n states in increasing time: one
    compiled pass (`CompiledRHS.outputs`, the effects write them inside the
    kernel) / the effects' Python `__call__` and `channels` at each state
    (`outputs.python_effect_channels`); latched switches advance alike."""
    from types import SimpleNamespace

    from modesel.model.outputs import python_effect_channels
    effects = [e for e in built.acting if e.CHANNELS]
    names = [c for e in effects for c in e.CHANNELS]
    assert names, "the scene must have effects with channels"
    free = list(built.model.system.free)
    q = built.q0 + rng.normal(size=(n, len(free))) * 0.05
    qd = rng.normal(size=(n, len(free))) * 0.05
    if "GeAz" in free:
        q[:, free.index("GeAz")] = rng.uniform(0.0, 2 * np.pi, n)
        qd[:, free.index("GeAz")] = rng.uniform(*speeds, n)
    integ = SimpleNamespace(t=np.sort(rng.uniform(0.0, 30.0, n)), q=q, qd=qd)
    compiled = built.rhs(all_rows=True).outputs(integ.t, q, qd, (), names)
    reference = python_effect_channels(built, integ, effects)
    return [(f"{what} {c}", reference[c], compiled[:, k], vector_scale(reference, c))
            for k, c in enumerate(names)]


def vector_scale(channels, name):
    """The scale of a component of AeroDyn's rotor force or moment in the hub
    frame (RtAeroF<a>h, RtAeroM<a>h): the largest magnitude of the whole
    vector. The y and z components are sums over the blades that cancel to
    a tenth of one blade's (its root bending), so a round-off turn of the
    frame moves them by that fraction of the vector, not of themselves.
    None for other channels (the largest reference value)."""
    if not (name.startswith("RtAero") and name[6] in "FM" and name[-1] == "h"):
        return None
    parts = [channels.get(f"RtAero{name[6]}{a}h") for a in "xyz"]
    return float(np.max(np.sqrt(sum(np.asarray(v, float) ** 2 for v in parts)))) if all(
        v is not None for v in parts) else None


@twin("compiled_channels")
def compiled_channels(rng):
    """The effects' output channels (AeroDyn's RtAeroFxh/Mxh/Pwr/Cp, GenTq, GenPwr): one
    compiled pass over the output times, CompiledRHS.outputs (the effects write them
    inside the kernel) / the effects' Python __call__ and channels at each time
    (model/outputs.py python_effect_channels), ServoDyn's switches latching alike."""
    # twice the states, in increasing time; the induction generator above its
    # synchronous speed, so that it produces until off_time (below it, its
    # first negative power switches it off for good and every channel is 0)
    speeds_of = {"ServoDyn induction": (1.3, 1.4)}
    return [pair for what, effects, modes, n, speeds in LOAD_SCENES
            for pair in channel_pairs(turbine_with(effects, modes=modes), rng, what, n=2 * n,
                                      speeds=speeds_of.get(what, speeds))]


# ----------------------------------------------------------------------------- the test

@pytest.mark.parametrize("name", list(TWINS))
def test_twins_agree(name):
    check = TWINS[name]
    pairs = check(np.random.default_rng(sum(map(ord, name))))
    assert pairs
    halves = check.__doc__.splitlines()[0]
    for what, reference, got, *scale in pairs:
        reference, got = np.asarray(reference, float), np.asarray(got, float)
        assert reference.shape == got.shape, (what, reference.shape, got.shape)
        err = np.abs(got - reference).max()
        scale = scale[0] if scale and scale[0] is not None else np.abs(reference).max()
        assert err <= REL * scale, f"{halves} {what}: difference {err:.2e}, reference scale {scale:.2e}"


def test_node_moment_work():
    """A node moment m does the work m . w_r of the body's partial angular
    velocity w_r (Kane): on a blade, about the shaft axis for the azimuth and
    the drivetrain twist (independent of both numerical halves above: the
    kinematics give the hub's x axis), and on the tower, about its axis, the
    torsion shapes; none through a blade's bending coordinates (the loading
    effect adds that part, effects/aero.py `node_moments`)."""
    built = turbine_built()
    eq = built.eq
    rng = np.random.default_rng(7)
    q, qd = random_state(eq, rng)
    states = eq.kinematics(q, qd)
    x_shaft = states[eq.body_index["hub"]].R[:, 0]
    m = np.array([2.0e4, -1.0e4, 3.0e4])
    blade = eq.system.body("blade1")
    loads = np.zeros((len(blade.node_mass), 6))
    loads[5, 3:] = m
    for evaluate in (eq.evaluate_full, eq.evaluate_full_reference):
        _, F0 = evaluate(q, qd)
        _, F1 = evaluate(q, qd, {"blade1": loads})
        dF = F1 - F0
        for name in ("GeAz", "DrTr"):
            assert dF[eq.index[name]] == pytest.approx(m @ x_shaft, rel=1e-9)
        for name in blade.dofs:
            assert abs(dF[eq.index[name]]) < 1e-9 * np.linalg.norm(m)
    # the tower: a moment about the tower's (deflected-frame) axis works through its torsion shape
    tower = eq.system.body("tower")
    R_t = states[eq.body_index["tower"]].R
    k = len(tower.node_mass) - 1
    loads = np.zeros((len(tower.node_mass), 6))
    loads[k, 3:] = 5.0e3 * (R_t @ np.asarray(tower.axis, float))
    eta = np.asarray(tower.torsion, float)[k]
    assert np.abs(eta).max() > 0
    for evaluate in (eq.evaluate_full, eq.evaluate_full_reference):
        _, F0 = evaluate(q, qd)
        _, F1 = evaluate(q, qd, {"tower": loads})
        for j, name in enumerate(tower.dofs):
            assert (F1 - F0)[eq.index[name]] == pytest.approx(5.0e3 * eta[j], rel=1e-9, abs=1e-6)
