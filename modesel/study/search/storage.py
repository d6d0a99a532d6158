"""Where the study's trials are kept, and what a resumed study queues first.

By default an Optuna journal file ``study.journal`` in the output folder
(safe for several processes; a study resumes from it without repeating
finished trials, and trials an interruption cut short are queued again); or
any SQLAlchemy URL (``sqlite:///x.db``, ``postgresql://user@host/db``) so
that several machines run `modesel worker` on one study. Only Optuna's
public API is used: a storage's methods and `Study.tell`.
"""
from __future__ import annotations

import re
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


def open_storage(url):
    """An Optuna storage for `url`: a SQLAlchemy URL ('scheme://...') gives an
    RDB storage (with heartbeats so trials of a dead worker are failed), any
    other string is a journal file path; an open storage is returned as is."""
    import optuna
    if isinstance(url, optuna.storages.BaseStorage):   # already open
        return url
    if "://" in url:
        import time
        import sqlalchemy.exc
        for attempt in range(5):
            try:
                return optuna.storages.RDBStorage(url, heartbeat_interval=60, grace_period=180)
            except sqlalchemy.exc.IntegrityError:
                # two workers creating the schema of an empty database at once:
                # one wins, the other retries and finds the tables made
                time.sleep(0.2 * (attempt + 1))
            except (ImportError, ValueError, sqlalchemy.exc.SQLAlchemyError, OSError) as exc:
                msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
                raise ModeselError(f"cannot open storage: {msg}", file=mask_url(url)) from None
        raise ModeselError("cannot open storage: schema creation kept conflicting", file=mask_url(url))
    path = Path(url)
    if not path.parent.is_dir():
        raise ModeselError("storage folder does not exist", file=url)
    try:
        from optuna.storages.journal import JournalFileBackend
        return optuna.storages.JournalStorage(JournalFileBackend(str(path)))
    except OSError as exc:
        raise ModeselError(f"cannot open storage: {exc.strerror}", file=url) from None


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


def requeue_interrupted(opt, storage, *, fail_running: bool) -> int:
    """Queue again the sets whose trials an interruption cut short. With
    `fail_running` (private storage: nothing else can be running) RUNNING
    trials are first marked FAIL 'interrupted'. Each interrupted trial is
    considered once (study user attribute ``requeued``); its set is not
    queued when it has been evaluated since or is queued already (the copy
    would only repeat it). Returns how many were queued."""
    import optuna
    TS = optuna.trial.TrialState
    if fail_running:
        for t in opt.get_trials(deepcopy=False, states=(TS.RUNNING,)):
            fail_interrupted(opt, storage, t.number)
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
