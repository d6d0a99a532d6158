"""Study file: the question `modesel run` answers, as TOML.

"Which mode set reproduces my reference within tolerance at the lowest cost,
and what does more accuracy cost?" A study names the load case (one or more
scenes), the reference to match, how to compare, which families and counts to
search per flexible field, and the budget. Paths are relative to the study
file. Every key is checked: an unknown key, a wrong type, a count < 1, a range
with min > max or an unknown family is a `ModeselError` naming the study file
and the dotted field (e.g. ``search.fields.tower_fa.max_count``).

Example (every key shown; only [[scene]], [compare].channels and
[search.fields.*] are required)::

    [study]
    name = "nrel5mw-free-decay"        # default: the study file name without .toml
    description = "tower free decay"

    [[scene]]                          # one per scene of the load case
    path = "scenes/free_decay.toml"    # scene TOML or ElastoDyn main .dat/.fst
    reference = "ref/free_decay.outb"  # this scene's reference file (default [reference].path)
    name = "free_decay"                # default: file name without extension
    weight = 1.0                       # > 0; weight of this scene in the load case
    tmax = 20.0                        # [s] default: the scene's
    dt = 0.05                          # [s] output step, default: the scene's

    [reference]
    kind = "openfast"                  # "openfast" (.out/.outb) | "csv" | "internal"
    path = "ref/free_decay.outb"       # single-scene studies may give it here
    time_offset = 0.0                  # [s] added to the reference time before comparing
    window = [5.0, 20.0]               # [s] comparison window in simulation time
                                       # (default: where simulation and reference overlap)
    [reference.channels]               # simulation name = reference name (default: same);
    TTDspFA = "TTDspFA"                # a leading "-" negates the reference channel, e.g.
    TTDspSS = "-Q_TSS1"                # ElastoDyn's Q_TSS1 displaces along -y
    # kind = "internal": a converged reference from the same engine, raising
    # the count of `family` per active field until the response changes by
    # less than `tolerance` (nrmse) between successive counts:
    # family = "fem"; tolerance = 0.001; start_count = 1; max_count = 10

    [compare]
    channels = { TTDspFA = 1.0, TTDspSS = 1.0 }  # channel = weight, or a list (weights 1)
    metric = "nrmse"                   # see modesel.study.metrics (nrmse, max_abs, mean,
                                       # amplitude, frequency, r2, periodic)
    # with metric = "periodic" (against rotor azimuth), its parameters:
    # [compare.periodic]
    # last_s = 30.0                    # [s] compare the last 30 s of the window (default: all)
    # harmonics = 3                    # mean + this many azimuth harmonics (default 3)
    tolerance = 0.035                  # worst weighted channel error allowed (3.5 %, paper 2)
    levels = [0.035, 0.01]             # extra tolerance levels reported ("1 % costs K times")

    [search]
    sampler = "tpe"                    # "tpe" | "nsga2" | "random" | "fieldwise" (structured), seeded
    cost = "model"                     # "model" (deterministic: right-hand-side evaluations x
                                       # calibrated unit cost, s per simulated s) |
                                       # "wall_time" (measured wall s per simulated s) | "dofs"

    [search.fields.tower_fa]           # one table per searched field; others keep the scene default
    families = ["clamped", "relaxed_root"]   # see `modesel candidates`
    min_count = 1                      # default 1
    max_count = 4                      # default 4; capped by each family's own maximum
    [search.fields.tower_fa.params.relaxed_root]
    free_end_weight = [0.0, 0.5]       # continuous range [low, high] searched for this family

    [budget]
    n_trials = 100                     # default 100
    timeout_s = 3600.0                 # default: none
    stop_when_met = true               # stop once a set meets the tolerance ...
    keep_searching_trials = 20         # ... and this many more trials looked for a cheaper one

    [run]
    n_jobs = 1                         # parallel worker processes
    storage = "postgresql://user@host/db"  # SQLAlchemy URL or journal file path (relative to
                                       # this file); default: study.journal in the output folder
    seed = 0
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import re
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path

from modesel.errors import ModeselError, unknown_name
from modesel.modeset import FIELDS

from modesel.study import schema
from modesel.study.schema import COST_NAMES, REFERENCE_KINDS, SAMPLER_NAMES  # noqa: F401  (re-exported)

D = schema.default   # D(table, key): the declared default (allowed keys and defaults come from schema.py)


@dataclass(frozen=True)
class SceneSpec:
    """One scene of the load case. `tmax`, `dt` [s] None = the scene's own."""

    path: Path
    name: str
    weight: float = 1.0
    tmax: float | None = None
    dt: float | None = None
    reference: Path | None = None


@dataclass(frozen=True)
class ReferenceSpec:
    """Where the reference response comes from and how it lines up in time.

    `channels` maps simulation channel -> reference channel. `time_offset` [s]
    is added to the reference time; `window` (t0, t1) [s] restricts the
    comparison (simulation time). The `family`, `tolerance`, `start_count`,
    `max_count` settings drive the `internal` (converged) reference.
    """

    kind: str = "internal"
    path: Path | None = None
    channels: dict = field(default_factory=dict)
    time_offset: float = 0.0
    window: tuple | None = None
    family: str = "fem"
    tolerance: float = 0.001
    start_count: int = 1
    max_count: int = 10

    def reference_name(self, channel: str) -> str:
        return self.channels.get(channel, channel)


@dataclass(frozen=True)
class CompareSpec:
    """Channels (with weights), metric, tolerance and report levels (sorted loosest first)."""

    channels: dict
    metric: str = "nrmse"
    tolerance: float = 0.035
    levels: tuple = (0.035,)
    metric_params: dict = field(default_factory=dict)   # periodic: last_s [s], harmonics


@dataclass(frozen=True)
class FamilySpace:
    """Counts min_count..max_count of `family`, and ranges {param: (low, high)}."""

    family: str
    min_count: int
    max_count: int
    params: dict = field(default_factory=dict)


@dataclass(frozen=True)
class FieldSpace:
    field: str
    families: tuple  # of FamilySpace

    def family(self, name: str) -> FamilySpace:
        return next(f for f in self.families if f.family == name)


@dataclass(frozen=True)
class SearchSpec:
    fields: tuple  # of FieldSpace, in modeset.FIELDS order
    sampler: str = "tpe"
    cost: str = "wall_time"


@dataclass(frozen=True)
class BudgetSpec:
    n_trials: int = 100
    timeout_s: float | None = None
    stop_when_met: bool = True
    keep_searching_trials: int = 0


@dataclass(frozen=True)
class RunSpec:
    n_jobs: int = 1
    storage: str | None = None
    seed: int = 0


@dataclass(frozen=True)
class Study:
    """A parsed, validated study file."""

    path: Path
    name: str
    description: str
    scenes: tuple
    reference: ReferenceSpec
    compare: CompareSpec
    search: SearchSpec
    budget: BudgetSpec
    run: RunSpec
    text: str = ""

    def criterion(self):
        from modesel.study.metrics import Criterion
        return Criterion(self.compare.metric, self.compare.tolerance, dict(self.compare.channels))

    def fingerprint(self) -> str:
        """Hash of everything that changes a trial's recorded values (scenes,
        reference, channels and weights, metric, search space, cost). Not the
        tolerance, levels, budget or run settings: those may change on resume.
        Paths enter relative to the study file, so machines with the same
        layout agree."""
        base = self.path.parent

        def plain(obj):
            data = asdict(obj)
            for key in ("path", "reference"):
                if isinstance(data.get(key), Path):
                    data[key] = os.path.relpath(data[key], base)
            return data

        data = {"scenes": [plain(s) for s in self.scenes], "reference": plain(self.reference),
                "channels": self.compare.channels, "metric": self.compare.metric,
                **({"metric_params": self.compare.metric_params} if self.compare.metric_params else {}),
                "fields": asdict(self.search)["fields"], "cost": self.search.cost}
        text = json.dumps(data, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


# --------------------------------------------------------------------------- parsing helpers

_SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]{0,99}")


def safe_name(value: str, *, file: str, field: str) -> str:
    """`value` when it can name files and folders: 1-100 letters, digits or
    ``_ . + -``, starting with a letter or digit, no ``..`` (so no path
    separator and no way out of the output folder); else a one-line error."""
    if not _SAFE_NAME.fullmatch(value) or ".." in value:
        raise ModeselError(f"must be 1-100 letters, digits or '_.+-', starting with a letter or digit "
                           f"and without '..' (it names files and folders), got {value!r}",
                           file=file, field=field)
    return value


def slug(text: str) -> str:
    """A safe name made from a file name (unsafe characters become '_')."""
    name = re.sub(r"[^A-Za-z0-9_.+-]", "_", text).replace("..", "_")[:100].lstrip("._+-")
    return name or "study"

class _Reader:
    """Typed access to one TOML table with the study file and dotted path in every error."""

    def __init__(self, data, where: str, file: str):
        self.file = file
        self.where = where
        if not isinstance(data, dict):
            raise self.error(f"must be a table, got {type(data).__name__}")
        self.data = data

    def at(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def error(self, message: str, key: str | None = None) -> ModeselError:
        return ModeselError(message, file=self.file, field=self.at(key) if key else self.where or None)

    def allow(self, *keys: str) -> None:
        for key in self.data:
            if key not in keys:
                raise unknown_name("key", key, keys, file=self.file, field=self.at(key))

    def table(self, key: str, required: bool = False) -> "_Reader":
        if key not in self.data:
            if required:
                raise self.error("missing table", key)
            return _Reader({}, self.at(key), self.file)
        return _Reader(self.data[key], self.at(key), self.file)

    def string(self, key: str, default=None, choices=None, required=False):
        if key not in self.data:
            if required:
                raise self.error("missing", key)
            return default
        value = self.data[key]
        if not isinstance(value, str):
            raise self.error(f"must be a string, got {value!r}", key)
        if choices is not None and value not in choices:
            raise unknown_name(key.replace("_", " "), value, choices, file=self.file, field=self.at(key))
        return value

    def number(self, key: str, default=None, *, integer=False, low=None, positive=False,
               required=False, value=None, where=None):
        if value is None:
            if key not in self.data:
                if required:
                    raise self.error("missing", key)
                return default
            value = self.data[key]
        where = where or key
        kind = "an integer" if integer else "a number"
        if isinstance(value, bool) or not isinstance(value, (int, float)) or (
                integer and not isinstance(value, int)):
            raise self.error(f"must be {kind}, got {value!r}", where)
        if not math.isfinite(value):
            raise self.error(f"must be finite, got {value!r}", where)
        if positive and not value > 0:
            raise self.error(f"must be > 0, got {value!r}", where)
        if low is not None and value < low:
            raise self.error(f"must be >= {low}, got {value!r}", where)
        return value if integer else float(value)

    def boolean(self, key: str, default: bool) -> bool:
        value = self.data.get(key, default)
        if not isinstance(value, bool):
            raise self.error(f"must be true or false, got {value!r}", key)
        return value

    def pair(self, key: str, value=None, where=None) -> tuple:
        """[low, high] with low <= high."""
        value = self.data.get(key) if value is None else value
        where = where or key
        if not isinstance(value, list) or len(value) != 2:
            raise self.error(f"must be a [low, high] pair, got {value!r}", where)
        low, high = (self.number(key, value=v, where=where) for v in value)
        if low > high:
            raise self.error(f"range has min > max: [{low:g}, {high:g}]", where)
        return (low, high)

    def path(self, key: str, base: Path, required=False):
        text = self.string(key, required=required)
        return None if text is None else (base / text).resolve()


# --------------------------------------------------------------------------- sections

def _scenes(data, file: str, base: Path) -> tuple:
    if "scene" not in data:
        raise ModeselError("missing [[scene]]: a study needs at least one scene", file=file, field="scene")
    entries = data["scene"]
    if not isinstance(entries, list) or not entries:
        raise ModeselError("must be an array of tables [[scene]] with at least one entry",
                           file=file, field="scene")
    scenes, names = [], set()
    for i, entry in enumerate(entries):
        r = _Reader(entry, f"scene[{i}]", file)
        r.allow(*schema.keys("scene"))
        path = r.path("path", base, required=True)
        name = r.string("name")
        name = slug(path.stem) if name is None else safe_name(name, file=file, field=r.at("name"))
        if name in names:
            raise r.error(f"scene name '{name}' used twice; give each scene a distinct name", "name")
        names.add(name)
        scenes.append(SceneSpec(
            path=path, name=name, weight=r.number("weight", D("scene", "weight"), positive=True),
            tmax=r.number("tmax", positive=True), dt=r.number("dt", positive=True),
            reference=r.path("reference", base)))
    return tuple(scenes)


def _reference(r: _Reader, base: Path, scenes: tuple) -> tuple[ReferenceSpec, tuple]:
    r.allow(*schema.keys("reference"))
    kind = r.string("kind", default=D("reference", "kind"), choices=REFERENCE_KINDS)
    channels_r = r.table("channels")
    channels = {}
    for sim_name in channels_r.data:
        channels[sim_name] = channels_r.string(sim_name)
    family = r.string("family", default=D("reference", "family"))
    start = r.number("start_count", D("reference", "start_count"), integer=True, low=1)
    max_count = r.number("max_count", D("reference", "max_count"), integer=True, low=1)
    if max_count < start:
        raise r.error(f"range has min > max: start_count={start} > max_count={max_count}", "max_count")
    spec = ReferenceSpec(
        kind=kind, path=r.path("path", base), channels=channels,
        time_offset=r.number("time_offset", D("reference", "time_offset")),
        window=r.pair("window") if "window" in r.data else None,
        family=family, tolerance=r.number("tolerance", D("reference", "tolerance"), positive=True),
        start_count=start, max_count=max_count)
    if kind == "internal":
        for key in ("path", "channels", "time_offset"):
            if key in r.data:
                raise r.error(f"not used by an internal reference (kind = \"internal\")", key)
        for i, s in enumerate(scenes):
            if s.reference is not None:
                raise ModeselError("not used by an internal reference (kind = \"internal\")",
                                   file=r.file, field=f"scene[{i}].reference")
        _family(family, r, "family")
        scenes_out = scenes
    else:
        for key in ("family", "tolerance", "start_count", "max_count"):
            if key in r.data:
                raise r.error(f"only used by kind = \"internal\", this reference is \"{kind}\"", key)
        scenes_out = []
        for i, s in enumerate(scenes):
            ref_path = s.reference or spec.path
            if ref_path is None:
                raise ModeselError(f"no reference file for scene '{s.name}': set [reference].path "
                                   f"or scene[{i}].reference", file=r.file, field=f"scene[{i}].reference")
            if s.reference is None and len(scenes) > 1:
                raise ModeselError(f"several scenes share [reference].path; give scene '{s.name}' "
                                   f"its own reference", file=r.file, field=f"scene[{i}].reference")
            scenes_out.append(SceneSpec(s.path, s.name, s.weight, s.tmax, s.dt, ref_path))
        scenes_out = tuple(scenes_out)
    return spec, scenes_out


def _compare(r: _Reader) -> CompareSpec:
    from modesel.study.metrics import METRICS
    r.allow(*schema.keys("compare"))
    if "channels" not in r.data:
        raise r.error("missing: list the channels to compare, e.g. channels = [\"TTDspFA\"]", "channels")
    raw = r.data["channels"]
    if isinstance(raw, list):
        if not raw or not all(isinstance(c, str) for c in raw):
            raise r.error(f"must be a non-empty list of channel names or a table "
                          f"{{channel = weight}}, got {raw!r}", "channels")
        if len(set(raw)) != len(raw):
            raise r.error("a channel is listed twice", "channels")
        channels = {c: 1.0 for c in raw}
    elif isinstance(raw, dict) and raw:
        cr = r.table("channels")
        channels = {c: cr.number(c, positive=True) for c in raw}
    else:
        raise r.error(f"must be a non-empty list of channel names or a table {{channel = weight}}, "
                      f"got {raw!r}", "channels")
    metric = r.string("metric", default=D("compare", "metric"), choices=tuple(METRICS))
    tolerance = r.number("tolerance", D("compare", "tolerance"), positive=True)
    levels = [tolerance]
    if "levels" in r.data:
        raw_levels = r.data["levels"]
        if not isinstance(raw_levels, list):
            raise r.error(f"must be a list of tolerances, got {raw_levels!r}", "levels")
        levels += [r.number("levels", value=v, positive=True, where=f"levels[{i}]")
                   for i, v in enumerate(raw_levels)]
    levels = tuple(sorted(set(levels), reverse=True))
    params = {}
    if "periodic" in r.data:
        if metric != "periodic":
            raise r.error(f"only used by metric = \"periodic\", the metric is \"{metric}\"", "periodic")
        pr = r.table("periodic")
        pr.allow(*schema.keys("compare.periodic"))
        params = {"last_s": pr.number("last_s", D("compare.periodic", "last_s"), positive=True),
                  "harmonics": pr.number("harmonics", D("compare.periodic", "harmonics"), integer=True, low=1)}
    elif metric == "periodic":
        params = {"last_s": D("compare.periodic", "last_s"), "harmonics": D("compare.periodic", "harmonics")}
    return CompareSpec(channels, metric, tolerance, levels, params)


def _family(name: str, r: _Reader, key: str):
    from modesel.candidates.base import get_family
    try:
        return get_family(name)
    except ModeselError as exc:
        raise ModeselError(exc.message, file=r.file, field=r.at(key)) from None


def _search(r: _Reader) -> SearchSpec:
    r.allow(*schema.keys("search"))
    fields_r = r.table("fields", required=True)
    for name in fields_r.data:
        if name not in FIELDS:
            raise unknown_name("field", name, FIELDS, file=r.file, field=fields_r.at(name))
    if not fields_r.data:
        raise fields_r.error("no field to search: add e.g. [search.fields.tower_fa]")
    spaces = []
    for name in (f for f in FIELDS if f in fields_r.data):
        fr = fields_r.table(name)
        fr.allow(*schema.keys("search.fields.<field>"))
        fams = fr.data.get("families")
        if not isinstance(fams, list) or not fams or not all(isinstance(f, str) for f in fams):
            raise fr.error(f"must be a non-empty list of family names, got {fams!r}", "families")
        if len(set(fams)) != len(fams):
            raise fr.error("a family is listed twice", "families")
        min_count = fr.number("min_count", D("search.fields.<field>", "min_count"), integer=True, low=1)
        max_count = fr.number("max_count", D("search.fields.<field>", "max_count"), integer=True, low=1)
        if min_count > max_count:
            raise fr.error(f"range has min > max: min_count={min_count} > max_count={max_count}",
                           "max_count")
        params_r = fr.table("params")
        for fam_name in params_r.data:
            if fam_name not in fams:
                raise unknown_name("family (not in 'families')", fam_name, fams, file=r.file,
                                   field=params_r.at(fam_name))
        families = []
        for i, fam_name in enumerate(fams):
            fam = _family(fam_name, fr, f"families[{i}]")
            if name not in fam.fields:
                raise fr.error(f"family '{fam_name}' does not describe field '{name}' "
                               f"(it describes {', '.join(fam.fields)})", f"families[{i}]")
            cap = fam.max_count_for(name)      # the family's own maximum for this field
            top = max_count if cap is None else min(max_count, cap)
            if top < min_count:
                raise fr.error(f"family '{fam_name}' provides at most {cap} modes, "
                               f"below min_count={min_count}", f"families[{i}]")
            pr = params_r.table(fam_name)
            known = {p.name: p for p in fam.parameters}
            ranges = {}
            for pname in pr.data:
                if pname not in known:
                    raise unknown_name(f"parameter of family '{fam_name}'", pname,
                                       known or ["(none)"], file=r.file, field=pr.at(pname))
                low, high = pr.pair(pname)
                p = known[pname]
                if low < p.low or high > p.high:
                    raise pr.error(f"range [{low:g}, {high:g}] leaves the family's allowed "
                                   f"[{p.low:g}, {p.high:g}]", pname)
                ranges[pname] = (low, high)
            families.append(FamilySpace(fam_name, min_count, top, ranges))
        spaces.append(FieldSpace(name, tuple(families)))
    return SearchSpec(tuple(spaces), r.string("sampler", D("search", "sampler"), SAMPLER_NAMES),
                      r.string("cost", D("search", "cost"), COST_NAMES))


def _budget(r: _Reader) -> BudgetSpec:
    r.allow(*schema.keys("budget"))
    return BudgetSpec(
        n_trials=r.number("n_trials", D("budget", "n_trials"), integer=True, low=1),
        timeout_s=r.number("timeout_s", D("budget", "timeout_s"), positive=True),
        stop_when_met=r.boolean("stop_when_met", D("budget", "stop_when_met")),
        keep_searching_trials=r.number("keep_searching_trials", D("budget", "keep_searching_trials"),
                                       integer=True, low=0))


def _run(r: _Reader, base: Path) -> RunSpec:
    r.allow(*schema.keys("run"))
    storage = r.string("storage")
    if storage is not None and "://" not in storage:   # a journal file, relative to the study file
        storage = str((base / storage).resolve())
    return RunSpec(n_jobs=r.number("n_jobs", D("run", "n_jobs"), integer=True, low=1),
                   storage=storage, seed=r.number("seed", D("run", "seed"), integer=True, low=0))


# --------------------------------------------------------------------------- front

def parse_study(text: str, path: str | Path) -> Study:
    """Parse study TOML `text` as if read from `path` (relative paths resolve from there)."""
    path = Path(path).resolve()
    file = str(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModeselError(f"not valid TOML: {exc}", file=file) from None
    top = _Reader(data, "", file)
    top.allow(*schema.TOP_LEVEL)
    meta = top.table("study")
    meta.allow(*schema.keys("study"))
    base = path.parent
    scenes = _scenes(data, file, base)
    reference, scenes = _reference(top.table("reference"), base, scenes)
    compare = _compare(top.table("compare", required=True))
    search = _search(top.table("search", required=True))
    name = meta.string("name")
    name = slug(path.stem) if name is None else safe_name(name, file=file, field=meta.at("name"))
    return Study(path=path, name=name,
                 description=meta.string("description", default=D("study", "description")), scenes=scenes,
                 reference=reference, compare=compare, search=search,
                 budget=_budget(top.table("budget")), run=_run(top.table("run"), base), text=text)


def load_study(path: str | Path) -> Study:
    """Read and validate a study file."""
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise ModeselError("study file not found", file=str(path)) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ModeselError(f"cannot read study file: {exc}", file=str(path)) from None
    return parse_study(text, path)
