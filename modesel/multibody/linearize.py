"""Linearisation about an operating point (first paper eq. 23-25):

    M0 dqdd + C0 dqd + K0 dq = Q0 du,   M0 = M(q0), C0 = -dF/dqd, K0 = -dF/dq

by central finite differences of the numeric equations, then the
eigenvalues of the first-order state matrix give natural frequencies [Hz]
and damping ratios, each labelled by its dominant coordinate (largest
kinetic-energy share |phi_i|^2 M_ii of the eigenvector).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg


@dataclass
class LinearModel:
    names: list
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray


@dataclass
class Mode:
    frequency_hz: float          # undamped natural frequency |lambda| / 2 pi
    damping_ratio: float         # -Re(lambda) / |lambda|
    label: str                   # dominant coordinate
    shape: np.ndarray

    def as_dict(self):
        return {"frequency_hz": float(self.frequency_hz), "damping_ratio": float(self.damping_ratio),
                "label": self.label}


def linearize(M_F, q0, qd0, names, t=0.0, rel_step=1e-6) -> LinearModel:
    """M_F(t, q, qd) -> (M, F). Central differences with steps scaled by the state."""
    q0 = np.asarray(q0, float)
    qd0 = np.asarray(qd0, float)
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


def modes(lin: LinearModel, include_rigid: bool = False, tol_hz: float = 1e-5) -> list:
    """Eigen-analysis of the first-order system, sorted by frequency.

    One entry per complex-conjugate pair (or per real eigenvalue)."""
    n = len(lin.names)
    Minv = np.linalg.inv(lin.M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ lin.K, -Minv @ lin.C]])
    lam, vec = scipy.linalg.eig(A)
    out = []
    used = np.zeros(len(lam), bool)
    for i in np.argsort(np.abs(lam)):
        if used[i]:
            continue
        used[i] = True
        if abs(lam[i].imag) > 1e-12:
            partner = np.argmin(np.abs(lam - np.conj(lam[i])) + used * 1e99)
            used[partner] = True
        w = abs(lam[i])
        f = w / (2 * np.pi)
        if f < tol_hz and not include_rigid:
            continue
        zeta = -lam[i].real / w if w > 0 else 0.0
        phi = vec[:n, i]
        energy = np.abs(phi) ** 2 * np.abs(np.diag(lin.M))
        label = lin.names[int(np.argmax(energy))]
        if lam[i].imag < 0:
            phi = np.conj(phi)
        out.append(Mode(f, zeta, label, phi))
    out.sort(key=lambda m: m.frequency_hz)
    return out
