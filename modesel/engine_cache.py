"""numba's on-disk cache of the compiled engine, kept in step with its sources.

numba marks a cached function stale when the source file that defines it
changes, but not when a function it calls (and compiled into itself) changes
in another file (numba's documentation, "Cache invalidation"). The engine's
compiled functions call one another across the modules of `ENGINE_FOLDERS`
(the kernel's loops call the effects' loads, which call the BEM, the wind
and the kinematics, and take their constants), so after an edit or a
`git pull` that touches one of them, a function cached from another would
run the old code.

`discard_stale()` runs once when modesel is imported. It hashes the sources
of `ENGINE_FOLDERS` (about 40 files; a millisecond or two) and compares the
hash with a stamp beside the cache of each folder. Where they differ, it
deletes that folder's numba cache files and writes the new stamp, so the next
simulation compiles the engine again, with its progress line. It reads and
writes nothing else, and a cache it cannot read or write is left to numba.

`cache_place(folder)` is where numba keeps the cache of a source folder:
NUMBA_CACHE_DIR when set, else `__pycache__` beside the sources when the
folder is writable, else the user-wide cache; under a cache folder numba
names each source folder `<name>_<sha1 of its absolute path>` (numba's cache
locators), so that modules of one name in two folders are told apart.
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

#: the source folders of the compiled engine (every module that imports numba
#: lies in one of them; tests/test_architecture.py checks it)
ENGINE_FOLDERS = ("multibody", "aero", "model/effects")
#: the stamp file in each cache folder: the hash of the sources it was compiled from
STAMP = "modesel-engine-sources.sha1"

_ROOT = Path(__file__).resolve().parent


def engine_sources() -> list:
    """The engine's source files (`ENGINE_FOLDERS`, not their sub-folders), sorted."""
    return sorted(p for folder in ENGINE_FOLDERS for p in (_ROOT / folder).glob("*.py"))


def sources_digest() -> str:
    """sha1 of the engine's sources (their paths below modesel/ and contents)."""
    h = hashlib.sha1()
    for path in engine_sources():
        h.update(path.relative_to(_ROOT).as_posix().encode())
        h.update(b"\0")
        h.update(path.read_bytes())
        h.update(b"\0")
    return h.hexdigest()


def cache_places(folder: Path) -> list:
    """The places numba may keep the cache of source folder `folder`, in the
    order it tries them (module doc)."""
    folder = Path(os.path.abspath(folder))
    subpath = f"{folder.name}_{hashlib.sha1(str(folder).encode()).hexdigest()}"
    if os.environ.get("NUMBA_CACHE_DIR"):      # numba then uses this folder only
        return [Path(os.environ["NUMBA_CACHE_DIR"]) / subpath]
    return [folder / "__pycache__", Path.home() / ".cache" / "numba" / subpath]


def cache_place(folder: Path) -> Path:
    """Where numba writes the cache of source folder `folder` (module doc)."""
    places = cache_places(folder)
    if len(places) == 1 or os.access(folder, os.W_OK):
        return places[0]
    return places[1]


def discard_stale() -> list:
    """Delete the engine's numba cache files where they were compiled from
    other sources than these (module doc); returns the files deleted. Never
    raises for a cache it cannot read or write."""
    deleted = []
    try:
        digest = sources_digest()
    except OSError:
        return deleted
    for name in ENGINE_FOLDERS:
        folder = _ROOT / name
        stems = {p.stem for p in folder.glob("*.py")}
        for place in cache_places(folder):
            stamp = place / STAMP
            try:
                if stamp.is_file() and stamp.read_text().strip() == digest:
                    continue
                if place.is_dir():
                    for f in place.iterdir():
                        if f.suffix in (".nbi", ".nbc") and f.name.split(".")[0] in stems:
                            f.unlink(missing_ok=True)
                            deleted.append(f)
                if place == cache_place(folder) or place.is_dir():
                    place.mkdir(parents=True, exist_ok=True)
                    part = place / f"{STAMP}.{os.getpid()}"
                    part.write_text(digest + "\n")
                    os.replace(part, stamp)
            except OSError:
                continue
    return deleted
