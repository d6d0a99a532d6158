"""The Butcher tableau of Dormand and Prince's 5(4) method with its dense
output (Dormand & Prince 1980; Hairer, Norsett & Wanner, Solving ODEs I,
II.4-5), as scipy.integrate.RK45 holds it in its public class attributes:
here as numbers, so that a simulation run by "compiled-RK45"
(`kernel.runge_kutta` with RK45_KIND) does not import scipy.integrate.
`tests/test_kernel.py` holds them equal to scipy's, bit for bit, and the
compiled loop equal to scipy's steps.

A (6 x 5) and C (6): the six stages; B (6) the fifth-order weights; E (7)
the error estimator (with the first stage of the next step, FSAL); P (7 x 4)
the dense-output coefficients. TABLE is in the layout of the kernel's loop,
(A, B, C, E, E, P).

Why a fifth-order pair beside DOP853: a turbine with BEM has a right-hand
side with kinks (AeroDyn's polars are interpolated linearly in the angle of
attack, so every element crossing a table angle bends the loads). An
eighth-order step is no more accurate across a kink than a fifth-order one,
and it costs twice the stages; at the loose tolerances of an OpenFAST case
DOP853 spends most of its right-hand sides on rejected steps
(`integrate.LOW_ORDER_RTOL`).
"""
import numpy as np

#: stage nodes, coefficients and weights (scipy RK45.C, A, B)
C = np.array([0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1])
A = np.array([
    [0, 0, 0, 0, 0],
    [1 / 5, 0, 0, 0, 0],
    [3 / 40, 9 / 40, 0, 0, 0],
    [44 / 45, -56 / 15, 32 / 9, 0, 0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
])
B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
#: error estimator (difference of the fifth- and fourth-order weights, with the FSAL stage)
E = np.array([-71 / 57600, 0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
#: dense output: y(t + x h) = y + h sum_k (K^T P)[:, k] x^(k+1)
P = np.array([
    [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0, 0, 0, 0],
    [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
    [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
])
A, B, C, E, P = (np.asarray(x, float) for x in (A, B, C, E, P))
TABLE = (A, B, C, E, E, P)
