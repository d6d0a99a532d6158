"""Uniform Euler-Bernoulli cantilever: characteristic roots and eigenfunctions.

Shared by the `clamped` family (bare cantilever) and the `relaxed_tipmass`
family (cantilever carrying a tip mass M and a tip rotary inertia J).
On the normalised span x in [0, 1] the eigenfunctions are

    phi(x) = A (cosh bx - cos bx) + B (sinh bx - sin bx),

which satisfy phi(0) = phi'(0) = 0. With mu = M / (m L) and
eta = J / (m L^3) and omega^2 = b^4 EI / (m L^4), the tip conditions are

    phi''(1)  =  eta b^4 phi'(1)    (bending moment = tip rotary inertia load)
    phi'''(1) = -mu  b^4 phi(1)     (shear force    = tip mass inertia load)

and the characteristic determinant, divided by 2, is

    1 + cos b cosh b + mu b (cos b sinh b - sin b cosh b)
      - eta b^3 (sinh b cos b + sin b cosh b) + mu eta b^4 (1 - cos b cosh b) = 0,

which reduces to the classical 1 + cos b cosh b = 0 for mu = eta = 0
(the MF3 shape of eq. 53-54 of the second paper is its first root,
b = 1.8751, sigma = 1/1.3622). It is evaluated divided by cosh b, so it
stays O(b^4) for any b.

Numerical stability: cosh bx and sinh bx grow like e^b while the shape
stays O(1), so the textbook form cancels catastrophically for b > ~20.
Here the hyperbolic part is regrouped as

    A cosh bx + B sinh bx = (A+B)/2 e^{bx} + (A-B)/2 e^{-bx},

with (A, B) taken from the shear-force row (A = b12, B = -b11) and
A + B written in closed form, with no large terms left to cancel:

    A + B = e^{-b} + cos b + sin b + mu b (cos b - sin b - e^{-b})

(for mu = eta = 0 this is (1 - sigma) (cosh b + cos b) with the classical
sigma = (sinh b - sin b)/(cosh b + cos b), equal at a root to
(cosh b + cos b)/(sinh b + sin b)). All coefficients are then scaled by
2 e^{-b}, so every term is an exponential of a non-positive number times an
O(b^4) coefficient. Mode 20 agrees with 80-digit arithmetic to 3e-15.
"""
from __future__ import annotations

import numpy as np


def characteristic(b, mu: float = 0.0, eta: float = 0.0):
    """Characteristic function of a uniform cantilever with tip mass ratio `mu`
    and tip inertia ratio `eta`, divided by 2 cosh b (see module docstring).
    Vectorised in `b` (> 0)."""
    b = np.asarray(b, dtype=float)
    e = np.exp(-b)
    sech = 2.0 * e / (1.0 + e * e)
    tanh = (1.0 - e * e) / (1.0 + e * e)
    c, s = np.cos(b), np.sin(b)
    return (sech + c + mu * b * (c * tanh - s) - eta * b ** 3 * (tanh * c + s)
            + mu * eta * b ** 4 * (sech - c))


def clamped_free_roots(count: int) -> np.ndarray:
    """First `count` roots of 1 + cos b cosh b = 0 (bare uniform cantilever).

    Root k lies in ((k-1) pi, k pi), where cos b + sech b changes sign, and
    tends to (2k-1) pi / 2."""
    return characteristic_roots(count, 0.0, 0.0)


def characteristic_roots(count: int, mu: float = 0.0, eta: float = 0.0) -> np.ndarray:
    """First `count` positive roots b_k of `characteristic(b, mu, eta)`.

    Bare cantilever: one root in each interval ((k-1) pi, k pi), refined by
    Brent's method. With a tip mass/inertia the roots are found by scanning a
    grid (step 0.02, far below the ~pi root spacing) for sign changes and
    refining each with Brent's method. Adding tip mass lowers every root
    (Rayleigh's theorem), so the first `count` roots lie below the bare
    cantilever's root `count`; the scan stops there, and the count found
    is checked.
    """
    count = int(count)
    if mu == 0.0 and eta == 0.0:
        brackets = [((k - 1) * np.pi, k * np.pi) for k in range(1, count + 1)]
    else:
        top = (count - 0.5) * np.pi + 1.0   # above the bare root `count`
        grid = np.linspace(1e-3, top, int(np.ceil(top / 0.02)) + 1)
        f = characteristic(grid, mu, eta)
        idx = np.nonzero(np.sign(f[:-1]) * np.sign(f[1:]) <= 0)[0]
        brackets = [(grid[i], grid[i + 1]) for i in idx][:count]
        if len(brackets) < count:   # cannot happen for mu, eta >= 0 (interlacing)
            raise RuntimeError(f"found {len(brackets)} of {count} tip-mass cantilever roots")
    from scipy.optimize import brentq        # here: scipy.optimize is 0.18 s of every simulation's start-up
    roots = []
    for lo, hi in brackets:
        f_lo = float(characteristic(lo, mu, eta))
        roots.append(lo if f_lo == 0.0 else brentq(lambda b: float(characteristic(b, mu, eta)),
                                                   lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps,
                                                   maxiter=200))
    return np.array(roots)


def eigenfunctions(x, roots, mu: float = 0.0, eta: float = 0.0):
    """Tip-normalised eigenfunctions for the roots `roots` (from
    `characteristic_roots(., mu, eta)`), evaluated stably at normalised
    stations `x`.

    Returns (phi, dphi, ddphi), each (len(roots), len(x)), derivatives d/dx.
    """
    x = np.asarray(x, dtype=float)[None, :]
    b = np.asarray(roots, dtype=float)[:, None]
    e = np.exp(-b)
    c, s = np.cos(b), np.sin(b)
    # Coefficients scaled by 2 e^{-b}: a_hat = 2e^{-b} A, b_hat = 2e^{-b} B,
    # with A = (cosh b + cos b) + mu b (sinh b - sin b),
    #      B = -[(sinh b - sin b) + mu b (cosh b - cos b)]  (shear row, see docstring).
    a_hat = (1 + e * e) + 2 * e * c + mu * b * (1 - e * e - 2 * e * s)
    b_hat = -((1 - e * e) - 2 * e * s + mu * b * (1 + e * e - 2 * e * c))
    plus = e + c + s + mu * b * (c - s - e)            # A + B, closed form
    minus = 1 + e * (c - s) + mu * b * (1 - e * (s + c))  # 2e^{-b}(A - B)/2
    grow = np.exp(b * (x - 1.0)) * plus     # 2e^{-b} * (A+B)/2 e^{bx}
    decay = np.exp(-b * x) * minus          # 2e^{-b} * (A-B)/2 e^{-bx}
    cx, sx = np.cos(b * x), np.sin(b * x)
    phi = grow + decay - a_hat * cx - b_hat * sx
    dphi = b * (grow - decay + a_hat * sx - b_hat * cx)
    ddphi = b * b * (grow + decay + a_hat * cx + b_hat * sx)
    tip = (plus + e * minus - a_hat * c - b_hat * s)   # phi at x = 1
    return phi / tip, dphi / tip, ddphi / tip
