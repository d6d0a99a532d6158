"""Turn a beam (distributed properties) and its assumed modes into a
`FlexibleBody`: quadrature nodes, shapes at the nodes, axial-shortening
matrices, elastic stiffness and damping.

Quadrature: properties are interpolated linearly between the deck stations
and integrated with Gauss-Legendre points inside each station interval
(`points_per_interval`, chosen so that a beam has at least ~40 nodes), the
rule documented in the README. The same nodes carry the mass (node_mass =
m(s_k) w_k) so every shape integral of Appendix A is the sum over nodes.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modesel.multibody.bodies import FlexibleBody, Joint, Rotation, Shortening
from modesel.multibody.quadrature import gauss_legendre
from modesel.vocabulary import FIELD_DIRECTION   # displacement direction of each bending field


def beam_quadrature(span: np.ndarray, min_nodes: int = 40):
    """Gauss-Legendre points and weights [m] inside each station interval
    (`multibody.quadrature.gauss_legendre`), at least `min_nodes` in all."""
    n_int = len(span) - 1
    return gauss_legendre(span, max(2, int(np.ceil(min_nodes / n_int))))


def interpolate(beam, values: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Property linearly interpolated between deck stations."""
    return np.interp(s, beam.span, values)


@dataclass
class FieldShapes:
    """Modes of one field on one beam: DOF names, ShapeSet evaluator results.

    phi/dphi/ddphi at the nodes (count, N) and at the tip (count,), already
    in physical units (dphi in 1/m, ddphi in 1/m^2)."""

    field: str
    dofs: tuple
    phi: np.ndarray
    dphi: np.ndarray
    ddphi: np.ndarray
    tip: np.ndarray
    tip_slope: np.ndarray
    slope_fine: np.ndarray      # (count, M) slopes on `fine_s` for shortening
    damping_ratio: tuple = ()
    stiffness_tuner: tuple = ()
    #: structural-twist coupling (blades, `twist_correction`): (count, 3, N)
    #: displacement added at the nodes, (count, 3) at the tip, (count, 3, M)
    #: slope added on the fine grid; None: the shape displaces along
    #: FIELD_DIRECTION only
    twist_nodes: np.ndarray | None = None
    twist_tip: np.ndarray | None = None
    twist_slope_fine: np.ndarray | None = None
    twist_slope_nodes: np.ndarray | None = None   # (count, 3, N) slope added at the nodes


def evaluate_field(field, dofs, shape_fn, s_nodes, length, fine_s, damping_ratio=(), tuner=()):
    """Evaluate `shape_fn(x) -> ShapeSet` at nodes, tip and a fine grid."""
    L = length
    at_nodes = shape_fn(s_nodes / L)
    at_tip = shape_fn(np.array([1.0]))
    fine = shape_fn(fine_s / L)
    return FieldShapes(field, tuple(dofs), at_nodes.phi, at_nodes.dphi / L, at_nodes.ddphi / L**2,
                       at_tip.phi[:, 0], at_tip.dphi[:, 0] / L, fine.dphi / L,
                       tuple(damping_ratio), tuple(tuner))


def twisted_direction(field: str, theta) -> np.ndarray:
    """(3, M) direction in which the curvature of a `field` mode acts at
    stations of structural twist `theta` [rad]: FIELD_DIRECTION turned about
    the beam axis z by -theta (twist, like pitch, is positive towards
    feather; the blade frame is the coned frame turned by -pitch).
    ElastoDyn (Coeff, TwistedSF): flap curvature along (cos, -sin), edge
    curvature along (sin, cos) of the twist in the pitched blade frame."""
    theta = np.asarray(theta, float)
    e = FIELD_DIRECTION[field]
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * e[0] + s * e[1], -s * e[0] + c * e[1], np.zeros_like(theta)])


def twist_correction(field: str, fine_s: np.ndarray, ddphi_fine: np.ndarray, theta_fine: np.ndarray):
    """Structural-twist coupling of a blade bending field (ElastoDyn's
    TwistedSF, Coeff routine; Jonkman 2005 FAST theory, blade mode shapes in
    the principal axes that turn with the structural twist).

    A mode is defined by its curvature phi''(s) about the local principal
    axis; the displacement is its double integral along the span with the
    curvature turned by the local twist theta(s):
        u(s) = int_0^s int_0^s' phi''(r) d(theta(r)) dr ds'
    (d: `twisted_direction`). The strain energy stays 1/2 int EI phi''^2
    (curvature along one principal axis: no flap-edge stiffness coupling, as
    ElastoDyn's KBF/KBE), while the kinetic energy, gravity, centrifugal
    stiffening (axial shortening with both slope components, ElastoDyn's
    AxRedBld) and the loads see the twisted displacement.

    Returned as the *difference* to the untwisted shape e phi(s), so that a
    beam without twist is unchanged to round-off: (disp (count, 3, M),
    slope (count, 3, M)) on `fine_s` [m, from 0 to the beam length];
    ddphi_fine (count, M) in 1/m^2; theta_fine (M,) rad. Integrals by the
    trapezoidal rule on the fine grid (the curvature is smooth between
    stations; 801 points keep the integration error ~1e-6 of the shape).
    """
    e = FIELD_DIRECTION[field]
    extra = twisted_direction(field, theta_fine) - e[:, None]                # (3, M)
    curv = ddphi_fine[:, None, :] * extra[None, :, :]                         # (count, 3, M)
    ds = np.diff(fine_s)
    zero = np.zeros(curv.shape[:2] + (1,))
    slope = np.concatenate([zero, np.cumsum(0.5 * (curv[..., 1:] + curv[..., :-1]) * ds, axis=-1)], axis=-1)
    disp = np.concatenate([zero, np.cumsum(0.5 * (slope[..., 1:] + slope[..., :-1]) * ds, axis=-1)], axis=-1)
    return disp, slope


def elastodyn_nodes(length: float, count: int):
    """ElastoDyn's analysis nodes of a beam (BldNodes / TwrNodes): `count`
    equal elements, a node at the middle of each, weight = element length
    DRNodes (ElastoDyn's midpoint rule for every spanwise integral:
    BElmntMass = MassB DRNodes, KBF = sum StiffBF DRNodes SHP''^2, ...)."""
    dr = float(length) / int(count)
    return (np.arange(count) + 0.5) * dr, np.full(count, dr)


def elastodyn_twisted(field: str, dr: float, ddphi_nodes: np.ndarray, theta_nodes: np.ndarray):
    """ElastoDyn's discrete twisted shapes (Coeff: TwistedSF(:,:,:,J,0:2),
    and the tip, TipNode): the curvature phi''(r_J) turned by the twist
    (`twisted_direction`) is constant over element J of length dr and
    integrated twice by ElastoDyn's half-element rule:
        slope(J) = slope(J-1) + (a(J-1) + a(J)) dr / 2,  slope(1) = a(1) dr / 2
        disp(J)  = disp(J-1) + (slope(J-1) + slope(J)) dr / 2, disp(1) = slope(1) dr / 2
        tip: slope(N) + a(N) dr / 2, disp(N) + slope(N) dr / 2.
    ddphi_nodes (count, N) in 1/m^2, theta_nodes (N,) rad. Returns disp and
    slope at the nodes (count, 3, N) and at the tip (count, 3)."""
    a = ddphi_nodes[:, None, :] * twisted_direction(field, theta_nodes)[None, :, :]     # (count, 3, N)
    h = 0.5 * dr
    slope = np.cumsum(a, axis=-1) * dr - a * h
    disp = np.cumsum(slope, axis=-1) * dr - slope * h
    return disp, slope, disp[..., -1] + slope[..., -1] * h, slope[..., -1] + a[..., -1] * h


def elastodyn_axial(slopes: np.ndarray, dr: float):
    """ElastoDyn's axial-shortening integrals (Coeff: AxRedBld, AxRedTFA,
    AxRedTSS) from the node slopes (ne, 3, N) of elements of length dr:
    S(J)_ij = sum_{K<J} dr s_i(K).s_j(K) + dr/2 s_i(J).s_j(J), tip: the
    full sum. Returns S (N, ne, ne) and the tip (ne, ne)."""
    prod = np.einsum("iak,jak->kij", slopes, slopes) * dr                  # (N, ne, ne)
    full = np.cumsum(prod, axis=0)
    return full - 0.5 * prod, full[-1]


def interpolate_fine(fine_s: np.ndarray, values: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(count, 3, M) values on the fine grid -> (count, 3, len(s)) at `s`."""
    out = np.empty(values.shape[:2] + (len(s),))
    for i in range(values.shape[0]):
        for a in range(3):
            out[i, a] = np.interp(s, fine_s, values[i, a])
    return out


def elastodyn_damping(K: np.ndarray, M: np.ndarray, zeta) -> np.ndarray:
    """ElastoDyn's modal damping: D_il = zeta_l K_il / (pi f_l), with
    f_l = sqrt(K_ll / M_ll) / (2 pi) the field's own (beam-only, no top mass,
    no gravity) frequency of shape l. For orthogonal modes this is
    2 zeta_l omega_l M_ll on the diagonal (first paper Appendix B)."""
    n = K.shape[0]
    D = np.zeros_like(K)
    if n == 0:
        return D
    z = np.array([zeta[min(l, len(zeta) - 1)] if len(zeta) else 0.0 for l in range(n)])
    f = np.sqrt(np.abs(np.diag(K)) / np.diag(M)) / (2 * np.pi)
    return K * (z / (np.pi * f))[None, :]


def build_flexible_body(name: str, joint: Joint, beam, fields: list, *, shortening: bool = True,
                        min_nodes: int = 40, extra_nodes=None, ed_nodes=None) -> tuple[FlexibleBody, dict]:
    """FlexibleBody of `beam` with the bending/torsion `fields` (FieldShapes
    evaluated at `beam_nodes(beam)`). The beam axis is the body z axis and
    node z = root_offset + s.

    Returns the body and `tip`: {"displacement": {dof: 3-vector}, "slope_y": {dof: rad per unit},
    "slope_x": {...}, "twist": {...}, "shortening": (dofs, G)} for the joint of
    a body carried at the tip.
    """
    # ed_nodes=(s, w) of `elastodyn_nodes`: ElastoDyn's midpoint rule, with its
    # discrete axial-shortening integrals (`elastodyn_axial`)
    s, w = beam_quadrature(beam.span, min_nodes) if ed_nodes is None else ed_nodes
    N = len(s)
    m_nodes = interpolate(beam, beam.mass, s) * w
    nodes = np.zeros((N, 3))
    nodes[:, 2] = beam.root_offset + s
    dofs = [d for fs in fields for d in fs.dofs]
    ne = len(dofs)
    Phi = np.zeros((N, 3, ne))
    eta = np.zeros((N, ne))
    K = np.zeros((ne, ne))
    D = np.zeros((ne, ne))
    Mfield = np.zeros((ne, ne))
    tip = {"displacement": {}, "slope_y": {}, "slope_x": {}, "twist": {}}
    col = 0
    fine_blocks = []
    for fs in fields:
        k = len(fs.dofs)
        sl = slice(col, col + k)
        if fs.field == "tower_torsion":
            eta[:, sl] = fs.phi.T
            stiff = interpolate(beam, beam.gj, s) * w
            Kf = (fs.dphi * stiff) @ fs.dphi.T                               # int GJ eta' eta'
            Mf = (fs.phi * interpolate(beam, beam.polar_inertia, s) * w) @ fs.phi.T
            for i, d in enumerate(fs.dofs):
                tip["twist"][d] = fs.tip[i]
        else:
            e = FIELD_DIRECTION[fs.field]
            Phi[:, :, sl] = e[None, :, None] * fs.phi.T[:, None, :]
            if fs.twist_nodes is not None:                                   # twisted shapes
                Phi[:, :, sl] += np.transpose(fs.twist_nodes, (2, 1, 0))
            ei = beam.ei_1 if fs.field in ("tower_fa", "blade_flap") else beam.ei_2
            stiff = interpolate(beam, ei, s) * w
            Kf = (fs.ddphi * stiff) @ fs.ddphi.T                             # eq. B2
            # eq. B1; ElastoDyn's MBF (for the damping frequency) uses the untwisted shapes
            Mf = (fs.phi * m_nodes) @ fs.phi.T
            fine_blocks.append((sl, e, fs.slope_fine, fs.twist_slope_fine, fs.dphi, fs.twist_slope_nodes))
            for i, d in enumerate(fs.dofs):
                tip["displacement"][d] = e * fs.tip[i] + (0.0 if fs.twist_tip is None else fs.twist_tip[i])
                # slope of a +x displacement tilts about +y; of a -y displacement about +x
                if e[0] != 0:
                    tip["slope_y"][d] = e[0] * fs.tip_slope[i]
                else:
                    tip["slope_x"][d] = -e[1] * fs.tip_slope[i]
        if fs.stiffness_tuner:
            t = np.array([fs.stiffness_tuner[min(i, len(fs.stiffness_tuner) - 1)] for i in range(k)])
            Kf = Kf * np.sqrt(np.outer(t, t))
        K[sl, sl] = Kf
        Mfield[sl, sl] = Mf
        D[sl, sl] = elastodyn_damping(Kf, Mf, fs.damping_ratio)
        col += k
    S = None
    G_tip = None
    if shortening and fine_blocks and ed_nodes is not None:
        slopes = np.zeros((ne, 3, N))
        for sl, e, _, _, dphi, extra in fine_blocks:
            slopes[sl] = e[None, :, None] * dphi[:, None, :]
            if extra is not None:
                slopes[sl] += extra
        S, G_tip = elastodyn_axial(slopes, float(w[0]))
    elif shortening and fine_blocks:
        # S_k,ij = int_0^{s_k} phi_i' . phi_j' ds  (second paper eq. 3, first paper D4)
        fine_s = np.linspace(0.0, beam.length, fields[0].slope_fine.shape[1])
        slopes = np.zeros((ne, 3, len(fine_s)))
        for sl, e, sf, extra, _, _ in fine_blocks:
            slopes[sl] = e[None, :, None] * sf[:, None, :]
            if extra is not None:                  # twisted slopes: ElastoDyn's AxRedBld
                slopes[sl] += extra
        prod = np.einsum("iak,jak->ijk", slopes, slopes)
        ds = np.diff(fine_s)
        cum = np.concatenate([np.zeros((ne, ne, 1)),
                              np.cumsum(0.5 * (prod[:, :, 1:] + prod[:, :, :-1]) * ds, axis=2)], axis=2)
        S = np.stack([np.stack([np.interp(s, fine_s, cum[i, j]) for j in range(ne)]) for i in range(ne)])
        S = np.moveaxis(S, 2, 0)                                                # (N, ne, ne)
        G_tip = cum[:, :, -1]
    body = FlexibleBody(name, joint, nodes, m_nodes, np.array([0.0, 0.0, 1.0]), tuple(dofs), Phi,
                        S, eta if np.any(eta) else None,
                        interpolate(beam, beam.polar_inertia, s) * w if np.any(eta) else None, K, D, Mfield)
    tip["shortening"] = None if G_tip is None else (tuple(dofs), G_tip)
    tip["length"] = beam.root_offset + beam.length
    return body, tip


def tip_joint(parent: str, tip: dict, *, extra_rotations=(), pre_rotation=None, offset=None) -> Joint:
    """Joint of a body carried at a flexible body's tip: elastic translation,
    axial shortening and the elastic rotation from the tip slopes/twist
    (first paper Appendix D2; second paper eq. 11 to second order)."""
    off = np.array([0.0, 0.0, tip["length"]]) if offset is None else np.asarray(offset, float)
    rots = []
    if tip["slope_y"]:
        rots.append(Rotation(1, dict(tip["slope_y"])))
    if tip["slope_x"]:
        rots.append(Rotation(0, dict(tip["slope_x"])))
    if tip["twist"]:
        rots.append(Rotation(2, dict(tip["twist"])))
    rots.extend(extra_rotations)
    sh = None
    if tip["shortening"] is not None:
        dofs, G = tip["shortening"]
        sh = Shortening(np.array([0.0, 0.0, 1.0]), dofs, G)
    return Joint(parent, off, np.eye(3) if pre_rotation is None else pre_rotation,
                 dict(tip["displacement"]), sh, rots)
