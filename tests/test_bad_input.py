"""Bad input, everywhere a user types or points: one line naming the file, the
field and the problem, exit code 2, no traceback (`--debug` shows it).

Three layers:
- every command run in a subprocess with garbage arguments or files: exit
  code 2, a single stderr line starting with 'modesel: error:', no
  'Traceback' (and with --debug the traceback is there);
- a table of specific mistakes (malformed TOML, unknown keys, wrong types,
  counts, ranges, ElastoDyn decks with missing files or tables, references
  with missing channels, NaN, unsorted or duplicated time, units that cannot
  be matched, output folders and storages that cannot be used), run through
  `modesel.cli.main` in-process: the line names the file, field and problem;
- property-based fuzzing (hypothesis) of the study parser and the reference
  reader: any input either parses or raises ModeselError, never another
  exception.
"""
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from modesel.cli import main
from modesel.errors import ModeselError
from modesel.study.reference import load_reference
from modesel.study.spec import parse_study

REPO = Path(__file__).resolve().parents[1]
NREL = REPO / "modesel" / "turbine" / "data" / "nrel5mw"
SCENE_2DOF = REPO / "studies" / "scenes" / "paper_2dof_tower_shaft.toml"


# --------------------------------------------------------------------------- fixtures

@pytest.fixture
def files(tmp_path):
    """A folder of good and bad inputs: a scene, a study with a CSV reference, mode sets, decks."""
    f = tmp_path
    (f / "scene.toml").write_text('turbine = "nrel5mw"\ntmax = 1.0\n[modes]\n'
                                  'tower_fa = { family = "clamped", count = 1 }\n[dofs]\nfree = ["GeAz"]\n')
    t = np.arange(0.0, 2.0001, 0.05)
    pd.DataFrame({"Time": t, "TTDspFA": np.cos(2 * np.pi * 0.32 * t)}).to_csv(f / "ref.csv", index=False)
    (f / "study.toml").write_text(study_text(f / "ref.csv"))
    (f / "ms.json").write_text(json.dumps({"fields": {"tower_fa": {"family": "clamped", "count": 2}}}))
    deck = f / "deck"
    deck.mkdir()
    for p in NREL.glob("*.dat"):
        shutil.copy(p, deck / p.name)
    return f


def study_text(ref, **replace):
    text = f"""\
[study]
name = "bad_input"
[[scene]]
path = "{SCENE_2DOF}"
tmax = 2.0
dt = 0.05
[reference]
kind = "csv"
path = "{ref}"
[compare]
channels = ["TTDspFA"]
tolerance = 0.05
[search.fields.tower_fa]
families = ["clamped", "polynomial"]
max_count = 2
[budget]
n_trials = 2
"""
    for old, new in replace.items():
        assert old in text, old
        text = text.replace(old, new)
    return text


def write(path, text, mode="w"):
    path = Path(path)
    with open(path, mode) as fh:
        fh.write(text)
    return str(path)


def reference_csv(folder, name, frame=None, text=None):
    path = Path(folder) / name
    if text is not None:
        path.write_text(text)
    else:
        frame.to_csv(path, index=False)
    return path


def deck_with(folder, file, edit):
    """Copy of the bundled main deck whose `file` (a deck file name) is edited by `edit(text)`."""
    deck = Path(folder) / "deck"
    target = deck / file
    target.write_text(edit(target.read_text()))
    return str(deck / "NREL5MW_ED_Onshore.dat")


def one_line_error(capsys, argv):
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:          # argparse (command-line syntax)
        code = exc.code
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, (argv, code, err)
    assert len(err) == 1 and err[0].startswith("modesel: error: "), err
    return err[0]


# --------------------------------------------------------------------------- the table

def _cases():
    """(id, argv builder(files) -> argv, substrings the line must contain)."""
    t = np.arange(0.0, 2.0001, 0.05)
    good = pd.DataFrame({"Time": t, "TTDspFA": np.cos(t)})

    def study(f, **replace):
        return ["run", write(f / "s.toml", study_text(f / "ref.csv", **replace)), "--out", f / "out"]

    def study_ref(f, name, frame=None, text=None):
        ref = reference_csv(f, name, frame, text)
        return ["run", write(f / "s.toml", study_text(ref)), "--out", f / "out"]

    def scene(f, text):
        return ["simulate", write(f / "sc.toml", text), "--out", f / "o.csv"]

    base = 'turbine = "nrel5mw"\n[modes]\ntower_fa = { family = "clamped", count = 1 }\n'
    nan_frame = good.copy()
    nan_frame.loc[7, "TTDspFA"] = np.nan
    dup_frame = good.copy()
    dup_frame.loc[5, "Time"] = dup_frame.loc[4, "Time"]
    back_frame = good.copy()
    back_frame.loc[5, "Time"] = 0.01
    return [
        # files that are not there or not readable
        ("scene not found", lambda f: ["simulate", f / "nope.toml", "--out", f / "o.csv"],
         ["nope.toml", "scene file not found"]),
        ("scene is a folder", lambda f: ["simulate", f, "--out", f / "o.csv"], ["not a file"]),
        ("scene not UTF-8", lambda f: ["simulate", write(f / "b.toml", b"\xff\xfe\x00", "wb"), "--out",
                                       f / "o.csv"], ["b.toml", "cannot read"]),
        ("study not found", lambda f: ["run", f / "nope.toml", "--out", f / "out"], ["nope.toml", "not found"]),
        ("mode set not found", lambda f: ["simulate", f / "scene.toml", "--modeset", f / "no.json", "--out",
                                          f / "o.csv"], ["no.json", "not found"]),
        # malformed TOML / JSON, with the line number
        ("malformed scene TOML", lambda f: scene(f, 'turbine = "nrel5mw"\ntmax = \n'),
         ["sc.toml", "malformed TOML", "line 2"]),
        ("malformed study TOML", lambda f: ["run", write(f / "s.toml", "[study\nname='x'\n"), "--out", f / "o"],
         ["s.toml", "not valid TOML", "line 1"]),
        ("malformed mode-set JSON", lambda f: ["simulate", f / "scene.toml", "--modeset",
                                               write(f / "m.json", "{\n'x'"), "--out", f / "o.csv"],
         ["m.json", "not valid JSON", "line 2"]),
        # unknown keys, with did-you-mean
        ("unknown scene key", lambda f: scene(f, "tmaxx = 3\n" + base), ["sc.toml", "tmaxx", "did you mean 'tmax'"]),
        ("unknown study key", lambda f: study(f, **{"tolerance = 0.05": "tolerence = 0.05"}),
         ["s.toml", "compare.tolerence", "did you mean 'tolerance'"]),
        ("unknown family", lambda f: scene(f, base.replace("clamped", "clampd")),
         ["sc.toml", "modes.tower_fa.family", "did you mean 'clamped'"]),
        ("unknown field", lambda f: study(f, **{"search.fields.tower_fa": "search.fields.tower_fx"}),
         ["s.toml", "search.fields.tower_fx", "did you mean 'tower_fa'"]),
        ("unknown family parameter", lambda f: scene(f, base.replace("count = 1", "count = 1, params = { x = 1 }")),
         ["sc.toml", "modes.tower_fa.params", "unknown parameter"]),
        ("unknown solver method", lambda f: scene(f, base + '[solver]\nmethod = "Euler"\n'),
         ["sc.toml", "solver.method", "unknown solver method"]),
        ("family for another field", lambda f: scene(f, base.replace("tower_fa = { family = \"clamped\"",
                                                                      "tower_torsion = { family = \"polynomial\"")),
         ["sc.toml", "modes.tower_torsion.family", "does not describe field"]),
        # wrong types
        ("scene tmax a string", lambda f: scene(f, 'tmax = "ten"\n' + base), ["sc.toml", "tmax", "must be a number"]),
        ("scene free DOFs a string", lambda f: scene(f, base + '[dofs]\nfree = "GeAz"\n'),
         ["sc.toml", "dofs.free", "list of DOF names"]),
        ("scene fixed DOFs a number", lambda f: scene(f, base + "[dofs]\nfixed = 3\n"),
         ["sc.toml", "dofs.fixed", "must be a table"]),
        ("study count a string", lambda f: study(f, **{"max_count = 2": 'max_count = "two"'}),
         ["s.toml", "search.fields.tower_fa.max_count", "must be an integer"]),
        ("mode-set params a number", lambda f: ["simulate", f / "scene.toml", "--modeset", write(
            f / "m.json", '{"fields": {"tower_fa": {"family": "clamped", "count": 1, "params": 5}}}'),
            "--out", f / "o.csv"], ["m.json", "fields.tower_fa.params", "table of parameter values"]),
        ("NaN initial condition", lambda f: scene(f, base + "[initial]\nTTDspFA = nan\n"),
         ["sc.toml", "initial.TTDspFA", "finite"]),
        ("negative nacelle mass", lambda f: scene(f, base + "[overrides]\nnacelle_mass = -1.0\n"),
         ["sc.toml", "overrides.nacelle_mass", ">= 0"]),
        # negative or zero counts, ranges with min > max
        ("scene count 0", lambda f: scene(f, base.replace("count = 1", "count = 0")),
         ["sc.toml", "modes.tower_fa.count", ">= 1"]),
        ("scene count above the family's", lambda f: scene(f, base.replace("clamped\", count = 1",
                                                                           "fem\", count = 100")),
         ["sc.toml", "modes.tower_fa.count", "at most 40"]),
        ("study count negative", lambda f: study(f, **{"max_count = 2": "max_count = -1"}),
         ["s.toml", "search.fields.tower_fa.max_count", ">= 1"]),
        ("study min > max", lambda f: study(f, **{"max_count = 2": "min_count = 3\nmax_count = 2"}),
         ["s.toml", "search.fields.tower_fa.max_count", "min > max"]),
        ("compared channel the scene does not compute", lambda f: [
            "run", write(f / "s.toml", study_text(reference_csv(f, "r.csv", good.assign(RtAeroFxh=1.0)),
                                                  **{'channels = ["TTDspFA"]': 'channels = ["TTDspFA", "RtAeroFxh"]'})),
            "--out", f / "out"], ["s.toml", "compare.channels", "RtAeroFxh", "does not compute"]),
        ("window min > max", lambda f: study(f, **{'kind = "csv"': 'kind = "csv"\nwindow = [3.0, 1.0]'}),
         ["s.toml", "reference.window", "min > max"]),
        ("window outside the scene", lambda f: study(f, **{'kind = "csv"': 'kind = "csv"\nwindow = [5.0, 8.0]'}),
         ["s.toml", "reference.window", "do not overlap"]),
        ("--n-trials 0", lambda f: ["run", f / "study.toml", "--out", f / "out", "--n-trials", "0"],
         ["--n-trials", ">= 1"]),
        ("shapes --count 0", lambda f: ["shapes", "nrel5mw", "--field", "tower_fa", "--family", "clamped",
                                        "--count", "0"], ["--count", ">= 1"]),
        ("--rpm NaN", lambda f: ["linearize", f / "scene.toml", "--rpm", "nan"], ["--rpm", "finite"]),
        # ElastoDyn decks with missing files or tables
        ("deck: tower file missing", lambda f: ["shapes", deck_with(
            f, "NREL5MW_ED_Onshore.dat", lambda s: s.replace('"NRELOffshrBsline5MW_Onshore_ElastoDyn_Tower.dat"',
                                                             '"gone.dat"')), "--field", "tower_fa", "--family",
            "clamped", "--count", "1"], ["NREL5MW_ED_Onshore.dat", "TwrFile", "gone.dat", "not found"]),
        ("deck: tower table cut short", lambda f: ["shapes", deck_with(
            f, "NRELOffshrBsline5MW_Onshore_ElastoDyn_Tower.dat", lambda s: "\n".join(s.splitlines()[:25])),
            "--field", "tower_fa", "--family", "clamped", "--count", "1"],
         ["NRELOffshrBsline5MW_Onshore_ElastoDyn_Tower.dat", "NTwInpSt", "station table"]),
        ("deck: negative mass", lambda f: ["shapes", deck_with(
            f, "NRELOffshrBsline5MW_Onshore_ElastoDyn_Tower.dat",
            lambda s: s.replace("5.2324300E+03", "-5.2324300E+03", 1)),
            "--field", "tower_fa", "--family", "clamped", "--count", "1"], ["TMassDen", "must be > 0"]),
        ("deck: input missing", lambda f: ["simulate", deck_with(
            f, "NREL5MW_ED_Onshore.dat", lambda s: "\n".join(s.splitlines()[:40])), "--out", f / "o.csv"],
         ["NREL5MW_ED_Onshore.dat", "input missing from the deck"]),
        # references: missing channels, NaN, unsorted or duplicated time, units
        ("reference channel missing", lambda f: study_ref(f, "r.csv", good.rename(columns={"TTDspFA": "TTDspFX"})),
         ["r.csv", "TTDspFA", "did you mean 'TTDspFX'"]),
        ("reference NaN", lambda f: study_ref(f, "r.csv", nan_frame), ["r.csv", "TTDspFA", "row 7"]),
        ("reference text value", lambda f: study_ref(f, "r.csv", text="Time,TTDspFA\n0,1\n0.1,abc\n0.2,3\n"),
         ["r.csv", "TTDspFA", "non-numeric", "row 1"]),
        ("reference duplicated time", lambda f: study_ref(f, "r.csv", dup_frame),
         ["r.csv", "Time", "duplicated time"]),
        ("reference time going back", lambda f: study_ref(f, "r.csv", back_frame),
         ["r.csv", "Time", "not increasing"]),
        ("reference without Time", lambda f: study_ref(f, "r.csv", good.rename(columns={"Time": "Tim"})),
         ["r.csv", "Time", "did you mean 'Tim'"]),
        ("reference column twice", lambda f: study_ref(f, "r.csv", text="Time,TTDspFA,TTDspFA\n0,1,1\n1,2,2\n"),
         ["r.csv", "TTDspFA", "twice"]),
        ("reference ragged", lambda f: study_ref(f, "r.csv", text="Time,TTDspFA\n0,1\n1,2,3\n"),
         ["r.csv", "cannot read CSV"]),
        ("reference empty", lambda f: study_ref(f, "r.csv", text=""), ["r.csv", "cannot read CSV"]),
        ("reference units that cannot be matched", lambda f: study_ref(
            f, "r.csv", good.rename(columns={"TTDspFA": "TTDspFA [deg]"})),
         ["r.csv", "TTDspFA", "'deg'", "'m'"]),
        # output folders and storages
        ("output folder under a file", lambda f: ["run", f / "study.toml", "--out", f / "ref.csv" / "out"],
         ["ref.csv", "cannot create output folder"]),
        ("simulate output is a folder", lambda f: ["simulate", f / "scene.toml", "--tmax", "0.1", "--out", f],
         ["cannot write"]),
        ("storage folder missing", lambda f: ["run", f / "study.toml", "--out", f / "out", "--storage",
                                              f / "no" / "study.journal"], ["study.journal", "does not exist"]),
        ("storage database unreachable", lambda f: ["run", f / "study.toml", "--out", f / "out", "--storage",
                                                    f"sqlite:///{f}/no/x.db"], ["x.db", "cannot open storage"]),
        ("storage of an unknown kind", lambda f: ["worker", f / "study.toml", "--storage", "nosuch://host/db"],
         ["nosuch://host/db", "cannot open storage"]),
        ("report of a folder that is no output", lambda f: ["report", f], ["no run.json"]),
        ("report of a file", lambda f: ["report", f / "ref.csv"], ["ref.csv", "no run.json"]),
    ]


CASES = _cases()


@pytest.mark.parametrize("builder,expected", [pytest.param(b, e, id=i) for i, b, e in CASES])
def test_bad_input_gives_one_line(files, capsys, builder, expected):
    line = one_line_error(capsys, builder(files))
    for text in expected:
        assert text in line, (text, line)


# --------------------------------------------------------------------------- subprocesses

#: every command with garbage arguments or files (relative to the `files` folder)
GARBAGE = {
    "candidates": ["candidates", "--field", "towr_fa"],
    "shapes": ["shapes", "garbage.toml", "--field", "tower_fa", "--family", "clamped", "--count", "2"],
    "simulate": ["simulate", "garbage.toml", "--out", "o.csv"],
    "linearize": ["linearize", "garbage.toml", "--rpm", "x,y"],
    "derive": ["derive", "garbage.toml", "--python", "o.py"],
    "run": ["run", "garbage.toml", "--out", "out"],
    "worker": ["worker", "garbage.toml", "--storage", "garbage://"],
    "report": ["report", "garbage.toml"],
    "export": ["export", "garbage.toml", "--turbine", "garbage.toml", "--json", "o.json"],
    "syntax": ["run", "--n-trials", "many"],
}


def test_every_command_with_garbage_in_a_subprocess(files):
    (files / "garbage.toml").write_bytes(b"\x00\x01 [[[ garbage = = \xff\n")
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    procs = {name: subprocess.Popen([sys.executable, "-m", "modesel", *argv], cwd=files, env=env,
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for name, argv in GARBAGE.items()}
    debug = subprocess.Popen([sys.executable, "-m", "modesel", "--debug", *GARBAGE["simulate"]], cwd=files,
                             env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    for name, proc in procs.items():
        _, err = proc.communicate(timeout=120)
        lines = err.strip().splitlines()
        assert proc.returncode == 2, (name, proc.returncode, err)
        assert len(lines) == 1 and lines[0].startswith("modesel: error:"), (name, err)
        assert "Traceback" not in err
    _, err = debug.communicate(timeout=120)
    assert debug.returncode != 0 and "Traceback" in err and "ModeselError" in err


# --------------------------------------------------------------------------- fuzzing

def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(v)


def to_toml(data: dict) -> str:
    """A small TOML writer: top-level scalars, tables (one level of sub-tables
    as inline tables) and arrays of tables."""
    lines = [f"{json.dumps(k)} = {_toml_value(v)}" for k, v in data.items() if not isinstance(v, (dict, list))
             or (isinstance(v, list) and not all(isinstance(x, dict) for x in v)) or v == []]
    for key, value in data.items():
        if isinstance(value, dict):
            lines.append(f"[{json.dumps(key)}]")
            lines += [f"{json.dumps(k)} = {_toml_value(v)}" for k, v in value.items()]
        elif isinstance(value, list) and value and all(isinstance(x, dict) for x in value):
            for item in value:
                lines.append(f"[[{json.dumps(key)}]]")
                lines += [f"{json.dumps(k)} = {_toml_value(v)}" for k, v in item.items()]
    return "\n".join(lines) + "\n"


VALID_STUDY = {
    "study": {"name": "fuzz", "description": "d"},
    "scene": [{"path": "scene.toml", "name": "a", "weight": 1.0, "tmax": 2.0, "dt": 0.05}],
    "reference": {"kind": "csv", "path": "ref.csv", "time_offset": 0.0, "window": [0.0, 2.0],
                  "channels": {"TTDspFA": "-Q_TFA1"}},
    "compare": {"channels": {"TTDspFA": 1.0}, "metric": "nrmse", "tolerance": 0.01, "levels": [0.035]},
    "search": {"sampler": "tpe", "cost": "wall_time",
               "fields": {"tower_fa": {"families": ["clamped", "fem"], "min_count": 1, "max_count": 3,
                                       "params": {"fem": {"elements": [10.0, 60.0]}}}}},
    "budget": {"n_trials": 10, "timeout_s": 60.0, "stop_when_met": True, "keep_searching_trials": 2},
    "run": {"n_jobs": 1, "seed": 0},
}

scalars = (st.none() | st.booleans() | st.integers(-10**6, 10**6) | st.floats(allow_nan=True, allow_infinity=True)
           | st.text(max_size=12) | st.sampled_from(["clamped", "fem", "tower_fa", "internal", "nrmse", "x"]))
values = st.recursive(scalars, lambda inner: st.lists(inner, max_size=3)
                      | st.dictionaries(st.text(max_size=8), inner, max_size=3), max_leaves=6)


def _paths(node, prefix=()):
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, prefix + (i,))


@st.composite
def mutated_studies(draw):
    """The valid study with a few random edits: delete, replace or add a key anywhere."""
    data = json.loads(json.dumps(VALID_STUDY))
    for _ in range(draw(st.integers(1, 4))):
        paths = [p for p in _paths(data) if p]
        path = draw(st.sampled_from(paths))
        parent = data
        for k in path[:-1]:
            parent = parent[k]
        action = draw(st.sampled_from(["delete", "replace", "add"]))
        value = draw(values)
        if value is None:
            action = "delete"
        if action == "delete":
            del parent[path[-1]]
        elif action == "replace":
            parent[path[-1]] = value
        elif isinstance(parent, dict):
            parent[draw(st.text(min_size=1, max_size=10))] = value
    return data


def _only_modesel_errors(call):
    try:
        call()
    except ModeselError as exc:
        assert str(exc) and "\n" not in str(exc)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated_studies())
def test_study_parser_fuzz_structured(data):
    try:
        text = to_toml(data)
    except TypeError:
        return
    _only_modesel_errors(lambda: parse_study(text, "/tmp/fuzz/study.toml"))


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=300) | st.sampled_from(["[study]\nname = 1", "[[scene]]\npath = 3",
                                                  "scene = 3", "[search.fields]\ntower_fa = 2"]))
def test_study_parser_fuzz_text(text):
    _only_modesel_errors(lambda: parse_study(text, "/tmp/fuzz/study.toml"))


cells = (st.floats(allow_nan=True, allow_infinity=True) | st.integers(-5, 5)
         | st.text(alphabet="0123456789.-eE, \"abcnaN", max_size=6))


@st.composite
def csv_texts(draw):
    names = draw(st.lists(st.sampled_from(["Time", "TTDspFA", "TTDspFA [m]", "TTDspFA (deg)", "Time [s]",
                                           "X", "", "Time", "TTDspFA [kN]"]), min_size=0, max_size=4))
    rows = draw(st.lists(st.lists(cells, min_size=0, max_size=5), max_size=8))
    lines = [",".join(names)] + [",".join(str(c) for c in row) for row in rows]
    if draw(st.booleans()):     # a well-formed numeric body, time possibly unsorted
        t = draw(st.lists(st.floats(-1, 10), min_size=0, max_size=8))
        lines = ["Time,TTDspFA"] + [f"{x},{np.sin(x)}" for x in t]
    return "\n".join(lines) + draw(st.sampled_from(["", "\n", "\n\n"]))


@settings(max_examples=300, deadline=None)
@given(csv_texts(), st.sampled_from([{}, {"TTDspFA": "-TTDspFA"}, {"TTDspFA": "X"}]),
       st.floats(-5, 5), st.sampled_from([None, (0.0, 1.0), (2.0, 1.0)]))
def test_reference_reader_fuzz(text, mapping, offset, window):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "ref.csv"
        path.write_text(text)

        def load():
            ref = load_reference(path, "csv", ["TTDspFA"], mapping=mapping, time_offset=offset, window=window)
            sim = pd.DataFrame({"Time": np.linspace(0, 1, 11), "TTDspFA": np.zeros(11)})
            sim.attrs["units"] = {"TTDspFA": "m"}
            ref.align(sim, ["TTDspFA"])
        _only_modesel_errors(load)


@settings(max_examples=100, deadline=None)
@given(st.binary(max_size=200))
def test_reference_reader_fuzz_bytes(raw):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "ref.csv"
        path.write_bytes(raw)
        _only_modesel_errors(lambda: load_reference(path, "csv", ["TTDspFA"]))


def test_a_compared_channel_under_an_elastodyn_alias_is_not_refused(tmp_path, capsys):
    """The warm-up's check of the compared channels (above: "compared channel
    the scene does not compute") takes ElastoDyn's other names of a computed
    channel as computed: LSSTipVxa is RotSpeed, which the trials then write
    under that name."""
    t = np.arange(0.0, 2.0001, 0.05)
    ref = reference_csv(tmp_path, "r.csv", pd.DataFrame({"Time": t, "LSSTipVxa": 10.0 + np.sin(t)}))
    study = write(tmp_path / "s.toml", study_text(ref, **{'channels = ["TTDspFA"]': 'channels = ["LSSTipVxa"]',
                                                           "n_trials = 2": "n_trials = 1"}))
    assert main(["run", study, "--out", str(tmp_path / "out"), "--quiet"]) == 0, capsys.readouterr().err
    trials = pd.read_csv(tmp_path / "out" / "trials.csv", header=[0, 1]).droplevel(1, axis=1)
    assert len(trials) == 1 and np.isfinite(trials.error_pct_LSSTipVxa.iloc[0])
