"""Who simulates a mode set: the claim protocol of the trials.

Several workers (processes, machines) propose sets at the same time, and a
sampler that has converged proposes the same set again and again. A set is
simulated once; every other trial proposing it takes that trial's record
(user attribute ``duplicate_of``). The storage offers no atomic
test-and-set, only user attributes that every worker reads, so the owner of
a set is decided by Lamport's bakery algorithm (Lamport 1974, "A new
solution of Dijkstra's concurrent programming problem") with the set's
label as the lock:

1. claim: user attribute ``modeset`` = label (the trial is *choosing*);
2. ticket: user attribute ``ticket`` = 1 + the largest ticket of the trials
   that claimed the label;
3. wait while another claimant of the label is choosing or holds a smaller
   (ticket, trial number); then take the record of a claimant that has
   finished, or, when there is none, simulate the set.

A trial that takes its ticket after another trial's claim is visible gets a
larger ticket, so two trials never both simulate a set. (Ordering by trial
number alone does not do that: the number is fixed when the trial is
created, before its set is known, so a trial created later that claimed
first and one created earlier that claimed second both simulated.)
Trials cut short by an interruption (fail_reason ``interrupted``), trials
of a worker that died (failed by the storage's heartbeat: FAIL with no
record and no reason) and repeats never own a set.
"""
from __future__ import annotations

import time

INTERRUPTED = "interrupted"


def interrupted(trial) -> bool:
    """Whether `trial` (a FrozenTrial) was cut short by an interruption."""
    return trial.user_attrs.get("fail_reason") == INTERRUPTED


def abandoned(trial) -> bool:
    """Whether `trial` ended without a result of its own: interrupted, or
    failed by the storage because its worker died (FAIL with neither a
    fail_reason nor values nor duplicate_of)."""
    import optuna
    a = trial.user_attrs
    return interrupted(trial) or (trial.state == optuna.trial.TrialState.FAIL and "fail_reason" not in a
                                  and "duplicate_of" not in a)


def distinct_sets(study) -> set:
    """Labels of the mode sets evaluated so far (interrupted trials excluded)."""
    import optuna
    TS = optuna.trial.TrialState
    return {t.user_attrs["modeset"] for t in study.get_trials(deepcopy=False, states=(TS.COMPLETE, TS.FAIL))
            if "modeset" in t.user_attrs and not abandoned(t)}


def _claims(study, trial, label) -> list:
    """Other trials that claimed `label` and may own it (finished or running)."""
    import optuna
    TS = optuna.trial.TrialState
    return [t for t in study.get_trials(deepcopy=False, states=(TS.COMPLETE, TS.FAIL, TS.RUNNING))
            if t.number != trial.number and t.user_attrs.get("modeset") == label
            and not abandoned(t) and "duplicate_of" not in t.user_attrs]


def _dead(trial) -> bool:
    """Whether the process running `trial` is known to be gone (its ``owner``
    on this host is dead): it will never finish, so it is not waited for."""
    from modesel.study.search.owners import OWNER, owner_alive
    owner = trial.user_attrs.get(OWNER)
    return owner is not None and owner_alive(owner) is False


#: a waiting claimant spends about 1/POLL_SHARE of its wait reading the storage
POLL_SHARE = 10.0


def claim(trial, label: str, *, wait_s: float = 600.0, poll_s: float = 0.5):
    """Claim the set `label` for the running `trial` (an optuna Trial).

    Returns the finished trial whose record `trial` takes, or None when
    `trial` simulates the set itself (also when the claimant ahead has not
    finished within `wait_s` seconds, or its process is known to be dead).

    While a claimant ahead simulates the set, this worker's core is idle, so
    it reads the storage again after a pause of POLL_SHARE times the last
    read (at least 10 ms, at most `poll_s` [s]): on a journal file, whose
    reads take milliseconds, it notices the record within tens of
    milliseconds; on a database, whose reads of all trials take about a
    tenth of a second, every `poll_s`."""
    import optuna
    study = trial.study
    trial.set_user_attr("modeset", label)                                   # 1. choosing
    others = [t for t in study.get_trials(deepcopy=False)
              if t.number != trial.number and t.user_attrs.get("modeset") == label]
    ticket = 1 + max((int(t.user_attrs.get("ticket", 0)) for t in others), default=0)
    trial.set_user_attr("ticket", ticket)                                   # 2. ticket
    mine = (ticket, trial.number)
    deadline = time.monotonic() + wait_s
    while True:                                                             # 3. wait for those ahead
        read = time.monotonic()
        rivals = _claims(study, trial, label)
        read = time.monotonic() - read
        finished = [t for t in rivals if t.state != optuna.trial.TrialState.RUNNING]
        if finished:
            return finished[0]
        ahead = [t for t in rivals if not _dead(t) and
                 ("ticket" not in t.user_attrs or (int(t.user_attrs["ticket"]), t.number) < mine)]
        if not ahead or time.monotonic() > deadline:
            return None
        time.sleep(min(poll_s, max(0.01, POLL_SHARE * read)))
