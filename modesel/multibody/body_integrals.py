"""Shape integrals of a flexible body formed once, at pack time, so that the
kernel's generalised mass and force of the body (first paper eq. 11-19,
A2-A19) cost a number of operations independent of its node count
(the kernel's "invariant" route, `kernel._invariant_sums`; the other route
sums over the nodes at every right-hand side, `kernel._node_sums`).

A node k (mass m_k, undeformed position s0_k, shapes Phi_k (3 x ne),
shortening matrix S_k (ne x ne), body frame) moves to

    s_k = s0_k + Phi_k q - 1/2 (q^T S_k q) a,      B_k = Phi_k - a (S_k q)^T

(first paper D4; a the beam axis). Every node sum the equations need is a
polynomial in q (and qd) whose coefficients are sums over the nodes of
products of s0_k, Phi_k and S_k: those sums, listed in `BLOCKS`, are the
invariants (the first paper's shape integrals, Appendix B, extended to the
axial shortening and to the node polar inertia). S is kept only on the
`shortening_modes` (the coordinates with a non-zero row of some S_k), so a
torsion mode costs nothing in the S terms.

Cost per evaluation, in operations (`invariant_cost`, `node_cost`, their
weights set by timing `kernel._flexible` both ways on the turbine with 1-10
fem modes per field): about 2 ns^4 + 6 ne ns^2 + 30 ne^2 (ns the
shortening modes), plus N (2 ns^2 + 6 ne) for the node forces of a loading
effect (known only at evaluation, so still summed over the nodes), against
about N (5 ne^2 + 30 ne) for the node sums. `choose_invariants` takes the
invariants where they are `INVARIANT_GAIN` times cheaper and their largest
tensor stays below `MAX_ENTRIES`. Measured (us per body evaluation,
node sums / invariants): NREL 5-MW blade with 214 nodes, 4 fem modes per
field 34 / 15, 6 modes 50 / 30, 10 modes 95 / 105 (node sums kept); a
blade with 17 nodes and 3 modes (OpenFAST deck) 3.5 / 3.8 (node sums kept).
"""
from __future__ import annotations

import numpy as np

#: the invariants in the order of the flat block the kernel reads
#: (`kernel._invariant_sums`; shapes in terms of ne elastic coordinates and
#: ns shortening modes; every sum is over the nodes, weighted by m_k unless
#: it names Jp, the node polar inertia, and eta, the node twist per mode)
BLOCKS = (
    ("M0", ()),                       # sum m
    ("ms0", (3,)),                    # sum m s0
    ("mPhi", (3, "ne")),              # sum m Phi
    ("mS", ("ns", "ns")),             # sum m S
    ("Js0", (3, 3)),                  # sum m s0 s0^T
    ("Xs0P", (3, 3, "ne")),           # sum m s0_i Phi_jl
    ("XPP", (3, "ne", 3, "ne")),      # sum m Phi_il Phi_jm
    ("P0", ("ne", "ne")),             # sum m Phi_l . Phi_m
    ("K1", (3, "ne", "ne")),          # sum m (Phi_l x Phi_m)_i
    ("Ys0S", (3, "ns", "ns")),        # sum m s0_i S_ab
    ("YPS", (3, "ne", "ns", "ns")),   # sum m Phi_il S_ab
    ("ZSS", ("ns", "ns", "ns", "ns")),  # sum m S_ab S_cd
    ("Jsum", ()),                     # sum Jp
    ("Jeta", ("ne",)),                # sum Jp eta_l
    ("Jee", ("ne", "ne")),            # sum Jp eta_l eta_m
    ("Sn", ("N", "ns", "ns")),        # S_k of each node on the shortening modes (node forces)
    ("s0n", ("N", 3)),                # s0 of each node (node forces)
)
#: the invariants are used where the node sums would cost this many times more
INVARIANT_GAIN = 1.5
#: and where their largest tensor (ns^4 or 3 ne ns^2) has at most this many entries
MAX_ENTRIES = 1 << 20

_EPS = np.zeros((3, 3, 3))
_EPS[0, 1, 2] = _EPS[1, 2, 0] = _EPS[2, 0, 1] = 1.0
_EPS[0, 2, 1] = _EPS[2, 1, 0] = _EPS[1, 0, 2] = -1.0


def shortening_modes(f) -> np.ndarray:
    """Indices of the elastic coordinates with a non-zero row in some S_k
    (`FlexibleArrays` f); empty without shortening."""
    if f.S is None:
        return np.zeros(0, np.int64)
    return np.flatnonzero(np.any(f.S != 0.0, axis=(0, 2))).astype(np.int64)


def block_size(ne: int, ns: int, n_nodes: int) -> int:
    """Length of the flat invariant block of a body."""
    dims = {"ne": ne, "ns": ns, "N": n_nodes}
    return sum(int(np.prod([dims.get(d, d) for d in shape], dtype=np.int64)) for _, shape in BLOCKS)


def node_cost(n_nodes: int, ne: int, has_eta: bool) -> float:
    """Operations of the node sums per evaluation (`kernel._node_sums`)."""
    return n_nodes * (5 * ne * ne + 30 * ne + 40 + (ne * ne if has_eta else 0))


def invariant_cost(n_nodes: int, ne: int, ns: int, loaded: bool) -> float:
    """Operations of the invariant route per evaluation, with node forces
    summed over the nodes when `loaded`."""
    return 2 * ns ** 4 + 2 * ns ** 3 + 6 * ne * ns * ns + 30 * ne * ne + 100 * ne + (
        n_nodes * (2 * ns * ns + 6 * ne + 30) if loaded else 0)


def choose_invariants(f) -> bool:
    """Whether the body `f` (`FlexibleArrays`) is cheaper through its
    invariants, counting node forces on it (the packer does not know which
    bodies the effects load)."""
    ne, ns, N = len(f.idx), len(shortening_modes(f)), len(f.m)
    if ne == 0 or max(ns ** 4, 3 * ne * ns * ns) > MAX_ENTRIES:
        return False
    return INVARIANT_GAIN * invariant_cost(N, ne, ns, True) < node_cost(N, ne, f.eta is not None)


def invariants(f) -> tuple[np.ndarray, np.ndarray]:
    """(flat block in the order of `BLOCKS`, shortening modes) of the
    `FlexibleArrays` f."""
    m, s0, Phi = f.m, f.s0, f.Phi
    ne = Phi.shape[2]
    sidx = shortening_modes(f)
    ns = len(sidx)
    S = f.S[:, sidx][:, :, sidx] if ns else np.zeros((len(m), 0, 0))
    Jp = np.zeros(len(m)) if f.Jp is None else f.Jp
    eta = np.zeros((len(m), ne)) if f.eta is None else f.eta
    # the node sums of products as matrix products over the nodes k (BLAS)
    N = len(m)
    P2, S2 = Phi.reshape(N, 3 * ne), S.reshape(N, ns * ns)
    mP2 = m[:, None] * P2
    XPP = (mP2.T @ P2).reshape(3, ne, 3, ne)                   # sum m Phi_il Phi_jm
    values = {
        "M0": m.sum(),
        "ms0": m @ s0,
        "mPhi": np.einsum("k,kil->il", m, Phi),
        "mS": np.einsum("k,kab->ab", m, S),
        "Js0": np.einsum("k,ki,kj->ij", m, s0, s0),
        "Xs0P": np.einsum("k,ki,kjl->ijl", m, s0, Phi),
        "XPP": XPP,
        "P0": np.einsum("ilim->lm", XPP),
        "K1": np.einsum("ijh,jlhm->ilm", _EPS, XPP),              # eps_ijh sum m Phi_jl Phi_hm
        "Ys0S": np.einsum("k,ki,kab->iab", m, s0, S),
        "YPS": (mP2.T @ S2).reshape(3, ne, ns, ns),
        "ZSS": ((m[:, None] * S2).T @ S2).reshape(ns, ns, ns, ns),
        "Jsum": Jp.sum(),
        "Jeta": Jp @ eta,
        "Jee": np.einsum("k,kl,km->lm", Jp, eta, eta),
        "Sn": S,
        "s0n": s0,
    }
    flat = np.concatenate([np.ravel(values[name]) for name, _ in BLOCKS]).astype(float)
    assert flat.size == block_size(ne, ns, len(m))
    return flat, sidx


def with_load_rows(flat: np.ndarray, ne: int, sidx: np.ndarray, n_nodes: int, s0: np.ndarray,
                   S: np.ndarray | None) -> np.ndarray:
    """The flat block of a body (`invariants`) with its last two blocks, the
    geometry of the rows that carry its loads (Sn on the shortening modes
    sidx, s0n), those of the load points (s0 (P, 3), S (P, ne, ne) or None)
    in place of its nodes' (`packing.with_load_points`)."""
    ns = len(sidx)
    tail = n_nodes * (ns * ns + 3)
    assert flat.size == block_size(ne, ns, n_nodes)
    Sn = np.zeros((len(s0), ns, ns)) if (S is None or not ns) else S[:, sidx][:, :, sidx]
    return np.concatenate([flat[:flat.size - tail], np.ravel(Sn), np.ravel(s0)]).astype(float)


def scratch_size(ne: int, ns: int) -> int:
    """Floats of the invariant route's scratch (`work[14]`): its inputs and
    outputs, and the intermediate sums of `invariant_sums`."""
    return 2 * ne * ne + ns ** 3 + 4 * ns * ns + 14 * ns + 5 * ne * ns + 40 * ne + 160
