"""Fault injection (issue 13): `modesel run --n-jobs 2` killed with SIGKILL at
random instants, and its journal cut at random byte offsets, then resumed
each time. Checked after every fault: no process of the killed study
survives (its process group is empty), no complete trial is lost, no set is
simulated twice; at the end, the study holds the same evaluated sets with the
same values as an uninterrupted run.

The study is the fake problem of tests/test_search.py (25 discrete sets,
deterministic errors and costs), run in a subprocess through
tests/faults/fake_modesel.py so that a whole run takes seconds. The default
run kills 3 times and cuts 2 times; `-m slow` kills 20 more times (one kill in four during the start-up, the others
at a random instant up to 1.5 s after the first trial record of that run;
each run has a budget of 6 sets and each fake simulation takes 0.4 s, so the
kills land while sets are being simulated and the study progresses; once all
25 sets are in, a run serves its proposals from the record and ends, so only
the kills on runs with sets left must land) and cuts 8
more times (random instants and offsets from a fixed seed, printed).
"""
from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import optuna
import pandas as pd
import pytest

from test_search import make_study
from test_interrupt import terminal_sigint

REPO = Path(__file__).resolve().parents[2]
LAUNCHER = Path(__file__).with_name("fake_modesel.py")
N_SETS = 25                   # test_exact:1..5 for tower_fa and blade_flap
SIM_S = 0.4                   # wall seconds added to each fake simulation
PER_RUN = "6"                 # --n-trials of each run that is killed


def new_study(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    return make_study(folder, n_trials=40, tower_families='["test_exact"]')


def launch(study: Path, out: Path, *extra) -> subprocess.Popen:
    """`modesel run` in its own session (so its process group can be checked and cleaned)."""
    env = dict(os.environ, MODESEL_FAKE_SIM_S=str(SIM_S),
               PYTHONPATH=os.pathsep.join([str(REPO), str(REPO / "tests"), str(REPO / "tests" / "faults"),
                                           os.environ.get("PYTHONPATH", "")]))
    return subprocess.Popen([sys.executable, str(LAUNCHER), "run", str(study), "--out", str(out),
                             "--n-jobs", "2", *extra], cwd=study.parent, env=env, start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=terminal_sigint)


def group_members(pgid: int) -> list:
    """Live (not zombie) processes of process group `pgid`."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            fields = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] not in "ZX":
            found.append(int(entry))
    return found


def trial_records(out: Path) -> int:
    """Journal records that create or finish trials (op codes 4 and 6)."""
    path = out / "study.journal"
    if not path.exists():
        return 0
    data = path.read_bytes()
    return data.count(b'{"op_code":4,') + data.count(b'{"op_code":6,')


def kill_at(proc: subprocess.Popen, delay: float, out: Path | None = None) -> list:
    """SIGKILL the study process `delay` s after it starts writing trials
    (after `delay` s from its start when `out` is None), unless it ended
    first (then None); return the processes of its group still alive 3 s
    later (then kill them)."""
    if out is not None:                             # start-up (imports, references) is not the target
        before = trial_records(out)
        deadline = time.monotonic() + 120.0
        while trial_records(out) == before and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
    try:
        proc.communicate(timeout=delay)
        return None                                 # finished before the fault
    except subprocess.TimeoutExpired:
        pass
    os.kill(proc.pid, signal.SIGKILL)
    proc.communicate()
    return survivors(proc.pid)


def survivors(pgid: int, wait_s: float = 3.0) -> list:
    """Processes of group `pgid` still alive `wait_s` s after its leader ended
    (they are killed then, so that a failing test leaves none behind)."""
    deadline = time.monotonic() + wait_s
    while (alive := group_members(pgid)) and time.monotonic() < deadline:
        time.sleep(0.05)
    if alive:
        try:
            os.killpg(pgid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    return alive


def finish(proc: subprocess.Popen, timeout: float = 180.0) -> tuple:
    out, err = proc.communicate(timeout=timeout)
    assert "Traceback" not in err, err
    return proc.returncode, out, err


def trials(out: Path) -> list:
    from optuna.storages.journal import JournalFileBackend
    path = out / "study.journal"
    if not path.exists() or path.stat().st_size == 0:
        return []
    storage = optuna.storages.JournalStorage(JournalFileBackend(str(path)))
    try:
        return optuna.load_study(study_name="fake", storage=storage).get_trials(deepcopy=False)
    except KeyError:                               # killed before the study was created
        return []


def evaluated(all_trials) -> dict:
    """{label: values} of the trials that simulated their set and completed."""
    TS = optuna.trial.TrialState
    return {t.user_attrs["modeset"]: tuple(t.values) for t in all_trials
            if t.state == TS.COMPLETE and "duplicate_of" not in t.user_attrs}


def simulated_twice(all_trials) -> list:
    """Labels recorded by more than one trial that simulated it (not repeats,
    not trials cut short: a killed trial's set is simulated again, once)."""
    TS = optuna.trial.TrialState
    labels = [t.user_attrs["modeset"] for t in all_trials
              if "modeset_json" in t.user_attrs and "duplicate_of" not in t.user_attrs
              and (t.state == TS.COMPLETE or (t.state == TS.FAIL
                                              and t.user_attrs.get("fail_reason") != "interrupted"))]
    return sorted({x for x in labels if labels.count(x) > 1})


def run_to_the_end(study: Path, out: Path) -> dict:
    """Resume until every set is evaluated (a run stops at its budget)."""
    for _ in range(4):
        code, _, err = finish(launch(study, out))
        assert code == 0, err
        done = evaluated(trials(out))
        if len(done) == N_SETS:
            break
    assert not [t.number for t in trials(out) if t.state == optuna.trial.TrialState.RUNNING]
    assert not simulated_twice(trials(out))
    return done


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory) -> dict:
    folder = tmp_path_factory.mktemp("uninterrupted")
    done = run_to_the_end(new_study(folder), folder / "out")
    assert len(done) == N_SETS
    return done


def kill_cycle(tmp_path: Path, kills: int, seed: int, uninterrupted: dict) -> None:
    rng = random.Random(seed)
    study = new_study(tmp_path)
    out = tmp_path / "out"
    kept, report, landed, open_runs = {}, [], 0, 0
    for i in range(kills):
        # a kill can only land on a run that has sets left to simulate: once the
        # study holds all N_SETS, a run serves every proposal from the record and ends
        open_runs += len(kept) < N_SETS
        # one kill in four at a random instant of the start-up, the others while trials run
        early = i % 4 == 0
        delay = rng.uniform(0.2, 4.0) if early else rng.uniform(0.0, 1.5)
        survivors = kill_at(launch(study, out, "--n-trials", PER_RUN), delay, None if early else out)
        assert not survivors, f"kill {i} at {delay:.2f} s (seed {seed}): processes survived: {survivors}"
        landed += survivors is not None and len(kept) < N_SETS
        now = trials(out)
        done = evaluated(now)
        lost = {k for k in kept if k not in done or done[k] != kept[k]}
        assert not lost, f"kill {i} at {delay:.2f} s (seed {seed}): complete trials lost: {lost}"
        twice = simulated_twice(now)
        assert not twice, f"kill {i} at {delay:.2f} s (seed {seed}): simulated twice: {twice}"
        kept = done
        report.append(f"{'start+' if early else 'trials+'}{delay:.2f}s{'' if survivors is not None else '(ended)'}"
                      f":{len(done)}")
    print(f"kills on runs with sets left: {open_runs}, landed: {landed}; {' '.join(report)}")
    assert open_runs >= min(kills, 3) and landed >= 0.75 * open_runs, report    # the faults hit running studies
    final = run_to_the_end(study, out)
    assert all(final[k] == v for k, v in kept.items())
    assert final == uninterrupted                   # the same sets, the same values
    rows = pd.read_csv(out / "trials.csv", header=[0, 1]).droplevel(1, axis=1)
    assert not rows["modeset"].isna().any()         # no row without a mode set
    print(f"kills (seed {seed}; instant: complete sets after the kill): {' '.join(report)}")


def test_kill_9_three_times_loses_and_repeats_nothing(tmp_path, uninterrupted):
    kill_cycle(tmp_path, 3, 13, uninterrupted)


@pytest.mark.slow
def test_kill_9_twenty_times_loses_and_repeats_nothing(tmp_path, uninterrupted):
    kill_cycle(tmp_path, 20, 1313, uninterrupted)


def truncate_cycle(tmp_path: Path, cuts: int, seed: int, uninterrupted: dict) -> None:
    rng = random.Random(seed)
    study = new_study(tmp_path)
    out = tmp_path / "out"
    code, _, err = finish(launch(study, out, "--n-trials", "12"))
    assert code == 0, err
    for i in range(cuts):
        journal = out / "study.journal"
        data = journal.read_bytes()
        first_end = data.index(b"\n") + 1
        at = rng.randrange(first_end, len(data))      # keep the study's first record
        journal.write_bytes(data[:at])
        before = evaluated(trials(out))               # what the cut journal still holds whole
        boundary = data.rfind(b"\n", 0, at) + 1
        code, _, err = finish(launch(study, out, "--n-trials", "4"))
        assert code == 0, f"cut {i} at byte {at} (seed {seed}): {err}"
        notes = [ln for ln in err.splitlines() if "damaged tail" in ln]
        if boundary != at:
            assert len(notes) == 1 and f"dropped {at - boundary} bytes" in notes[0], err
            assert any(p.read_bytes() == data[:at] for p in out.glob("study.journal.damaged-*"))
        else:
            assert not notes, err
        after = evaluated(trials(out))
        assert all(after.get(k) == v for k, v in before.items()), f"cut {i} at byte {at}: lost"
        assert not simulated_twice(trials(out))
    assert run_to_the_end(study, out) == uninterrupted


def test_journal_cut_at_random_offsets_resumes_twice(tmp_path, uninterrupted):
    truncate_cycle(tmp_path, 2, 7, uninterrupted)


@pytest.mark.slow
def test_journal_cut_at_random_offsets_resumes_eight_times(tmp_path, uninterrupted):
    truncate_cycle(tmp_path, 8, 77, uninterrupted)


def test_sigint_to_the_process_group_leaves_no_row_without_a_mode_set(tmp_path):
    study = new_study(tmp_path)
    out = tmp_path / "out"
    proc = launch(study, out)
    deadline = time.monotonic() + 120
    while len(evaluated(trials(out))) < 3:
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGINT)                # Ctrl-C in a terminal reaches the whole group
    code, _, err = finish(proc)
    assert code == 130, err
    assert survivors(proc.pid) == []
    rows = pd.read_csv(out / "trials.csv", header=[0, 1]).droplevel(1, axis=1)
    failed = rows[rows["status"] == "FAIL"]
    assert not rows["modeset"].isna().any() and not failed["reason"].isna().any(), rows
    start = time.monotonic()                          # no stale lock delays the next run
    code, _, err = finish(launch(study, out, "--n-trials", "1"))
    assert code == 0, err
    assert time.monotonic() - start < 60.0
