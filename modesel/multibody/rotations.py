"""Vector algebra of body frames: elementary rotations, cross products and
the skew-symmetric matrix of a vector, ElastoDyn's small-rotation matrix
(the one home of each, for the numpy reference of the Kane equations, the
shape integrals, the turbine template, the output channels and the symbolic
layer).

    [v~] w = v x w,    [v~] = [[0, -v3, v2], [v3, 0, -v1], [-v2, v1, 0]]

(first paper eq. 2-3: omega x s = [omega~] s). Angles in rad.
"""
from __future__ import annotations

import numpy as np


def skew(v):
    """Skew-symmetric matrices [v~] of vectors v (..., 3) -> (..., 3, 3),
    [v~] w = v x w. Float arrays give float matrices; object arrays (SymPy
    expressions) give object matrices with the same entries."""
    v = np.asarray(v)
    if v.dtype != object:
        v = v.astype(float)
    out = np.zeros(v.shape + (3,), v.dtype)
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def cross(a, b):
    """Cross product of 3-vectors or (N,3) arrays (faster than np.cross)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def elementary_rotation(axis: int, angle) -> np.ndarray:
    """Rotation matrix (body -> parent) about x (0), y (1) or z (2) by `angle`
    [rad]; for an array of n angles, the (n, 3, 3) stack of them."""
    c, s = np.cos(angle), np.sin(angle)
    if np.ndim(angle):
        R = np.zeros(np.shape(angle) + (3, 3))
        i, j = [k for k in range(3) if k != axis]
        R[..., axis, axis] = 1.0
        R[..., i, i], R[..., j, j] = c, c
        R[..., i, j], R[..., j, i] = (s, -s) if axis == 1 else (-s, s)
        return R
    if axis == 0:
        return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])
    if axis == 1:
        return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def small_rotation(t1, t2, t3=0.0) -> np.ndarray:
    """ElastoDyn's SmllRotTrans (NWTC_Num.f90): the orthonormal matrix of
    the small rotation (t1, t2, t3) [rad] about x1, x2, x3 (rows: the turned
    axes in the old ones); for arrays of angles, the (..., 3, 3) stack."""
    t1, t2, t3 = np.broadcast_arrays(*(np.asarray(t, float) for t in (t1, t2, t3)))
    w = np.sqrt(1.0 - 0.25 * (t1 * t1 + t2 * t2 + t3 * t3))
    m = np.array([
        [1.0 - 0.5 * (t2 * t2 + t3 * t3), 0.5 * t1 * t2 + t3 * w, 0.5 * t1 * t3 - t2 * w],
        [0.5 * t1 * t2 - t3 * w, 1.0 - 0.5 * (t1 * t1 + t3 * t3), 0.5 * t2 * t3 + t1 * w],
        [0.5 * t1 * t3 + t2 * w, 0.5 * t2 * t3 - t1 * w, 1.0 - 0.5 * (t1 * t1 + t2 * t2)]])
    return np.moveaxis(m, (0, 1), (-2, -1)) if t1.ndim else m
