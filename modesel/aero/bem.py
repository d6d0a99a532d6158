"""Quasi-steady blade-element momentum (BEM) theory for many elements at once.

Second paper, section 3: the distributed blade loads whose work enters eq. 52
come from BEM with Prandtl tip/hub loss, the Glauert (Buhl) high-induction
correction and the Pitt/Peters skewed-wake correction. This module solves
all elements of all blades in one vectorised call, cheap enough for every
right-hand-side evaluation of a time integrator (no state, no memory).

Element inputs (any broadcastable shapes, SI units)
---------------------------------------------------
With v_rel = v_wind - v_element (air velocity relative to the moving element),
e_n the rotor-axis direction (normal to the element's plane of rotation,
downwind) and e_rot the direction of rotation at the element:
r      distance of the element from the rotation axis [m] (AeroDyn's rLocal:
       the deflected element position projected on the rotor plane); it
       sets the local solidity sigma' and, over the largest r of the blade,
       the Pitt/Peters radius ratio
V_n    normal inflow [m/s] = v_rel . e_n
V_t    tangential inflow [m/s] = -v_rel . e_rot = rotor speed * r + the
       element's structural velocity along e_rot - the wind along e_rot
       (positive values increase the in-plane relative flow)
pitch  blade pitch [rad] (plus any elastic torsion), added to the static
       twist: alpha = phi - (pitch + twist)
skew, skew_azimuth   Pitt/Peters inputs (see `pitt_peters`)

Outputs (`ElementLoads`): a, a', phi, alpha, Cl, Cd, Cm, W, loss factor F,
f_n [N/m] along the rotor axis (positive downwind), f_t [N/m] along the
direction of rotation (positive = driving torque), m [N m/m] pitching
moment about the section reference (positive nose up).

Method (Ning 2014, Wind Energy 17:1327, "A simple solution method for the
blade element momentum equations with guaranteed convergence"): the BEM
equations reduce to one residual in the inflow angle phi,

    R(phi) = sin(phi) / (1 - a(phi)) - cos(phi) (1 - k'(phi)) / lambda_r   (Ning eq. 22)
    k  = sigma' c_n / (4 F sin^2 phi),   k' = sigma' c_t / (4 F sin phi cos phi),
    sigma' = B c / (2 pi r),   lambda_r = V_t / V_n,

with a(k) from momentum theory (a = k / (1 + k), k <= 2/3 i.e. a <= 0.4),
Buhl's empirical relation beyond (`axial_induction`), and the propeller-brake
branch (phi < 0: a = k / (k - 1)); a' = k' / (1 - k'). The root is bracketed
in (0, pi/2], else [-pi/4, 0), else [pi/2, pi) (Ning's order) and found with
Chandrupatla's bracketed inverse-quadratic / bisection method: convergence
is guaranteed once a sign change is found. The per-element work runs in a
compiled (numba) loop over all elements, called once per evaluation with
numpy arrays in and out (`BemSolver.solve` allocates its result;
`BemSolver.solve_into` fills arrays preallocated by `BemSolver.allocate`,
for callers at every right-hand side); the model functions (`prandtl_loss`,
`axial_induction`, `pitt_peters`) are compiled ufuncs shared by that loop
and by Python callers.
As in AeroDyn (AIDrag/TIDrag = False by default) the drag terms in c_n, c_t
can be left out of the induction; the loads always include drag.

Tip and hub loss: F = 2/pi acos(exp(-c / |sin phi|)) with AeroDyn's loss
constants c_tip = B (z_tip - z) / (2 z), c_hub = B (z - z_hub) / (2 z_hub),
z the distance along the undeflected blade from the apex (AeroDyn's zLocal:
the hub radius plus the polygon length through its nodes, `z_local`); without
`z_local` the constants follow from r and the tip and hub radii (a straight
coned blade: the same ratios).

Safeguards follow AeroDyn (OpenFAST modules/aerodyn/src/BEMTUncoupled.f90): F is floored at 1e-4 in
the induction equations; inductions are limited to -1 <= a <= 1.5 and
-1 <= a' <= 1; elements at or beyond the tip or hub radius (loss constant
<= 0) get the "fixed inductions" a = 1, a' = 0, so their inflow is purely
tangential (phi = 0) and their loads follow from W = V_t (AeroDyn's tip-node
loads). Elements with no root bracket, V_n or V_t below 1 mm/s (AeroDyn's
VelocityIsZero: still air; or negative: parked, reversed flow) get no
induction (a = a' = 0, geometric inflow angle) and `converged=False`. Loads are always 1/2 rho W^2 c (Cl, Cd) resolved with
the final phi = atan2(V_n (1 - a), V_t (1 + a')).

Low tip-speed ratio (AeroDyn BEMT.f90 `check_turnOffBEMT`): below a rotor
tip-speed ratio of 2 the inductions of every element are scaled by the
weight `bem_weight(TSR)`, a cosine blend from 1 at TSR 2 to 0 at TSR 1 and
below (NWTC `BlendCosine`, bounds BEMT_lowerBoundTSR / BEMT_upperBoundTSR),
and phi follows from the scaled inductions: a rotor at rest or starting up
sees the geometric inflow. AeroDyn's TSR is the rotor speed about the shaft
times the largest rLocal of all blades over the disk-averaged relative wind
along the shaft (`modesel.model.effects.aero.inflow`); `solve_into` and the
compiled loop take the weight, `BemSolver.solve` the TSR. With weight 0 no
root is solved (the inductions would be scaled to zero).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from modesel.errors import ModeselError
from modesel.aero.airfoils import polar_coefficients

#: Pitt/Peters constant (AeroDyn SkewModFactor default).
PITT_PETERS_FACTOR = 15.0 * np.pi / 32.0
#: AeroDyn's safeguards: loss factor floor in the induction equations and
#: induction limits (BEMT_MinInduction / BEMT_MaxInduction).
F_MIN = 1e-4
A_LIMITS = (-1.0, 1.5)
AP_LIMITS = (-1.0, 1.0)
#: AeroDyn's InductionLimit: a' where k' = 1 (getTangentialInduction), before the limits above
#: AeroDyn's VelocityIsZero (BEMTUncoupled.f90): below 1 mm/s of normal or tangential
#: inflow an element gets no induction (phi 0 or +-pi/2 in the solve, then from the inflow)
VELOCITY_ZERO = 1e-3          # m/s
INDUCTION_LIMIT = 1e6
#: AeroDyn's BEMT_lowerBoundTSR / BEMT_upperBoundTSR (BEMTUncoupled.f90): no induction at or
#: below the lower tip-speed ratio, full induction from the upper (module doc, "Low tip-speed ratio")
TSR_BEM_OFF = 1.0
TSR_BEM_ON = 2.0


@dataclass(frozen=True)
class BemOptions:
    """Model switches (AeroDyn names in brackets) and solver tolerances.

    tip_loss [TipLoss], hub_loss [HubLoss], tangential_induction [TanInd],
    axial_drag [AIDrag], tangential_drag [TIDrag] : flags.
    skew_correction [SkewMod = 2], skew_factor [SkewModFactor] : Pitt/Peters.
    tolerance : absolute tolerance on phi [rad]; max_iterations : root solve.
    """

    tip_loss: bool = True
    hub_loss: bool = True
    tangential_induction: bool = True
    axial_drag: bool = False
    tangential_drag: bool = False
    skew_correction: bool = True
    skew_factor: float = PITT_PETERS_FACTOR
    tolerance: float = 1e-10
    max_iterations: int = 100

    @classmethod
    def from_deck(cls, deck, **overrides):
        """Options as set in an `AeroDynDeck` (its `bem`), with keyword overrides."""
        return replace(deck.bem, **overrides)


# --------------------------------------------------------------------------- models
# Compiled scalar functions (`_name`), called by the compiled element loop
# below, and their element-wise fronts (`name`) for arrays from Python (one
# implementation of each model). Plain njit functions load from the on-disk
# cache; numba's cached @vectorize ufuncs recompiled at every import (~1 s).

def _elementwise(scalar):
    """Front of a compiled scalar model: broadcasts its arguments (numpy rules)
    and applies it element by element; 0-d inputs give a float."""
    def front(*args):
        arrays = np.broadcast_arrays(*(np.asarray(a, float) for a in args))
        out = np.empty(arrays[0].shape)
        for index in np.ndindex(out.shape):
            out[index] = scalar(*(a[index] for a in arrays))
        return float(out) if out.ndim == 0 else out
    front.__name__ = front.__qualname__ = scalar.__name__.lstrip("_")
    front.__doc__ = scalar.__doc__
    return front


#: exponent f from which 2/pi acos(exp(-f)) is 1.0 in double precision:
#: exp(-f) < 8.6e-17 lies below half the spacing of doubles at pi/2, so acos
#: returns pi/2 itself (numba's compiled acos and exp give 1.0 from f = 36.3
#: on, 4 million f in [35, 800]). Most elements' hub loss lies there
#: (NREL 5-MW: f = B (r - R_hub) / (2 R_hub |sin phi|) > 37 from r = 5 m).
PRANDTL_ONE = 37.0


@njit(cache=True, inline="always")
def _prandtl(c, s):
    """2/pi acos(exp(-c / |sin phi|)) (AeroDyn getHubTipLossCorrection), 0 for c <= 0;
    1.0 without exp and acos where it is 1.0 in double precision (PRANDTL_ONE)."""
    if c <= 0.0:
        return 0.0
    f = c / max(abs(s), 1e-300)
    if f >= PRANDTL_ONE:
        return 1.0
    return (2.0 / np.pi) * np.arccos(np.exp(-f))


@njit(cache=True)
def _prandtl_factor(distance, num_blades, radius, sin_phi):
    """Prandtl factor 2/pi acos(exp(-B d / (2 rho |sin phi|))), 0 for d <= 0.

    Tip: d = R - r, rho = r.  Hub: d = r - R_hub, rho = R_hub.
    """
    return _prandtl(0.5 * num_blades * distance / radius, sin_phi)


def prandtl_loss(r, tip_radius, hub_radius, num_blades, sin_phi, tip=True, hub=True):
    """Prandtl tip and hub loss factor F = F_tip F_hub in [0, 1].

    F_tip = 2/pi acos(exp(-B (R - r) / (2 r |sin phi|))),
    F_hub = 2/pi acos(exp(-B (r - R_hub) / (2 R_hub |sin phi|))).
    F = 0 at (and beyond) the tip or hub radius, F -> 1 far from both.
    """
    F = np.ones(np.broadcast(r, sin_phi).shape)
    if tip:
        F = F * prandtl_factor(tip_radius - np.asarray(r, float), num_blades, r, sin_phi)
    if hub:
        F = F * prandtl_factor(np.asarray(r, float) - hub_radius, num_blades, hub_radius, sin_phi)
    return F


@njit(cache=True)
def _one_minus_a_buhl(k, F):
    """1 - a on Buhl's branch (k > 2/3), evaluated without cancellation.

    Buhl (2005, NREL/TP-500-36834): C_T = 8/9 + (4F - 40/9) a + (50/9 - 4F) a^2
    for a > 0.4, equated to the blade-element thrust 4 F k (1 - a)^2. The
    quadratic root a = (g1 - sqrt g2) / g3 (Ning 2014 eq. 27) has a removable
    singularity at g3 = 0; the equivalent rationalised form divides by
    g1 + sqrt g2 instead, and the two denominators never vanish together.
    The form with the larger denominator is used.
    """
    two_fk = 2.0 * F * k
    g1 = two_fk - (10.0 / 9.0 - F)
    root_g2 = np.sqrt(max(two_fk - (4.0 / 3.0 - F) * F, 0.0))
    g3 = two_fk - (25.0 / 9.0 - 2.0 * F)
    d_rat = g1 + root_g2
    if abs(g3) > abs(d_rat):
        return (root_g2 - (5.0 / 3.0 - F)) / g3
    return (root_g2 - (2.0 / 3.0 - F)) / d_rat


@njit(cache=True)
def _axial_induction(k, F):
    """Axial induction a(k, F) for phi > 0: momentum theory a = k / (1 + k) up
    to a = 0.4 (k <= 2/3), Buhl's Glauert correction beyond (continuous in
    value and slope at a = 0.4). At k = -1 AeroDyn's -InductionLimit."""
    if k <= 2.0 / 3.0:
        return k / (1.0 + k) if k != -1.0 else -INDUCTION_LIMIT
    return 1.0 - _one_minus_a_buhl(k, F)


def thrust_coefficient(a, F=1.0):
    """Local thrust coefficient C_T(a): momentum theory 4 a F (1 - a) for
    a <= 0.4, Buhl's empirical parabola above (the relation `axial_induction` inverts)."""
    a = np.asarray(a, float)
    buhl = 8.0 / 9.0 + (4.0 * F - 40.0 / 9.0) * a + (50.0 / 9.0 - 4.0 * F) * a * a
    return np.where(a <= 0.4, 4.0 * a * F * (1.0 - a), buhl)


@njit(cache=True)
def _pitt_peters(a, skew, skew_azimuth, r_over_R, factor):
    """Pitt/Peters skewed-wake correction of the axial induction.

        chi   = (0.6 a + 1) chi_0                       (wake skew, Burton et al.)
        a_sk  = a [1 + factor (r/R) tan(chi / 2) cos(psi)]

    chi_0 = `skew` [rad]: angle between the rotor axis and the inflow;
    psi = `skew_azimuth` [rad]: element azimuth measured from the position
    deepest in the skewed wake (the direction of the inflow's in-plane
    component, see `skew_angles`). factor = 15 pi / 32 (AeroDyn default,
    `PITT_PETERS_FACTOR`). This is the form of AeroDyn's 2-D BEM option (its
    OpenFAST 4 3-D option also multiplies the correction by F). No
    correction for |chi_0| >= pi/2; chi_0 = 0 returns a unchanged.
    """
    if skew == 0.0 or abs(skew) >= 0.5 * np.pi:
        return a
    chi = min(max((0.6 * a + 1.0) * skew, -0.5 * np.pi + 1e-9), 0.5 * np.pi - 1e-9)
    return a * (1.0 + factor * r_over_R * np.tan(0.5 * chi) * np.cos(skew_azimuth))


prandtl_factor = _elementwise(_prandtl_factor)
one_minus_a_buhl = _elementwise(_one_minus_a_buhl)
axial_induction = _elementwise(_axial_induction)
pitt_peters = _elementwise(_pitt_peters)


def skew_angles(wind, axis, radial):
    """(chi_0, psi) for `pitt_peters` from vectors (..., 3) in any common frame.

    wind: inflow velocity relative to the rotor; axis: unit rotor axis
    (downwind); radial: unit in-plane radial direction of the element.
    """
    wind, axis, radial = (np.asarray(v, float) for v in (wind, axis, radial))
    w_axial = np.sum(wind * axis, axis=-1)
    in_plane = wind - w_axial[..., None] * axis
    w_plane = np.sqrt(np.sum(in_plane * in_plane, axis=-1))
    chi0 = np.arctan2(w_plane, w_axial)
    cos_psi = np.sum(radial * in_plane, axis=-1) / np.where(w_plane > 0, w_plane, 1.0)
    psi = np.where(w_plane > 0, np.arccos(np.clip(cos_psi, -1.0, 1.0)), 0.0)
    return chi0, psi


# --------------------------------------------------------------------------- compiled solver
# Per element: e = (c_tip, theta = pitch + twist, sigma' / 4 = B c / (8 pi r),
# lambda_r = V_t / V_n, c_hub) and the polar row `offset` (c_tip, c_hub: the loss
# constants, `loss_constants`); flags = (tip, hub, tangential induction, axial
# drag, tangential drag).

@njit(cache=True)
def bem_weight(tsr):
    """Weight of the BEM inductions at rotor tip-speed ratio `tsr` (module doc,
    "Low tip-speed ratio"): NWTC BlendCosine(|tsr|, TSR_BEM_OFF, TSR_BEM_ON)."""
    x = abs(tsr)
    if x >= TSR_BEM_ON:
        return 1.0
    if x <= TSR_BEM_OFF:
        return 0.0
    return 0.5 * (1.0 - np.cos((x - TSR_BEM_OFF) / (TSR_BEM_ON - TSR_BEM_OFF) * np.pi))


@njit(cache=True, inline="always")
def _loss_raw(e, s, flags):
    F = 1.0
    if flags[0]:
        F *= _prandtl(e[0], s)
    if flags[1]:
        F *= _prandtl(e[4], s)
    return F


@njit(cache=True, inline="always")
def _loss(e, s, flags):
    """Loss factor as used in the induction: floored at F_MIN (as AeroDyn)."""
    return max(_loss_raw(e, s, flags), F_MIN)


def loss_constants(z, z_tip, z_hub, num_blades):
    """AeroDyn's tip and hub loss constants (c_tip, c_hub) of elements at
    distance z [m] from the apex along the blade: B (z_tip - z) / (2 z) and
    B (z - z_hub) / (2 z_hub)."""
    z = np.asarray(z, float)
    return num_blades * (z_tip - z) / (2.0 * z), num_blades * (z - z_hub) / (2.0 * z_hub)


@njit(cache=True, inline="always")
def _residual(phi, e, offset, flags, grid, value, slope):
    """Ning's residual R(phi) (Ning 2014 eq. 22 with his propeller-brake branch)."""
    s, c = np.sin(phi), np.cos(phi)
    cl, cd, _ = polar_coefficients(phi - e[1], offset, grid, value, slope)
    cn = cl * c + cd * s if flags[3] else cl * c
    F = _loss(e, s, flags)
    q = e[2] / F                                     # sigma' / (4 F)
    k = q * cn / (s * s)
    # sin(phi) / (1 - a): momentum s (1 + k); Buhl s / (1 - a); brake s (1 - k)
    if phi > 0.0:
        lead = s * (1.0 + k) if k <= 2.0 / 3.0 else s / _one_minus_a_buhl(k, F)
    else:
        lead = s * (1.0 - k)
    if flags[2]:
        ct = cl * s - cd * c if flags[4] else cl * s
        return lead - (c - q * ct / s) / e[3]         # cos(phi) (1 - k') / lambda_r
    return lead - c / e[3]


@njit(cache=True)
def _residual_apart(phi, e, offset, flags, grid, value, slope):
    """`_residual` compiled apart, for the five evaluations of `_solve_phi`'s
    cold brackets (after the first right-hand side the warm bracket nearly
    always holds the root). Each inlined call site is a copy of the residual
    and of the polar lookup in the compiled code: seven of them cost 2.3 s of
    the first run's compile; a call costs about 5 % more than an inlined one."""
    return _residual(phi, e, offset, flags, grid, value, slope)


#: spacing [rad] of the lattice a warm solve starts on, and the width of its
#: bracket beside the lattice point (`_solve_phi`'s guess)
WARM_BRACKET = 2e-3


@njit(cache=True)
def _solve_phi(e, offset, flags, grid, value, slope, tol, max_iter, guess):
    """Bracket (Ning's order) and solve R(phi) = 0 with Chandrupatla's method.

    guess [rad]: a root of this element at a nearby state (the previous
    right-hand side), or NaN. A guess in Ning's first bracket (0, pi/2]
    starts at c, the multiple of WARM_BRACKET nearest the guess (so the
    result depends on the guess only through c, not on the last digits that
    the path of the previous solve set): R at c, then at c + WARM_BRACKET
    toward the root (R increases through it on the momentum branch: up where
    R(c) < 0), or, where R has no sign change there, at c - WARM_BRACKET
    (all clipped to the bracket). A sign change brackets a root of the
    first bracket, the one the cold solve finds wherever R has a single root
    in (0, pi/2] (with several, the warm solve stays on the previous right-hand
    side's branch), in about half the residual evaluations of the cold
    solve. Otherwise the cold brackets in Ning's order.

    Returns (phi, found, iterations)."""
    eps = 1e-6
    lo, hi = eps, 0.5 * np.pi
    if guess > eps and guess <= hi:             # NaN compares False
        centre = min(max(np.floor(guess / WARM_BRACKET + 0.5) * WARM_BRACKET, eps), hi)
        f_c = _residual(centre, e, offset, flags, grid, value, slope)
        if f_c == 0.0:
            return centre, True, 0
        for side in (1.0, -1.0):
            other = min(max(centre + side * np.copysign(WARM_BRACKET, -f_c), eps), hi)
            if other != centre:
                f_o = _residual(other, e, offset, flags, grid, value, slope)
                if f_c * f_o <= 0.0:
                    return _chandrupatla(centre, f_c, other, f_o, e, offset, flags, grid, value, slope, tol,
                                         max_iter)
    f_lo = _residual_apart(lo, e, offset, flags, grid, value, slope)
    f_hi = _residual_apart(hi, e, offset, flags, grid, value, slope)
    if f_lo * f_hi > 0.0:
        f_a = _residual_apart(-0.25 * np.pi, e, offset, flags, grid, value, slope)
        f_b = _residual_apart(-eps, e, offset, flags, grid, value, slope)
        if f_a * f_b <= 0.0:
            lo, hi, f_lo, f_hi = -0.25 * np.pi, -eps, f_a, f_b
        else:
            f_c = _residual_apart(np.pi - eps, e, offset, flags, grid, value, slope)
            if f_hi * f_c <= 0.0:
                lo, f_lo, hi, f_hi = hi, f_hi, np.pi - eps, f_c
            else:
                return 0.0, False, 0
    return _chandrupatla(lo, f_lo, hi, f_hi, e, offset, flags, grid, value, slope, tol, max_iter)


@njit(cache=True, inline="always")
def _step_floor(x1, x2, tol):
    """Chandrupatla's smallest step, as a fraction of the bracket [x1, x2]:
    half the tolerance (tol plus four ulps of the larger end) over its width."""
    return 0.5 * (4.0 * 2.2e-16 * max(abs(x1), abs(x2)) + tol) / abs(x2 - x1)


@njit(cache=True)
def _chandrupatla(a, f_a, b, f_b, e, offset, flags, grid, value, slope, tol, max_iter):
    """Chandrupatla (1997) on the bracket of a and b (f_a f_b <= 0, either order):
    (phi, True, iterations). The first step is the secant's (regula falsi)
    where Chandrupatla bisects: a warm bracket (`_solve_phi`) holds the root
    within a fraction of its width. It stops where the bracket is narrower
    than tol, or where the secant over it puts the newest point within
    tol / 10 of the root (|f1| |x2 - x1| / |f2 - f1|): the step that would
    only shrink the bracket onto a point already converged is left out."""
    if f_a == 0.0:
        return a, True, 0
    if f_b == 0.0:
        return b, True, 0
    # Chandrupatla (1997): x1 newest point, x2 the other bracket end, x3 the previous
    x1, f1, x2, f2 = b, f_b, a, f_a
    x3, f3 = x2, f2
    tl = _step_floor(x1, x2, tol)
    t = min(max(f1 / (f1 - f2), tl), 1.0 - tl)
    it = 0
    while it < max_iter:
        it += 1
        xt = x1 + t * (x2 - x1)
        ft = _residual(xt, e, offset, flags, grid, value, slope)
        if (ft > 0.0) == (f1 > 0.0):
            x3, f3 = x1, f1
        else:
            x3, f3 = x2, f2
            x2, f2 = x1, f1
        x1, f1 = xt, ft
        width = abs(x2 - x1)
        tl = _step_floor(x1, x2, tol)
        if tl > 0.5 or f1 == 0.0 or abs(f1) * width <= 0.1 * tol * abs(f2 - f1):
            break
        xi = (x1 - x2) / (x3 - x2)
        ph = (f1 - f2) / (f3 - f2)
        t = 0.5
        if ph * ph < xi and (1.0 - ph) * (1.0 - ph) < 1.0 - xi:
            t = (f1 / (f2 - f1) * f3 / (f2 - f3)
                 + (x3 - x1) / (x2 - x1) * f1 / (f3 - f1) * f2 / (f3 - f2))
        t = min(max(t, tl), 1.0 - tl)
    return (x1 if abs(f1) <= abs(f2) else x2), True, it


@njit(cache=True)
def _solve_elements(r, vn, vt, theta, chord, offset, skew, psi, tip_ratio, c_tip, c_hub, grid, value, slope,
                    B, rho, tip, hub, tan_ind, ai_drag, ti_drag,
                    skew_corr, skew_factor, tol, max_iter, weight, out, guess):
    """All elements; fills `out` rows: a, a', phi, alpha, cl, cd, cm, W, F,
    f_n, f_t, m, converged. tip_ratio: r / R of the Pitt/Peters correction;
    c_tip, c_hub: loss constants; weight: `bem_weight` of the rotor's
    tip-speed ratio, scaling every element's inductions (0: none solved, the
    guesses kept). guess: empty (every element solved cold),
    or one inflow angle [rad] per element, read as `_solve_phi`'s guess and
    overwritten with this solve's root (NaN where none): the compiled
    integration loop keeps it between right-hand sides. Returns the largest
    iteration count."""
    worst = 0
    flags = (tip, hub, tan_ind, ai_drag, ti_drag)
    warm = guess.size == r.size
    for i in range(r.size):
        ri = r[i]
        # AeroDyn "fixed inductions": no loss-factor support at/beyond the tip or hub
        fixed = (tip and c_tip[i] <= 0.0) or (hub and c_hub[i] <= 0.0)
        a, ap, ok = (1.0, 0.0, True) if fixed else (0.0, 0.0, False)
        e = (c_tip[i], theta[i], 0.0, 1.0, c_hub[i])
        if weight == 0.0:
            a, ap, ok = 0.0, 0.0, True
        elif vn[i] >= VELOCITY_ZERO and vt[i] >= VELOCITY_ZERO and ri > 0.0 and not fixed:
            sigma4 = B * chord[i] / (8.0 * np.pi * ri)
            e = (c_tip[i], theta[i], sigma4, vt[i] / vn[i], c_hub[i])
            phi, found, it = _solve_phi(e, offset[i], flags, grid, value, slope, tol, max_iter,
                                        guess[i] if warm else np.nan)
            worst = max(worst, it)
            if warm:
                guess[i] = phi if found else np.nan
            if found:
                s, c = np.sin(phi), np.cos(phi)
                cl, cd, _ = polar_coefficients(phi - theta[i], offset[i], grid, value, slope)
                cn = cl * c + cd * s if ai_drag else cl * c
                ct = cl * s - cd * c if ti_drag else cl * s
                F = _loss(e, s, flags)
                k = sigma4 * cn / (F * s * s)
                # propeller brake at k = 1: AeroDyn marks the solution invalid (no induction)
                a = _axial_induction(k, F) if phi > 0.0 else (k / (k - 1.0) if k != 1.0 else np.nan)
                if tan_ind:     # AeroDyn getTangentialInduction, with its guards at cos(phi) = 0 and k' = 1
                    if c == 0.0:
                        ap = -1.0
                    else:
                        kp = sigma4 * ct / (F * s * c)
                        ap = kp / (1.0 - kp) if kp != 1.0 else INDUCTION_LIMIT
                ok = np.isfinite(a) and np.isfinite(ap)
                if ok:  # AeroDyn limitInductionFactors, then the skewed wake on the limited a (AeroDyn's order)
                    a = min(max(a, A_LIMITS[0]), A_LIMITS[1])
                    ap = min(max(ap, AP_LIMITS[0]), AP_LIMITS[1])
                    if skew_corr:
                        a = _pitt_peters(a, skew[i], psi[i], tip_ratio[i], skew_factor)
                else:
                    a = ap = 0.0
        a *= weight
        ap *= weight
        un, ut = vn[i] * (1.0 - a), vt[i] * (1.0 + ap)
        phi = np.arctan2(un, ut)
        s, c = np.sin(phi), np.cos(phi)
        cl, cd, cm = polar_coefficients(phi - theta[i], offset[i], grid, value, slope)
        w2 = un * un + ut * ut
        qc = 0.5 * rho * w2 * chord[i]
        out[0, i], out[1, i], out[2, i], out[3, i] = a, ap, phi, phi - theta[i]
        out[4, i], out[5, i], out[6, i], out[7, i] = cl, cd, cm, np.sqrt(w2)
        out[8, i] = 0.0 if fixed else _loss_raw(e, s, flags)
        out[9, i] = qc * (cl * c + cd * s)
        out[10, i] = qc * (cl * s - cd * c)
        out[11, i] = qc * chord[i] * cm
        out[12, i] = 1.0 if ok else 0.0
    return worst


#: no guesses: `solve_into` solves every element cold (the reference of the compiled loop's warm solves)
_COLD = np.zeros(0)

#: the compiled element loop, public for the compiled integration loop
#: (`modesel.model.effects.compiled`), which calls it with the arguments that
#: `BemSolver.solve_into` passes
solve_elements = _solve_elements


# --------------------------------------------------------------------------- front

_FIELDS = ("a", "a_prime", "phi", "alpha", "cl", "cd", "cm", "w", "loss", "f_n", "f_t", "m")


@dataclass
class ElementLoads:
    """BEM result per element (arrays of the broadcast element shape)."""

    a: np.ndarray
    a_prime: np.ndarray
    phi: np.ndarray          # inflow angle [rad] (from the plane of rotation)
    alpha: np.ndarray        # angle of attack [rad]
    cl: np.ndarray
    cd: np.ndarray
    cm: np.ndarray
    w: np.ndarray            # relative speed [m/s]
    loss: np.ndarray         # Prandtl factor F
    f_n: np.ndarray          # [N/m], along the rotor axis, positive downwind
    f_t: np.ndarray          # [N/m], along rotation, positive = driving
    m: np.ndarray            # [N m/m], pitching moment, positive nose up
    converged: np.ndarray    # bool: BEM root found (else no-induction fallback)
    iterations: int = 0      # largest root-solver iteration count


@dataclass(frozen=True)
class BemBuffers:
    """Arrays preallocated for `BemSolver.solve_into` on one element shape.

    twist [rad], chord [m], offset (polar rows): the solver's static element
    data broadcast to `shape` (C-contiguous); theta [rad] (pitch + twist,
    `shape`) and `out` (13, n: the `ElementLoads` fields in order, then
    converged as 0/1) are overwritten by every solve.
    """

    shape: tuple
    twist: np.ndarray
    chord: np.ndarray
    offset: np.ndarray
    theta: np.ndarray
    out: np.ndarray
    #: loss constants (static with `z_local`, else recomputed from r) and the
    #: Pitt/Peters radius ratio of the last solve (`shape`)
    c_tip: np.ndarray | None = None
    c_hub: np.ndarray | None = None
    tip_ratio: np.ndarray | None = None

    @property
    def f_n(self) -> np.ndarray:
        """Normal load [N/m] of the last solve (a view of `out`, shape `shape`)."""
        return self.out[9].reshape(self.shape)

    @property
    def f_t(self) -> np.ndarray:
        """Tangential load [N/m] of the last solve (a view of `out`, shape `shape`)."""
        return self.out[10].reshape(self.shape)

    def loads(self, iterations: int = 0) -> ElementLoads:
        """The last solve as `ElementLoads` (views of `out`; `converged` a copy)."""
        fields = {name: self.out[i].reshape(self.shape) for i, name in enumerate(_FIELDS)}
        return ElementLoads(**fields, converged=self.out[12].reshape(self.shape) > 0.5,
                            iterations=int(iterations))


class BemSolver:
    """BEM element solver for a fixed set of elements (chord, twist, airfoil).

    Build once (`BemSolver(...)` or `BemSolver.from_blade`), then call
    `solve(r, v_normal, v_tangential, pitch, skew, skew_azimuth)` at every
    right-hand-side evaluation. Static arrays and call arrays broadcast
    together, e.g. static (n_span,) with call arrays (n_blades, n_span).
    Without allocation: `buffers = solver.allocate(shape)` once, then
    `solver.solve_into(buffers, ...)` with arrays of that shape.

    tip_radius, hub_radius : distances of the undeflected blade tip / root
        from the rotation axis [m] (coned: TipRad cos(precone)).
    z_local, z_tip, z_hub : AeroDyn's distances along the undeflected blade
        from the apex [m] of the elements, the tip and the root: the static
        tip/hub loss constants (`loss_constants`). None: the constants follow
        from the element radius r of each solve and tip_radius, hub_radius.
    """

    def __init__(self, chord, twist, airfoil, polars, *, num_blades: int, tip_radius: float,
                 hub_radius: float, air_density: float = 1.225, options: BemOptions | None = None,
                 z_local=None, z_tip: float | None = None, z_hub: float | None = None):
        self.chord = np.asarray(chord, float)
        self.twist = np.asarray(twist, float)
        self.airfoil = np.asarray(airfoil, dtype=np.int64)
        self.polars = polars
        self.offset = polars.offsets(self.airfoil)
        self.num_blades = int(num_blades)
        self.tip_radius = float(tip_radius)
        self.hub_radius = float(hub_radius)
        self.air_density = float(air_density)
        self.options = options or BemOptions()
        self.loss = None if z_local is None else loss_constants(z_local, z_tip, z_hub, self.num_blades)
        self._static = {}  # element shape -> (twist, chord, offset, c_tip, c_hub) broadcast to it
        o = self.options
        self._constants = (float(self.num_blades), self.air_density,
                           o.tip_loss, o.hub_loss, o.tangential_induction, o.axial_drag,
                           o.tangential_drag, o.skew_correction, float(o.skew_factor),
                           float(o.tolerance), int(o.max_iterations))
        if self.num_blades < 1:
            raise ModeselError(f"number of blades must be >= 1, got {num_blades}", field="NumBl")
        if not 0 < self.hub_radius < self.tip_radius:
            raise ModeselError(f"need 0 < hub radius ({hub_radius}) < tip radius ({tip_radius})",
                               field="HubRad")
        if self.air_density <= 0:
            raise ModeselError("air density must be > 0", field="AirDens")

    @classmethod
    def from_blade(cls, blade, span, *, num_blades: int, hub_radius: float, precone: float = 0.0,
                   air_density: float = 1.225, options: BemOptions | None = None,
                   curve_losses: bool = False):
        """Elements at `span` [m from the blade root] of an `AeroBlade`.

        hub_radius : HubRad along the (coned) blade axis [m]; precone [rad].
        The tip radius from the axis is (HubRad + last BlSpn) cos(precone).
        curve_losses : loss constants from AeroDyn's zLocal (`AeroBlade.curve_length`,
        static) instead of the radius of each solve.
        """
        chord, twist, airfoil = blade.at(span)
        c = np.cos(precone)
        curve = {}
        if curve_losses:
            z = blade.curve_length(hub_radius)
            curve = dict(z_local=np.interp(span, blade.span, z), z_tip=float(z[-1]), z_hub=float(hub_radius))
        return cls(chord, twist, airfoil, blade.polars, num_blades=num_blades,
                   tip_radius=(hub_radius + blade.span[-1]) * c, hub_radius=hub_radius * c,
                   air_density=air_density, options=options, **curve)

    def allocate(self, shape) -> BemBuffers:
        """Buffers for `solve_into` on elements of `shape` (the static element
        arrays must broadcast to it)."""
        shape = tuple(shape)
        static = self._static.get(shape)
        if static is None:
            loss = (np.empty(shape), np.empty(shape)) if self.loss is None else self.loss
            static = self._static[shape] = tuple(
                np.ascontiguousarray(np.broadcast_to(x, shape)) for x in (self.twist, self.chord, self.offset)) \
                + tuple(np.array(np.broadcast_to(x, shape), float) for x in loss)
        return BemBuffers(shape, *static[:3], np.empty(shape), np.empty((13, int(np.prod(shape)))),
                          *static[3:], np.empty(shape))

    def solve_into(self, buffers: BemBuffers, r, v_normal, v_tangential, pitch, skew,
                   skew_azimuth, tip_ratio=None, section_angle=None, weight: float = 1.0) -> int:
        """Solve all elements into `buffers` (from `allocate`) without allocating.

        r, v_normal, v_tangential, skew, skew_azimuth : C-contiguous float
        arrays of `buffers.shape` (or flat, of its size; inputs as in the
        module docstring); pitch [rad] : broadcastable to `buffers.shape`;
        tip_ratio : r / R of the Pitt/Peters correction (AeroDyn: rLocal over
        the largest rLocal of the blade), default r / tip_radius;
        section_angle [rad] : each element's pitch + twist (aerodynamic and
        elastic, AeroDyn's theta) replacing pitch + the blade's twist;
        weight : `bem_weight` of the rotor's tip-speed ratio (module doc).
        Returns the largest root-solver iteration count; the loads are
        `buffers.f_n`, `buffers.f_t` or `buffers.loads()`.
        """
        n = buffers.theta.size
        if not r.size == v_normal.size == v_tangential.size == skew.size == skew_azimuth.size == n:
            raise ValueError(f"solve_into: element arrays must have shape {buffers.shape}")
        if section_angle is None:
            np.add(pitch, buffers.twist, out=buffers.theta)
        else:
            np.copyto(buffers.theta, np.reshape(section_angle, buffers.shape))
        flat_r = r.reshape(buffers.shape)
        if self.loss is None:       # constants from the radius of this solve (straight coned blade)
            np.copyto(buffers.c_tip, 0.5 * self.num_blades * (self.tip_radius - flat_r) / flat_r)
            np.copyto(buffers.c_hub, 0.5 * self.num_blades * (flat_r - self.hub_radius) / self.hub_radius)
        if tip_ratio is None:
            np.divide(flat_r, self.tip_radius, out=buffers.tip_ratio)
        else:
            np.copyto(buffers.tip_ratio, np.reshape(tip_ratio, buffers.shape))
        grid, value, slope = self.polars.arrays
        return _solve_elements(r.ravel(), v_normal.ravel(), v_tangential.ravel(), buffers.theta.ravel(),
                               buffers.chord.ravel(), buffers.offset.ravel(), skew.ravel(),
                               skew_azimuth.ravel(), buffers.tip_ratio.ravel(), buffers.c_tip.ravel(),
                               buffers.c_hub.ravel(), grid, value, slope, *self._constants, float(weight),
                               buffers.out, _COLD)

    def solve(self, r, v_normal, v_tangential, pitch=0.0, skew=0.0, skew_azimuth=0.0,
              tip_ratio=None, tsr=np.inf) -> ElementLoads:
        """Solve all elements; see the module docstring for inputs and outputs.
        tsr: the rotor's tip-speed ratio in AeroDyn's definition (module doc,
        "Low tip-speed ratio"; default: high, full induction)."""
        r, vn, vt, pitch, skew, psi = (np.asarray(x, dtype=float) for x in
                                       (r, v_normal, v_tangential, pitch, skew, skew_azimuth))
        shape = np.broadcast_shapes(r.shape, vn.shape, vt.shape, pitch.shape, skew.shape,
                                    psi.shape, self.chord.shape)
        size = int(np.prod(shape))

        def flat(x):  # 1-D contiguous view or copy of x broadcast to `shape`
            if x.shape == shape:
                return x.ravel()
            if x.ndim == 0:
                return np.full(size, float(x))
            return np.broadcast_to(x, shape).ravel()

        buffers = self.allocate(shape)
        iterations = self.solve_into(buffers, *(flat(x) for x in (r, vn, vt)), pitch,
                                     *(flat(x) for x in (skew, psi)),
                                     None if tip_ratio is None else flat(np.asarray(tip_ratio, float)),
                                     weight=bem_weight(float(tsr)))
        return buffers.loads(iterations)
