"""Where the study's trials are kept, and what a resumed study queues first.

By default an Optuna journal file ``study.journal`` in the output folder
(safe for several processes; a study resumes from it without repeating
finished trials, and trials an interruption cut short are queued again); or
any SQLAlchemy URL (``sqlite:///x.db``, ``postgresql://user@host/db``) so
that several machines run `modesel worker` on one study. Only Optuna's
public API is used: a storage's methods and `Study.tell`.

Faults (issue 13):

- the journal is checked before Optuna reads it (`check_journal`): a torn
  or damaged tail (a crash mid-write) is cut back to the last complete
  record after a copy of the damaged file is kept (one line says what was
  dropped); damage followed by valid records is a one-line error naming the
  byte offset; an emptied journal beside a trials.csv is refused;
- the journal lock is an `flock` (`FlockLock`) that dies with its process, so
  a killed run leaves no lock file that delays the next one;
- each running trial names its process (user attribute ``owner``:
  host:pid:start time:run); a rerun marks the RUNNING trials of dead processes
  interrupted and queues their sets again once, and leaves the trials of live
  processes alone. On RDB storages a heartbeat does the same for other
  machines (`RetryFailedTrialCallback`, one retry).
"""
from __future__ import annotations

import functools
import json
import os
import re
import shutil
import sys
import time
from pathlib import Path

from modesel.errors import ModeselError
from modesel.study.search.claims import INTERRUPTED, distinct_sets, interrupted
from modesel.study.search.space import SearchSpace

DIRECTIONS = ("minimize", "minimize")   # (error, cost)
JOURNAL_NAME = "study.journal"


def mask_url(url: str) -> str:
    return re.sub(r"//([^:/@]+):[^@]*@", r"//\1:***@", str(url))


def default_storage(out_dir) -> str:
    return str(Path(out_dir).resolve() / JOURNAL_NAME)


def _say(msg: str) -> None:
    print(f"modesel: {msg}", file=sys.stderr)


def quiet_optuna() -> None:
    """Optuna's log and experimental-feature warnings off (modesel says what matters in one line)."""
    import logging
    import warnings

    import optuna
    optuna.logging.set_verbosity(logging.ERROR)
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)


def sqlalchemy_url(url: str) -> str:
    """`url` with a driver SQLAlchemy can import: a plain ``postgresql://``
    names no driver and SQLAlchemy picks its default (psycopg 3 in
    SQLAlchemy 2.1, psycopg2 before); when that one is not installed and the
    other is, the URL names the installed one (``postgresql+psycopg2://``)."""
    import importlib.util
    scheme, sep, rest = url.partition("://")
    if scheme != "postgresql":
        return url
    try:
        from sqlalchemy.engine import make_url
        preferred = make_url(url).get_dialect().driver
    except Exception:   # noqa: BLE001 (SQLAlchemy too old or odd URL: let it report)
        return url
    drivers = [preferred] + [d for d in ("psycopg2", "psycopg") if d != preferred]
    for driver in drivers:
        if importlib.util.find_spec(driver) is not None:
            return url if driver == preferred else f"postgresql+{driver}{sep}{rest}"
    return url


def _retry_once() -> dict:
    """The RDBStorage argument that queues a heartbeat-stale trial again once
    (Optuna >= 4.9 renamed the callback and its argument)."""
    import optuna
    if hasattr(optuna.storages, "RetryHeartbeatStaleTrialCallback"):
        return {"heartbeat_stale_trial_callback": optuna.storages.RetryHeartbeatStaleTrialCallback(max_retry=1)}
    return {"failed_trial_callback": optuna.storages.RetryFailedTrialCallback(max_retry=1)}


def _schema_race(exc) -> bool:
    """Whether `exc` is the loser's error when two workers create the schema
    of an empty database at once (a unique violation, or PostgreSQL's
    DuplicateTable "relation ... already exists"): it retries and finds the
    tables made."""
    import sqlalchemy.exc
    return isinstance(exc, sqlalchemy.exc.IntegrityError) or (
        isinstance(exc, sqlalchemy.exc.ProgrammingError) and "already exists" in str(exc))


def open_storage(url, *, log=None):
    """An Optuna storage for `url`: a SQLAlchemy URL ('scheme://...') gives an
    RDB storage (with heartbeats, so the trials of a dead worker are failed
    and queued again once), any other string is a journal file path (checked
    and repaired by `check_journal`; `log` gets its one-line notes); an open
    storage is returned as is."""
    import optuna
    if isinstance(url, optuna.storages.BaseStorage):   # already open
        return url
    quiet_optuna()
    if "://" in url:
        import sqlalchemy.exc
        for attempt in range(5):
            try:
                return optuna.storages.RDBStorage(sqlalchemy_url(url), heartbeat_interval=20,
                                                  grace_period=60, **_retry_once())
            except (ImportError, ValueError, sqlalchemy.exc.SQLAlchemyError, OSError) as exc:
                if _schema_race(exc):
                    time.sleep(0.2 * (attempt + 1))
                    continue
                msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
                raise ModeselError(f"cannot open storage: {msg}", file=mask_url(url)) from None
        raise ModeselError("cannot open storage: schema creation kept conflicting", file=mask_url(url))
    path = Path(url)
    if not path.parent.is_dir():
        raise ModeselError("storage folder does not exist", file=url)
    try:
        lock = FlockLock(str(path))
        legacy = Path(str(path) + ".lock")      # Optuna's own lock file, left by a killed process
        if legacy.is_symlink() or legacy.is_file():
            legacy.unlink(missing_ok=True)      # modesel locks with flock: nobody holds this one
        with lock:
            check_journal(path, log=log or _say)
        return optuna.storages.JournalStorage(JournalBackend(str(path), lock))
    except OSError as exc:
        raise ModeselError(f"cannot open storage: {exc.strerror}", file=url) from None


# --------------------------------------------------------------------------- journal integrity

class FlockLock:
    """The journal's writer lock for Optuna's `JournalFileBackend(lock_obj=)`:
    an exclusive `flock` on the journal file itself. The kernel releases it
    when its process dies (even by kill -9), so no stale lock file is left to
    delay the next run. One open file per acquisition, so threads of one
    process exclude each other too."""

    def __init__(self, path: str):
        self.path = path
        self._fd = None

    def acquire(self) -> bool:
        import fcntl
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_APPEND, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
        except BaseException:
            os.close(fd)
            raise
        self._fd = fd
        return True

    @property
    def fd(self) -> int:
        """The locked journal file, open for appending (while acquired)."""
        return self._fd

    def release(self) -> None:
        fd, self._fd = self._fd, None
        if fd is not None:
            os.close(fd)                      # closing the file releases the flock

    def __enter__(self):
        self.acquire()
        return self

    def __exit__(self, *exc):
        self.release()


def _needs_sync(record: dict) -> bool:
    """Whether a journal record must be on disk (fsync) before its writer goes
    on: records that finish or queue a trial and study-level records. The
    details of a running trial (its parameters, user attributes, start) are
    not synced one by one: the record that finishes the trial syncs them with
    it, and a running trial lost with the machine is queued again anyway."""
    from optuna.trial import TrialState
    running = TrialState.RUNNING.value
    if "trial_id" in record:                    # a running trial's parameter, attribute or state
        return record.get("state", running) != running
    if "state" in record:                       # a trial created in a given state (queued, told)
        return record["state"] != running
    return "datetime_start" not in record       # not a trial started by ask: a study record


@functools.lru_cache(maxsize=None)
def _journal_backend_class():
    from optuna.storages.journal import JournalFileBackend

    class _Backend(JournalFileBackend):
        """Optuna's journal file backend with a cheaper append: one write
        through the locked file (`FlockLock`), and one fsync per finished
        trial (`_needs_sync`), made after the lock is released so that
        other workers do not wait on the disk. Optuna's own backend syncs
        every record under the lock: ~15 records per trial at ~6 ms each on
        the development machine's disk, serialised across all workers. A
        process killed (even by SIGKILL) loses nothing written: the kernel
        holds it; a torn record is repaired by `check_journal`."""

        def __init__(self, path: str, lock: FlockLock):
            super().__init__(path, lock_obj=lock)
            self.modesel_path = path
            self.modesel_lock = lock

        def append_logs(self, logs: list) -> None:
            data = ("\n".join(json.dumps(log, separators=(",", ":")) for log in logs) + "\n").encode("utf-8")
            with self.modesel_lock as lock:
                view = memoryview(data)
                while view:                     # O_APPEND: every write goes to the end
                    view = view[os.write(lock.fd, view):]
            if any(_needs_sync(log) for log in logs):
                fd = os.open(self.modesel_path, os.O_RDONLY)
                try:
                    os.fsync(fd)
                finally:
                    os.close(fd)

    return _Backend


def JournalBackend(path: str, lock: FlockLock):
    """The journal backend of `open_storage` (see `_journal_backend_class`)."""
    return _journal_backend_class()(path, lock)


def _is_record(line: bytes) -> bool:
    try:
        data = json.loads(line)
    except (ValueError, UnicodeDecodeError):
        return False
    return isinstance(data, dict) and isinstance(data.get("op_code"), int)


def scan_journal(data: bytes) -> tuple:
    """(records, end, bad_at, later) of journal bytes: the number of complete
    records before the first damaged one, the byte where they end, the byte
    offset of the first damaged line (None when all are sound; a last line
    without its newline counts as damaged) and the number of sound records
    after it."""
    records, end, bad_at, later, pos = 0, 0, None, 0, 0
    while pos < len(data):
        nl = data.find(b"\n", pos)
        stop = len(data) if nl < 0 else nl + 1
        sound = nl >= 0 and _is_record(data[pos:stop])
        if bad_at is None:
            if sound:
                records, end = records + 1, stop
            else:
                bad_at = pos
        elif sound:
            later += 1
        pos = stop
    return records, end, bad_at, later


def check_journal(path, *, log=_say) -> int:
    """Check the journal file `path` before Optuna reads it (call with the
    journal lock held, so no write is in progress). Damage with sound records
    after it is a ModeselError naming the byte offset. A damaged tail (a
    record cut by a crash, garbage after the last record) is cut off after
    the file is copied to ``<name>.damaged-<time>``, and `log` gets one line
    saying what was dropped. Returns the number of records kept."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return 0
    records, end, bad_at, later = scan_journal(data)
    if bad_at is None:
        return records
    if later:
        raise ModeselError(
            f"damaged record at byte {bad_at} of {len(data)} ({later} sound records follow it): the "
            f"journal is corrupted in the middle and cannot be resumed; restore it from a backup "
            f"or use another output folder", file=str(path))
    backup = path.with_name(f"{path.name}.damaged-{time.strftime('%Y%m%d-%H%M%S')}")
    n = 1
    while backup.exists():
        backup = path.with_name(f"{path.name}.damaged-{time.strftime('%Y%m%d-%H%M%S')}-{n}")
        n += 1
    shutil.copyfile(path, backup)
    dropped = data[end:]
    pieces = dropped.count(b"\n") + (0 if dropped.endswith(b"\n") else 1)
    with open(path, "r+b") as fh:
        fh.truncate(end)
        fh.flush()
        os.fsync(fh.fileno())
    log(f"{path}: damaged tail: dropped {len(dropped)} bytes ({pieces} incomplete or damaged "
        f"record{'s' if pieces != 1 else ''}) after record {records} at byte {end}; resuming from "
        f"the last complete record; the damaged file is kept as {backup.name}")
    return records


def results_rows(out_dir) -> dict:
    """{trial number: status} of the trials.csv in `out_dir` (empty when there is none)."""
    import csv
    path = Path(out_dir) / "trials.csv"
    try:
        with open(path, newline="") as fh:
            return {int(row["trial"]): row.get("status", "") for row in csv.DictReader(fh)
                    if str(row.get("trial", "")).strip().isdigit()}
    except (OSError, KeyError, ValueError, csv.Error):
        return {}


def check_against_results(path, out_dir) -> None:
    """Refuse a journal that is empty (or holds no study) while the
    trials.csv written from it in `out_dir` lists trials: starting a new
    study there would silently drop them."""
    rows = results_rows(out_dir)
    if not rows:
        return
    try:
        empty = not any(_is_record(line) for line in Path(path).read_bytes().splitlines(keepends=True)[:1])
    except FileNotFoundError:
        empty = True
    if empty:
        raise ModeselError(
            f"the journal is missing or empty but {Path(out_dir) / 'trials.csv'} lists {len(rows)} trials "
            f"of it: the storage was lost; restore it, or remove trials.csv (or use another --out) to "
            f"start a new study", file=str(path))


def note_lost_trials(opt, out_dir, log) -> int:
    """One line when trials that trials.csv lists as COMPLETE are no longer
    complete in the storage (records lost, e.g. a journal cut at a record
    boundary): their sets will be evaluated again. Returns how many."""
    import optuna
    rows = results_rows(out_dir)
    complete = {t.number for t in opt.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,))}
    lost = sorted(n for n, status in rows.items() if status == "COMPLETE" and n not in complete)
    if lost:
        log(f"{Path(out_dir) / 'trials.csv'} lists {len(lost)} complete trials that the storage no "
            f"longer holds (records lost, first: trial {lost[0]}); their sets are evaluated again "
            f"when proposed")
    return len(lost)


# --------------------------------------------------------------------------- trial owners

from modesel.study.search.owners import OWNER, STALE_UNOWNED_S, owner_alive  # noqa: E402


def dead_running_trials(opt, *, private: bool = False) -> list:
    """RUNNING trials whose process is gone: its owner (on this host) is dead,
    or it never named one (a process killed between creating the trial and
    naming itself, or a modesel before owners) and either the storage is
    `private` (the output folder's own journal) or it started more than
    STALE_UNOWNED_S ago."""
    import datetime

    import optuna
    dead = []
    now = datetime.datetime.now()
    for t in opt.get_trials(deepcopy=False, states=(optuna.trial.TrialState.RUNNING,)):
        owner = t.user_attrs.get(OWNER)
        if owner is not None:
            if owner_alive(owner) is False:
                dead.append(t)
        elif private or t.datetime_start is None or \
                (now - t.datetime_start).total_seconds() > STALE_UNOWNED_S:
            dead.append(t)
    return dead


def open_study(study, storage_url, sampler=None, *, create: bool = True, storage=None):
    """Create or load the Optuna study named after `study` in `storage_url`
    (a URL/path or an open storage; `storage`: the storage it names, when
    already open) and check that it was made from the same study definition
    (`Study.fingerprint`)."""
    import optuna
    storage = open_storage(storage if storage is not None else storage_url)
    storage_url = getattr(storage_url, "url", None) or str(storage_url)
    try:
        if create:
            opt = optuna.create_study(study_name=study.name, storage=storage, sampler=sampler,
                                      directions=list(DIRECTIONS), load_if_exists=True)
        else:
            opt = optuna.load_study(study_name=study.name, storage=storage, sampler=sampler)
    except KeyError:
        raise ModeselError(f"no study named '{study.name}' in this storage; start it with "
                           f"`modesel run` or `modesel worker`", file=mask_url(storage_url)) from None
    except ValueError as exc:
        raise ModeselError(f"cannot use study '{study.name}': {exc}", file=mask_url(storage_url)) from None
    if len(opt.directions) != len(DIRECTIONS):
        raise ModeselError(f"study '{study.name}' in this storage is not an (error, cost) study",
                           file=mask_url(storage_url))
    found = opt.user_attrs.get("fingerprint")
    if found is None and create:
        opt.set_user_attr("fingerprint", study.fingerprint())
        opt.set_user_attr("study_file", str(study.path))
        opt.set_user_attr("channels", list(study.compare.channels))
        opt.set_user_attr("metric", study.compare.metric)
    elif found is not None and found != study.fingerprint():
        raise ModeselError(
            f"study '{study.name}' in this storage was made from a different definition (scenes, "
            f"reference, channels, metric or search space changed); use another output folder, "
            f"storage or [study] name", file=mask_url(storage_url))
    return opt


def fail_interrupted(opt, storage, number: int) -> None:
    """Mark the RUNNING trial `number` of `opt` (kept in the open `storage`)
    FAIL with fail_reason 'interrupted'."""
    import optuna
    study_id = storage.get_study_id_from_name(opt.study_name)
    storage.set_trial_user_attr(storage.get_trial_id_from_study_id_trial_number(study_id, number),
                                "fail_reason", INTERRUPTED)
    opt.tell(number, state=optuna.trial.TrialState.FAIL)


def requeue_interrupted(opt, storage, *, private: bool = False) -> int:
    """Queue again the sets whose trials an interruption cut short. RUNNING
    trials whose process is dead (`dead_running_trials`; `private`: the
    output folder's own journal) are first marked
    FAIL 'interrupted'; those of live processes are left to them. Each interrupted trial is
    considered once (study user attribute ``requeued``); its set is not
    queued when it has been evaluated since or is queued already (the copy
    would only repeat it). Returns how many were queued."""
    import optuna
    TS = optuna.trial.TrialState
    for t in dead_running_trials(opt, private=private):
        try:
            fail_interrupted(opt, storage, t.number)
        except (optuna.exceptions.UpdateFinishedTrialError, RuntimeError, ValueError):
            pass                # finished meanwhile (its process was alive after all)
    before = set(opt.user_attrs.get("requeued", []))
    retried, evaluated, seen = set(before), distinct_sets(opt), set()
    queued = 0
    for t in opt.get_trials(deepcopy=False, states=(TS.FAIL,)):
        if not interrupted(t) or t.number in retried or not t.params:
            continue
        retried.add(t.number)
        key = tuple(sorted(t.params.items()))
        if t.user_attrs.get("modeset") in evaluated or key in seen:
            continue          # evaluated since, or queued already: a copy would only be a repeat
        seen.add(key)
        opt.enqueue_trial(t.params, skip_if_exists=False)
        queued += 1
    if retried != before:
        opt.set_user_attr("requeued", sorted(retried))
    return queued


def queue_baseline(opt, study, scenes: dict) -> bool:
    """On a new study, queue the first scene's default mode set (restricted to
    the searched fields) as trial 0 when it lies in the search space, so the
    results show what the default costs and how far off it is."""
    if opt.get_trials(deepcopy=False):
        return False
    default = getattr(scenes[study.scenes[0].name], "default_modeset", None)
    space = SearchSpace(study.search)
    if default is None or not space.contains(default):
        return False
    opt.enqueue_trial(space.params(default))
    return True
