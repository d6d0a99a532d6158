"""The study-file schema: every table and key, its type, default and unit.

One declaration serves two readers: the validator (`spec.py` takes each
table's allowed keys and defaults from here) and the reference document
`docs/study-file.md` (`render_reference()`; `modesel docs study-file`
prints it, and a test fails when the committed file differs), so the two
cannot drift apart.
"""
from __future__ import annotations

from dataclasses import dataclass

REQUIRED = object()   # marker: the key has no default


@dataclass(frozen=True)
class Key:
    """One key of a study-file table."""

    name: str
    type: str            # as written in TOML: string, number, integer, boolean, table, list, [low, high]
    default: object      # REQUIRED, None (= unset / "the scene's"), or the value
    unit: str            # SI unit, "-" for dimensionless, "" for text
    doc: str
    choices: tuple = ()


@dataclass(frozen=True)
class Table:
    """A TOML table (or array of tables) and its keys."""

    name: str            # dotted, e.g. "search.fields.<field>"
    doc: str
    keys: tuple
    array: bool = False  # [[name]]
    required: bool = False


REFERENCE_KINDS = ("openfast", "csv", "internal")
SAMPLER_NAMES = ("tpe", "nsga2", "random", "fieldwise")
COST_NAMES = ("wall_time", "dofs", "model")

TABLES = (
    Table("study", "What the study is called.", (
        Key("name", "string", None, "", "study name: letters, digits, '-', '_' and '.'; "
            "default: the study file name without .toml"),
        Key("description", "string", "", "", "one line shown in the report"),
    )),
    Table("scene", "One entry per scene of the load case (at least one).", (
        Key("path", "string", REQUIRED, "", "scene TOML, ElastoDyn main .dat or OpenFAST .fst, relative to the study file"),
        Key("name", "string", None, "", "default: the file name without extension; same rules as [study].name"),
        Key("weight", "number", 1.0, "-", "weight of this scene in the load case, > 0"),
        Key("tmax", "number", None, "s", "simulated time; default: the scene's"),
        Key("dt", "number", None, "s", "output step; default: the scene's"),
        Key("reference", "string", None, "", "this scene's reference file; default: [reference].path"),
    ), array=True, required=True),
    Table("reference", "The response each mode set must reproduce.", (
        Key("kind", "string", "internal", "", "openfast (.out/.outb), csv (a Time column in s and "
            "channel columns), or internal (a converged model of the same engine)", REFERENCE_KINDS),
        Key("path", "string", None, "", "reference file for a single-scene study, relative to the study file"),
        Key("channels", "table", None, "", "simulation channel = reference channel (default: same name); "
            "a leading '-' negates the reference channel"),
        Key("time_offset", "number", 0.0, "s", "added to the reference time before comparing"),
        Key("window", "[low, high]", None, "s", "comparison window in simulation time; default: the overlap"),
        Key("family", "string", "fem", "", "internal reference: the family whose count is raised until converged"),
        Key("tolerance", "number", 0.001, "-", "internal reference: nrmse change between successive counts "
            "that counts as converged (0.001 = 0.1 %)"),
        Key("start_count", "integer", 1, "-", "internal reference: first count tried"),
        Key("max_count", "integer", 10, "-", "internal reference: last count tried"),
    )),
    Table("compare", "How a simulated response is compared with the reference.", (
        Key("channels", "list or table", REQUIRED, "", "channels to compare (OpenFAST names), a list "
            "(weights 1) or a table channel = weight (> 0)"),
        Key("metric", "string", "nrmse", "-", "error metric, see Metrics below", ()),
        Key("tolerance", "number", 0.035, "-", "worst weighted channel error allowed, as a fraction "
            "(0.035 = 3.5 %, the second paper's tolerance)"),
        Key("levels", "list", None, "-", "further tolerance levels reported (\"1 % costs K times\"), fractions"),
        Key("periodic", "table", None, "", "parameters of metric = \"periodic\" (next table)"),
    ), required=True),
    Table("compare.periodic", "Parameters of the periodic metric (only with metric = \"periodic\"): the "
          "response in periodic operation compared through its mean and azimuth harmonics.", (
        Key("last_s", "number", None, "s", "compare the last last_s seconds; default: the whole window"),
        Key("harmonics", "integer", 3, "-", "number H of azimuth harmonics compared"),
    )),
    Table("search", "What is searched and how.", (
        Key("fields", "table", REQUIRED, "", "one table per searched field (below); other fields keep the scene's modes"),
        Key("sampler", "string", "tpe", "", "Optuna sampler, seeded: tpe, nsga2, random, or fieldwise "
            "(structured: coordinate descent, one field at a time from the best set so far, counts in "
            "increasing order, each channel's error attributed to every field that moves it; then the "
            "combinations predicted to meet each level, cheapest first; modesel.study.search.structured)", SAMPLER_NAMES),
        Key("cost", "string", "wall_time", "", "cost objective: wall_time (wall seconds per simulated second), "
            "model (right-hand-side evaluations x calibrated unit cost per simulated second: "
            "deterministic) or dofs (number of degrees of freedom)", COST_NAMES),
    ), required=True),
    Table("search.fields.<field>", "The families and counts searched for one flexible field "
          "(tower_fa, tower_ss, tower_torsion, blade_flap, blade_edge).", (
        Key("families", "list", REQUIRED, "", "family names, see Families below"),
        Key("min_count", "integer", 1, "-", "fewest modes per family"),
        Key("max_count", "integer", 4, "-", "most modes per family; capped by each family's own maximum"),
        Key("params", "table", None, "", "per family, ranges of its shape parameters (next table)"),
    )),
    Table("search.fields.<field>.params.<family>", "Ranges searched for a family's shape parameters.", (
        Key("<parameter>", "[low, high]", None, "see Families", "continuous range, inside the family's allowed range"),
    )),
    Table("budget", "When the search stops.", (
        Key("n_trials", "integer", 100, "-", "most trials (mode sets evaluated)"),
        Key("timeout_s", "number", None, "s", "wall-clock limit of the search"),
        Key("stop_when_met", "boolean", True, "", "stop once a set meets the tolerance ..."),
        Key("keep_searching_trials", "integer", 0, "-", "... after this many more trials looked for a cheaper one"),
    )),
    Table("run", "Where and how the search runs.", (
        Key("n_jobs", "integer", 1, "-", "parallel worker processes"),
        Key("storage", "string", None, "", "SQLAlchemy URL (e.g. postgresql://user@host:port/db) or a journal "
            "file path relative to the study file; default: study.journal in the output folder"),
        Key("seed", "integer", 0, "-", "seed of the sampler"),
    )),
)

TOP_LEVEL = ("study", "scene", "reference", "compare", "search", "budget", "run")


def table(name: str) -> Table:
    """The declared table `name` (dotted, with <field>/<family> placeholders)."""
    for t in TABLES:
        if t.name == name:
            return t
    raise KeyError(name)


def keys(name: str) -> tuple:
    """Allowed key names of table `name`, in declaration order."""
    return tuple(k.name for k in table(name).keys)


def default(table_name: str, key: str):
    """Declared default of `key` in `table_name` (REQUIRED if it has none)."""
    for k in table(table_name).keys:
        if k.name == key:
            return k.default
    raise KeyError(f"{table_name}.{key}")


def _default_text(value) -> str:
    if value is REQUIRED:
        return "required"
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"' if value else '""'
    return repr(value)


def render_reference() -> str:
    """Markdown reference of the study file: tables and keys, metrics, families."""
    from modesel.candidates.base import families
    from modesel.study.metrics import METRICS

    out = ["# Study-file reference", "",
           "Generated from `modesel/study/schema.py`, the schema the validator uses "
           "(`modesel docs study-file` prints it; a test fails if this file differs). "
           "Paths are relative to the study file. Every key is checked: an unknown key, a wrong "
           "type or an out-of-range value is a one-line error naming the file and the dotted key.", ""]
    for t in TABLES:
        head = f"[[{t.name}]]" if t.array else f"[{t.name}]"
        out += [f"## `{head}`" + (" (required)" if t.required else ""), "", t.doc, "",
                "| key | type | default | unit | meaning |", "|---|---|---|---|---|"]
        for k in t.keys:
            doc = k.doc + (f" ({', '.join(k.choices)})" if k.choices else "")
            if k.name == "metric" and t.name == "compare":
                doc += f" ({', '.join(METRICS)})"
            out.append(f"| `{k.name}` | {k.type} | {_default_text(k.default)} | {k.unit or ''} | {doc} |")
        out.append("")
    out += ["## Metrics", "",
            "Every metric is a dimensionless error (0 = perfect match) compared with `[compare].tolerance`. "
            "R is the reference, S the simulation, <.> the time average over the window "
            "(trapezoidal rule), range R = max R - min R.", "",
            "| metric | formula | meaning |", "|---|---|---|"]
    for m in METRICS.values():
        formula = m.formula.replace("|", "\\|")
        out.append(f"| `{m.name}` | {f'`{formula}`' if formula else ''} | {m.description} |")
    out += ["", "## Families", "",
            "Counts are capped by each family's maximum. Parameters can be searched within "
            "`[search.fields.<field>.params.<family>]` ranges inside the allowed range.", "",
            "| family | fields | most modes | parameters: default [allowed range] |", "|---|---|---|---|"]
    for fam in sorted(families(), key=lambda f: f.name):
        params = "; ".join(f"`{p.name}` = {p.default:g} [{p.low:g}, {p.high:g}]"
                           + (f": {p.description}" if p.description else "") for p in fam.parameters)
        top = "any" if fam.max_count is None else str(fam.max_count)
        out.append(f"| `{fam.name}` | {', '.join(fam.fields)} | {top} | {params or '-'} |")
    out.append("")
    return "\n".join(out)
