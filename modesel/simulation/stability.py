"""Static stability check of a linearised scene, run before simulating:
a configuration that cannot stand (e.g. a tower-top mass beyond the
buckling load) is refused with the coordinate that gives way."""
from __future__ import annotations

import numpy as np

from modesel.errors import PhysicallyUnstable
from modesel.multibody.linearize import LinearModel, eigen, eigenvalues, simple_participation, state_matrix
from modesel.vocabulary import RIGID_BODY_DOFS, coordinate_field

#: a real eigenvalue below this fraction of the largest |eigenvalue| (plus an
#: absolute 1e-6 1/s) is round-off of the finite-difference linearisation
STABILITY_NOISE = 1e-7


def coordinate_fields(names) -> dict:
    """{coordinate: what it is} for messages: the field of an elastic
    coordinate, 'drivetrain' for DrTr/HSSTw (vocabulary.coordinate_field)."""
    return {n: f for n in names if (f := coordinate_field(n)) is not None}


def _unstable(lam: np.ndarray) -> np.ndarray:
    """Indices of the real positive eigenvalues beyond round-off (STABILITY_NOISE)."""
    noise = STABILITY_NOISE * float(np.abs(lam).max()) + 1e-6
    return np.flatnonzero((lam.real > noise) & (np.abs(lam.imag) <= noise))


def _dominant_coordinates(A: np.ndarray, lam: np.ndarray, which, n: int):
    """{eigenvalue index: its dominant coordinate} for the eigenvalues `which`
    of the state matrix A when each is simple (`linearize.simple_participation`:
    numpy only, so scipy.linalg stays off a simulation's start-up), else None."""
    out = {}
    for i in which:
        p = simple_participation(A, lam, int(i), n)
        if p is None:
            return None
        out[int(i)] = int(np.argmax(p))
    return out


def check_static_stability(lin: LinearModel, *, file=None, fields=None, lam=None) -> None:
    """Raise `PhysicallyUnstable` when the linearised model has a statically
    unstable elastic mode: a real positive eigenvalue lambda [1/s] of the
    first-order system [[0, I], [-M^-1 K, -M^-1 C]] (a negative effective
    stiffness: no damping can hold it, only gyroscopic coupling could, and
    that would make the eigenvalue complex), whose dominant coordinate (modal
    participation, `linearize.modes`) is elastic or a drivetrain twist.
    Zero-frequency and drifting rigid-body modes (free rotor, yaw, platform:
    RIGID_BODY_DOFS) are not flagged, nor real eigenvalues within round-off
    of zero (STABILITY_NOISE). fields: {coordinate: what it is} for the
    message; lam: the state matrix's eigenvalues if known."""
    if len(lin.names) == 0:
        return
    lam = eigenvalues(lin) if lam is None else lam
    unstable = _unstable(lam)
    if not len(unstable):
        return
    dominant = _dominant_coordinates(state_matrix(lin), lam, unstable, len(lin.names))
    if dominant is None:
        lam, _, participation = eigen(lin)
        unstable = _unstable(lam)
        dominant = {i: int(np.argmax(participation[i])) for i in unstable}
    worst = None
    for i in unstable:
        label = lin.names[dominant[i]]
        if label in RIGID_BODY_DOFS:
            continue
        if worst is None or lam[i].real > worst[1]:
            worst = (label, float(lam[i].real))
    if worst is not None:
        what = (fields or {}).get(worst[0])
        raise PhysicallyUnstable(f"{what} ({worst[0]})" if what else worst[0], worst[1], file=file,
                                 detail="e.g. a tower-top mass beyond the buckling load; check the "
                                        "masses and stiffnesses (or set [solver] stability_check = false, "
                                        "or give `modesel simulate` --no-stability-check, to simulate it "
                                        "anyway)")
