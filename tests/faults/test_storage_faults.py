"""Torn and damaged journals, emptied storage, stale locks, hostile names and
the last bad inputs of issue 13: each gives one line (exit code 2 for a bad
input), never a traceback, never a silent restart; nothing is written outside
the output folder. In-process `modesel` on the fake problem of test_search.py."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import optuna
import pandas as pd
import pytest

import modesel.study.search.engine
from modesel.cli import main
from modesel.study.search.storage import FlockLock, scan_journal, sqlalchemy_url
from test_search import FAKE_ENGINE, make_study

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def fake_engine(monkeypatch):
    monkeypatch.setattr(modesel.study.search.engine, "default_engine", lambda: FAKE_ENGINE)


def one_line(capsys, argv, code=2):
    """Run `modesel argv`; assert the exit code and return the one stderr line."""
    assert main(argv) == code
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.fixture
def finished(tmp_path, capsys):
    """A study of 8 sets run to its end: (study file, output folder)."""
    study = make_study(tmp_path, n_trials=8, tower_families='["test_exact"]')
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out)]) == 0
    capsys.readouterr()
    return study, out


def complete_sets(out: Path) -> dict:
    """{mode-set label: values} of the trials that simulated a set and completed."""
    from optuna.storages.journal import JournalFileBackend
    storage = optuna.storages.JournalStorage(JournalFileBackend(str(out / "study.journal")))
    trials = optuna.load_study(study_name="fake", storage=storage).get_trials(deepcopy=False)
    return {t.user_attrs["modeset"]: tuple(t.values) for t in trials
            if t.state == optuna.trial.TrialState.COMPLETE and "duplicate_of" not in t.user_attrs}


def record_ends(data: bytes) -> list:
    return [i + 1 for i, b in enumerate(data) if b == 0x0A]


# --------------------------------------------------------------------------- journal damage

def test_torn_tail_is_cut_back_kept_as_backup_and_resumed(finished, capsys):
    study, out = finished
    journal = out / "study.journal"
    before = complete_sets(out)
    data = journal.read_bytes()
    journal.write_bytes(data[:-100])                 # a crash mid-write: the last record cut
    assert main(["run", str(study), "--out", str(out), "--n-trials", "2"]) == 0
    err = capsys.readouterr().err
    assert "Traceback" not in err
    notes = [ln for ln in err.splitlines() if "damaged tail" in ln]
    last_end = record_ends(data[:-100])[-1]
    assert len(notes) == 1 and f"dropped {len(data) - 100 - last_end} bytes" in notes[0], err
    backups = list(out.glob("study.journal.damaged-*"))
    assert len(backups) == 1 and backups[0].read_bytes() == data[:-100]
    after = complete_sets(out)
    lost = set(before) - set(after)
    assert len(lost) <= 1                             # only the trial whose record was cut
    assert all(after[k] == v for k, v in before.items() if k in after)
    assert scan_journal(journal.read_bytes())[2] is None          # sound again


def test_nul_bytes_at_the_end_are_a_damaged_tail(finished, capsys):
    study, out = finished
    journal = out / "study.journal"
    with open(journal, "ab") as fh:
        fh.write(b"\0" * 500)
    assert main(["run", str(study), "--out", str(out), "--n-trials", "1"]) == 0
    err = capsys.readouterr().err
    assert "dropped 500 bytes" in err and "Traceback" not in err


@pytest.mark.parametrize("command", ["run", "report"])
def test_damage_in_the_middle_is_one_line_with_the_byte_offset(finished, capsys, command):
    study, out = finished
    journal = out / "study.journal"
    data = journal.read_bytes()
    at = record_ends(data)[3]
    journal.write_bytes(data[:at + 10] + b"\0" * 500 + data[at + 10:])
    argv = ["run", str(study), "--out", str(out)] if command == "run" else ["report", str(out)]
    line = one_line(capsys, argv)
    assert str(journal) in line and f"byte {at}" in line and "corrupted in the middle" in line
    assert journal.read_bytes()[at + 10:at + 510] == b"\0" * 500          # left as it was


def test_cut_at_a_record_boundary_is_not_silent(finished, capsys):
    study, out = finished
    journal = out / "study.journal"
    data = journal.read_bytes()
    ends = record_ends(data)
    journal.write_bytes(data[:ends[len(ends) // 2]])
    assert main(["run", str(study), "--out", str(out), "--n-trials", "1"]) == 0
    err = capsys.readouterr().err
    assert "complete trials that the storage no longer holds" in err and "Traceback" not in err


@pytest.mark.parametrize("emptied", [b"", b"{\"op_co"])
def test_emptied_journal_beside_results_is_refused(finished, capsys, emptied):
    study, out = finished
    (out / "study.journal").write_bytes(emptied)
    line = one_line(capsys, ["run", str(study), "--out", str(out)])
    assert "study.journal" in line and "trials.csv lists" in line
    assert len(pd.read_csv(out / "trials.csv", header=[0, 1]).droplevel(1, axis=1)) == 8                  # the results are untouched


def test_missing_journal_beside_results_is_refused(finished, capsys):
    study, out = finished
    (out / "study.journal").unlink()
    line = one_line(capsys, ["run", str(study), "--out", str(out)])
    assert "missing or empty" in line


# --------------------------------------------------------------------------- locks

def test_stale_optuna_lock_file_does_not_delay_the_next_run(finished, capsys):
    study, out = finished
    os.symlink(out / "study.journal", out / "study.journal.lock")   # as a killed Optuna writer leaves it
    start = time.monotonic()
    assert main(["run", str(study), "--out", str(out), "--n-trials", "1"]) == 0
    assert time.monotonic() - start < 20.0          # Optuna's grace period alone is 30 s
    assert not (out / "study.journal.lock").exists()


def test_the_journal_lock_dies_with_its_process(tmp_path):
    journal = tmp_path / "study.journal"
    journal.write_bytes(b"")
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time; from modesel.study.search.storage import FlockLock; "
         f"FlockLock({str(journal)!r}).acquire(); print('held', flush=True); time.sleep(60)"],
        env=dict(os.environ, PYTHONPATH=str(REPO)), stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "held"
    import fcntl
    probe = os.open(journal, os.O_RDWR)
    with pytest.raises(BlockingIOError):
        fcntl.flock(probe, fcntl.LOCK_EX | fcntl.LOCK_NB)            # held by the live process
    holder.send_signal(signal.SIGKILL)
    holder.wait()
    fcntl.flock(probe, fcntl.LOCK_EX | fcntl.LOCK_NB)                # free at once after kill -9
    os.close(probe)
    lock = FlockLock(str(journal))
    with lock:
        pass


# --------------------------------------------------------------------------- names and paths

@pytest.mark.parametrize("name", ["../../../evil", "", "a/b", "..", "x\\y", ".hidden", "a b", "x" * 101])
def test_hostile_study_name_is_refused(tmp_path, capsys, name):
    study = make_study(tmp_path, n_trials=2, tower_families='["test_exact"]')
    study.write_text(study.read_text().replace('name = "fake"', f"name = {json.dumps(name)}"))
    line = one_line(capsys, ["run", str(study), "--out", str(tmp_path / "out")])
    assert str(study) in line and "study.name" in line
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_hostile_scene_name_is_refused(tmp_path, capsys):
    study = make_study(tmp_path, n_trials=2, tower_families='["test_exact"]')
    study.write_text(study.read_text().replace('path = "scene.toml"', 'path = "scene.toml"\nname = "../x"'))
    line = one_line(capsys, ["run", str(study), "--out", str(tmp_path / "out")])
    assert "scene[0].name" in line


def test_every_file_a_run_writes_stays_in_the_output_folder(tmp_path, capsys):
    work = tmp_path / "work"
    work.mkdir()
    study = make_study(work, n_trials=3, tower_families='["test_exact"]')
    before = {p for p in tmp_path.rglob("*")}
    out = work / "out"
    assert main(["run", str(study), "--out", str(out)]) == 0
    new = {p for p in tmp_path.rglob("*")} - before
    assert new and all(p == out or out in p.parents for p in new), sorted(new)


# --------------------------------------------------------------------------- resource limits and the rest

def _scene(tmp_path, **values) -> Path:
    text = (REPO / "studies" / "scenes" / "paper_2dof_tower_shaft.toml").read_text()
    lines = [ln for ln in text.splitlines() if not ln.split("=")[0].strip() in values]
    path = tmp_path / "scene.toml"
    path.write_text("".join(f"{k} = {v}\n" for k, v in values.items()) + "\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("values, field, words", [
    ({"tmax": "1e9", "dt": "1.0"}, "tmax/dt", "output rows"),
    ({"tmax": "10.0", "dt": "1e-9"}, "tmax/dt", "output rows"),
    ({"tmax": "1.0", "dt": "2.0"}, "dt", "larger than tmax"),
])
def test_time_grid_beyond_budget_is_refused_up_front(tmp_path, capsys, values, field, words):
    scene = _scene(tmp_path, **values)
    start = time.monotonic()
    line = one_line(capsys, ["simulate", str(scene), "--out", str(tmp_path / "x.csv")])
    assert f"{scene}: {field}:" in line and words in line
    assert time.monotonic() - start < 10.0


def test_time_grid_override_on_the_command_line_is_refused(tmp_path, capsys):
    scene = REPO / "studies" / "scenes" / "paper_2dof_tower_shaft.toml"
    line = one_line(capsys, ["simulate", str(scene), "--dt", "1e-9", "--out", str(tmp_path / "x.csv")])
    assert "tmax/dt" in line and "output rows" in line


def test_study_time_grid_beyond_budget_names_the_study_field(tmp_path, capsys):
    study = make_study(tmp_path, n_trials=2, tower_families='["test_exact"]')
    study.write_text(study.read_text().replace('path = "scene.toml"', 'path = "scene.toml"\ntmax = 1e9\ndt = 1.0'))
    line = one_line(capsys, ["run", str(study), "--out", str(tmp_path / "out")])
    assert f"{study}: scene[0].tmax/dt:" in line


def test_unknown_turbine_names_the_scene_file_and_field(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text('turbine = "nrel15mw"\n')
    line = one_line(capsys, ["simulate", str(scene), "--out", str(tmp_path / "x.csv")])
    assert line.startswith(f"modesel: error: {scene}: turbine: 'nrel15mw'") and "nrel5mw" in line


def test_report_with_unknown_storage_scheme_is_one_line_without_warning(finished, capsys):
    _, out = finished
    line = one_line(capsys, ["report", str(out), "--storage", "foo://bar"])
    assert line.startswith("modesel: error: foo://bar: cannot open storage")


def test_plain_postgresql_url_names_an_installed_driver():
    import importlib.util
    url = sqlalchemy_url("postgresql://user@127.0.0.1:5432/db")
    from sqlalchemy.engine import make_url
    driver = make_url(url).get_dialect().driver
    if importlib.util.find_spec("psycopg2") is None and importlib.util.find_spec("psycopg") is None:
        pytest.skip("no PostgreSQL driver installed")
    assert importlib.util.find_spec(driver) is not None, url
    assert url.endswith("user@127.0.0.1:5432/db")
    assert sqlalchemy_url("sqlite:///x.db") == "sqlite:///x.db"


# --------------------------------------------------------------------------- trial owners

def _dead_owner() -> str:
    from modesel.study.search.owners import process_owner
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(0.2)"])
    owner = process_owner(proc.pid, run="gone")
    proc.wait()
    return owner


def _shared_study(tmp_path):
    """A journal used as a shared storage (not an output folder's own)."""
    from modesel.study.search.storage import open_storage, open_study
    from modesel.study.spec import load_study
    study = load_study(make_study(tmp_path, n_trials=4, tower_families='["test_exact"]'))
    storage = open_storage(str(tmp_path / "shared.journal"))
    return study, storage, open_study(study, str(tmp_path / "shared.journal"), storage=storage)


def test_rerun_requeues_dead_trials_once_and_leaves_live_ones(tmp_path):
    from modesel.study.search.space import SearchSpace
    from modesel.study.search.owners import OWNER, process_owner
    from modesel.study.search.storage import requeue_interrupted
    study, storage, opt = _shared_study(tmp_path)
    space = SearchSpace(study.search)
    live, dead = opt.ask(), opt.ask()
    for trial, owner in ((live, process_owner(run="live")), (dead, _dead_owner())):
        space.suggest(trial)
        trial.set_user_attr(OWNER, owner)
    assert requeue_interrupted(opt, storage) == 1
    assert requeue_interrupted(opt, storage) == 0                      # once, not at every rerun
    TS = optuna.trial.TrialState
    trials = opt.get_trials(deepcopy=False)
    assert trials[live.number].state == TS.RUNNING                   # its process lives: left to it
    assert trials[dead.number].state == TS.FAIL and trials[dead.number].user_attrs["fail_reason"] == "interrupted"
    waiting = [t for t in trials if t.state == TS.WAITING]
    assert len(waiting) == 1
    again = opt.ask()                                                  # takes the queued trial
    space.suggest(again)
    assert again.number == waiting[0].number and again.params == trials[dead.number].params


def test_a_claim_held_by_a_dead_process_is_not_waited_for(tmp_path):
    from modesel.study.search.claims import claim
    from modesel.study.search.owners import OWNER
    _, _, opt = _shared_study(tmp_path)
    gone, mine = opt.ask(), opt.ask()
    for key, value in ((OWNER, _dead_owner()), ("modeset", "tower_fa=test_exact:1"), ("ticket", 1)):
        gone.set_user_attr(key, value)
    start = time.monotonic()
    assert claim(mine, "tower_fa=test_exact:1", wait_s=60.0) is None     # simulates it itself
    assert time.monotonic() - start < 5.0
