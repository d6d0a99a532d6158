"""Convergence: how far a simulated channel is from its reference, and when a
mode set is good enough.

Every metric is an *error*: dimensionless, 0 for a perfect match, lower is
better, so one tolerance applies to every metric. Call them through the front
function::

    metric("nrmse", sim, ref, time)        # -> float

with `sim` and `ref` sampled on the same `time` grid [s] (see
`modesel.study.reference.Reference.align`). Time averages use the trapezoidal rule
over the window, so non-uniform grids are handled and a sine over whole
periods averages exactly to zero.

Metrics (R = ref, S = sim, <.> = time average over the window):

- ``nrmse``      sqrt(<(S-R)^2>) / (max R - min R): the RMS of the difference
                 normalised by the reference range; the default. Dai et al.
                 (second paper, section 5, Figs. 13-14) accept a mode set when
                 its "relative error" against OpenFAST is within 3.5 % without
                 defining that error; nrmse is our reading of it (a pointwise
                 relative error is undefined where the response crosses 0).
- ``max_abs``    max |S-R| / (max R - min R).
- ``mean``       |<S> - <R>| / |<R>|: relative error of the mean (undefined
                 when the reference mean is ~0, e.g. a free decay about 0).
- ``amplitude``  |std S - std R| / std R, std = sqrt(<(x-<x>)^2>). For a sine
                 the std is amplitude/sqrt(2), so this is the relative error of
                 the amplitude, and it is robust to noise, unlike half the
                 peak-to-peak.
- ``frequency``  |f_S - f_R| / f_R with f the dominant spectral peak: mean
                 removed, Hann window, zero padded to >= 8x the record (next
                 power of 2), peak refined by a parabola through the log
                 magnitudes of the 3 bins around it. Bin spacing
                 1/(n_fft*dt) <= 1/(8 T) for a record of length T; after
                 refinement a clean sine with >= 10 cycles in the record is
                 located to better than 1e-3/T (measured 7e-5/T for 12
                 cycles), with 3 cycles to ~4e-3/T. Two peaks closer than
                 ~2/T (Hann main lobe) are not separated.
- ``r2``         1 - R^2 with R^2 = 1 - sum (S-R)^2 / sum (R-<R>)^2 (the
                 coefficient of determination), so 0 is a perfect match.
- ``periodic``   periodic operation compared against rotor azimuth, not time
                 (a 0.1 % rotor-speed difference shifts the phase by 36 deg
                 per 100 revolutions; against azimuth it costs nothing).
                 Over the last `last_s` seconds of the window (default: all
                 of it), each side is fitted by least squares with its own
                 azimuth psi (unwrapped, rad) as
                     x ~ a_0 + sum_{k=1..H} (a_k cos k psi + b_k sin k psi),
                 H = `harmonics` (default 3), and
                     e = sqrt(da_0^2 + 1/2 sum_k (da_k^2 + db_k^2)) / (max R - min R),
                 d = sim - ref coefficients, the range over the whole window:
                 by Parseval, the RMS over one revolution of the difference of
                 the two azimuth-periodic responses, normalised like nrmse.
                 Needs the Azimuth channel [deg] in the simulation and the
                 reference, and at least one revolution in the last `last_s`.
                 Study file: ``metric = "periodic"`` and
                 ``[compare.periodic] last_s = 30.0, harmonics = 3``.

`Criterion` turns per-channel errors into one verdict, and `StopWhenMet` is
an Optuna callback that stops a study once the criterion is met.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from modesel.errors import ModeselError, unknown_name

# A reference whose range is below this fraction of its magnitude (or exactly 0)
# is treated as constant: range-normalised metrics are undefined for it.
_TINY = 1e-12


def _average(x: np.ndarray, time: np.ndarray) -> float:
    """Time average of x over [time[0], time[-1]] (trapezoidal rule)."""
    return float(np.trapezoid(x, time) / (time[-1] - time[0]))


def _reference_range(ref: np.ndarray) -> float:
    span = float(np.max(ref) - np.min(ref))
    if not span > _TINY * max(1.0, float(np.max(np.abs(ref)))):
        raise ModeselError("reference is constant over the comparison window; "
                           "a range-normalised metric is undefined (use 'mean')")
    return span


def nrmse(sim, ref, time) -> float:
    """RMS of (sim - ref) divided by the reference range (max - min)."""
    diff = sim - ref
    return float(np.sqrt(_average(diff * diff, time))) / _reference_range(ref)


def max_abs(sim, ref, time) -> float:
    """Largest |sim - ref| divided by the reference range."""
    return float(np.max(np.abs(sim - ref))) / _reference_range(ref)


def mean_error(sim, ref, time) -> float:
    """|mean(sim) - mean(ref)| / |mean(ref)|."""
    ref_mean = _average(ref, time)
    if abs(ref_mean) <= _TINY * max(1.0, float(np.max(np.abs(ref)))) or ref_mean == 0.0:
        raise ModeselError("reference mean is 0; the relative error of the mean is undefined")
    return abs(_average(sim, time) - ref_mean) / abs(ref_mean)


def _std(x, time) -> float:
    centred = x - _average(x, time)
    return float(np.sqrt(_average(centred * centred, time)))


def amplitude_error(sim, ref, time) -> float:
    """|std(sim) - std(ref)| / std(ref): relative error of the oscillation amplitude."""
    ref_std = _std(ref, time)
    if not ref_std > _TINY * max(1.0, float(np.max(np.abs(ref)))):
        raise ModeselError("reference does not oscillate; the amplitude error is undefined")
    return abs(_std(sim, time) - ref_std) / ref_std


def dominant_frequency(x, time) -> float:
    """Frequency [Hz] of the largest spectral peak of x (mean removed).

    Hann window, zero padding to the next power of 2 >= 8*len, parabolic
    refinement on the log magnitude. A non-uniform grid is first linearly
    interpolated onto a uniform one with the median step.
    """
    x = np.asarray(x, dtype=float)
    time = np.asarray(time, dtype=float)
    if len(x) < 8:
        raise ModeselError(f"need at least 8 samples for a spectrum, got {len(x)}")
    dt = float(np.median(np.diff(time)))
    uniform = np.arange(time[0], time[-1] + 0.5 * dt, dt)
    uniform = uniform[uniform <= time[-1] + 1e-9 * dt]
    if len(uniform) != len(time) or not np.allclose(uniform, time, rtol=0, atol=1e-6 * dt):
        x = np.interp(uniform, time, x)
    scale = max(1.0, float(np.max(np.abs(x))))
    x = x - x.mean()
    if not float(np.max(np.abs(x))) > _TINY * scale:
        raise ModeselError("signal does not oscillate; its dominant frequency is undefined")
    n_fft = 1 << int(np.ceil(np.log2(8 * len(x))))
    magnitude = np.abs(np.fft.rfft(x * np.hanning(len(x)), n_fft))
    k = int(np.argmax(magnitude[1:])) + 1          # skip the DC bin
    delta = 0.0
    if 1 <= k < len(magnitude) - 1:
        a, b, c = np.log(np.maximum(magnitude[k - 1:k + 2], 1e-300))
        denom = a - 2.0 * b + c
        if denom < 0.0:
            delta = 0.5 * (a - c) / denom
    return (k + delta) / (n_fft * dt)


def frequency_error(sim, ref, time) -> float:
    """|f_sim - f_ref| / f_ref with f the dominant spectral peak [Hz]."""
    f_ref = dominant_frequency(ref, time)
    return abs(dominant_frequency(sim, time) - f_ref) / f_ref


def r_squared(sim, ref, time) -> float:
    """Coefficient of determination of sim as a prediction of ref."""
    ss_res = _average((sim - ref) ** 2, time)
    centred = ref - _average(ref, time)
    ss_tot = _average(centred * centred, time)
    if not ss_tot > 0.0:
        raise ModeselError("reference is constant; R^2 is undefined")
    return 1.0 - ss_res / ss_tot


def one_minus_r2(sim, ref, time) -> float:
    """1 - R^2, so that 0 is a perfect match like every other metric."""
    return 1.0 - r_squared(sim, ref, time)


def azimuth_harmonics(x, azimuth, harmonics: int) -> np.ndarray:
    """Least-squares coefficients (a_0, a_1, b_1, ..., a_H, b_H) of
    x ~ a_0 + sum_k a_k cos(k psi) + b_k sin(k psi), psi = `azimuth` [rad]."""
    psi = np.asarray(azimuth, dtype=float)
    columns = [np.ones_like(psi)]
    for k in range(1, int(harmonics) + 1):
        columns += [np.cos(k * psi), np.sin(k * psi)]
    coeffs, *_ = np.linalg.lstsq(np.column_stack(columns), np.asarray(x, dtype=float), rcond=None)
    return coeffs


def periodic_error(sim, ref, time, *, azimuth_sim=None, azimuth_ref=None, last_s=None,
                   harmonics: int = 3) -> float:
    """Mean and first `harmonics` azimuth harmonics over the last `last_s` s,
    compared as the RMS over one revolution of their difference, divided by
    the reference range over the whole window (module docstring)."""
    if azimuth_sim is None or azimuth_ref is None:
        raise ModeselError("needs the rotor azimuth: the 'Azimuth' channel [deg] must be in the "
                           "simulation outputs and in the reference file")
    time = np.asarray(time, dtype=float)
    span = _reference_range(ref)
    keep = time >= time[-1] - last_s - 1e-9 if last_s is not None else np.ones(len(time), bool)
    psi_s, psi_r = np.asarray(azimuth_sim, float)[keep], np.asarray(azimuth_ref, float)[keep]
    n = 2 * int(harmonics) + 1
    revolutions = min(abs(psi_s[-1] - psi_s[0]), abs(psi_r[-1] - psi_r[0])) / (2 * np.pi)
    if keep.sum() < 4 * n or revolutions < 1.0:
        raise ModeselError(f"the last {time[keep][-1] - time[keep][0]:g} s hold {int(keep.sum())} samples "
                           f"and {revolutions:.3g} rotor revolutions; {harmonics} harmonics need at least "
                           f"{4 * n} samples and 1 revolution (raise last_s or lower harmonics)")
    d = azimuth_harmonics(sim[keep], psi_s, harmonics) - azimuth_harmonics(ref[keep], psi_r, harmonics)
    return float(np.sqrt(d[0] ** 2 + 0.5 * np.sum(d[1:] ** 2))) / span


@dataclass(frozen=True)
class Metric:
    name: str
    function: Callable
    description: str
    formula: str = ""     # as written in docs/study-file.md (R reference, S simulation, <.> time average)


METRICS = {m.name: m for m in (
    Metric("nrmse", nrmse, "RMS of the difference / reference range (max - min)",
           formula="sqrt(<(S - R)^2>) / (max R - min R)"),
    Metric("max_abs", max_abs, "largest absolute difference / reference range",
           formula="max |S - R| / (max R - min R)"),
    Metric("mean", mean_error, "relative error of the time average",
           formula="|<S> - <R>| / |<R>|"),
    Metric("amplitude", amplitude_error, "relative error of the standard deviation (amplitude)",
           formula="|std S - std R| / std R, std x = sqrt(<(x - <x>)^2>)"),
    Metric("frequency", frequency_error, "relative error of the dominant spectral peak",
           formula="|f_S - f_R| / f_R, f = peak of the Hann-windowed, zero-padded spectrum "
                   "(parabolic refinement)"),
    Metric("r2", one_minus_r2, "1 - coefficient of determination R^2",
           formula="sum (S - R)^2 / sum (R - <R>)^2"),
    Metric("periodic", periodic_error,
           "periodic operation against rotor azimuth: over the last last_s s, the mean and the first H "
           "azimuth harmonics of each side, least squares on its own azimuth psi",
           formula="sqrt(da0^2 + 1/2 sum_k=1..H (da_k^2 + db_k^2)) / (max R - min R), "
                   "x ~ a0 + sum_k (a_k cos k psi + b_k sin k psi)"),
)}

# metrics compared against the rotor azimuth: they take azimuth_sim, azimuth_ref [rad]
AZIMUTH_METRICS = ("periodic",)


def metric(name: str, sim, ref, time, *, channel: str | None = None, **options) -> float:
    """Front function: the error `name` of `sim` against `ref` on `time` [s];
    `options` go to the metric (periodic: azimuth_sim, azimuth_ref [rad],
    last_s [s], harmonics).

    Raises ModeselError for an unknown metric, mismatched lengths, fewer than 2
    samples, non-finite values, or a metric undefined for this reference
    (e.g. constant reference); `channel` names the channel in the message.
    """
    if name not in METRICS:
        raise unknown_name("metric", name, METRICS, field=channel)
    sim = np.asarray(sim, dtype=float)
    ref = np.asarray(ref, dtype=float)
    time = np.asarray(time, dtype=float)
    if not (sim.shape == ref.shape == time.shape) or sim.ndim != 1:
        raise ModeselError(f"sim, ref and time must be 1-D of equal length, got "
                           f"{sim.shape}, {ref.shape}, {time.shape}", field=channel)
    if len(time) < 2 or not time[-1] > time[0]:
        raise ModeselError("need at least 2 samples spanning a positive time window", field=channel)
    for label, values in (("simulation", sim), ("reference", ref)):
        if not np.all(np.isfinite(values)):
            raise ModeselError(f"{label} has NaN or infinite values", field=channel)
    try:
        return float(METRICS[name].function(sim, ref, time, **options))
    except ModeselError as exc:
        raise ModeselError(f"{name}: {exc.message}", field=channel) from None


@dataclass(frozen=True)
class Assessment:
    """Verdict of a `Criterion` on one set of per-channel errors.

    `error` is the worst weighted channel error, `worst_channel` its channel,
    `weighted` the weighted error of every channel, `meets` whether every
    channel is within tolerance.
    """

    error: float
    worst_channel: str
    weighted: dict
    meets: bool


@dataclass(frozen=True)
class Criterion:
    """When is a mode set good enough?

    Each channel's error e_c is multiplied by its weight w_c (default 1); the
    trial's error is the worst weighted channel, max_c w_c e_c, and the
    criterion is met when every channel is within its tolerance
    tolerance / w_c (equivalently, the trial error <= tolerance). A weight of
    0.5 lets a channel be twice as far off; 2 makes it twice as strict.
    """

    metric: str = "nrmse"
    tolerance: float = 0.035
    weights: dict = field(default_factory=dict)

    def channel_tolerance(self, channel: str) -> float:
        return self.tolerance / self.weights.get(channel, 1.0)

    def assess(self, errors: dict, tolerance: float | None = None) -> Assessment:
        """Assess per-channel errors {channel: e}; `tolerance` overrides the criterion's."""
        if not errors:
            raise ModeselError("no channel errors to assess")
        tol = self.tolerance if tolerance is None else tolerance
        weighted = {ch: self.weights.get(ch, 1.0) * float(e) for ch, e in errors.items()}
        worst = max(weighted, key=lambda ch: weighted[ch])
        error = weighted[worst]
        return Assessment(error, worst, weighted, bool(np.isfinite(error) and error <= tol))


class StopWhenMet:
    """Optuna callback: stop the study once it holds a trial meeting the
    criterion and `keep_searching_trials` more trials have finished after it
    (to look for a cheaper set); trials that only repeated an evaluated set
    (user attribute `duplicate_of`) do not count.

    A trial's per-channel errors are read from its user attribute `errors`
    ({channel: error}), so the verdict follows the criterion given here even
    for trials recorded under another tolerance. Works across processes and
    machines sharing one storage: each worker stops after its current trial.
    """

    def __init__(self, criterion: Criterion, keep_searching_trials: int = 0):
        self.criterion = criterion
        self.keep_searching_trials = int(keep_searching_trials)

    def first_meeting_trial(self, trials) -> int | None:
        import optuna
        numbers = [t.number for t in trials
                   if t.state == optuna.trial.TrialState.COMPLETE and t.user_attrs.get("errors")
                   and self.criterion.assess(t.user_attrs["errors"]).meets]
        return min(numbers, default=None)

    def is_satisfied(self, study) -> bool:
        import optuna
        finished = study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,
                                                            optuna.trial.TrialState.FAIL))
        first = self.first_meeting_trial(finished)
        if first is None:
            return False
        later = sum(1 for t in finished if t.number > first and "duplicate_of" not in t.user_attrs)
        return later >= self.keep_searching_trials

    def __call__(self, study, trial) -> None:
        if self.is_satisfied(study):
            study.stop()
