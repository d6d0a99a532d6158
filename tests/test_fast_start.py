"""Fast start of `modesel simulate` (issue 12): the simulate path imports no
search, plotting or symbolic package, and parsed decks are cached."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DECAY = ROOT / "studies/data/openfast_free_decay/tower_fa_ss_shaft/Spar_ED_ForED.dat"
#: packages `modesel simulate` must not import (search, plotting, symbolic, the
#: candidate-family command; scipy's integrators and splines, 0.17 s together,
#: which a compiled run of the deck's shapes does not use)
NOT_ON_SIMULATE_PATH = ("optuna", "matplotlib", "sympy", "modesel.commands.candidates",
                        "modesel.commands.run", "modesel.multibody.symbolic",
                        "scipy.integrate", "scipy.interpolate")


def test_simulate_imports_no_optuna_matplotlib_or_sympy(tmp_path):
    out = tmp_path / "decay.csv"
    code = (
        "import json, sys\n"
        "from modesel.cli import main\n"
        f"rc = main(['simulate', {str(DECAY)!r}, '--tmax', '0.05', '--out', {str(out)!r}])\n"
        f"print(json.dumps([rc, [m for m in {NOT_ON_SIMULATE_PATH!r} if m in sys.modules]]))\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
               MODESEL_CACHE_DIR=str(tmp_path / "cache"))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                          cwd=tmp_path, timeout=900)
    assert done.returncode == 0, done.stderr
    rc, imported = json.loads(done.stdout.strip().splitlines()[-1])
    assert rc == 0 and out.is_file()
    assert imported == []


@pytest.mark.parametrize("argv, command", [
    (["simulate", "x.fst"], "simulate"), (["--debug", "simulate", "x"], "simulate"),
    (["--help"], None), ([], None), (["simulat", "x"], None), (["--", "simulate"], None)])
def test_cli_builds_only_the_named_command(argv, command):
    from modesel import cli
    assert cli._command_of(argv) == command


def test_parsed_decks_are_cached_and_reread_when_a_file_changes(tmp_path, monkeypatch):
    import shutil

    from modesel.turbine import deck_cache
    from modesel.turbine.elastodyn import read_elastodyn
    monkeypatch.setenv("MODESEL_CACHE_DIR", str(tmp_path / "cache"))
    case = tmp_path / "case"
    shutil.copytree(DECAY.parent, case, ignore=shutil.ignore_patterns("*.outb"))
    main = case / DECAY.name
    first = read_elastodyn(main)
    entries = sorted((tmp_path / "cache" / "decks").glob("*.pickle"))
    assert len(entries) == 3            # main, blade and tower decks, one entry each
    stamps = [e.stat().st_mtime_ns for e in entries]
    again = read_elastodyn(main)        # from the cache: entries not rewritten
    assert [e.stat().st_mtime_ns for e in entries] == stamps
    assert again.tip_radius == first.tip_radius == 63.0
    # a changed deck (other size and time) is read again
    text = main.read_text().replace("63   TipRad", "64.5   TipRad")
    assert text != main.read_text()
    main.write_text(text)
    os.utime(main, ns=(main.stat().st_atime_ns, main.stat().st_mtime_ns + 10**9))
    assert read_elastodyn(main).tip_radius == 64.5
    # switched off: no entries written
    monkeypatch.setenv("MODESEL_CACHE_DIR", "off")
    assert deck_cache.cache_dir() is None


def test_deck_cache_keeps_at_most_max_entries(tmp_path, monkeypatch):
    from modesel.turbine import deck_cache
    monkeypatch.setenv("MODESEL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(deck_cache, "MAX_ENTRIES", 4)
    reads = []
    for k in range(6):
        deck = tmp_path / f"deck{k}.dat"
        deck.write_text(f"value {k}\n")
        assert deck_cache.cached(lambda p: reads.append(p) or Path(p).read_text(), deck) == f"value {k}\n"
    assert len(reads) == 6
    assert 2 <= len(list((tmp_path / "cache" / "decks").glob("*.pickle"))) <= 4
