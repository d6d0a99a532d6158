"""report.html: one self-contained page answering the study's question.

`render` turns a study's ranked results (`modesel.study.results`, which
writes the page) into the HTML text; this module writes no file. The page
has no external reference at all: figures are inline SVG drawn with
matplotlib (Agg), namespace and metadata links stripped, and the style sheet
is inline. Sections: the answer (one sentence per tolerance level, e.g.
"3.5 % needs tower_fa=clamped:2 (4 DOFs, 0.012 s per simulated s); 1 % needs
tower_fa=fem:4 (8 DOFs, 0.05 s per simulated s) at 4.2 times the cost."),
the study summary, accuracy (error in %) versus cost with the Pareto front
(every point an SVG <title>: trial, set, error, cost), convergence history,
the ranked table (failed trials marked, with their reason), time series of
the featured sets against the reference (tower-top panels, one row per
blade, then the other channels; from ``timeseries/``), the error of those
sets over time, a Campbell diagram of the chosen set for a scene that turns
a rotor (`campbell_figure`, also `modesel linearize --plot`), the chosen
mode shapes and the failed trials with their reasons. Every axis carries a
unit (`_unit`: model/outputs.py `channel_unit`), legends sit below the data,
tables and figures sit in boxes that scroll sideways inside a 1300 px page.
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
CAMPBELL_POINTS = 5      # rotor speeds of the report's Campbell sweep, 0 to 1.2 x the scene's


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
        kind = getattr(getattr(study, "search", None), "cost", "wall_time")
        if kind == "model":      # the ranked cost first, the measured wall time for information
            cost = f"model cost {row['cost']:.3g} s per simulated s, measured {wall_per_s:.3g} s"
        else:
            cost = f"{wall_per_s:.3g} s per simulated s"
        text = f"{_pct(level)} needs {row['modeset']} ({int(row['n_dofs'])} DOFs, {cost})"
        if base is None:
            base = row
        elif base["cost"] > 0:
            text += f" at {row['cost'] / base['cost']:.3g} times the {'model ' if kind == 'model' else ''}cost"
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


def standalone_svg(svg: str) -> str:
    """An inline figure (`_svg`) as a standalone .svg file: with the XML
    namespaces that HTML5 leaves implicit."""
    return svg.replace("<svg ", '<svg xmlns="http://www.w3.org/2000/svg" '
                       'xmlns:xlink="http://www.w3.org/1999/xlink" ', 1)


def _figure(w=7.0, h=4.0):
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    return plt.subplots(figsize=(w, h))


def _unit(channel: str) -> str:
    """'TTDspFA [m]': a channel name with its unit (model/outputs.py `channel_unit`)."""
    from modesel.model.outputs import channel_unit
    unit = channel_unit(channel)
    return f"{channel} [{unit}]" if unit else f"{channel} [-]"


def _legend_below(fig, ax=None, ncol=2, fontsize=8):
    """Legend outside the data: centred under the figure."""
    handles, labels = (ax or fig.axes[0]).get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=ncol,
                   fontsize=fontsize, frameon=False)


def _cost_label(study) -> str:
    return {"dofs": "DOFs [-]", "model": "cost [model s per simulated s]"}.get(
        study.search.cost, "cost [wall s per simulated s]")


def pareto_figure(table: pd.DataFrame, front: pd.DataFrame, study, featured: dict) -> str:
    """Error [%] versus cost of every completed set; each point carries an SVG
    <title> (trial, set, error, cost) shown on hover; featured sets are labelled."""
    fig, ax = _figure()
    done = table[(table["status"] == "COMPLETE") & table["duplicate_of"].isna()]
    titles = {}
    for _, r in done.iterrows():
        gid = f"trial-{int(r['trial'])}"
        ax.plot([r["cost"]], [100.0 * r["error"]], "o", ms=5 if r["meets_tolerance"] else 4,
                color="tab:green" if r["meets_tolerance"] else "0.6", gid=gid)
        titles[gid] = (f"#{int(r['trial'])} {r['modeset']}: error {_pct(r['error'])}, "
                       f"cost {r['cost']:.4g}" + ("" if study.search.cost == "dofs" else " s/s")
                       + f", {int(r['n_dofs']) if not pd.isna(r['n_dofs']) else '?'} DOFs")
    ax.plot([], [], "o", color="0.6", label="trial (hover a point: trial and set)")
    ax.plot([], [], "o", color="tab:green", label="meets tolerance")
    if not front.empty:
        ax.step(front["cost"], 100.0 * front["error"], where="post", color="tab:blue", lw=1.2,
                label="Pareto front")
    for level in study.compare.levels:
        ax.axhline(100.0 * level, color="tab:red", lw=0.8, ls="--")
        ax.annotate(_pct(level), (1.0, 100.0 * level), xycoords=("axes fraction", "data"), fontsize=8,
                    color="tab:red", ha="right", va="bottom")
    labelled = set()
    for what, number in featured.items():
        row = done[done["trial"] == number]
        if not row.empty and number not in labelled:
            labelled.add(number)
            ax.annotate(f"#{number}", (row["cost"].iloc[0], 100.0 * row["error"].iloc[0]), fontsize=8,
                        xytext=(4, 4), textcoords="offset points")
    _log_if_positive(ax, done["error"], "y")
    _log_if_positive(ax, done["cost"], "x")
    ax.set_xlabel(_cost_label(study))
    ax.set_ylabel(f"error [%] ({study.compare.metric}, worst channel)")
    ax.grid(True, which="both", alpha=0.3)
    _legend_below(fig, ax, ncol=3)
    return _with_titles(_svg(fig), titles)


def _with_titles(svg: str, titles: dict) -> str:
    """Insert <title> text as the first child of each <g id="gid"> of `svg`."""
    for gid, text in titles.items():
        svg = svg.replace(f'<g id="{gid}">', f'<g id="{gid}"><title>{html.escape(text)}</title>', 1)
    return svg


def _log_if_positive(ax, values, axis):
    values = pd.to_numeric(values, errors="coerce").dropna()
    if len(values) and (values > 0).all() and values.max() / values.min() > 20:
        (ax.set_yscale if axis == "y" else ax.set_xscale)("log")


def history_figure(table: pd.DataFrame, study) -> str:
    fig, ax = _figure(7.0, 3.5)
    t = table.sort_values("trial")
    done = t[t["status"] == "COMPLETE"]
    failed = t[t["status"] != "COMPLETE"]
    ax.scatter(done["trial"], 100.0 * done["error"], s=12, color="0.6", label="trial error")
    best = done["error"].cummin()
    ax.step(done["trial"], 100.0 * best, where="post", color="tab:blue", label="best so far")
    if not failed.empty and not done.empty:
        ax.scatter(failed["trial"], np.full(len(failed), 100.0 * done["error"].max()), marker="x", s=18,
                   color="tab:red", label="failed (drawn at the largest error)")
    for level in study.compare.levels:
        ax.axhline(100.0 * level, color="tab:red", lw=0.8, ls="--")
    _log_if_positive(ax, done["error"], "y")
    ax.set_xlabel("trial number [-]")
    ax.set_ylabel(f"error [%] ({study.compare.metric})")
    ax.grid(True, which="both", alpha=0.3)
    _legend_below(fig, ax, ncol=3)
    return _svg(fig)


def panel_layout(channels) -> list[list]:
    """Rows of panels as in the papers' figures: the tower top (TTDsp*), then
    one row per blade (its tip out-of-plane and in-plane deflections, then its
    other channels), then the rest (e.g. RotSpeed), at most 3 per row."""
    import re as _re
    tower = [c for c in channels if c.startswith("TTDsp") or c.startswith("YawBr")]
    blades: dict = {}
    rest = []
    for c in channels:
        if c in tower:
            continue
        m = _re.fullmatch(r"(\D+?)(\d)", c)
        if m and not c.startswith("Q"):
            blades.setdefault(int(m.group(2)), []).append(c)
        else:
            rest.append(c)
    order = {"OoPDefl": 0, "IPDefl": 1, "TipDxc": 2, "TipDyc": 3}
    rows = [tower] if tower else []
    for b in sorted(blades):
        rows.append(sorted(blades[b], key=lambda c: order.get(c[:-1], 9)))
    rows += [rest[i:i + 3] for i in range(0, len(rest), 3)]
    return [r for r in rows if r]


def _featured_series(out_dir, featured: dict):
    reasons = {}
    for what, number in featured.items():
        reasons.setdefault(number, []).append(what)
    sims = {}
    for number, whats in reasons.items():
        s = read_series(out_dir, number)
        if s is not None:
            sims[number] = ("; ".join(whats), s)
    return sims


def _colours(featured: dict) -> dict:
    """{trial number: colour} of the featured sets, the same in every figure."""
    numbers = sorted(set(featured.values()))
    return {n: f"C{i % 10}" for i, n in enumerate(numbers)}


def _legend_all(fig, axes, ncol=1, fontsize=8):
    """One legend below the figure with every distinct label of `axes`."""
    seen = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(lab, h)
    if seen:
        fig.legend(list(seen.values()), list(seen), loc="upper center", bbox_to_anchor=(0.5, 0.0),
                   ncol=ncol, fontsize=fontsize, frameon=False)


#: tower-top channels drawn for every scene where they move
TOWER_TOP = ("TTDspFA", "TTDspSS")
#: per-blade channels drawn for every blade of a scene with a rotor, where they move
BLADE_TIP = ("OoPDefl", "IPDefl")


def shown_channels(compared, outputs: pd.DataFrame | None, rotor: bool, num_blades: int = 3) -> list:
    """The compared channels, plus, from the chosen set's full `outputs`, the
    tower-top deflections and (scene with a rotor) the tip out-of-plane and
    in-plane deflections of every blade, where they are not constant (a
    tower held rigid is not drawn): the panels of the papers' figures."""
    out = list(compared)
    if outputs is None:
        return out
    extra = list(TOWER_TOP)
    if rotor:
        extra += [f"{c}{b}" for b in range(1, num_blades + 1) for c in BLADE_TIP]
    for c in extra:
        if c not in out and c in outputs.columns and float(np.ptp(outputs[c].to_numpy(float))) > 0.0:
            out.append(c)
    return out


def series_figures(out_dir, study, featured: dict, table: pd.DataFrame, runs: dict | None = None,
                   chosen_trial: int | None = None) -> list[str]:
    """One figure per scene: tower-top panels, one row per blade, then the
    other compared channels; reference and featured sets, legend below.
    `runs` ({scene: (Scene, result)}, `chosen_runs`): the chosen set's full
    outputs, which add the tower-top and every blade's panels where the
    study compares only some of them (`shown_channels`); the reference is
    drawn where it has the channel."""
    reference = read_series(out_dir, "reference") or {}
    labels = dict(zip(table["trial"], table["modeset"])) if not table.empty else {}
    sims = _featured_series(out_dir, featured)
    colours = _colours(featured)
    runs = runs or {}
    compared = list(study.compare.channels)
    figs = []
    import matplotlib.pyplot as plt
    for scene in (s.name for s in study.scenes):
        run = runs.get(scene)
        if scene not in reference and not any(scene in s for _, s in sims.values()) and run is None:
            continue
        full = run[1].outputs if run is not None else None
        rotor = run is not None and has_rotor(run[0])
        blades = int(getattr(getattr(run[0], "turbine", None), "num_blades", 3) or 3) if run else 3
        rows = panel_layout(shown_channels(compared, full, rotor, blades))
        ncol = max(len(r) for r in rows)
        fig, axes = plt.subplots(len(rows), ncol, figsize=(3.6 * ncol + 0.6, 2.3 * len(rows) + 0.4),
                                 sharex=True, squeeze=False)
        for i, row in enumerate(rows):
            for j in range(ncol):
                ax = axes[i, j]
                if j >= len(row):
                    ax.set_visible(False)
                    continue
                ch = row[j]
                if scene in reference and ch in reference[scene]:
                    ref = reference[scene]
                    ax.plot(ref["Time"], ref[ch], color="k", lw=1.6, label="reference")
                for number, (what, s) in sims.items():
                    label = f"#{number} {labels.get(number, '')} ({what})"
                    if scene in s and ch in s[scene]:
                        ax.plot(s[scene]["Time"], s[scene][ch], lw=1.0, color=colours.get(number),
                                label=label)
                    elif number == chosen_trial and full is not None and ch in full:
                        ax.plot(full["Time"], full[ch], lw=1.0, color=colours.get(number), label=label)
                ax.set_ylabel(_unit(ch), fontsize=8)
                ax.set_title(ch if ch in compared else f"{ch} (not compared)", fontsize=9)
                ax.grid(True, alpha=0.3)
                ax.set_xlabel("time [s]", fontsize=8)
        fig.suptitle(f"scene {scene}", fontsize=10)
        fig.tight_layout()
        _legend_all(fig, [a for a in axes.flat if a.get_visible()], ncol=1)
        figs.append(_svg(fig))
    return figs


def error_figures(out_dir, study, featured: dict, table: pd.DataFrame) -> list[str]:
    """Per scene: the error of each featured set over time, (S - R) / range R
    [%] per compared channel, the reference interpolated on the simulation's
    time grid (the quantity whose RMS is the nrmse)."""
    reference = read_series(out_dir, "reference") or {}
    sims = _featured_series(out_dir, featured)
    labels = dict(zip(table["trial"], table["modeset"])) if not table.empty else {}
    channels = list(study.compare.channels)
    import matplotlib.pyplot as plt
    figs = []
    for scene in (s.name for s in study.scenes):
        drawn = [(n, w, s[scene]) for n, (w, s) in sims.items() if scene in s and scene in reference]
        if not drawn:
            continue
        ref = reference[scene]
        fig, axes = plt.subplots(len(drawn), 1, figsize=(7.5, 2.0 * len(drawn) + 0.6), sharex=True,
                                 squeeze=False)
        for ax, (number, what, sim) in zip(axes[:, 0], drawn):
            for ch in channels:
                if ch not in sim or ch not in ref:
                    continue
                r = np.interp(sim["Time"], ref["Time"], ref[ch])
                span = float(np.ptp(ref[ch]))
                if span > 0:
                    ax.plot(sim["Time"], 100.0 * (sim[ch] - r) / span, lw=0.9, label=ch)
            ax.set_title(f"#{number} {labels.get(number, '')} ({what})", fontsize=8)
            ax.set_ylabel("(S - R) / range R [%]", fontsize=8)
            ax.grid(True, alpha=0.3)
        axes[-1, 0].set_xlabel("time [s]")
        fig.suptitle(f"scene {scene}: error over time", fontsize=10)
        fig.tight_layout()
        _legend_below(fig, axes[0, 0], ncol=min(5, len(channels)))
        figs.append(_svg(fig))
    return figs


# --------------------------------------------------------------------------- what ran

def chosen_runs(study, chosen: ModeSet | None, engine, notes: list) -> dict:
    """{scene name: (Scene, SimulationResult)}: the chosen set simulated once
    more on every scene of the study (the stored series hold the compared
    channels only), for the DOFs and effects that ran (`what_ran`) and the
    tower-top and per-blade panels (`series_figures`). A scene that cannot be
    simulated adds a line to `notes`."""
    if chosen is None or engine is None:
        return {}
    out = {}
    for spec in study.scenes:
        try:
            scene = engine.load_scene(spec.path)
            out[spec.name] = (scene, engine.simulate(scene, chosen, tmax=spec.tmax, dt=spec.dt))
        except (ModeselError, OSError) as exc:
            notes.append(f"scene {spec.name}: the chosen set was not simulated again: {exc}")
    return out


def what_ran(runs: dict) -> list[dict]:
    """Per scene of `runs` (`chosen_runs`): the DOFs, the effects evaluated,
    the system flags and the warnings about inert settings, as `modesel
    simulate` prints them (`model.effects.effects_in_scene`, the
    selection of `modesel.model.effects.select`)."""
    from modesel.model.effects import effects_in_scene
    rows = []
    for name, (scene, result) in runs.items():
        dofs = list(getattr(result, "dof_names", None) or [])
        n = int(getattr(result, "n_dofs", len(dofs)) or len(dofs))
        if isinstance(getattr(scene, "effects", None), dict):
            on, flags, warnings = effects_in_scene(scene, dofs)
        else:
            on, flags, warnings = None, None, []
        rows.append({"scene": name, "n_dofs": n, "dofs": ", ".join(dofs) or "(not reported by the engine)",
                     "effects": "(not reported by the engine)" if on is None else ", ".join(on) or "none",
                     "flags": "(not reported by the engine)" if flags is None else ", ".join(flags) or "none",
                     "warnings": warnings})
    return rows


# --------------------------------------------------------------------------- Campbell diagram

CAMPBELL_HARMONICS = (1, 3, 6)


def has_rotor(scene) -> bool:
    """Whether `scene` (modesel.simulation.Scene) turns a rotor or has flexible blades."""
    from modesel.vocabulary import ROTOR_AZIMUTH
    free = getattr(scene, "free", ()) or ()
    turning = ROTOR_AZIMUTH in free or ROTOR_AZIMUTH in (getattr(scene, "constant_speed", {}) or {})
    return bool(turning)


def scene_rpm(scene) -> float:
    """The rotor speed of `scene` [rpm]: prescribed, else initial, else 0."""
    from modesel.vocabulary import ROTOR_AZIMUTH
    omega = (getattr(scene, "constant_speed", {}) or {}).get(ROTOR_AZIMUTH)
    if omega is None:
        omega = (getattr(scene, "initial", {}) or {}).get("RotSpeed", 0.0)
    return float(omega) * 30.0 / np.pi


#: effects left out of the report's Campbell sweep: the aerodynamic loads
AERO_EFFECTS = ("wind", "aero", "tower_drag")


def structural_scene(scene):
    """`scene` without aerodynamic loads (AERO_EFFECTS off): the structure,
    gravity, stiffening, structural damping and drivetrain only. A Campbell
    diagram sweeps the rotor speed at the scene's wind, which is not an
    operating point away from the scene's own speed; at 0 rpm the BEM inflow
    has no tangential velocity, the branch where AeroDyn's (and modesel's)
    BEM switches induction off, so its loads are not differentiable there and
    a linearisation through them gives spurious real eigenvalues (e.g. an
    unstable 16 Hz root in place of the edge collective mode). Without them,
    the sweep is the structural Campbell diagram that OpenFAST's own
    linearisation (ElastoDyn, generator locked) reproduces, labels included
    (tests/test_campbell.py)."""
    from dataclasses import replace
    effects = {k: v for k, v in (getattr(scene, "effects", {}) or {}).items() if k not in AERO_EFFECTS}
    effects.update(aero=False, tower_drag=False)
    return replace(scene, effects=effects)


def aero_at_rest_warning(scene, rpms) -> str | None:
    """A warning when `rpms` holds 0 and `scene` has aerodynamic loads (see
    `structural_scene`), else None."""
    effects = getattr(scene, "effects", {}) or {}
    if not any(r == 0.0 for r in rpms) or not any(effects.get(k) for k in ("aero", "tower_drag")):
        return None
    return ("at 0 rpm the rotor has no tangential inflow, where the BEM switches induction off: its "
            "loads are not differentiable there and the 0 rpm modes with aerodynamics are not "
            "meaningful (add --no-aero for the structure only, or use a small speed)")


def campbell_sweep(scene, modeset, rpms) -> list:
    """[(rpm, [modesel.multibody.linearize.Mode])] of `scene`'s structure
    (`structural_scene`) linearised at each rotor speed [rpm]."""
    from modesel.simulation.api import linearize_scene
    bare = structural_scene(scene)
    return [(float(r), linearize_scene(bare, modeset, rpm=float(r))[0]) for r in rpms]


def mode_kind(mode) -> tuple[str, str]:
    """(family of the mode, kind): e.g. ('F1', 'backward whirl'), ('F1', 'collective'), ('TFA1', '')."""
    label = re.sub(r"#\d+$", "", mode.label.split("+")[0])
    base, _, part = label.rpartition("_")
    if not base:
        from modesel.vocabulary import blade_dof_type, parse_dof
        try:
            blade = parse_dof(label).blade
        except ValueError:
            blade = None
        if blade is not None:           # a rotor on a rigid support: each blade in its rotating frame
            return blade_dof_type(label), f"blade {blade} (rotating frame)"
        return label, ""
    if mode.whirl:
        return base, f"{mode.whirl} whirl"
    if part == "coll":
        return base, "collective"
    return base, f"cyclic ({part})"


def campbell_figure(sweep, title: str = "") -> str:
    """Campbell diagram: frequency [Hz] versus rotor speed [rpm] of each mode
    (modes with |damping ratio| >= 0.9, overdamped or real, left out), lines
    by mode family and kind (collective, backward/forward whirl), and the
    1P, 3P and 6P excitation lines."""
    fig, ax = _figure(7.5, 4.5)
    curves: dict = {}
    for rpm, modes in sweep:
        kept = [m for m in modes if np.isfinite(m.frequency_hz) and abs(m.damping_ratio) < 0.9]
        kinds = [mode_kind(m) for m in kept]
        # a parked rotor's cyclic pair (cos, sin) is where the whirl branches start:
        # the lower one continues as backward whirl, the higher as forward whirl
        for base in {b for b, k in kinds if k.startswith("cyclic")}:
            pair = sorted((kept[i].frequency_hz, i) for i, (b, k) in enumerate(kinds)
                          if b == base and k.startswith("cyclic"))
            if len(pair) == 2:
                kinds[pair[0][1]] = (base, "backward whirl")
                kinds[pair[1][1]] = (base, "forward whirl")
        for m, kind in zip(kept, kinds):
            curves.setdefault(kind, []).append((rpm, m.frequency_hz))
    import matplotlib.pyplot as plt
    styles = {"collective": "-", "backward whirl": "--", "forward whirl": ":"}
    bases = sorted({base for base, _ in curves})
    palette = plt.get_cmap("tab10" if len(bases) <= 10 else "tab20")
    colours = {base: palette(i % palette.N) for i, base in enumerate(bases)}
    for (base, kind), pts in sorted(curves.items()):
        pts = sorted(pts)
        x, y = zip(*pts)
        label = f"{base} {kind}".strip()
        if kind.startswith("blade "):      # identical blades: one legend entry per blade mode
            label = f"{base} of each blade (rotating frame)" if kind.startswith("blade 1 ") else "_nolegend_"
        ax.plot(x, y, styles.get(kind, "-"), marker="o", ms=3, lw=1.2, color=colours[base], label=label)
    rpms = [r for r, _ in sweep]
    top = max(rpms) if rpms else 1.0
    fmax = max((f for pts in curves.values() for _, f in pts), default=1.0)
    # the axis reaches 3 times the 6P line at the top speed: modes far above the rotor
    # harmonics (e.g. a second edge collective at 10 Hz) would squash the ones that matter
    limit = max(3.0 * max(CAMPBELL_HARMONICS) * top / 60.0, 1e-9)
    shown = [f for pts in curves.values() for _, f in pts if f <= limit]
    limit = 1.1 * (max(shown) if shown else fmax)
    ax.set_ylim(0, limit)
    for k in CAMPBELL_HARMONICS:
        ax.plot([0, top], [0, k * top / 60.0], color="0.5", lw=0.8, ls="-.")
        x_end = min(top, 0.92 * limit * 60.0 / k)        # label inside the axes, where the line leaves it
        ax.annotate(f"{k}P", (x_end, k * x_end / 60.0), fontsize=8, color="0.4",
                    ha="left" if x_end < top else "right", va="bottom")
    above = sorted({f"{base} {kind}".strip() for (base, kind), pts in curves.items()
                    if min(f for _, f in pts) > limit and not kind.startswith("blade ")}
                   | {f"{base} of each blade" for (base, kind), pts in curves.items()
                      if min(f for _, f in pts) > limit and kind.startswith("blade ")})
    if above:
        ax.annotate("above the axis: " + ", ".join(above), (0.01, 0.99), xycoords="axes fraction",
                    fontsize=7, va="top", color="0.3")
    ax.set_xlabel("rotor speed [rpm]")
    ax.set_ylabel("frequency [Hz]")
    if title:
        ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    _legend_below(fig, ax, ncol=3, fontsize=7)
    return _svg(fig)


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
    ncol = min(3, len(drawn))
    nrow = -(-len(drawn) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.4 * ncol + 0.5, 3.0 * nrow + 0.3), squeeze=False)
    for ax in axes.flat[len(drawn):]:
        ax.set_visible(False)
    for ax, (fld, fm, shapes) in zip(axes.flat, drawn):
        for k in range(shapes.count):
            ax.plot(shapes.x, shapes.phi[k], label=f"mode {k + 1}")
        ax.set_title(f"{fld}: {fm.label()}", fontsize=9)
        ax.set_xlabel("x = s/L [-]")
        ax.set_ylabel("phi [-] (unit tip)", fontsize=8)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(0.0, -0.22), ncol=3, frameon=False)
    fig.tight_layout()
    return _svg(fig), notes


# --------------------------------------------------------------------------- HTML

STYLE = """
*{box-sizing:border-box}
body{font-family:sans-serif;max-width:1300px;margin:1em auto;padding:0 1em;color:#222}
h1{font-size:1.5em}h2{font-size:1.2em;border-bottom:1px solid #ccc;margin-top:2em}
.scroll{max-width:100%;overflow-x:auto;margin:0.5em 0}
.fig{max-width:100%;overflow-x:auto;margin:0.5em 0}
table{border-collapse:collapse;font-size:0.8em;max-width:100%}
td,th{border:1px solid #ccc;padding:2px 6px;text-align:right;vertical-align:top}
td.l,th.l{text-align:left}td.wrap{max-width:28em;overflow-wrap:anywhere;white-space:normal}
td.set{overflow-wrap:normal}
th{background:#f0f0f0}tr.fail td{background:#fff3f0}
.answer{font-size:1.1em;background:#eef6ee;padding:0.6em}
.note{color:#555;font-size:0.9em}.warn{color:#a40}svg{max-width:100%;height:auto;display:block}
"""

#: ranked-table columns: internal name -> header with unit
HEADERS = {"n_dofs": "DOFs", "error": "error [%]", "worst_channel": "worst channel",
           "wall_time_s": "wall time [s]", "speed": "speed [x real time]",
           "meets_tolerance": "meets tolerance", "rank": "rank", "trial": "trial",
           "modeset": "mode set", "status": "status", "reason": "reason"}
PERCENT = ("error",)


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


def _table(df: pd.DataFrame, columns, left=(), headers=None, percent=(), wrap=()) -> str:
    """An HTML table in its own horizontally scrolling box (the mode-set
    column wraps between fields, never inside "family:count"); `percent` columns
    (fractions) shown in %; a failed row (status FAIL) is marked and its
    empty numeric cells say 'failed'."""
    headers = headers or {}

    def cls(c):
        return " ".join(x for x in ("l" if c in left else "", "wrap" if c in wrap else "",
                                    "set" if c == "modeset" else "") if x)

    head = "".join(f"<th class='{cls(c)}'>{_e(headers.get(c, c))}</th>" for c in columns)
    rows = []
    for _, r in df.iterrows():
        failed = r.get("status") == "FAIL"
        cells = []
        for c in columns:
            v = r.get(c)
            if c in percent and not (v is None or v is pd.NA or (isinstance(v, float) and math.isnan(v))):
                v = 100.0 * float(v)
            text = _fmt(v)
            if failed and text == "" and c in percent:
                text = "failed"
            cells.append(f"<td class='{cls(c)}'>{_e(text)}</td>")
        rows.append(f"<tr{' class=fail' if failed else ''}>" + "".join(cells) + "</tr>")
    return f"<div class='scroll'><table><tr>{head}</tr>{''.join(rows)}</table></div>"


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
              _table(pd.DataFrame(ref_rows), list(ref_rows[0]), left=("scene", "file", "reference"),
                     wrap=("file", "reference"))]

    ran = figures.get("what_ran") or []
    if ran:
        parts.append("<h2>What ran</h2><p class='note'>The chosen set on each scene, as <code>modesel "
                     "simulate</code> reports it: the degrees of freedom, the effects evaluated and the "
                     "system flags.</p>")
        parts.append(_table(pd.DataFrame([{k: v for k, v in r.items() if k != "warnings"} for r in ran]),
                            ["scene", "n_dofs", "dofs", "effects", "flags"],
                            headers={"scene": "scene", "n_dofs": "DOFs", "dofs": "free coordinates",
                                     "effects": "effects evaluated", "flags": "system flags on"},
                            left=("scene", "dofs", "effects", "flags"), wrap=("dofs", "effects", "flags")))
        warned = [(r["scene"], w) for r in ran for w in r["warnings"]]
        if warned:
            parts.append("<ul class='warn'>" + "".join(f"<li>warning: scene {_e(n)}: {_e(w)}</li>"
                                                      for n, w in warned) + "</ul>")

    def fig(svg):
        return f"<div class='fig'>{svg}</div>"

    parts.append("<h2>Accuracy versus cost</h2>")
    parts.append(fig(figures["pareto"]) if "pareto" in figures else "<p class='note'>no completed trial</p>")
    if "pareto" in figures:
        parts.append("<p class='note'>Hover a point for its trial number and mode set.</p>")
    parts.append("<h2>Convergence history</h2>")
    parts.append(fig(figures["history"]) if "history" in figures else "<p class='note'>no completed trial</p>")

    parts.append(f"<h2>Ranked mode sets (first {TABLE_ROWS})</h2>")
    if not ranked.empty:
        parts.append("<p class='note'>Ranked: sets meeting the tolerance first, cheapest first (cost, "
                     "then DOFs, then error); then the others, most accurate first; failed trials last "
                     "(as trials.csv).</p>")
        channel_cols = [f"error_{c}" for c in study.compare.channels]
        headers = dict(HEADERS, cost=_cost_label(study),
                       **{f"error_{c}": f"error {c} [%]" for c in study.compare.channels})
        cols = ["rank", "trial", "modeset", "n_dofs", "error", "worst_channel"] + channel_cols + \
               ["wall_time_s", "speed", "cost", "meets_tolerance", "status", "reason"]
        parts.append(_table(ranked.head(TABLE_ROWS), cols, headers=headers,
                            left=("modeset", "worst_channel", "status", "reason"),
                            percent=("error", *channel_cols), wrap=("modeset", "reason")))

    parts.append("<h2>Time series</h2>")
    if figures.get("series_extra"):
        parts.append("<p class='note'>Panels marked \"not compared\": the chosen set simulated again "
                     "with all its outputs (tower top and every blade); the reference where it has "
                     "the channel.</p>")
    parts += [fig(f) for f in figures.get("series", [])] or ["<p class='note'>no stored time series</p>"]
    if figures.get("errors"):
        parts.append("<h2>Error of the chosen sets over time</h2>")
        parts += [fig(f) for f in figures["errors"]]
    if figures.get("campbell"):
        parts.append("<h2>Campbell diagram</h2>")
        parts.append("<p class='note'>Modes of the chosen set's structure (no aerodynamic loads; "
                     "gravity, stiffening, structural damping and drivetrain as in the scene) linearised "
                     "at constant rotor speeds, generator locked; a rotor on a flexible tower in "
                     "multi-blade coordinates (frequencies in the fixed frame: collective, backward and "
                     "forward whirl), a rotor on a rigid support blade by blade in the rotating frame; "
                     "1P, 3P and 6P: rotor harmonics.</p>")
        parts.append(f"<div class='fig campbell'>{figures['campbell']}</div>")
    parts.append("<h2>Chosen mode shapes</h2>")
    parts.append(fig(figures["shapes"]) if figures.get("shapes") else "<p class='note'>no shapes drawn</p>")

    failed = table[table["status"] != "COMPLETE"] if n_total else table
    if n_total and not failed.empty:
        parts.append("<h2>Failed trials</h2>")
        failed = failed.assign(modeset=failed["modeset"].fillna("").replace("", "(set not recorded)"),
                               reason=failed["reason"].fillna("").replace("", "(no reason recorded)"))
        parts.append(_table(failed.head(TABLE_ROWS), ["trial", "modeset", "reason"], headers=HEADERS,
                            left=("modeset", "reason"), wrap=("modeset", "reason")))
    if notes:
        parts.append("<h2>Notes</h2><ul>" + "".join(f"<li class='note'>{_e(n)}</li>" for n in notes) + "</ul>")
    parts.append("</body></html>")
    return "\n".join(parts)


def render(out_dir, study, summary: dict, sentences: list, chosen: ModeSet | None, scene, notes: list,
           info: dict, engine=None) -> str:
    """The page for the results `summary` (`modesel.study.results.write_results`)
    of `study`, whose time series are stored in `out_dir`; `chosen`: the
    selected set, its shapes drawn with the turbine of `scene` (or None);
    `engine` (`modesel.study.search.engine.Engine`, or None): simulates the
    chosen set once more on every scene for the DOFs and effects that ran and
    the tower-top and per-blade panels (`chosen_runs`); `notes` (extended
    with what could not be drawn) are listed at the end."""
    table, featured = summary["table"], summary["featured"]
    figures = {}
    if not table.empty and (table["status"] == "COMPLETE").any():
        figures["pareto"] = pareto_figure(table, summary["pareto"], study, featured)
        figures["history"] = history_figure(table, study)
    runs = chosen_runs(study, chosen, engine, notes)
    figures["what_ran"] = what_ran(runs)
    chosen_trial = summary.get("best", {}).get("trial")
    figures["series"] = series_figures(out_dir, study, featured, table, runs, chosen_trial)
    figures["series_extra"] = any(
        set(shown_channels(study.compare.channels, r.outputs, has_rotor(sc))) - set(study.compare.channels)
        for sc, r in runs.values())
    figures["errors"] = error_figures(out_dir, study, featured, table)
    if chosen is not None:
        svg, shape_notes = shapes_figure(chosen, scene)
        figures["shapes"] = svg
        notes += shape_notes
        if scene is not None and has_rotor(scene):
            top = max(scene_rpm(scene), 1.0)
            try:
                sweep = campbell_sweep(scene, chosen, np.linspace(0.0, 1.2 * top, CAMPBELL_POINTS))
                figures["campbell"] = campbell_figure(sweep, f"{chosen.label()} on {study.scenes[0].name}")
            except ModeselError as exc:
                notes.append(f"Campbell diagram not drawn: {exc}")
    return render_html(study, summary, sentences, figures, notes, info)
