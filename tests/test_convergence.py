"""Metrics against analytic signals with exact expected values, the criterion
and the stopping callback."""
from __future__ import annotations

import math

import numpy as np
import optuna
import pytest

from modesel.study.metrics import (METRICS, Criterion, StopWhenMet, dominant_frequency, metric,
                                 r_squared)
from modesel.errors import ModeselError

# 10 whole periods of a 1 Hz sine, endpoints included: trapezoidal time
# averages of sin, sin^2 over whole periods are exact
T = np.linspace(0.0, 10.0, 2001)
S = np.sin(2 * np.pi * T)


def test_nrmse_of_an_offset_is_offset_over_range():
    # difference = 0.1 everywhere, range of reference = 2
    assert metric("nrmse", S + 0.1, S, T) == pytest.approx(0.05, rel=1e-12)


def test_nrmse_of_a_scaled_sine():
    # difference -0.2 sin: RMS 0.2/sqrt(2); range 2
    assert metric("nrmse", 0.8 * S, S, T) == pytest.approx(0.2 / math.sqrt(2) / 2, rel=1e-12)


def test_nrmse_of_a_phase_lag():
    # sin(x - p) - sin(x) has amplitude 2 sin(p/2): RMS sqrt(2) sin(p/2)
    p = 0.1
    assert metric("nrmse", np.sin(2 * np.pi * T - p), S, T) == \
        pytest.approx(math.sqrt(2) * math.sin(p / 2) / 2, rel=1e-10)


def test_max_abs():
    ref = 3.0 * S
    sim = ref + 0.3 * np.cos(2 * np.pi * T)     # largest difference 0.3 at t = 0
    assert metric("max_abs", sim, ref, T) == pytest.approx(0.3 / 6.0, rel=1e-12)


def test_mean_error():
    ref = 2.0 + S
    sim = 2.1 + 0.5 * S
    assert metric("mean", sim, ref, T) == pytest.approx(0.05, rel=1e-12)


def test_amplitude_error_is_relative_amplitude_independent_of_phase_and_offset():
    ref = 3.0 * S
    sim = 1.0 + 2.7 * np.sin(2 * np.pi * T + 0.7)
    assert metric("amplitude", sim, ref, T) == pytest.approx(0.1, rel=1e-12)


def test_r2_of_a_scaled_prediction():
    # sim = a ref with zero-mean ref: 1 - R^2 = (1 - a)^2
    assert r_squared(0.9 * S, S, T) == pytest.approx(1 - 0.01, rel=1e-12)
    assert metric("r2", 0.9 * S, S, T) == pytest.approx(0.01, rel=1e-10)


def test_dominant_frequency_resolution():
    t = np.arange(0.0, 40.0 + 1e-9, 0.01)
    record = t[-1] - t[0]
    for f in (0.3, 0.45, 1.234, 3.7):
        x = 0.5 + np.sin(2 * np.pi * f * t + 0.3) + 0.2 * np.sin(2 * np.pi * 3.1 * f * t)
        # documented: >= 10 cycles in the record -> better than 1e-3 / T
        assert abs(dominant_frequency(x, t) - f) < 1e-3 / record


def test_frequency_error():
    t = np.arange(0.0, 40.0 + 1e-9, 0.01)
    sim = np.sin(2 * np.pi * 0.5 * t)
    ref = np.sin(2 * np.pi * 0.45 * t)
    # each estimate within 1e-3/T Hz: relative error within 2e-3/(T f_ref) of the exact 1/9
    assert metric("frequency", sim, ref, t) == pytest.approx(0.05 / 0.45, abs=2e-3 / 40 / 0.45)


def test_frequency_on_a_non_uniform_grid():
    rng = np.random.default_rng(1)
    t = np.sort(np.concatenate([[0.0, 40.0], rng.uniform(0, 40, 3998)]))
    assert dominant_frequency(np.sin(2 * np.pi * 0.7 * t), t) == pytest.approx(0.7, abs=2e-3 / 40)


def test_perfect_match_is_zero_for_every_metric():
    ref = 1.5 + S
    from modesel.study.metrics import AZIMUTH_METRICS
    psi = 4 * np.pi * (T - T[0]) / (T[-1] - T[0])      # two rotor revolutions
    for name in METRICS:
        opts = dict(azimuth_sim=psi, azimuth_ref=psi) if name in AZIMUTH_METRICS else {}
        assert metric(name, ref.copy(), ref, T, **opts) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("name", ["nrmse", "max_abs", "amplitude", "frequency", "r2"])
def test_constant_reference_is_refused(name):
    with pytest.raises(ModeselError, match=f"TTDspFA: {name}"):
        metric(name, S, np.ones_like(S), T, channel="TTDspFA")


def test_zero_mean_reference_refused_for_mean():
    with pytest.raises(ModeselError, match="mean is 0"):
        metric("mean", S + 1, S, T)


def test_bad_inputs():
    with pytest.raises(ModeselError, match="did you mean 'nrmse'"):
        metric("nrsme", S, S, T)
    with pytest.raises(ModeselError, match="equal length"):
        metric("nrmse", S[:-1], S, T)
    bad = S.copy()
    bad[5] = np.nan
    with pytest.raises(ModeselError, match="TTDspSS: simulation has NaN"):
        metric("nrmse", bad, S, T, channel="TTDspSS")
    with pytest.raises(ModeselError, match="at least 2 samples"):
        metric("nrmse", S[:1], S[:1], T[:1])


def test_criterion_worst_weighted_channel():
    c = Criterion("nrmse", 0.035, {"TTDspSS": 2.0})
    verdict = c.assess({"TTDspFA": 0.03, "TTDspSS": 0.02})
    assert verdict.error == pytest.approx(0.04)
    assert verdict.worst_channel == "TTDspSS"
    assert not verdict.meets
    assert c.channel_tolerance("TTDspSS") == pytest.approx(0.0175)
    assert c.channel_tolerance("TTDspFA") == pytest.approx(0.035)
    assert c.assess({"TTDspFA": 0.03, "TTDspSS": 0.017}).meets
    assert c.assess({"TTDspFA": 0.03, "TTDspSS": 0.017}, tolerance=0.01).meets is False
    assert not c.assess({"TTDspFA": math.nan}).meets


def _trial(number, errors, duplicate_of=None, state=optuna.trial.TrialState.COMPLETE):
    attrs = {"errors": errors} if errors else {}
    if duplicate_of is not None:
        attrs = {"duplicate_of": duplicate_of}
    return optuna.trial.create_trial(state=state, values=None if state != optuna.trial.TrialState.COMPLETE
                                     else [1.0, 1.0], user_attrs=attrs)


def test_stop_when_met_counts_new_sets_after_the_first_meeting_trial():
    optuna.logging.set_verbosity(optuna.logging.ERROR)
    study = optuna.create_study(directions=["minimize", "minimize"])
    crit = Criterion("nrmse", 0.035)
    stop = StopWhenMet(crit, keep_searching_trials=2)
    study.add_trial(_trial(0, {"a": 0.05}))
    assert not stop.is_satisfied(study)
    study.add_trial(_trial(1, {"a": 0.03}))            # first meeting trial
    assert stop.first_meeting_trial(study.trials) == 1
    study.add_trial(_trial(2, None, duplicate_of=1))   # a repeat does not count
    study.add_trial(_trial(3, None, state=optuna.trial.TrialState.FAIL))
    assert not stop.is_satisfied(study)
    study.add_trial(_trial(4, {"a": 0.04}))
    assert stop.is_satisfied(study)
    # a stricter tolerance re-judges the recorded errors
    assert not StopWhenMet(Criterion("nrmse", 0.01), 0).is_satisfied(study)


def test_stop_when_met_stops_optimize():
    optuna.logging.set_verbosity(optuna.logging.ERROR)
    study = optuna.create_study(directions=["minimize", "minimize"])
    errors = iter([0.2, 0.1, 0.03, 0.02, 0.01, 0.005])

    def objective(trial):
        e = next(errors)
        trial.set_user_attr("errors", {"TTDspFA": e})
        return e, 1.0

    study.optimize(objective, n_trials=6, callbacks=[StopWhenMet(Criterion(tolerance=0.035), 1)])
    assert len(study.trials) == 4      # met at trial 2, one more looked for a cheaper set
