"""Finite-element eigen-analysis of a non-uniform clamped-free beam.

Bending: Euler-Bernoulli elements with Hermite-cubic interpolation (nodal
deflection w and slope w'), consistent mass, and a geometric stiffness from
an axial force N(s) (positive = tension):

    K_e = int EI N''^T N'' ds,  M_e = int m N^T N ds,  G_e = int N(s) N'^T N' ds

(eq. 26-27 and 30 of the first paper, written for element shape functions),
all by 4-point Gauss quadrature per element with properties interpolated
linearly between the beam stations (exact for piecewise-linear properties
on the element level). A tip point mass and tip rotary inertia are added to
the last node's deflection and slope. A "spin softening" term
-kappa Omega^2 M_t (M_t: translational mass, distributed + tip) models the
in-plane centrifugal force of a rotating blade (eq. 32 of the first paper).

Torsion: two-node linear elements, K_e = int GJ N'^T N', M_e = int I_p N^T N,
with a tip inertia on the last node.

The root node is clamped (its degrees of freedom are removed). Modes are
normalised to a unit tip deflection (twist). Shapes at arbitrary normalised
stations come from the element interpolation itself: for bending phi and
phi' are continuous (C1) and phi'' is linear per element (it jumps at nodes,
where the value of the element to the right is used); for torsion phi is
piecewise linear, phi' piecewise constant and phi'' = 0.
"""
from __future__ import annotations

import numpy as np

GAUSS_XI, GAUSS_W = np.polynomial.legendre.leggauss(4)
GAUSS_XI = 0.5 * (GAUSS_XI + 1.0)     # on [0, 1]
GAUSS_W = 0.5 * GAUSS_W


def hermite(xi, h):
    """Hermite-cubic shape functions for DOFs (w1, w1', w2, w2') on an element of
    length h at local coordinates xi in [0, 1]; returns N, dN/ds, d2N/ds2, each
    (len(xi), 4) (h may be an array broadcasting against xi)."""
    xi = np.asarray(xi, dtype=float)
    h = np.broadcast_to(np.asarray(h, dtype=float), xi.shape)
    x2, x3 = xi * xi, xi ** 3
    n = np.stack([1 - 3 * x2 + 2 * x3, h * (xi - 2 * x2 + x3), 3 * x2 - 2 * x3, h * (x3 - x2)], -1)
    dn = np.stack([(-6 * xi + 6 * x2) / h, 1 - 4 * xi + 3 * x2, (6 * xi - 6 * x2) / h,
                   3 * x2 - 2 * xi], -1)
    ddn = np.stack([(-6 + 12 * xi) / h ** 2, (-4 + 6 * xi) / h, (6 - 12 * xi) / h ** 2,
                    (6 * xi - 2) / h], -1)
    return n, dn, ddn


def _gauss_points(nodes):
    """Element lengths (E,), Gauss abscissae (E, G) and weights * length (E, G)."""
    h = np.diff(nodes)
    s = nodes[:-1, None] + h[:, None] * GAUSS_XI[None, :]
    return h, s, h[:, None] * GAUSS_W[None, :]


def _assemble(blocks, dofs_per_node, n_nodes):
    """Sum element matrices (E, d, d) into a global (n, n) matrix; element e
    couples nodes e and e + 1."""
    e, d, _ = blocks.shape
    size = dofs_per_node * n_nodes
    out = np.zeros((size, size))
    for i in range(e):   # E is small (tens to hundreds); a loop is clear and fast
        j = i * dofs_per_node
        out[j:j + d, j:j + d] += blocks[i]
    return out


def bending_matrices(nodes, span, mass, ei, *, tip_mass=0.0, tip_inertia=0.0, axial_force=None,
                     spin_softening=0.0):
    """Global (K, M) of a clamped-free bending beam, root DOFs removed.

    nodes : element boundaries [m] measured like `span`; span/mass/ei: the
    beam stations [m], mass per length [kg/m], EI [N m^2]; tip_mass [kg] and
    tip_inertia [kg m^2] on the last node; axial_force : callable s -> N(s) [N]
    (tension positive) or None; spin_softening : kappa * Omega^2 [1/s^2] of the
    term -kappa Omega^2 M_t.
    """
    h, s, w = _gauss_points(nodes)
    n, dn, ddn = hermite(np.broadcast_to(GAUSS_XI, s.shape), h[:, None])
    m_g = np.interp(s, span, mass) * w
    ei_g = np.interp(s, span, ei) * w
    k_el = np.einsum("eg,egi,egj->eij", ei_g, ddn, ddn)
    m_el = np.einsum("eg,egi,egj->eij", m_g, n, n)
    if axial_force is not None:
        k_el = k_el + np.einsum("eg,egi,egj->eij", axial_force(s) * w, dn, dn)
    n_nodes = len(nodes)
    k = _assemble(k_el, 2, n_nodes)
    m = _assemble(m_el, 2, n_nodes)
    m[-2, -2] += tip_mass
    if spin_softening:
        k -= spin_softening * m     # translational mass only: tip inertia not yet added
    m[-1, -1] += tip_inertia
    return k[2:, 2:], m[2:, 2:]


def torsion_matrices(nodes, span, polar_inertia, gj, *, tip_inertia=0.0):
    """Global (K, M) of a clamped-free torsion shaft with linear elements, root DOF removed."""
    h, s, w = _gauss_points(nodes)
    xi = np.broadcast_to(GAUSS_XI, s.shape)
    n = np.stack([1 - xi, xi], -1)
    dn = np.stack([-1 / h[:, None] * np.ones_like(xi), 1 / h[:, None] * np.ones_like(xi)], -1)
    k_el = np.einsum("eg,egi,egj->eij", np.interp(s, span, gj) * w, dn, dn)
    m_el = np.einsum("eg,egi,egj->eij", np.interp(s, span, polar_inertia) * w, n, n)
    k = _assemble(k_el, 1, len(nodes))
    m = _assemble(m_el, 1, len(nodes))
    m[-1, -1] += tip_inertia
    return k[1:, 1:], m[1:, 1:]


def lowest_modes(k, m, count):
    """(omega [rad/s] (count,), eigenvectors (n, count)) of K v = omega^2 M v.
    Raises ValueError when a mode is unstable (omega^2 <= 0, e.g. buckling)."""
    from scipy.linalg import eigh   # here: scipy.linalg costs a simulation 0.15 s of start-up
    lam, vec = eigh(k, m, subset_by_index=[0, count - 1])
    if lam[0] <= 0.0:
        raise ValueError(f"the beam is unstable (lowest eigenvalue {lam[0]:.3g} <= 0)")
    return np.sqrt(lam), vec


def sample_bending(x, nodes, vectors):
    """Shapes at normalised stations x from nodal (w, w') vectors of the clamped
    model (root DOFs removed), tip-normalised. Returns phi, dphi/dx, d2phi/dx2."""
    q = np.vstack([np.zeros((2, vectors.shape[1])), vectors])     # re-insert the root
    q = q / q[-2]                                                  # unit tip deflection
    length = nodes[-1] - nodes[0]
    s = nodes[0] + np.asarray(x, dtype=float) * length
    e = np.clip(np.searchsorted(nodes, s, side="right") - 1, 0, len(nodes) - 2)
    h = nodes[e + 1] - nodes[e]
    n, dn, ddn = hermite((s - nodes[e]) / h, h)
    idx = 2 * e[:, None] + np.arange(4)[None, :]                   # (len(x), 4) DOF indices
    qe = q[idx]                                                    # (len(x), 4, modes)
    phi = np.einsum("xi,xim->mx", n, qe)
    dphi = np.einsum("xi,xim->mx", dn, qe) * length
    ddphi = np.einsum("xi,xim->mx", ddn, qe) * length ** 2
    return phi, dphi, ddphi


def sample_torsion(x, nodes, vectors):
    """Shapes at normalised stations x from nodal twists of the clamped model,
    tip-normalised, with the linear-element interpolation."""
    q = np.vstack([np.zeros((1, vectors.shape[1])), vectors])
    q = q / q[-1]
    length = nodes[-1] - nodes[0]
    s = nodes[0] + np.asarray(x, dtype=float) * length
    e = np.clip(np.searchsorted(nodes, s, side="right") - 1, 0, len(nodes) - 2)
    h = nodes[e + 1] - nodes[e]
    xi = (s - nodes[e]) / h
    phi = (1 - xi)[None, :] * q[e].T + xi[None, :] * q[e + 1].T
    dphi = ((q[e + 1] - q[e]).T / h[None, :]) * length
    return phi, dphi, np.zeros_like(phi)


def tip_displacement_ok(vectors, tip_row, rel=1e-8):
    """True where the tip DOF of each mode is a usable fraction of its largest DOF."""
    return np.abs(vectors[tip_row]) > rel * np.abs(vectors).max(axis=0)
