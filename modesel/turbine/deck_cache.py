"""On-disk cache of parsed input decks (issue 12, fast start).

Reading an OpenFAST deck through openfast_io costs tens of milliseconds per
file in constant overhead (its reader copies the whole output-channel table
at every construction; the ElastoDyn layout is rebuilt from its writer), about
1 s for a full turbine. `cached(reader, path, *args, files=...)` stores what
`reader(path, *args)` returned, pickled, and returns the stored copy as long
as every file it came from is unchanged.

- Key: the reader's module and name, the resolved `path` and `args`.
  Validity: (resolved path, modification time in ns, size) of every file
  the value came from (`files(value)`, default: `path` alone), of the source
  files of the modules in `code` (the reader's module by default) and of
  openfast_io's reader module (a new openfast_io installs a new one; asking
  the installed distributions for its version scans them all, 7 ms). Any
  change reads the deck again.
- Place: `$MODESEL_CACHE_DIR/decks`; without it `$NUMBA_CACHE_DIR/modesel/decks`
  beside numba's own cache when that is set, else
  `$XDG_CACHE_HOME/modesel/decks` (default `~/.cache/modesel/decks`).
  `MODESEL_CACHE_DIR=off` switches the cache off.
- A cache that cannot be written or read (read-only home, a damaged entry)
  is skipped silently: the deck is read as without it. Errors of the reader
  (ModeselError for a bad deck) are never cached.
- A code module whose source changed after this module was imported (an
  upgrade or an edit while the process runs) may not be the code this
  process runs: while that is so, the cache is neither read nor written (a
  value pickled by the older code, stamped with the newer source, would be
  taken by every later process).
- Every call returns a fresh copy (unpickled), so callers may change it.
- At most `MAX_ENTRIES` entries: writing one more removes the older half.

`remembered(reader, path, ...)` also keeps the value in this process and
returns that same object again while the stamps of its files are those
taken when it was read (one `stat` per file and call): for a value its
callers do not change, read many times by one process (a search's trials,
the warm server `modesel serve` and the children it forks). An edited
file is read again at the next call, as by a fresh process.
"""
from __future__ import annotations

import functools
import hashlib
import os
import pickle
import sys
import tempfile
import time
from pathlib import Path

FORMAT = 1
#: when this module was imported [ns since the epoch], with the readers' modules
_IMPORTED_NS = time.time_ns()
OFF = ("off", "0", "no", "false")
#: most entries kept; beyond it the older half is removed (decks in temporary
#: folders, e.g. of tests, would otherwise pile up)
MAX_ENTRIES = 2000


def cache_dir() -> Path | None:
    """The folder of the deck cache (module doc), None when switched off."""
    own = os.environ.get("MODESEL_CACHE_DIR")
    if own is not None:
        return None if own.strip().lower() in OFF or not own.strip() else Path(own) / "decks"
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"]) / "modesel" / "decks"
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "modesel" / "decks"


def _stamp(path) -> tuple:
    path = Path(path).resolve()
    st = path.stat()
    return str(path), st.st_mtime_ns, st.st_size


@functools.lru_cache(maxsize=1)
def _openfast_io_stamp() -> tuple:
    import importlib.util
    try:
        spec = importlib.util.find_spec("openfast_io.FAST_reader")
        return _stamp(spec.origin)
    except (ImportError, AttributeError, TypeError, OSError):
        return ("openfast_io", "?")


def _code_stamps(code) -> list | None:
    """Stamps of the code modules' sources; None when one changed after this
    process loaded it (module doc)."""
    stamps = []
    for name in code:
        module = sys.modules.get(name)
        origin = getattr(module, "__file__", None)
        if origin:
            stamp = _stamp(origin)
            if stamp[1] > _IMPORTED_NS:
                return None
            stamps.append(stamp)
    return stamps


def _manifest(files, code_stamps) -> list:
    """Stamps of the value's files, of the code modules' sources
    (`_code_stamps`) and of openfast_io's reader."""
    return [_stamp(f) for f in files] + code_stamps + [_openfast_io_stamp()]


def cached(reader, path, *args, files=None, code=None):
    """`reader(path, *args)`, from the cache when its files are unchanged (module doc).

    files(value) -> the paths the value was read from (default [path]);
    code: module names whose source the value depends on (default the reader's).
    """
    code = tuple(code or (reader.__module__,))
    folder = cache_dir()
    if folder is None:
        return reader(path, *args)
    key = repr((FORMAT, reader.__module__, reader.__qualname__, str(Path(path).resolve()), args))
    entry = folder / (hashlib.sha256(key.encode()).hexdigest()[:32] + ".pickle")
    code_stamps = _code_stamps(code)
    if code_stamps is None:
        return reader(path, *args)
    try:
        with open(entry, "rb") as stream:
            stored_key, sources, manifest, value = pickle.load(stream)
        if stored_key == key and manifest == _manifest(sources, code_stamps):
            return value
    except Exception:   # absent, unreadable, damaged or stale: read the deck
        pass
    value = reader(path, *args)
    stream = None
    try:
        sources = [str(s) for s in (files(value) if files else [path])]
        code_stamps = _code_stamps(code)        # again: the code may have changed while reading
        if code_stamps is None:
            return value
        manifest = _manifest(sources, code_stamps)
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("wb", dir=folder, delete=False, suffix=".tmp") as stream:
            pickle.dump((key, sources, manifest, value), stream, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(stream.name, entry)
        _prune(folder)
    except Exception:   # unwritable cache or unpicklable value: no cache
        if stream is not None and os.path.exists(stream.name):
            os.unlink(stream.name)
    return value


#: values of `remembered`: key -> (files, their stamps, value)
_REMEMBERED: dict = {}


def remembered(reader, path, *args, files=None, code=None):
    """`cached(reader, path, *args, files=files, code=code)`, the same object
    again while every file it came from keeps its stamp (module doc). The
    stamps are taken after the read, as `cached` takes its manifest."""
    key = (reader.__module__, reader.__qualname__, str(Path(path).resolve()), args)
    kept = _REMEMBERED.get(key)
    if kept is not None:
        sources, stamps, value = kept
        try:
            if [_stamp(f) for f in sources] == stamps:
                return value
        except OSError:             # a file gone: read again (the reader names what is missing)
            pass
    _REMEMBERED.pop(key, None)
    value = cached(reader, path, *args, files=files, code=code)
    sources = [str(f) for f in (files(value) if files else [path])]
    try:
        _REMEMBERED[key] = (sources, [_stamp(f) for f in sources], value)
    except OSError:
        pass
    return value


def _prune(folder: Path) -> None:
    entries = list(folder.glob("*.pickle"))
    if len(entries) <= MAX_ENTRIES:
        return
    entries.sort(key=lambda e: e.stat().st_mtime)
    for old in entries[:len(entries) - MAX_ENTRIES // 2]:
        old.unlink(missing_ok=True)
