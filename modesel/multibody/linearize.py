"""Linearisation about an operating point (first paper eq. 23-25):

    M0 dqdd + C0 dqd + K0 dq = Q0 du,   M0 = M(q0), C0 = -dF/dqd, K0 = -dF/dq

by central finite differences of the numeric equations, then the
eigenvalues of the first-order state matrix give natural frequencies [Hz]
and damping ratios.

Mode labels come from modal participation (Perez-Arriaga, Verghese and
Schweppe 1982, IEEE Trans. PAS-101(9), eq. 9): with v_k and w_k the right and
left eigenvectors of eigenvalue k of the state matrix, the participation of
state i is p_ki = conj(w_ik) v_ik / (w_k^H v_k): dimensionless, independent
of how the coordinates are scaled, summing to 1 over the states. A
coordinate's participation adds its displacement and velocity states,
|p_k,i| + |p_k,n+i|, normalised to sum 1. A coordinate that only carries a
vibrating part along (the generator azimuth of a drivetrain mode) hardly
participates, the coordinate whose stiffness the mode exercises does.
Repeated eigenvalues (identical blades) have no preferred eigenvectors: the
participation of such a cluster is taken from its spectral projector (the
left vectors made dual to the right ones within the cluster), and its modes
are labelled by the cluster's most participating coordinates.

Each mode is labelled by its dominant coordinate, and labels are unique:
when several modes share a dominant coordinate d, the mode where d
participates most keeps d; another takes its second coordinate c when c
participates comparably (at least SHARED times d) and labels no other mode
(a whirling rotor's cos/sin pair), else 'd+c'; '#2', '#3', ... are appended
if that is taken too.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: relative distance below which eigenvalues count as repeated
CLUSTER_TOL = 1e-7
#: `simple_participation`: an eigenvalue is simple when every other lies
#: farther than SIMPLE_SEPARATION times the largest |eigenvalue| and the two
#: smallest singular values of A - lambda I differ by more than SIMPLE_GAP
SIMPLE_SEPARATION = 1e-6
SIMPLE_GAP = 1e6
#: a mode sharing its dominant coordinate is named after its second one when
#: that participates at least this fraction of the dominant one
SHARED = 0.5


@dataclass(frozen=True)
class LinearModel:
    """M qdd + C qd + K q = 0 about an operating point; `names` of the coordinates."""

    names: list
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray


@dataclass(frozen=True)
class Mode:
    """One vibration mode (a complex-conjugate eigenvalue pair, or a real eigenvalue)."""

    frequency_hz: float          # undamped natural frequency |lambda| / 2 pi
    damping_ratio: float         # -Re(lambda) / |lambda|
    label: str                   # dominant coordinate, unique among the modes (module doc)
    shape: np.ndarray            # eigenvector over the coordinates (positive-frequency member)
    participation: np.ndarray | None = None     # (n,) of each coordinate, sums to 1
    whirl: str | None = None     # "forward" / "backward" for a rotor's cyclic mode (simulation.coleman)

    def as_dict(self):
        out = {"frequency_hz": float(self.frequency_hz), "damping_ratio": float(self.damping_ratio),
               "label": self.label}
        if self.whirl is not None:
            out["whirl"] = self.whirl
        return out


def linearize(M_F, q0, qd0, names, t=0.0, rel_step=1e-6) -> LinearModel:
    """M_F(t, q, qd) -> (M, F). Central differences with steps scaled by the
    state. A compiled right-hand side (`compiled.CompiledRHS`) forms the same
    differences in one compiled call (its `linear_model`)."""
    q0 = np.asarray(q0, float)
    qd0 = np.asarray(qd0, float)
    compiled = getattr(M_F, "linear_model", None)
    model = None if compiled is None else compiled(t, q0, qd0, rel_step)
    if model is not None:
        return LinearModel(list(names), *model)
    n = len(q0)
    M0, _ = M_F(t, q0, qd0)
    K = np.zeros((n, n))
    C = np.zeros((n, n))
    for j in range(n):
        h = rel_step * max(1.0, abs(q0[j]))
        e = np.zeros(n)
        e[j] = h
        K[:, j] = -(M_F(t, q0 + e, qd0)[1] - M_F(t, q0 - e, qd0)[1]) / (2 * h)
        h = rel_step * max(1.0, abs(qd0[j]))
        e[j] = h
        C[:, j] = -(M_F(t, q0, qd0 + e)[1] - M_F(t, q0, qd0 - e)[1]) / (2 * h)
    return LinearModel(list(names), M0, C, K)


def state_matrix(lin: LinearModel) -> np.ndarray:
    """First-order system x' = A x, x = (q, qd): A = [[0, I], [-M^-1 K, -M^-1 C]]."""
    n = len(lin.names)
    return np.block([[np.zeros((n, n)), np.eye(n)],
                     [-np.linalg.solve(lin.M, lin.K), -np.linalg.solve(lin.M, lin.C)]])


def eigenvalues(lin: LinearModel) -> np.ndarray:
    """Eigenvalues [1/s] of the state matrix (no eigenvectors)."""
    return np.linalg.eigvals(state_matrix(lin))


def representatives(lam: np.ndarray) -> list:
    """Indices of one eigenvalue per complex-conjugate pair (the one with
    Im >= 0) and of every real eigenvalue, by increasing |lambda|."""
    out = []
    used = np.zeros(len(lam), bool)
    for i in np.argsort(np.abs(lam), kind="stable"):
        if used[i]:
            continue
        used[i] = True
        if abs(lam[i].imag) > 1e-12:
            partner = np.argmin(np.abs(lam - np.conj(lam[i])) + used * 1e99)
            used[partner] = True
            if lam[i].imag < 0:
                i = partner
        out.append(int(i))
    return out


def frequency_damping(lam: complex) -> tuple:
    """(undamped natural frequency [Hz], damping ratio) of eigenvalue `lam`."""
    w = abs(lam)
    return w / (2 * np.pi), (-lam.real / w if w > 0 else 0.0)


def spectrum(lin: LinearModel, include_rigid: bool = False, tol_hz: float = 1e-5, lam=None) -> list:
    """[(frequency [Hz], damping ratio)] of the modes, as `modes` without
    eigenvectors or labels; lam: the state matrix's eigenvalues if known."""
    lam = eigenvalues(lin) if lam is None else lam
    out = [frequency_damping(lam[i]) for i in representatives(lam)]
    return sorted((f, z) for f, z in out if include_rigid or f >= tol_hz)


def eigen(lin: LinearModel):
    """(eigenvalues (2n,), right eigenvectors (2n, 2n), participation (2n, n)
    of each coordinate in each eigenvalue, rows summing to 1, module doc)."""
    n = len(lin.names)
    import scipy.linalg   # here: scipy.linalg costs a simulation 0.15 s of start-up
    lam, left, right = scipy.linalg.eig(state_matrix(lin), left=True, right=True)
    return lam, right, participation(lam, left, right, n)[0]


def participation(lam, left, right, n: int):
    """(per-eigenvalue participation (2n, n), cluster number of each
    eigenvalue (2n,), per-cluster participation (clusters, n)) of the n
    coordinates, from the state-space eigenvectors (module doc)."""
    cluster = _clusters(lam)
    per_mode = np.zeros((len(lam), n))
    per_cluster = np.zeros((cluster.max() + 1 if len(lam) else 0, n))
    for c in range(len(per_cluster)):
        idx = np.flatnonzero(cluster == c)
        V, W = right[:, idx], left[:, idx]
        dual = np.linalg.lstsq(W.conj().T @ V, W.conj().T, rcond=None)[0]   # dual @ V = I
        p = dual.T * V                                                        # (2n, |idx|)
        per_mode[idx] = _coordinates(np.abs(p), n).T
        per_cluster[c] = _coordinates(np.abs(p.sum(axis=1))[:, None], n)[:, 0]
    return per_mode, cluster, per_cluster


def simple_participation(A: np.ndarray, lam: np.ndarray, i: int, n: int):
    """Participation (n,) of the n coordinates in eigenvalue lam[i] of the
    state matrix A (2n x 2n; lam: all its eigenvalues) when that eigenvalue
    is simple, else None; with numpy alone, as `eigen` gives it with scipy's
    eigenvectors. v and w, the right and left null vectors of A - lam[i] I,
    are the last right and left singular vectors of one SVD, and p_i =
    |w_i v_i| / |w^H v| (module doc). Simple: every other eigenvalue lies
    farther than SIMPLE_SEPARATION times the largest |eigenvalue| (a repeated
    or defective one, e.g. a free rotor's double zero, is not) and the two
    smallest singular values differ by more than SIMPLE_GAP."""
    if np.any(np.abs(np.delete(lam, i) - lam[i]) <= SIMPLE_SEPARATION * float(np.abs(lam).max())):
        return None
    u, sigma, vh = np.linalg.svd(A - lam[i] * np.eye(len(A)))
    if not sigma[-2] > SIMPLE_GAP * sigma[-1]:
        return None
    return _coordinates(np.abs(u[:, -1] * vh[-1])[:, None], n)[:, 0]


def _coordinates(p: np.ndarray, n: int) -> np.ndarray:
    """(2n, m) state participation -> (n, m) coordinate participation summing to 1."""
    out = p[:n] + p[n:]
    total = out.sum(axis=0)
    ok = np.isfinite(total) & (total > 0)
    return np.where(ok, out / np.where(ok, total, 1.0), 1.0 / max(n, 1))


def _clusters(lam: np.ndarray) -> np.ndarray:
    """Cluster number of each eigenvalue: repeated ones (CLUSTER_TOL) share one."""
    out = -np.ones(len(lam), int)
    scale = float(np.abs(lam).max()) if len(lam) else 1.0
    c = 0
    for i in range(len(lam)):
        if out[i] >= 0:
            continue
        near = np.abs(lam - lam[i]) <= CLUSTER_TOL * np.maximum(np.abs(lam), abs(lam[i])) + 1e-14 * scale
        out[near & (out < 0)] = c
        c += 1
    return out


def modes(lin: LinearModel, include_rigid: bool = False, tol_hz: float = 1e-5) -> list:
    """Eigen-analysis of the first-order system, sorted by frequency.

    One entry per complex-conjugate pair (or per real eigenvalue), labelled
    by modal participation (module doc)."""
    return state_modes(state_matrix(lin), lin.names, include_rigid, tol_hz)


def state_modes(A: np.ndarray, names, include_rigid: bool = False, tol_hz: float = 1e-5) -> list:
    """`modes` of a first-order state matrix A (2n x 2n, states (q, qd)) whose
    n coordinates are `names`: e.g. OpenFAST's linearisation."""
    n = len(names)
    import scipy.linalg   # here: scipy.linalg costs a simulation 0.15 s of start-up
    lam, left, right = scipy.linalg.eig(A, left=True, right=True)
    per_mode, cluster, per_cluster = participation(lam, left, right, n)
    kept = [i for i in representatives(lam) if include_rigid or frequency_damping(lam[i])[0] >= tol_hz]
    labels = unique_labels(names, per_mode, cluster, per_cluster, kept)
    out = []
    for i in kept:
        f, zeta = frequency_damping(lam[i])
        out.append(Mode(f, zeta, labels[i], right[:n, i], per_mode[i]))
    out.sort(key=lambda m: m.frequency_hz)
    return out


def unique_labels(names, per_mode, cluster, per_cluster, kept) -> dict:
    """{eigenvalue index: label} for the eigenvalues `kept` (module doc)."""
    names = list(names)
    dominant = {}
    for c in sorted({int(cluster[i]) for i in kept}):
        members = [i for i in kept if cluster[i] == c]
        candidates = np.argsort(-per_cluster[c], kind="stable")[:len(members)]
        pairs = sorted(((per_mode[i, q], i, q) for i in members for q in candidates), key=lambda p: -p[0])
        taken = set()
        for _, i, q in pairs:
            if i not in dominant and q not in taken:
                dominant[i] = int(q)
                taken.add(q)
    labels = {}
    used = {names[q] for q in dominant.values()}
    for q in sorted(set(dominant.values())):
        sharing = sorted((i for i in kept if dominant[i] == q), key=lambda i: -per_mode[i, q])
        labels[sharing[0]] = names[q]
        for i in sharing[1:]:
            order = [int(j) for j in np.argsort(-per_mode[i], kind="stable") if j != q]
            second = order[0] if order else None
            if second is not None and per_mode[i, second] >= SHARED * per_mode[i, q] \
                    and names[second] not in used:
                label = names[second]
            else:
                label = names[q] + (f"+{names[second]}" if second is not None else "")
            base, k = label, 2
            while label in used:
                label, k = f"{base}#{k}", k + 1
            labels[i] = label
            used.add(label)
    return labels
