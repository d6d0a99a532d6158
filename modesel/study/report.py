"""report.html: one self-contained page answering the study's question.

`render` turns a study's ranked results (`modesel.study.results`, which
writes the page) into the HTML text; this module writes no file. The page
has no external reference at all: figures are inline SVG drawn with
matplotlib (Agg), namespace and metadata links stripped, and the style sheet
is inline. Sections: the answer (one sentence per tolerance level, e.g.
"3.5 % needs tower_fa=clamped:2 (4 DOFs, 0.012 s per simulated s); 1 % needs
tower_fa=fem:4 (8 DOFs, 0.05 s per simulated s) at 4.2 times the cost."),
the study summary, accuracy versus cost with the Pareto front, convergence
history (best error versus trial), the ranked table, time series of the
featured sets against the reference (from ``timeseries/`` in the output
folder), the chosen mode shapes and the failed trials with their reasons.
"""
from __future__ import annotations

import html
import io
import math
import re
from datetime import datetime, timezone

import numpy as np
import pandas as pd

from modesel.errors import ModeselError
from modesel.modeset import ModeSet
from modesel.study.ranking import choose, most_accurate
from modesel.study.timeseries import read_series

TABLE_ROWS = 30


# --------------------------------------------------------------------------- the answer

def _pct(x: float) -> str:
    return f"{100.0 * x:.3g} %"


def tolerance_sentences(ranked: pd.DataFrame, study) -> list[str]:
    """One sentence per tolerance level, loosest first."""
    out, base = [], None
    n_sets = int((ranked["status"] == "COMPLETE").sum()) if not ranked.empty else 0
    for level in study.compare.levels:
        row = choose(ranked, level)
        if row is None:
            best = most_accurate(ranked)
            closest = (f" (closest: {_pct(best['error'])} with {best['modeset']})"
                       if best is not None else "")
            out.append(f"{_pct(level)} is not met by any of the {n_sets} sets evaluated{closest}.")
            continue
        if base is not None and row["trial"] == base["trial"]:
            out.append(f"{_pct(level)} is met by the same set.")
            continue
        wall_per_s = row["wall_time_s"] / row["simulated_time_s"] if row["simulated_time_s"] else math.nan
        text = (f"{_pct(level)} needs {row['modeset']} ({int(row['n_dofs'])} DOFs, "
                f"{wall_per_s:.3g} s per simulated s)")
        if base is None:
            base = row
        elif base["cost"] > 0:
            text += f" at {row['cost'] / base['cost']:.3g} times the cost"
        out.append(text + ".")
    return out


# --------------------------------------------------------------------------- figures

def _svg(fig) -> str:
    import matplotlib
    import matplotlib.pyplot as plt
    buf = io.StringIO()
    with matplotlib.rc_context({"svg.fonttype": "none"}):   # text as <text>, not glyph paths
        fig.savefig(buf, format="svg", bbox_inches="tight", metadata={"Date": None})
    plt.close(fig)
    text = buf.getvalue()
    text = text[text.index("<svg"):]                               # drop <?xml ?> and DOCTYPE
    text = re.sub(r"<metadata>.*?</metadata>", "", text, flags=re.S)
    text = re.sub(r'\s+xmlns(:\w+)?="[^"]*"', "", text)            # HTML5 knows the SVG namespace
    return text


def _figure(w=7.0, h=4.0):
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    return plt.subplots(figsize=(w, h))


def pareto_figure(table: pd.DataFrame, front: pd.DataFrame, study, featured: dict) -> str:
    fig, ax = _figure()
    done = table[(table["status"] == "COMPLETE") & table["duplicate_of"].isna()]
    cost_label = {"dofs": "DOFs", "model": "cost [model s per simulated s]"}.get(
        study.search.cost, "cost [wall s per simulated s]")
    ok = done[done["meets_tolerance"]]
    bad = done[~done["meets_tolerance"]]
    ax.scatter(bad["cost"], bad["error"], s=18, color="0.6", label="trial")
    ax.scatter(ok["cost"], ok["error"], s=22, color="tab:green", label="meets tolerance")
    if not front.empty:
        ax.step(front["cost"], front["error"], where="post", color="tab:blue", lw=1.2, label="Pareto front")
    for level in study.compare.levels:
        ax.axhline(level, color="tab:red", lw=0.8, ls="--")
        ax.annotate(_pct(level), (1.0, level), xycoords=("axes fraction", "data"), fontsize=8,
                    color="tab:red", ha="right", va="bottom")
    for what, number in featured.items():
        row = done[done["trial"] == number]
        if not row.empty:
            ax.annotate(f"#{number}", (row["cost"].iloc[0], row["error"].iloc[0]), fontsize=8,
                        xytext=(4, 4), textcoords="offset points")
    _log_if_positive(ax, done["error"], "y")
    _log_if_positive(ax, done["cost"], "x")
    ax.set_xlabel(cost_label)
    ax.set_ylabel(f"error ({study.compare.metric}, worst channel)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return _svg(fig)


def _log_if_positive(ax, values, axis):
    values = pd.to_numeric(values, errors="coerce").dropna()
    if len(values) and (values > 0).all() and values.max() / values.min() > 20:
        (ax.set_yscale if axis == "y" else ax.set_xscale)("log")


def history_figure(table: pd.DataFrame, study) -> str:
    fig, ax = _figure(7.0, 3.5)
    t = table.sort_values("trial")
    done = t[t["status"] == "COMPLETE"]
    failed = t[t["status"] != "COMPLETE"]
    ax.scatter(done["trial"], done["error"], s=12, color="0.6", label="trial error")
    best = done["error"].cummin()
    ax.step(done["trial"], best, where="post", color="tab:blue", label="best so far")
    if not failed.empty and not done.empty:
        ax.scatter(failed["trial"], np.full(len(failed), done["error"].max()), marker="x", s=18,
                   color="tab:red", label="failed")
    for level in study.compare.levels:
        ax.axhline(level, color="tab:red", lw=0.8, ls="--")
    _log_if_positive(ax, done["error"], "y")
    ax.set_xlabel("trial")
    ax.set_ylabel("error")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return _svg(fig)


def series_figures(out_dir, study, featured: dict, table: pd.DataFrame) -> list[str]:
    """One figure per scene: each compared channel, reference and featured sets."""
    reference = read_series(out_dir, "reference") or {}
    labels = dict(zip(table["trial"], table["modeset"])) if not table.empty else {}
    reasons = {}
    for what, number in featured.items():
        reasons.setdefault(number, []).append(what)
    sims = {}
    for number, whats in reasons.items():
        s = read_series(out_dir, number)
        if s is not None:
            sims[number] = ("; ".join(whats), s)
    figs = []
    channels = list(study.compare.channels)
    import matplotlib.pyplot as plt
    for scene in (s.name for s in study.scenes):
        if scene not in reference and not any(scene in s for _, s in sims.values()):
            continue
        fig, axes = plt.subplots(len(channels), 1, figsize=(7.5, 2.2 * len(channels) + 0.6),
                                 sharex=True, squeeze=False)
        for ax, ch in zip(axes[:, 0], channels):
            if scene in reference and ch in reference[scene]:
                ref = reference[scene]
                ax.plot(ref["Time"], ref[ch], color="k", lw=1.6, label="reference")
            for number, (what, s) in sims.items():
                if scene in s and ch in s[scene]:
                    ax.plot(s[scene]["Time"], s[scene][ch], lw=1.0,
                            label=f"#{number} {labels.get(number, '')} ({what})")
            ax.set_ylabel(ch)
            ax.grid(True, alpha=0.3)
        axes[0, 0].set_title(f"scene {scene}", fontsize=10)
        axes[0, 0].legend(fontsize=7)
        axes[-1, 0].set_xlabel("time [s]")
        figs.append(_svg(fig))
    return figs


def shapes_figure(modeset: ModeSet, scene=None) -> tuple[str | None, list[str]]:
    """Mode shapes of `modeset` (modesel.candidates.base.mode_shapes); notes for fields not drawn."""
    from modesel.candidates.base import FieldContext, mode_shapes
    import matplotlib.pyplot as plt
    notes, drawn = [], []
    for fld, fm in modeset.fields.items():
        context = FieldContext(fld)
        turbine = getattr(scene, "turbine", None)
        if turbine is not None:
            try:
                from modesel.candidates.context import field_context
                context = field_context(turbine, fld)
            except Exception as exc:  # context is a nicety for the picture only
                notes.append(f"{fld}: default context ({exc})")
        try:
            drawn.append((fld, fm, mode_shapes(fld, fm.family, fm.count, context, **fm.params)))
        except ModeselError as exc:
            notes.append(f"{fld} ({fm.label()}): not drawn: {exc}")
    if not drawn:
        return None, notes
    fig, axes = plt.subplots(1, len(drawn), figsize=(3.2 * len(drawn) + 0.5, 3.2), squeeze=False)
    for ax, (fld, fm, shapes) in zip(axes[0], drawn):
        for k in range(shapes.count):
            ax.plot(shapes.x, shapes.phi[k], label=f"mode {k + 1}")
        ax.set_title(f"{fld}: {fm.label()}", fontsize=9)
        ax.set_xlabel("x = s/L")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    axes[0, 0].set_ylabel("phi (unit tip)")
    return _svg(fig), notes


# --------------------------------------------------------------------------- HTML

STYLE = """
body{font-family:sans-serif;max-width:70em;margin:1em auto;padding:0 1em;color:#222}
h1{font-size:1.5em}h2{font-size:1.2em;border-bottom:1px solid #ccc;margin-top:2em}
table{border-collapse:collapse;font-size:0.8em}td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}
th{background:#f0f0f0}td.l,th.l{text-align:left}.answer{font-size:1.1em;background:#eef6ee;padding:0.6em}
.note{color:#555;font-size:0.9em}svg{max-width:100%;height:auto}
"""


def _e(x) -> str:
    return html.escape(str(x))


def _fmt(v) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)) or v is pd.NA:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (float, np.floating)):
        return f"{v:.4g}"
    return str(v)


def _table(df: pd.DataFrame, columns, left=()) -> str:
    head = "".join(f"<th class='{'l' if c in left else ''}'>{_e(c)}</th>" for c in columns)
    rows = []
    for _, r in df.iterrows():
        rows.append("<tr>" + "".join(f"<td class='{'l' if c in left else ''}'>{_e(_fmt(r.get(c)))}</td>"
                                     for c in columns) + "</tr>")
    return f"<table><tr>{head}</tr>{''.join(rows)}</table>"


def render_html(study, summary: dict, sentences: list, figures: dict, notes: list, info: dict) -> str:
    table, ranked, best = summary["table"], summary["ranked"], summary["best"]
    n_total = len(table)
    n_fail = int((table["status"] != "COMPLETE").sum()) if n_total else 0
    n_dup = int(table["duplicate_of"].notna().sum()) if n_total else 0
    parts = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>modesel: {_e(study.name)}</title>"
             f"<style>{STYLE}</style></head><body>",
             f"<h1>Mode-set study {_e(study.name)}</h1>"]
    if study.description:
        parts.append(f"<p>{_e(study.description)}</p>")
    parts.append("<div class='answer'>" + "".join(f"<p>{_e(s)}</p>" for s in sentences) + "</div>")
    parts.append(f"<p>Selected ({_e(best.get('selection'))}): <b>{_e(best.get('label', '-'))}</b>"
                 f" &mdash; written to best_modeset.json.</p>")

    ref = study.reference
    ref_rows = []
    for s in study.scenes:
        source = "internal" if ref.kind == "internal" else str(s.reference)
        counts = summary.get("reference_info", {}).get(s.name, {}).get("counts")
        if counts:
            source += " (" + ", ".join(f"{f}={ref.family}:{c}" for f, c in counts.items()) + ")"
        ref_rows.append({"scene": s.name, "file": str(s.path), "weight": s.weight,
                         "tmax [s]": s.tmax, "dt [s]": s.dt, "reference": source})
    space = "; ".join(f"{fs.field}: " + ", ".join(f"{f.family} {f.min_count}-{f.max_count}"
                                                   + (" (" + ", ".join(f"{p} {lo:g}-{hi:g}" for p, (lo, hi)
                                                                       in f.params.items()) + ")"
                                                      if f.params else "")
                                                   for f in fs.families)
                      for fs in study.search.fields)
    parts += ["<h2>Study</h2><ul>",
              f"<li>study file: {_e(study.path)}</li>",
              f"<li>reference: {_e(ref.kind)}"
              + (f", window {ref.window[0]:g}-{ref.window[1]:g} s" if ref.window else "")
              + (f", time offset {ref.time_offset:g} s" if ref.time_offset else "") + "</li>",
              f"<li>channels (weight): {_e(', '.join(f'{c} ({w:g})' for c, w in study.compare.channels.items()))}</li>",
              f"<li>metric: {_e(study.compare.metric)}; tolerance {_e(_pct(study.compare.tolerance))}; "
              f"levels {_e(', '.join(_pct(x) for x in study.compare.levels))}</li>",
              f"<li>search space: {_e(space)}; sampler {_e(study.search.sampler)}; "
              f"cost {_e(study.search.cost)}</li>",
              f"<li>trials: {n_total} finished ({n_fail} failed, {n_dup} repeated sets served from the "
              f"earlier record), {len(ranked)} distinct sets</li>",
              f"<li>storage: {_e(info.get('storage_display', ''))}; study name {_e(study.name)}</li>",
              f"<li>rendered {_e(datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC'))}</li></ul>",
              _table(pd.DataFrame(ref_rows), list(ref_rows[0]), left=("scene", "file", "reference"))]

    parts.append("<h2>Accuracy versus cost</h2>")
    parts.append(figures.get("pareto", "<p class='note'>no completed trial</p>"))
    parts.append("<h2>Convergence history</h2>")
    parts.append(figures.get("history", "<p class='note'>no completed trial</p>"))

    parts.append(f"<h2>Ranked mode sets (first {TABLE_ROWS})</h2>")
    if not ranked.empty:
        cols = ["rank", "trial", "modeset", "n_dofs", "error", "worst_channel"] + \
               [f"error_{c}" for c in study.compare.channels] + \
               ["wall_time_s", "speed", "cost", "meets_tolerance", "status", "reason"]
        parts.append(_table(ranked.head(TABLE_ROWS), cols, left=("modeset", "worst_channel", "status", "reason")))

    parts.append("<h2>Time series</h2>")
    parts += figures.get("series", []) or ["<p class='note'>no stored time series</p>"]
    parts.append("<h2>Chosen mode shapes</h2>")
    parts.append(figures.get("shapes") or "<p class='note'>no shapes drawn</p>")

    failed = table[table["status"] != "COMPLETE"] if n_total else table
    if n_total and not failed.empty:
        parts.append("<h2>Failed trials</h2>")
        parts.append(_table(failed.head(TABLE_ROWS), ["trial", "modeset", "reason"],
                            left=("modeset", "reason")))
    if notes:
        parts.append("<h2>Notes</h2><ul>" + "".join(f"<li class='note'>{_e(n)}</li>" for n in notes) + "</ul>")
    parts.append("</body></html>")
    return "\n".join(parts)


def render(out_dir, study, summary: dict, sentences: list, chosen: ModeSet | None, scene, notes: list,
           info: dict) -> str:
    """The page for the results `summary` (`modesel.study.results.write_results`)
    of `study`, whose time series are stored in `out_dir`; `chosen`: the
    selected set, its shapes drawn with the turbine of `scene` (or None);
    `notes` (extended with what could not be drawn) are listed at the end."""
    table, featured = summary["table"], summary["featured"]
    figures = {}
    if not table.empty and (table["status"] == "COMPLETE").any():
        figures["pareto"] = pareto_figure(table, summary["pareto"], study, featured)
        figures["history"] = history_figure(table, study)
    figures["series"] = series_figures(out_dir, study, featured, table)
    if chosen is not None:
        svg, shape_notes = shapes_figure(chosen, scene)
        figures["shapes"] = svg
        notes += shape_notes
    return render_html(study, summary, sentences, figures, notes, info)
