"""Time series of a study's output folder, ``timeseries/``: the compared
channels of the reference and of trials, one long CSV per trial (column
``scene``), so that `modesel report` can redraw the overlays. Written
atomically (temporary file, then `os.replace`)."""
from __future__ import annotations

from pathlib import Path

import pandas as pd

from modesel.files import atomic_write_text

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
    atomic_write_text(path, pd.concat(frames, ignore_index=True).to_csv(index=False, float_format="%.9g"))


def read_series(out_dir, trial: int | str) -> dict | None:
    """{scene: DataFrame(Time, channels...)} or None when not stored."""
    path = series_path(out_dir, trial)
    if not path.exists():
        return None
    df = pd.read_csv(path)
    return {str(s): g.drop(columns="scene").reset_index(drop=True) for s, g in df.groupby("scene", sort=False)}


def prune_series(out_dir, keep) -> None:
    """Delete stored trial series except those of trial numbers in `keep`."""
    folder = Path(out_dir) / SERIES_DIR
    keep = {series_path(out_dir, k).name for k in keep}
    for path in folder.glob("trial_*.csv"):
        if path.name not in keep:
            path.unlink(missing_ok=True)
