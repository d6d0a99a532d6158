"""What keeps parallel searches fast (issue 12, searches that scale): the
journal backend syncs the disk once per finished trial, outside the writer
lock, in Optuna's own journal format; forked workers report a death."""
import multiprocessing
import os
import signal

import optuna
import pytest

from modesel.study.search import runner, storage


def test_journal_syncs_once_per_finished_trial_and_stays_optuna_readable(tmp_path, monkeypatch):
    synced = []
    real_fsync = os.fsync
    monkeypatch.setattr(storage.os, "fsync", lambda fd: (synced.append(fd), real_fsync(fd))[1])
    path = tmp_path / "study.journal"
    study = optuna.create_study(study_name="s", storage=storage.open_storage(str(path)),
                                sampler=optuna.samplers.RandomSampler(seed=1))
    after_create = len(synced)

    def objective(trial):
        x = trial.suggest_int("x", 0, 9)
        for i in range(5):
            trial.set_user_attr(f"a{i}", i * x)
        return float(x)

    study.optimize(objective, n_trials=3)
    assert after_create == 1                       # the study's creation is synced
    assert len(synced) - after_create == 3         # one sync per finished trial, not per record
    records = path.read_bytes().count(b"\n")
    assert records >= 1 + 3 * 8                    # create, param, 5 attributes, state, finish

    plain = optuna.storages.JournalStorage(optuna.storages.journal.JournalFileBackend(str(path)))
    again = optuna.load_study(study_name="s", storage=plain).get_trials(deepcopy=False)
    assert [(t.params, t.values, t.user_attrs) for t in again] == \
        [(t.params, t.values, t.user_attrs) for t in study.get_trials(deepcopy=False)]


@pytest.mark.parametrize("record, sync", [
    ({"op_code": 0, "study_name": "s", "directions": [1]}, True),                  # study created
    ({"op_code": 2, "study_id": 0, "user_attr": {"k": 1}}, True),                 # study attribute
    ({"op_code": 4, "study_id": 0, "datetime_start": "t"}, False),                # trial started by ask
    ({"op_code": 4, "study_id": 0, "state": 4, "params": {}, "datetime_start": None}, True),   # queued
    ({"op_code": 5, "trial_id": 3, "param_name": "x"}, False),                    # parameter
    ({"op_code": 8, "trial_id": 3, "user_attr": {"k": 1}}, False),                # trial attribute
    ({"op_code": 6, "trial_id": 3, "state": 0, "values": None}, False),           # queued trial runs
    ({"op_code": 6, "trial_id": 3, "state": 1, "values": [0.1]}, True),           # complete
    ({"op_code": 6, "trial_id": 3, "state": 2, "values": None}, True),            # failed
])
def test_which_journal_records_are_synced(record, sync):
    assert storage._needs_sync(record) is sync


def _die():
    os.kill(os.getpid(), signal.SIGKILL)


def test_a_killed_worker_is_reported_in_one_line():
    ctx = multiprocessing.get_context("fork")
    mine, theirs = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_die)
    proc.start()
    theirs.close()
    [(error, owner)] = runner._wait_workers([runner._Worker(proc, mine)], poll=lambda: None)
    assert owner is None
    assert f"(pid {proc.pid}) was killed by signal {int(signal.SIGKILL)}" in error and "\n" not in error
