"""File writing that never leaves a half-written file behind."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from modesel.errors import ModeselError


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write `text` to `path` via a temporary file and os.replace (never half-written)."""
    path = Path(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise ModeselError(f"cannot write: {exc.strerror}", file=str(path)) from None
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.chmod(tmp, 0o666 & ~_umask())      # mkstemp creates 0600; use the usual mode
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):          # e.g. the target is a folder, disk full
            raise ModeselError(f"cannot write: {exc.strerror or exc}", file=str(path)) from None
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# --------------------------------------------------------------------------- CSV with units

def unit_csv_text(df, units: dict, float_format: str = "%.9g") -> str:
    """CSV text of `df` with a second header row of units in parentheses, as
    OpenFAST text outputs carry (``Time,TTDspFA`` then ``(s),(m)``); `units`
    maps column -> unit ("-" dimensionless or text, "%" percent). Read back
    with ``pandas.read_csv(path, header=[0, 1])`` (`read_unit_csv`)."""
    import pandas as pd
    cols = list(df.columns)
    frame = df.copy()
    frame.columns = pd.MultiIndex.from_arrays([cols, [f"({units.get(c) or '-'})" for c in cols]])
    return frame.to_csv(index=False, float_format=float_format)


def columns_csv_text(columns: dict, units: dict, float_format: str = "%.9g") -> str:
    """`unit_csv_text` of numeric columns {name: 1-D array, all one length}
    without pandas (the `modesel simulate` path does not import it): the same
    text as ``unit_csv_text(pandas.DataFrame(columns), units, float_format)``
    (NaN as an empty field, as pandas writes it)."""
    import csv
    import io

    import numpy as np
    names = list(columns)
    head = io.StringIO()
    writer = csv.writer(head, lineterminator="\n")
    writer.writerow(names)
    writer.writerow([f"({units.get(c) or '-'})" for c in names])
    table = np.column_stack([np.asarray(columns[c], float) for c in names]) if names else np.zeros((0, 0))
    row = ",".join([float_format] * len(names)) + "\n"
    nan = np.isnan(table).any(axis=1)
    lines = [row % tuple(values) if not bad else
             ",".join("" if v != v else float_format % v for v in values) + "\n"
             for values, bad in zip(table.tolist(), nan.tolist())]
    return head.getvalue() + "".join(lines)


def is_unit_row(cells) -> bool:
    """Whether the cells of a CSV's second line are a unit row: every cell '(...)'."""
    cells = [str(c).strip() for c in cells]
    return bool(cells) and all(len(c) >= 2 and c[0] == "(" and c[-1] == ")" for c in cells)


def read_unit_csv(path):
    """DataFrame of a CSV written by `unit_csv_text` (or one with a single
    header row), with ``attrs["units"]`` = {column: unit} from the unit row."""
    import csv

    import pandas as pd
    with open(path, newline="", errors="replace") as fh:
        reader = csv.reader(fh)
        header = next(reader, [])
        second = next(reader, [])
    if is_unit_row(second) and len(second) == len(header):
        df = pd.read_csv(path, header=0, skiprows=[1])
        df.attrs["units"] = {h.strip(): u.strip()[1:-1] for h, u in zip(header, second)}
    else:
        df = pd.read_csv(path)
        df.attrs["units"] = {}
    return df
