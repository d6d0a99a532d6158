"""OpenFAST time-series output (.out text or .outb binary) as a pandas DataFrame.

`read_openfast_output(path)` reads with openfast_io's `FASTOutputFile`
(`load_ascii_output` for .out: channel names on line 7, units in
parentheses on line 8, numbers below; `load_binary_output` for .outb).
Columns are the OpenFAST channel names without unit suffixes ('Time',
'Q_TFA1', 'Azimuth', ...); `df.attrs['units']` maps each channel to its
unit string as written by OpenFAST ('s', 'deg', 'm', ...). Values are not
converted: OpenFAST writes angles in deg and speeds in rpm.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from openfast_io.FAST_output_reader import FASTOutputFile

from modesel.errors import ModeselError

SUFFIXES = (".out", ".outb")


def read_openfast_output(path) -> pd.DataFrame:
    """Read an OpenFAST .out/.outb file; columns are channel names, units in attrs."""
    path = Path(path)
    if not path.is_file():
        raise ModeselError("OpenFAST output file not found", file=str(path))
    if path.suffix.lower() not in SUFFIXES:
        raise ModeselError(f"not an OpenFAST output file (expected {' or '.join(SUFFIXES)})", file=str(path))
    try:
        output = FASTOutputFile(str(path))
    except Exception as exc:  # openfast_io raises bare ValueError/struct.error/... on bad files
        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ModeselError(f"unreadable OpenFAST output: {reason}", file=str(path)) from None
    names = [str(n) for n in output.info["attribute_names"]]
    units = [str(u) for u in (output.info.get("attribute_units") or [""] * len(names))]
    data = np.asarray(output.data, dtype=float)
    if data.ndim != 2 or data.shape[1] != len(names) or len(units) != len(names):
        raise ModeselError(f"unreadable OpenFAST output: {len(names)} channel names, {len(units)} units, "
                           f"data of shape {data.shape}", file=str(path))
    if data.shape[0] == 0:
        raise ModeselError("OpenFAST output has no time steps", file=str(path))
    if not names or names[0] != "Time":
        raise ModeselError(f"first channel must be 'Time', got {names[:1]}", file=str(path))
    if len(set(names)) != len(names):
        dupes = sorted({n for n in names if names.count(n) > 1})
        raise ModeselError(f"duplicate channel names {', '.join(dupes)}", file=str(path))
    frame = pd.DataFrame(data, columns=names)
    frame.attrs["units"] = dict(zip(names, units))
    frame.attrs["source"] = str(path)
    frame.attrs["description"] = str(output.info.get("description", ""))
    return frame
