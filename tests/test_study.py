"""Study-file parsing: the documented example, defaults, and every error kind
(each a one-line ModeselError naming the study file and the dotted field)."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

import modesel.study.spec as study_module
from modesel.errors import ModeselError
from modesel.study.spec import load_study, parse_study

MINIMAL = """
[[scene]]
path = "scene.toml"
reference = "ref.csv"
[reference]
kind = "csv"
[compare]
channels = ["TTDspFA"]
[search.fields.tower_fa]
families = ["clamped", "polynomial"]
"""


def example_text() -> str:
    """The example of the modesel.study.spec docstring."""
    doc = study_module.__doc__
    block = doc.split("::\n", 1)[1]
    lines = block.splitlines()
    body = []
    for line in lines[1:]:
        if line and not line.startswith("    "):
            break
        body.append(line[4:])
    return "\n".join(body)


def parse(text: str, tmp_path: Path):
    return parse_study(text, tmp_path / "study.toml")


def error(text: str, tmp_path: Path) -> str:
    with pytest.raises(ModeselError) as info:
        parse(text, tmp_path)
    message = str(info.value)
    assert "\n" not in message
    assert str(tmp_path / "study.toml") in message
    return message


def test_documented_example_parses(tmp_path):
    s = parse(example_text(), tmp_path)
    assert s.name == "nrel5mw-free-decay"
    (scene,) = s.scenes
    assert scene.path == (tmp_path / "scenes/free_decay.toml").resolve()
    assert scene.reference == (tmp_path / "ref/free_decay.outb").resolve()
    assert (scene.weight, scene.tmax, scene.dt) == (1.0, 20.0, 0.05)
    assert s.reference.kind == "openfast" and s.reference.window == (5.0, 20.0)
    assert s.reference.reference_name("TTDspFA") == "TTDspFA"
    assert s.compare.channels == {"TTDspFA": 1.0, "TTDspSS": 1.0}
    assert s.compare.levels == (0.035, 0.01)
    (fa,) = s.search.fields
    assert fa.field == "tower_fa"
    assert [f.family for f in fa.families] == ["clamped", "relaxed_root"]
    assert fa.family("relaxed_root").params == {"free_end_weight": (0.0, 0.5)}
    assert s.budget.keep_searching_trials == 20 and s.budget.timeout_s == 3600.0
    assert s.run.storage.startswith("postgresql://")


def test_defaults(tmp_path):
    s = parse(MINIMAL, tmp_path)
    assert s.name == "study"
    assert s.compare.metric == "nrmse" and s.compare.tolerance == 0.035
    assert s.compare.levels == (0.035,)
    assert s.scenes[0].name == "scene" and s.scenes[0].weight == 1.0 and s.scenes[0].tmax is None
    assert s.budget.n_trials == 100 and s.budget.stop_when_met and s.budget.keep_searching_trials == 0
    assert s.run.n_jobs == 1 and s.run.storage is None and s.run.seed == 0
    assert s.search.sampler == "tpe" and s.search.cost == "wall_time"
    assert [(f.family, f.min_count, f.max_count) for f in s.search.fields[0].families] == \
        [("clamped", 1, 4), ("polynomial", 1, 4)]
    crit = s.criterion()
    assert crit.tolerance == 0.035 and crit.weights == {"TTDspFA": 1.0}


def test_family_max_count_caps_the_range(tmp_path):
    s = parse(MINIMAL.replace('"polynomial"]', '"elastodyn"]\nmax_count = 6'), tmp_path)
    assert s.search.fields[0].family("elastodyn").max_count == 2     # ElastoDyn has 2 tower modes
    assert s.search.fields[0].family("clamped").max_count == 6


def test_levels_sorted_loosest_first_and_include_tolerance(tmp_path):
    s = parse(MINIMAL.replace('channels = ["TTDspFA"]', 'channels = ["TTDspFA"]\ntolerance = 0.02\n'
                              'levels = [0.005, 0.05, 0.02]'), tmp_path)
    assert s.compare.levels == (0.05, 0.02, 0.005)


def test_fingerprint_ignores_tolerance_but_not_channels(tmp_path):
    a = parse(MINIMAL, tmp_path).fingerprint()
    b = parse(MINIMAL.replace('channels = ["TTDspFA"]', 'channels = ["TTDspFA"]\ntolerance = 0.01'),
              tmp_path).fingerprint()
    c = parse(MINIMAL.replace('["TTDspFA"]', '["TTDspFA", "TTDspSS"]'), tmp_path).fingerprint()
    assert a == b != c


@pytest.mark.parametrize("edit, pattern", [
    (lambda t: t.replace("[compare]", "[compare\n"), r"not valid TOML: .*line \d+"),
    (lambda t: t + "\n[compar]\nx = 1\n", r"compar: unknown key 'compar' \(did you mean 'compare'\?\)"),
    (lambda t: t + "max_cout = 3\n",
     r"search\.fields\.tower_fa\.max_cout: unknown key 'max_cout' \(did you mean 'max_count'\?\)"),
    (lambda t: t + "\n[budget]\nn_trials = \"ten\"\n", r"budget\.n_trials: must be an integer, got 'ten'"),
    (lambda t: t + "\n[budget]\nn_trials = true\n", r"budget\.n_trials: must be an integer"),
    (lambda t: t + "\n[budget]\nn_trials = 0\n", r"budget\.n_trials: must be >= 1, got 0"),
    (lambda t: t + "\n[run]\nn_jobs = 0\n", r"run\.n_jobs: must be >= 1"),
    (lambda t: t + "min_count = 0\n", r"search\.fields\.tower_fa\.min_count: must be >= 1"),
    (lambda t: t + "min_count = 3\nmax_count = 2\n",
     r"search\.fields\.tower_fa\.max_count: range has min > max"),
    (lambda t: t.replace('"polynomial"', '"polynomal"'),
     r"search\.fields\.tower_fa\.families\[1\]: unknown family 'polynomal' \(did you mean 'polynomial'\?\)"),
    (lambda t: t.replace('"polynomial"', '"linear"'),
     r"families\[1\]: family 'linear' does not describe field 'tower_fa'"),
    (lambda t: t.replace('"polynomial"]', '"elastodyn"]\nmin_count = 3\nmax_count = 4'),
     r"families\[1\]: family 'elastodyn' provides at most 2 modes, below min_count=3"),
    (lambda t: t.replace("[search.fields.tower_fa]", "[search.fields.tower_xx]"),
     r"search\.fields\.tower_xx: unknown field 'tower_xx' \(did you mean 'tower_ss'\?\)"),
    (lambda t: t.replace('"polynomial"]', '"relaxed_root"]\n[search.fields.tower_fa.params.relaxed_root]\n'
                                           'free_end_weight = [0.8, 0.2]'),
     r"params\.relaxed_root\.free_end_weight: range has min > max: \[0\.8, 0\.2\]"),
    (lambda t: t.replace('"polynomial"]', '"relaxed_root"]\n[search.fields.tower_fa.params.relaxed_root]\n'
                                           'free_end_weight = [0.0, 2.0]'),
     r"free_end_weight: range \[0, 2\] leaves the family's allowed \[0, 1\]"),
    (lambda t: t.replace('"polynomial"]', '"relaxed_root"]\n[search.fields.tower_fa.params.relaxed_root]\n'
                                           'free_end_wieght = [0.0, 0.5]'),
     r"unknown parameter of family 'relaxed_root' 'free_end_wieght' \(did you mean 'free_end_weight'\?\)"),
    (lambda t: t.replace('"polynomial"]', '"polynomial"]\n[search.fields.tower_fa.params.cosine]\nx = [0, 1]'),
     r"params\.cosine: unknown family \(not in 'families'\) 'cosine'"),
    (lambda t: t.replace('channels = ["TTDspFA"]', 'channels = ["TTDspFA"]\nmetric = "nrsme"'),
     r"compare\.metric: unknown metric 'nrsme' \(did you mean 'nrmse'\?\)"),
    (lambda t: t.replace('channels = ["TTDspFA"]', 'channels = []'), r"compare\.channels: must be a non-empty"),
    (lambda t: t.replace('channels = ["TTDspFA"]', 'channels = { TTDspFA = -1.0 }'),
     r"compare\.channels\.TTDspFA: must be > 0"),
    (lambda t: t.replace('channels = ["TTDspFA"]', 'channels = ["TTDspFA"]\ntolerance = 0'),
     r"compare\.tolerance: must be > 0"),
    (lambda t: t.replace('channels = ["TTDspFA"]', 'channels = ["TTDspFA"]\nlevels = [0.01, "x"]'),
     r"compare\.levels\[1\]: must be a number"),
    (lambda t: t.replace('kind = "csv"', 'kind = "openfst"'),
     r"reference\.kind: unknown kind 'openfst' \(did you mean 'openfast'\?\)"),
    (lambda t: t.replace('kind = "csv"', 'kind = "csv"\nwindow = [10.0, 2.0]'),
     r"reference\.window: range has min > max"),
    (lambda t: t.replace('reference = "ref.csv"\n', ""), r"scene\[0\]\.reference: no reference file"),
    (lambda t: t.replace('kind = "csv"', 'kind = "internal"'),
     r"scene\[0\]\.reference: not used by an internal reference"),
    (lambda t: t.replace('kind = "csv"', 'kind = "csv"\nfamily = "fem"'),
     r"reference\.family: only used by kind = \"internal\""),
    (lambda t: t.replace('path = "scene.toml"', 'path = 3'), r"scene\[0\]\.path: must be a string"),
    (lambda t: t.replace('path = "scene.toml"', 'path = "scene.toml"\nweight = 0'),
     r"scene\[0\]\.weight: must be > 0"),
    (lambda t: t.replace('path = "scene.toml"', 'path = "scene.toml"\ndt = -0.1'), r"scene\[0\]\.dt: must be > 0"),
    (lambda t: t.replace('path = "scene.toml"', 'pth = "scene.toml"'),
     r"scene\[0\]\.pth: unknown key 'pth' \(did you mean 'path'\?\)"),
    (lambda t: t.replace("[[scene]]", "[[scenes]]"), r"scenes: unknown key 'scenes' \(did you mean 'scene'\?\)"),
    (lambda t: t.replace("[search.fields.tower_fa]", '[search]\nsampler = "cmaes"\n[search.fields.tower_fa]'),
     r"search\.sampler: unknown sampler 'cmaes'"),
    (lambda t: t.replace('families = ["clamped", "polynomial"]', 'families = ["clamped", "clamped"]'),
     r"search\.fields\.tower_fa\.families: a family is listed twice"),
    (lambda t: t + "\n[budget]\nstop_when_met = 1\n", r"budget\.stop_when_met: must be true or false"),
])
def test_errors_name_file_and_field(tmp_path, edit, pattern):
    message = error(edit(MINIMAL), tmp_path)
    assert re.search(pattern, message), message


def test_missing_sections(tmp_path):
    no_scene = MINIMAL.split("[reference]", 1)[1]
    assert re.search(r"scene: missing \[\[scene\]\]", error("[reference]" + no_scene, tmp_path))
    assert re.search(r"compare: missing table", error(MINIMAL.replace('[compare]\nchannels = ["TTDspFA"]\n', ""),
                                                      tmp_path))
    assert re.search(r"search: missing table", error(MINIMAL.split("[search")[0], tmp_path))


def test_several_scenes_need_their_own_reference(tmp_path):
    text = MINIMAL.replace('reference = "ref.csv"', "") + '\n[[scene]]\npath = "other.toml"\n'
    text = text.replace('kind = "csv"', 'kind = "csv"\npath = "ref.csv"')
    assert re.search(r"scene\[0\]\.reference: several scenes share \[reference\]\.path", error(text, tmp_path))
    text = MINIMAL + '\n[[scene]]\npath = "scene.toml"\nreference = "b.csv"\n'
    assert re.search(r"scene\[1\]\.name: scene name 'scene' used twice", error(text, tmp_path))


def test_load_study_reports_missing_file(tmp_path):
    with pytest.raises(ModeselError, match="study file not found"):
        load_study(tmp_path / "nope.toml")
