"""The engine's numba cache is dropped when any engine source changes
(modesel.engine_cache): numba itself only notices a change of the file that
defines a cached function, not of the functions compiled into it from other
files."""
from __future__ import annotations

import re
from pathlib import Path

from modesel import engine_cache

ROOT = Path(engine_cache.__file__).resolve().parent


def _fake_cache(place: Path, stem: str) -> list:
    place.mkdir(parents=True, exist_ok=True)
    files = [place / f"{stem}.f-305.py311.nbi", place / f"{stem}.f-305.py311.1.nbc"]
    for f in files:
        f.write_bytes(b"x")
    return files


def test_cache_of_changed_sources_is_dropped_once(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    aero = engine_cache.cache_place(ROOT / "aero")
    kernel = engine_cache.cache_place(ROOT / "multibody")
    assert aero.parent == tmp_path and aero.name.startswith("aero_") and kernel != aero
    foreign = _fake_cache(aero, "kernel")           # not a module of aero/: never touched there
    # no stamp yet: the cache's sources are unknown, so it goes
    bem = _fake_cache(aero, "bem")
    assert set(engine_cache.discard_stale()) == set(bem)
    assert all(f.exists() for f in foreign)
    assert (aero / engine_cache.STAMP).read_text().strip() == engine_cache.sources_digest()
    # compiled from these sources: kept
    bem = _fake_cache(aero, "bem")
    kern = _fake_cache(kernel, "kernel")
    assert engine_cache.discard_stale() == []
    assert all(f.exists() for f in bem + kern + foreign)
    # an engine source changed (here: the digest): dropped in every engine folder's cache
    monkeypatch.setattr(engine_cache, "sources_digest", lambda: "0" * 40)
    assert set(engine_cache.discard_stale()) == set(bem + kern)
    assert all(f.exists() for f in foreign)
    assert (kernel / engine_cache.STAMP).read_text().strip() == "0" * 40


def test_digest_follows_every_engine_source(tmp_path, monkeypatch):
    sources = engine_cache.engine_sources()
    names = {p.relative_to(ROOT).as_posix() for p in sources}
    assert {"multibody/kernel.py", "aero/bem.py", "model/effects/compiled.py",
            "multibody/invariant_sums.py"} <= names
    copy = tmp_path / "modesel"
    for p in sources:
        target = copy / p.relative_to(ROOT)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(p.read_bytes())
    monkeypatch.setattr(engine_cache, "_ROOT", copy)
    before = engine_cache.sources_digest()
    assert before == engine_cache.sources_digest()
    bem = copy / "aero" / "bem.py"
    bem.write_text(bem.read_text().replace("WARM_BRACKET = 2e-3", "WARM_BRACKET = 3e-3"))
    assert engine_cache.sources_digest() != before


def test_every_cached_compiled_function_lives_in_an_engine_folder():
    """A module with numba-cached functions outside ENGINE_FOLDERS would escape the stamp."""
    engine = {p.resolve() for p in engine_cache.engine_sources()}
    decorator = re.compile(r"^\s*@(njit|jit|cfunc)\(.*cache\s*=\s*True", re.M)
    cached = [p for p in ROOT.rglob("*.py") if decorator.search(p.read_text())]
    assert cached and all(p.resolve() in engine for p in cached), \
        [str(p) for p in cached if p.resolve() not in engine]
