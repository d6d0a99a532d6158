"""Constrained sixth-order polynomial fit of a mode shape (ElastoDyn's form).

ElastoDyn describes every tower and blade bending mode by a polynomial in the
normalised span x = s/L (first paper, Branlard & Geisler, eq. 46)

    phi(x) = c2 x^2 + c3 x^3 + c4 x^4 + c5 x^5 + c6 x^6,   c2 + ... + c6 = 1,

so phi(0) = phi'(0) = 0 (clamped root) and phi(1) = 1 (unit tip value).
`fit_mode_polynomial` finds the coefficients that best reproduce a sampled
shape under that constraint.

Method. The tip constraint is eliminated: c6 = 1 - (c2 + ... + c5), so

    phi(x) - x^6 = sum_{k=2..5} c_k (x^k - x^6),

an unconstrained linear least-squares problem in (c2..c5), solved with an
SVD-based solver (`numpy.linalg.lstsq`) on columns scaled to unit norm (the
monomial basis is ill-conditioned; the scaled system stays ~1e3 on [0, 1]).
The sum of the returned coefficients is 1 to rounding by construction.

Weighting (`weighting=`):
- "uniform": minimise the continuous L2 error  int_0^1 (phi_fit - phi)^2 dx,
  discretised with trapezoidal weights, so the result does not depend on how
  the stations are spaced.
- "mass": minimise  int_0^1 m(x) (phi_fit - phi)^2 dx  with the mass per unit
  length m(x) (normalised by its mean): the error is weighted where the
  kinetic energy is, which is what sets the generalised mass.
- "stiffness": minimise  int_0^1 EI(x) (phi_fit'' - phi'')^2 dx  with the
  bending stiffness EI(x) (normalised by its mean), i.e. the error in the
  strain-energy norm. ElastoDyn's modal stiffness is int EI phi''^2, and
  the Rayleigh quotient's error is bounded by this norm of the shape error,
  so this fit keeps the mode's frequency best (NREL 5-MW `fem` flap 2:
  +1.3 % against +6.7 % with "uniform"), at the price of a larger
  displacement residual. phi(0) = phi'(0) = 0 and phi(1) = 1 hold as
  before, so the displacement still follows the curvature.

Reported residuals (`PolynomialFit`), relative to the tip value 1:
- `rms`: sqrt(int_0^1 (phi_fit - phi)^2 dx) (uniform weight whatever the fit
  weighting, trapezoidal rule on the given stations);
- `max_abs`: max over the stations of |phi_fit - phi|;
- `curvature_rms`: RMS of (phi_fit'' - phi'') divided by the RMS of phi'',
  when the shape's curvature is supplied. ElastoDyn's modal stiffness comes
  from the polynomial's curvature (int EI phi''^2), so this says how well the
  exported mode keeps the stiffness of the chosen shape.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modesel.errors import ModeselError

POWERS = np.arange(2, 7)          # exponents of the ElastoDyn polynomial, x^2..x^6
WEIGHTINGS = ("uniform", "mass", "stiffness")


def evaluate_polynomial(coefficients, x, derivative: int = 0) -> np.ndarray:
    """Evaluate sum_k c_k x^k (k = 2..6) or its first/second x-derivative."""
    c = np.asarray(coefficients, dtype=float)
    x = np.asarray(x, dtype=float)
    if c.shape != (5,):
        raise ValueError("need 5 coefficients (x^2..x^6)")
    if derivative == 0:
        factors, powers = np.ones(5), POWERS
    elif derivative == 1:
        factors, powers = POWERS.astype(float), POWERS - 1
    elif derivative == 2:
        factors, powers = (POWERS * (POWERS - 1)).astype(float), POWERS - 2
    else:
        raise ValueError("derivative must be 0, 1 or 2")
    return np.sum((c * factors)[:, None] * x[None, :] ** powers[:, None], axis=0)


@dataclass(frozen=True)
class PolynomialFit:
    """Coefficients of x^2..x^6 (summing to 1) and the fit residuals.

    `rms`, `max_abs` are relative to the unit tip value; `curvature_rms` is
    relative to the RMS curvature of the shape (None when not supplied).
    """

    coefficients: np.ndarray
    rms: float
    max_abs: float
    curvature_rms: float | None
    weighting: str

    def __call__(self, x, derivative: int = 0) -> np.ndarray:
        return evaluate_polynomial(self.coefficients, x, derivative)

    def to_dict(self) -> dict:
        return {"coefficients": [float(c) for c in self.coefficients],
                "rms": self.rms, "max_abs": self.max_abs,
                "curvature_rms": self.curvature_rms, "weighting": self.weighting}


def trapezoid_weights(x: np.ndarray) -> np.ndarray:
    """Quadrature weights w with sum(w * f) = trapezoidal integral of f over x."""
    dx = np.diff(x)
    w = np.zeros_like(x)
    w[:-1] += dx / 2
    w[1:] += dx / 2
    return w


def fit_mode_polynomial(x, phi, *, ddphi=None, weighting: str = "uniform", mass=None, stiffness=None,
                        field: str | None = None) -> PolynomialFit:
    """Best ElastoDyn polynomial (eq. 46 form, coefficients summing to 1) for a shape.

    Parameters
    ----------
    x : (N,) increasing normalised stations covering [0, 1].
    phi : (N,) shape values; scaled here to phi(1) = 1 if not already.
    ddphi : (N,) optional d2phi/dx2 (same scaling as phi) for `curvature_rms`.
    weighting : "uniform" or "mass" (see module docstring).
    mass : (N,) mass per unit length at x [kg/m], required for "mass".
    stiffness : (N,) bending stiffness EI at x [N m^2], required for
        "stiffness" (with `ddphi`).
    field : name used in error messages.
    """
    x = np.asarray(x, dtype=float)
    phi = np.asarray(phi, dtype=float)
    if weighting not in WEIGHTINGS:
        raise ModeselError(f"unknown weighting '{weighting}'; valid: {', '.join(WEIGHTINGS)}",
                           field="weighting")
    if x.ndim != 1 or phi.shape != x.shape or x.size < 6:
        raise ModeselError("need at least 6 stations with one shape value each", field=field)
    if not np.all(np.isfinite(phi)):
        raise ModeselError("shape has non-finite values", field=field)
    if np.any(np.diff(x) <= 0) or abs(x[0]) > 1e-12 or abs(x[-1] - 1.0) > 1e-12:
        raise ModeselError("stations must increase from 0 to 1", field=field)
    tip = phi[-1]
    if abs(tip) < 1e-9 * max(1.0, float(np.max(np.abs(phi)))):
        raise ModeselError("shape has zero tip value; ElastoDyn modes have unit tip value",
                           field=field)
    phi = phi / tip

    w = trapezoid_weights(x)
    derivative, target = 0, phi
    if weighting == "mass":
        fit_w = w * _distribution(mass, x, "mass", field)
    elif weighting == "stiffness":
        if ddphi is None:
            raise ModeselError("weighting 'stiffness' needs the shape's curvature", field=field)
        fit_w = w * _distribution(stiffness, x, "stiffness", field)
        derivative, target = 2, np.asarray(ddphi, dtype=float) / tip
        if target.shape != x.shape or not np.all(np.isfinite(target)):
            raise ModeselError("curvature must be finite, one value per station", field=field)
    else:
        fit_w = w
    sw = np.sqrt(fit_w)

    # eliminate c6 = 1 - (c2 + ... + c5): phi - x^6 = sum_k c_k (x^k - x^6) (or its 2nd derivative)
    sixth = evaluate_polynomial([0, 0, 0, 0, 1.0], x, derivative)
    basis = np.stack([evaluate_polynomial(np.eye(5)[k], x, derivative) - sixth for k in range(4)],
                     axis=1) * sw[:, None]
    scale = np.linalg.norm(basis, axis=0)
    z, *_ = np.linalg.lstsq(basis / scale, (target - sixth) * sw, rcond=None)
    head = z / scale
    coefficients = np.append(head, 1.0 - np.sum(head))

    err = evaluate_polynomial(coefficients, x) - phi
    rms = float(np.sqrt(np.sum(w * err ** 2)))
    max_abs = float(np.max(np.abs(err)))
    curvature_rms = None
    if ddphi is not None:
        dd = np.asarray(ddphi, dtype=float) / tip
        ref = np.sqrt(np.sum(w * dd ** 2))
        derr = evaluate_polynomial(coefficients, x, 2) - dd
        curvature_rms = float(np.sqrt(np.sum(w * derr ** 2)) / ref) if ref > 0 else None
    return PolynomialFit(coefficients, rms, max_abs, curvature_rms, weighting)


def _distribution(values, x, name: str, field) -> np.ndarray:
    """A weight distribution (mass or stiffness per station) normalised by its mean."""
    if values is None:
        raise ModeselError(f"weighting '{name}' needs the {name} distribution", field=field)
    v = np.asarray(values, dtype=float)
    if v.shape != x.shape or np.any(v < 0) or not np.any(v > 0):
        raise ModeselError(f"{name} distribution must be >= 0 at every station", field=field)
    w = trapezoid_weights(x)
    return v / (np.sum(w * v) / np.sum(w))
