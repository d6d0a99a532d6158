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


def evaluate_field(field, dofs, shape_fn, s_nodes, length, fine_s, damping_ratio=(), tuner=()):
    """Evaluate `shape_fn(x) -> ShapeSet` at nodes, tip and a fine grid."""
    L = length
    at_nodes = shape_fn(s_nodes / L)
    at_tip = shape_fn(np.array([1.0]))
    fine = shape_fn(fine_s / L)
    return FieldShapes(field, tuple(dofs), at_nodes.phi, at_nodes.dphi / L, at_nodes.ddphi / L**2,
                       at_tip.phi[:, 0], at_tip.dphi[:, 0] / L, fine.dphi / L,
                       tuple(damping_ratio), tuple(tuner))


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
                        min_nodes: int = 40, extra_nodes=None) -> tuple[FlexibleBody, dict]:
    """FlexibleBody of `beam` with the bending/torsion `fields` (FieldShapes
    evaluated at `beam_nodes(beam)`). The beam axis is the body z axis and
    node z = root_offset + s.

    Returns the body and `tip`: {"displacement": {dof: 3-vector}, "slope_y": {dof: rad per unit},
    "slope_x": {...}, "twist": {...}, "shortening": (dofs, G)} for the joint of
    a body carried at the tip.
    """
    s, w = beam_quadrature(beam.span, min_nodes)
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
    tip = {"displacement": {}, "slope_y": {}, "slope_x": {}, "twist": {}}
    slopes_fine = np.zeros((0, 3, 0))
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
            ei = beam.ei_1 if fs.field in ("tower_fa", "blade_flap") else beam.ei_2
            stiff = interpolate(beam, ei, s) * w
            Kf = (fs.ddphi * stiff) @ fs.ddphi.T                             # eq. B2
            Mf = (fs.phi * m_nodes) @ fs.phi.T                               # eq. B1
            fine_blocks.append((sl, e, fs.slope_fine))
            for i, d in enumerate(fs.dofs):
                tip["displacement"][d] = e * fs.tip[i]
                # slope of a +x displacement tilts about +y; of a -y displacement about +x
                if e[0] != 0:
                    tip["slope_y"][d] = e[0] * fs.tip_slope[i]
                else:
                    tip["slope_x"][d] = -e[1] * fs.tip_slope[i]
        if fs.stiffness_tuner:
            t = np.array([fs.stiffness_tuner[min(i, len(fs.stiffness_tuner) - 1)] for i in range(k)])
            Kf = Kf * np.sqrt(np.outer(t, t))
        K[sl, sl] = Kf
        D[sl, sl] = elastodyn_damping(Kf, Mf, fs.damping_ratio)
        col += k
    S = None
    G_tip = None
    if shortening and fine_blocks:
        # S_k,ij = int_0^{s_k} phi_i' . phi_j' ds  (second paper eq. 3, first paper D4)
        fine_s = np.linspace(0.0, beam.length, fields[0].slope_fine.shape[1])
        slopes = np.zeros((ne, 3, len(fine_s)))
        for sl, e, sf in fine_blocks:
            slopes[sl] = e[None, :, None] * sf[:, None, :]
        prod = np.einsum("iak,jak->ijk", slopes, slopes)
        ds = np.diff(fine_s)
        cum = np.concatenate([np.zeros((ne, ne, 1)),
                              np.cumsum(0.5 * (prod[:, :, 1:] + prod[:, :, :-1]) * ds, axis=2)], axis=2)
        S = np.stack([np.stack([np.interp(s, fine_s, cum[i, j]) for j in range(ne)]) for i in range(ne)])
        S = np.moveaxis(S, 2, 0)                                                # (N, ne, ne)
        G_tip = cum[:, :, -1]
    body = FlexibleBody(name, joint, nodes, m_nodes, np.array([0.0, 0.0, 1.0]), tuple(dofs), Phi,
                        S, eta if np.any(eta) else None,
                        interpolate(beam, beam.polar_inertia, s) * w if np.any(eta) else None, K, D)
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
