"""Time series of a study's output folder, ``timeseries/``: the compared
channels of the reference and of trials, one long CSV per trial (column
``scene``), so that `modesel report` can redraw the overlays. Written
atomically (temporary file, then `os.replace`), with a second header row of
units (``(-),(s),(m),...``, `modesel.model.outputs.channel_unit`), read back
by ``pandas.read_csv(path, header=[0, 1])`` or `read_series`."""
from __future__ import annotations

from pathlib import Path

import pandas as pd

from modesel.files import atomic_write_text, read_unit_csv, unit_csv_text

SERIES_DIR = "timeseries"


def series_path(out_dir, trial: int | str) -> Path:
    name = "reference" if trial == "reference" else f"trial_{int(trial):05d}"
    return Path(out_dir) / SERIES_DIR / f"{name}.csv"


def write_series(out_dir, trial: int | str, by_scene: dict) -> None:
    """Store {scene: (time, {channel: values})} as one long CSV (column `scene`)."""
    frames = []
    for scene, (time, channels) in by_scene.items():
        frames.append(pd.DataFrame({"scene": scene, "Time": time, **channels}))
    path = series_path(out_dir, trial)
    path.parent.mkdir(parents=True, exist_ok=True)
    df = pd.concat(frames, ignore_index=True)
    atomic_write_text(path, unit_csv_text(df, series_units(df.columns)))


def series_units(columns) -> dict:
    """{column: unit} of a time-series table: scene "-", Time "s", channels
    by `channel_unit` ("?" when unknown)."""
    from modesel.model.outputs import channel_unit
    return {c: "-" if c == "scene" else "s" if c == "Time" else (channel_unit(c) or "?") for c in columns}


def read_series(out_dir, trial: int | str) -> dict | None:
    """{scene: DataFrame(Time, channels...)} or None when not stored; each
    frame's ``attrs["units"]`` holds the units of its columns."""
    path = series_path(out_dir, trial)
    if not path.exists():
        return None
    df = read_unit_csv(path)
    units = df.attrs.get("units", {})
    out = {}
    for s, g in df.groupby("scene", sort=False):
        frame = g.drop(columns="scene").reset_index(drop=True)
        frame.attrs["units"] = {c: u for c, u in units.items() if c != "scene"}
        out[str(s)] = frame
    return out


def prune_series(out_dir, keep) -> None:
    """Delete stored trial series except those of trial numbers in `keep`."""
    folder = Path(out_dir) / SERIES_DIR
    keep = {series_path(out_dir, k).name for k in keep}
    for path in folder.glob("trial_*.csv"):
        if path.name not in keep:
            path.unlink(missing_ok=True)
