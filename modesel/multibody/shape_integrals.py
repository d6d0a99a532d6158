"""Shape integrals of a beam for a set of assumed modes (first paper, App. A-C).

Front function: `shape_integrals(beam, shapes, ...) -> ShapeIntegrals`.

Geometry. The beam lies along its body z axis; its root is at
z = root_offset above the body origin (tower: origin at the tower base,
root_offset 0; blade: origin at the rotor apex, root_offset = hub radius),
so an undeflected point at span s sits at s_P0 = (0, 0, root_offset + s).
Bending shapes displace along one unit `direction` d in the body x-y plane,
Phi_j(s) = phi_j(s/L) d:  'fa' and 'flap' -> +x, 'edge' -> +y, 'ss' -> -y
(ElastoDyn: a positive Q_TSS moves the tower top along -y). 'torsion'
shapes are rotations about z.

Quadrature. Properties are interpolated linearly between the deck stations
and integrated with `points_per_interval` Gauss-Legendre points inside each
station interval (8 by default: exact for integrands that are polynomials of
degree <= 15 inside an interval, e.g. linear m times the square of a
sixth-degree ElastoDyn polynomial). Axial loads N(s) are integrated exactly
(Simpson's rule on each linear piece: the integrands are at most quadratic).
Shapes are evaluated at the quadrature points by `evaluate_shapes`:
exactly when given as a callable x -> ShapeSet (e.g. a partial of
`modesel.candidates.mode_shapes`), otherwise by quintic Hermite
interpolation of (phi, phi', phi'') of a sampled ShapeSet (exact for
polynomials up to degree 5, O(h^6) otherwise). Shapes are functions of
x = s/L, so physical slopes and curvatures are dphi/L and ddphi/L^2.

Conditioning. The raw mass matrix M = A^T A with A_qj = sqrt(w_q m_q)
phi_j(x_q). When its condition number exceeds `ILL_CONDITIONED` (or when
asked) the basis is mass-orthonormalised by a Householder QR factorisation
A = Q R (stable: never forms M): the new shapes are psi = Phi T with
T = R^-1 (diag R > 0), so that T^T M T = I. Every matrix is computed in the
new basis from the transformed samples (psi, psi', psi'' = T^T (phi, ...)),
so nothing ill-conditioned is formed; `transform` = T maps the new
coordinates back, q_raw = T q.

The multibody engine uses the same factorisation (`conditioned_shapes`):
an ill-conditioned field is simulated in the mass-orthogonal basis, each new
shape rescaled to a unit tip value so that a coordinate still reads as the
tip deflection of its shape (the first shape is the family's first shape
unchanged, QR being triangular).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modesel.candidates.base import ShapeSet
from modesel.errors import ModeselError
from modesel.multibody.quadrature import gauss_legendre
from modesel.multibody.rotations import skew
from modesel.vocabulary import DIRECTIONS, FIELD_DIRECTIONS

ILL_CONDITIONED = 1e8


@dataclass(frozen=True)
class Quadrature:
    """Quadrature points `s` [m from the root] and weights `w` [m] of a beam."""

    s: np.ndarray
    w: np.ndarray
    length: float

    @property
    def x(self) -> np.ndarray:
        """Normalised positions s/L."""
        return self.s / self.length


def quadrature(beam, points_per_interval: int = 8) -> Quadrature:
    """Gauss-Legendre points inside each station interval of `beam`
    (`multibody.quadrature.gauss_legendre`)."""
    span = np.asarray(beam.span, dtype=float)
    if span.ndim != 1 or len(span) < 2 or np.any(np.diff(span) <= 0) or span[0] != 0.0:
        raise ModeselError("beam stations must increase from 0", file=getattr(beam, "source", None),
                           field="span")
    s, w = gauss_legendre(span, points_per_interval)
    return Quadrature(s, w, float(span[-1]))


def evaluate_shapes(shapes, x) -> ShapeSet:
    """`shapes` at normalised points `x`.

    `shapes` is a callable x -> ShapeSet (evaluated exactly) or a ShapeSet
    sampled elsewhere (resampled by quintic Hermite interpolation of
    phi, phi', phi'' between its samples).
    """
    x = np.asarray(x, dtype=float)
    if callable(shapes):
        out = shapes(x)
        if not np.allclose(out.x, x):
            raise ValueError("shape callable returned other points than asked for")
        return out
    if shapes.x.shape == x.shape and np.array_equal(shapes.x, x):
        return shapes
    xs = np.asarray(shapes.x, dtype=float)
    if x.min() < xs.min() - 1e-12 or x.max() > xs.max() + 1e-12:
        raise ModeselError(f"shapes sampled on [{xs.min():g}, {xs.max():g}] cannot be evaluated on "
                           f"[{x.min():g}, {x.max():g}]", field="shapes")
    from scipy.interpolate import BPoly           # here: most builds sample the shapes where needed
    rows = []
    for k in range(shapes.count):
        poly = BPoly.from_derivatives(xs, np.stack([shapes.phi[k], shapes.dphi[k], shapes.ddphi[k]], axis=1))
        rows.append([poly(x), poly.derivative(1)(x), poly.derivative(2)(x)])
    phi, dphi, ddphi = (np.array([r[i] for r in rows]) for i in range(3))
    return ShapeSet(shapes.field, shapes.family, x, phi, dphi, ddphi, dict(shapes.params))


@dataclass
class ShapeIntegrals:
    """Generalised matrices and SID shape integrals of one field's modes.

    n = number of modes. Matrices are n x n in SI units per unit modal
    coordinate (a coordinate is the tip value of its raw shape).

    mass M_e (eq. B1/26/A7; torsion: int I_p psi_i psi_j), stiffness K_e
    (eq. B2/27; torsion: int GJ psi_i' psi_j'; ElastoDyn modal stiffness
    tuners applied as K_il sqrt(t_i t_l) when given), damping D_e (App. B:
    2 zeta_i omega_i in the modal basis of (K_e, M_e)).
    geometric_stiffness: named n x n matrices (eq. B5 with an axial load N):
      'gravity_top_mass' K_gt = -g M_top int Phi_i'.Phi_j' (eq. 33) [N/m],
      'gravity_self_weight' K_gw = -g int N_m Phi_i'.Phi_j', N_m(s) = int_s^L m
      (eq. 34) [N/m],
      'gravity_axial_per_g' = K_gw / g: per unit axial acceleration a_z - g_z
      (eq. C3 with the sign of a compressive load, so K_g = (a_z - g_z) times
      it, eq. C2) [kg/m],
      'centrifugal_per_omega2' = (1 - (e.e_z)^2) int N_r Phi_i'.Phi_j' with
      N_r(s) = int_s^L m r' ds' + M_top r_tip, r = root_offset + s measured
      from the rotation axis (eq. 29-30, C5) [kg = N s^2/m]; for a coned blade
      (1 - (e.e_z)^2) = cos^2(precone) (ElastoDyn uses a single cos(precone),
      a 0.1 % difference at 2.5 deg).
    spin_softening_per_omega2: first-order O_e term omega^T O_e^1 omega / Omega^2
      for a spin about the rotation axis e, = -(1 - (d.e)^2) M_e (eq. A10/A12;
      K_omega of eq. 32 for edge modes) [kg]. Default e: the tower's own axis
      (yaw) for towers, the shaft for blades.
    frequencies_hz: of (K, M_e) with K = K_e + K_gt + K_gw for towers and
      K = K_e + Omega^2 (centrifugal + spin softening) for blades (eq. 31, 32,
      35); a negative value flags a negative eigenvalue (buckling).
    tip_deflection, tip_slope [1/m]: Phi(L) and Phi'(L) per mode.
    condition_number: of the raw mass matrix; orthonormalised/transform: see
      the module docstring.
    SID terms (App. A, body frame, q = 0): total_mass, s_cm (3,), J (3, 3)
      (A4, plus int I_p about z), C_t (n, 3) (A6), C_r (n, 3) (A5), G_r (n, 3, 3)
      (A11), O_e_j (n, 3, 3) (A12), O_e (n, 6) (A14), G_e (n, n, 3) (A13, G_e[j]
      is the n x 3 matrix of shape j), first-order M_xtheta_1 (n, 3, 3) and
      M_thetatheta_1 (n, 3, 3) (D2-D4). Torsion: rotation shapes carry no
      translation, so C_t, G, O and the first-order terms are zero and
      C_r[:, 2] = int I_p psi_j (section rotary inertia).
    """

    field: str
    family: str
    direction: str | tuple
    length: float
    mass: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    geometric_stiffness: dict
    spin_softening_per_omega2: np.ndarray
    frequencies_hz: np.ndarray
    tip_deflection: np.ndarray
    tip_slope: np.ndarray
    condition_number: float
    orthonormalised: bool
    transform: np.ndarray
    total_mass: float
    s_cm: np.ndarray
    J: np.ndarray
    C_t: np.ndarray
    C_r: np.ndarray
    G_r: np.ndarray
    O_e_j: np.ndarray
    O_e: np.ndarray
    G_e: np.ndarray
    M_xtheta_1: np.ndarray
    M_thetatheta_1: np.ndarray
    rotor_speed: float = 0.0
    notes: tuple = ()

    @property
    def count(self) -> int:
        return self.mass.shape[0]


def tail_integral(span, values, s, lever_offset=None) -> np.ndarray:
    """int_s^L f(s') ds' at points s, f = values (linear between stations),
    times (lever_offset + s') when lever_offset is given. Exact (Simpson on
    each linear piece, the integrand being at most quadratic)."""
    span, values, s = (np.asarray(a, dtype=float) for a in (span, values, s))

    def f(z):
        m = np.interp(z, span, values)
        return m if lever_offset is None else m * (lever_offset + z)

    def simpson(a, b):
        return (b - a) / 6.0 * (f(a) + 4.0 * f(0.5 * (a + b)) + f(b))

    pieces = simpson(span[:-1], span[1:])
    above = np.concatenate([np.cumsum(pieces[::-1])[::-1], [0.0]])  # int from station k to L
    k = np.clip(np.searchsorted(span, s, side="right") - 1, 0, len(span) - 2)
    return above[k + 1] + simpson(s, span[k + 1])


def shape_integrals(beam, shapes, *, direction=None, top_mass: float = 0.0, gravity: float = 9.80665,
                    rotor_speed: float = 0.0, precone: float = 0.0, rotation_axis=None,
                    stiffness_tuners=None, damping_ratios=None, orthonormalise="auto",
                    points_per_interval: int = 8) -> ShapeIntegrals:
    """Shape integrals of `shapes` (ShapeSet or callable x -> ShapeSet) on `beam`.

    direction: 'fa'/'ss'/'flap'/'edge'/'torsion' or a unit 3-vector in the
      body x-y plane; default from the shapes' field.
    top_mass [kg]: concentrated mass at the beam tip (tower: rotor-nacelle
      assembly; blade: tip brake) for eq. 33 and the centrifugal load.
    gravity [m/s^2]; rotor_speed [rad/s] (blades: eq. 31-32 frequencies);
    precone [rad] and rotation_axis (body frame; default e_z for a tower,
      (cos precone, 0, sin precone) for a blade).
    stiffness_tuners: ElastoDyn modal tuners t_i, K_il *= sqrt(t_i t_l); only
      meaningful for the deck's own modes, so never taken from the beam.
    damping_ratios: modal damping ratios (fractions); default
      beam.damping_ratio[field]; modes beyond the list are damped
      stiffness-proportionally from the last ratio, zeta_i = zeta_last
      omega_i / omega_last.
    orthonormalise: 'auto' (condition number > ILL_CONDITIONED), True, False.
    """
    quad = quadrature(beam, points_per_interval)
    sampled = evaluate_shapes(shapes, quad.x)
    tip = evaluate_shapes(shapes, np.array([1.0]))
    name = sampled.field
    source = getattr(beam, "source", None)
    kind, d = _direction(direction if direction is not None else FIELD_DIRECTIONS.get(name), name)
    n = sampled.count
    L = quad.length
    phi, dphi, ddphi = sampled.phi, sampled.dphi / L, sampled.ddphi / L ** 2
    if not all(np.all(np.isfinite(a)) for a in (phi, dphi, ddphi)):
        raise ModeselError("shapes contain non-finite values", field=name)
    if top_mass < 0:
        raise ModeselError(f"top mass must be >= 0, got {top_mass:g}", field="top_mass")
    notes = []

    def at(values):
        return np.interp(quad.s, beam.span, np.asarray(values, dtype=float))

    w, m = quad.w, at(beam.mass)
    inertia = at(beam.polar_inertia)
    density = inertia if kind == "torsion" else m
    weighted = np.sqrt(w * density)[None, :] * phi          # A, with M = A A^T (eq. B1/A7)
    condition = mass_condition_number(weighted, kind, source, name)

    # mass-orthonormalisation (module docstring): transform the sampled shapes
    do_orth = condition > ILL_CONDITIONED if orthonormalise == "auto" else bool(orthonormalise)
    # an ill-conditioned basis is always worked in orthonormalised; with
    # orthonormalise=False the results are mapped back to the raw basis at the end
    back_to_raw = not do_orth and condition > ILL_CONDITIONED
    if do_orth or back_to_raw:
        transform = orthonormalising_transform(weighted)
        notes.append(f"mass matrix condition number {condition:.3g}: basis mass-orthonormalised "
                     f"(QR, q_raw = transform q)." if do_orth else
                     f"mass matrix condition number {condition:.3g}: matrices given for the raw "
                     f"shapes as asked, frequencies and damping computed in the mass-orthonormal basis.")
    else:
        transform = np.eye(n)
    # ElastoDyn tuners scale the strain of raw mode i by sqrt(t_i): K_il -> sqrt(t_i t_l) K_il
    tuner = np.ones(n)
    if stiffness_tuners is not None:
        given = np.asarray(stiffness_tuners, dtype=float)[:n]
        if np.any(given <= 0):
            raise ModeselError("stiffness tuners must be > 0", field="stiffness_tuners")
        tuner[:len(given)] = given
    strain = (dphi if kind == "torsion" else ddphi) * np.sqrt(tuner)[:, None]
    T = transform.T
    weighted, phi, dphi, strain = T @ weighted, T @ phi, T @ dphi, T @ strain

    # eq. B1/26 and B2/27 (torsion: int I_p psi psi, int GJ psi' psi')
    mass = weighted @ weighted.T
    if kind == "torsion":
        stiffness = (w * at(beam.gj) * strain) @ strain.T
    else:
        stiffness = (w * (at(beam.ei_1) * d[0] ** 2 + at(beam.ei_2) * d[1] ** 2) * strain) @ strain.T

    # geometric stiffness, eq. B5 with the axial loads of eq. 29, 33, 34, C3, C5
    hub = float(beam.root_offset)
    axis = _rotation_axis(rotation_axis, beam, precone)
    slopes = dphi if kind != "torsion" else np.zeros_like(dphi)
    n_self = tail_integral(beam.span, beam.mass, quad.s)
    n_rot = tail_integral(beam.span, beam.mass, quad.s, lever_offset=hub) + top_mass * (hub + L)
    axial_per_g = -(w * n_self * slopes) @ slopes.T                                  # eq. C3
    geometric = {
        "gravity_top_mass": -gravity * top_mass * (w * slopes) @ slopes.T,          # eq. 33
        "gravity_self_weight": gravity * axial_per_g,                               # eq. 34
        "centrifugal_per_omega2": (1.0 - axis[2] ** 2) * (w * n_rot * slopes) @ slopes.T,  # eq. 30, C5
        "gravity_axial_per_g": axial_per_g,
    }
    if kind == "torsion":
        notes.append("torsion: axial loads and spin do not stiffen the rotation shapes in this model "
                     "(geometric matrices are zero).")

    # SID terms, App. A (q = 0): positions s_P0 and displacement fields Phi_j
    positions = np.zeros((len(quad.s), 3))
    positions[:, 2] = hub + quad.s
    dm = w * m
    fields = np.zeros((n, len(quad.s), 3)) if kind == "torsion" else phi[:, :, None] * d
    sk_p, sk_phi = skew(positions), skew(fields)
    spin = np.einsum("a,jqab,kqbc,c,q->jk", axis, sk_phi, sk_phi, axis, dm)   # eq. A10/A12 first order
    c_r = np.einsum("q,qab,jqb->ja", dm, sk_p, fields)                          # eq. A5
    if kind == "torsion":
        c_r[:, 2] = (w * inertia * phi).sum(axis=1)
    o = np.einsum("q,jqab,qbc->jac", dm, sk_phi, sk_p)                          # eq. A12
    o_e = np.stack([o[:, 0, 0], o[:, 1, 1], o[:, 2, 2], o[:, 0, 1] + o[:, 1, 0],
                    o[:, 1, 2] + o[:, 2, 1], o[:, 0, 2] + o[:, 2, 0]], axis=1)  # eq. A14

    # damping in the modal basis of (K_e, M_e), App. B
    if damping_ratios is None:
        damping_ratios = (getattr(beam, "damping_ratio", {}) or {}).get(name, [])
    damping = _modal_damping(stiffness, mass, damping_ratios)
    if len(damping_ratios) == 0:
        notes.append("no damping ratios given: D_e = 0.")

    # uncoupled frequencies, eq. 31, 32, 35
    total = stiffness.copy()
    if beam.name == "tower":
        total += geometric["gravity_top_mass"] + geometric["gravity_self_weight"]
    elif beam.name == "blade":
        total += rotor_speed ** 2 * (geometric["centrifugal_per_omega2"] + spin)
    import scipy.linalg   # here: scipy.linalg costs a simulation 0.15 s of start-up
    eig = scipy.linalg.eigh(total, mass, eigvals_only=True)
    frequencies = np.sign(eig) * np.sqrt(np.abs(eig)) / (2.0 * np.pi)

    result = ShapeIntegrals(
        field=name, family=sampled.family, direction=kind if kind != "vector" else tuple(d), length=L,
        mass=mass, stiffness=stiffness, damping=damping, geometric_stiffness=geometric,
        spin_softening_per_omega2=spin, frequencies_hz=frequencies,
        tip_deflection=T @ tip.phi[:, 0], tip_slope=T @ tip.dphi[:, 0] / L,
        condition_number=condition, orthonormalised=do_orth, transform=transform,
        total_mass=float(dm.sum()), s_cm=np.array([0.0, 0.0, (dm * positions[:, 2]).sum() / dm.sum()]),
        J=np.einsum("q,qab->ab", dm, (positions ** 2).sum(axis=1)[:, None, None] * np.eye(3)
                    - positions[:, :, None] * positions[:, None, :])
        + np.diag([0.0, 0.0, float((w * inertia).sum())]),                     # eq. A4
        C_t=np.einsum("q,jqa->ja", dm, fields),                                 # eq. A6
        C_r=c_r, G_r=-2.0 * np.einsum("q,qab,jqbc->jac", dm, sk_p, sk_phi),     # eq. A11
        O_e_j=o, O_e=o_e,
        G_e=-2.0 * np.einsum("q,kqa,jqab->jkb", dm, fields, sk_phi),             # eq. A13
        M_xtheta_1=-np.einsum("q,jqab->jab", dm, sk_phi),                        # eq. D4
        M_thetatheta_1=-np.einsum("q,qab,jqbc->jac", dm, sk_p, sk_phi)
        - np.einsum("q,jqab,qbc->jac", dm, sk_phi, sk_p),                        # eq. A4, first order
        rotor_speed=float(rotor_speed), notes=tuple(notes))
    return _in_raw_basis(result, transform) if back_to_raw else result


#: ShapeIntegrals arrays linear in the mode index (axis 0) and bilinear (axes 0 and 1)
_PER_MODE = ("tip_deflection", "tip_slope", "C_t", "C_r", "G_r", "O_e_j", "O_e", "M_xtheta_1",
             "M_thetatheta_1")
_PER_PAIR = ("mass", "stiffness", "damping", "spin_softening_per_omega2", "G_e")


def _in_raw_basis(result: ShapeIntegrals, transform: np.ndarray) -> ShapeIntegrals:
    """`result` computed for the shapes psi = T^T phi, expressed for the raw
    shapes phi = R^T psi (R = T^-1): per-mode arrays X -> R^T X, matrices
    X -> R^T X R (frequencies are basis-independent)."""
    from dataclasses import replace

    import scipy.linalg   # here: scipy.linalg costs a simulation 0.15 s of start-up
    R = scipy.linalg.solve_triangular(transform, np.eye(transform.shape[0]))

    def linear(x):
        return np.einsum("aj,a...->j...", R, x)

    def pair(x):
        return np.einsum("aj,bk,ab...->jk...", R, R, x)

    changes = {k: linear(getattr(result, k)) for k in _PER_MODE}
    changes.update({k: pair(getattr(result, k)) for k in _PER_PAIR})
    changes["geometric_stiffness"] = {k: pair(v) for k, v in result.geometric_stiffness.items()}
    changes["transform"] = np.eye(transform.shape[0])
    changes["orthonormalised"] = False
    return replace(result, **changes)


def mass_condition_number(weighted, kind="bending", source=None, name=None) -> float:
    """2-norm condition number of M = A A^T from the singular values of
    A = `weighted` (n, points) (never forms M); a singular M (linearly
    dependent shapes, zero mass) is a ModeselError."""
    singular = np.linalg.svd(weighted, compute_uv=False)
    tiny = singular[0] * max(weighted.shape) * np.finfo(float).eps
    condition = float((singular[0] / singular[-1]) ** 2) if singular[-1] > tiny else np.inf
    if not np.isfinite(condition):
        what = "polar inertia" if kind == "torsion" else "mass"
        raise ModeselError(f"mass matrix singular (shapes linearly dependent or zero {what}), "
                           f"condition number {condition:.3g}", file=source, field=name)
    return condition


def orthonormalising_transform(weighted) -> np.ndarray:
    """T = R^-1 of the Householder QR A^T = Q R (diag R > 0), so that the
    shapes psi = T^T phi have T^T M T = I (module docstring)."""
    n = weighted.shape[0]
    r = np.linalg.qr(weighted.T, mode="r")
    r = r * np.sign(np.diag(r))[:, None]
    import scipy.linalg   # here: scipy.linalg costs a simulation 0.15 s of start-up
    return scipy.linalg.solve_triangular(r, np.eye(n))


def transform_shapes(shapes: ShapeSet, transform: np.ndarray) -> ShapeSet:
    """The shapes psi = T^T phi (and their derivatives) of `shapes`."""
    T = np.asarray(transform, dtype=float).T
    return ShapeSet(shapes.field, shapes.family, shapes.x, T @ shapes.phi, T @ shapes.dphi,
                    T @ shapes.ddphi, dict(shapes.params))


def conditioned_shapes(beam, shapes, field: str, *, threshold: float = ILL_CONDITIONED,
                       points_per_interval: int = 8):
    """(callable x -> ShapeSet, condition number of the raw mass matrix) for
    the multibody engine.

    `shapes` is a callable x -> ShapeSet of one field on `beam`. When the raw
    mass matrix (beam mass; torsion: polar inertia) has a condition number
    above `threshold`, the returned callable gives the mass-orthogonal shapes
    psi_k = (T^T phi)_k / (T^T phi)_k(1): orthonormalised by QR (module
    docstring), then rescaled to a unit tip value so that a generalised
    coordinate still reads as the tip deflection (rotation) of its shape, and
    psi_1 = phi_1. A new shape whose tip value is below 1e-6 of its largest
    value cannot be tip-normalised (ModeselError). Otherwise `shapes` is
    returned unchanged."""
    quad = quadrature(beam, points_per_interval)
    kind = "torsion" if field == "tower_torsion" else "bending"
    density = np.interp(quad.s, beam.span, np.asarray(
        beam.polar_inertia if kind == "torsion" else beam.mass, dtype=float))
    sampled = evaluate_shapes(shapes, quad.x)
    weighted = np.sqrt(quad.w * density)[None, :] * sampled.phi
    condition = mass_condition_number(weighted, kind, getattr(beam, "source", None), field)
    if condition <= threshold:
        return shapes, condition
    transform = orthonormalising_transform(weighted)
    psi = transform.T @ sampled.phi
    tip = transform.T @ evaluate_shapes(shapes, np.array([1.0])).phi[:, 0]
    flat = np.abs(tip) <= 1e-6 * np.abs(psi).max(axis=1)
    if flat.any():
        raise ModeselError(f"the mass-orthogonalised shape {int(np.argmax(flat)) + 1} of this "
                           f"ill-conditioned basis (condition number {condition:.3g}) has no tip motion "
                           f"and cannot be tip-normalised; use fewer modes or another family",
                           file=getattr(beam, "source", None), field=field)
    transform = transform / tip[None, :]

    def conditioned(x):
        return transform_shapes(evaluate_shapes(shapes, x), transform)

    return conditioned, condition


def _direction(direction, field_name):
    """('fa'|'ss'|'flap'|'edge'|'torsion'|'vector', unit vector)."""
    if isinstance(direction, str):
        if direction == "torsion":
            return "torsion", np.array([0.0, 0.0, 1.0])
        if direction not in DIRECTIONS:
            raise ModeselError(f"unknown direction '{direction}' (fa, ss, flap, edge, torsion or a "
                               f"3-vector)", field="direction")
        return direction, np.array(DIRECTIONS[direction])
    if direction is None:
        raise ModeselError(f"no direction for field '{field_name}'", field="direction")
    d = np.asarray(direction, dtype=float)
    if d.shape != (3,) or abs(np.linalg.norm(d) - 1.0) > 1e-9 or abs(d[2]) > 1e-12:
        raise ModeselError("direction must be a unit vector in the body x-y plane", field="direction")
    return "vector", d


def _rotation_axis(rotation_axis, beam, precone):
    if rotation_axis is not None:
        e = np.asarray(rotation_axis, dtype=float)
        return e / np.linalg.norm(e)
    if beam.name == "blade":
        return np.array([np.cos(precone), 0.0, np.sin(precone)])
    return np.array([0.0, 0.0, 1.0])


def _modal_damping(stiffness, mass, ratios) -> np.ndarray:
    """D = M V diag(2 zeta_i omega_i) V^T M with K V = M V Omega^2, V^T M V = I."""
    n = mass.shape[0]
    ratios = np.asarray(list(ratios), dtype=float)
    if ratios.size == 0:
        return np.zeros((n, n))
    if np.any(ratios < 0):
        raise ModeselError("damping ratios must be >= 0", field="damping_ratio")
    import scipy.linalg   # here: scipy.linalg costs a simulation 0.15 s of start-up
    lam, vec = scipy.linalg.eigh(stiffness, mass)
    omega = np.sqrt(np.clip(lam, 0.0, None))
    zeta = np.empty(n)
    k = min(n, ratios.size)
    zeta[:k] = ratios[:k]
    if n > k:
        last = omega[k - 1] if omega[k - 1] > 0 else 1.0
        zeta[k:] = ratios[k - 1] * omega[k:] / last
    modal = mass @ vec
    damping = modal @ np.diag(2.0 * zeta * omega) @ modal.T
    return 0.5 * (damping + damping.T)
