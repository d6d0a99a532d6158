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

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from openfast_io.FAST_output_reader import FASTOutputFile

from modesel.errors import ModeselError

SUFFIXES = (".out", ".outb")

# OpenFAST binary output layout (OpenFAST's WrBinFAST; openfast_io's load_binary_output)
_WITH_TIME, _WITHOUT_TIME, _NO_COMPRESS, _CHANLEN_IN = 1, 2, 3, 4
MAX_CHANNELS = 100_000          # sanity bound on the header's channel count
MAX_NAME_LENGTH = 1024          # sanity bound on a channel name's length [characters]


def check_binary_header(path: Path) -> tuple[int, int]:
    """Validate an .outb header against the file size before anything is
    allocated; returns (channels, time steps). A file whose header promises
    more bytes than it holds is a one-line user error. Bytes beyond what
    the header promises are not read: OpenFAST 5.0 writes its .outb over an
    existing file without shortening it, so a run shorter than the one
    before leaves the old file's tail after its own data (seen when a
    10-s run replaced a 30-s one; openfast_io reads such a file as the
    header says)."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(2 + 2 + 4 + 4)
        if len(head) < 10:
            raise ModeselError(f"truncated OpenFAST binary header ({size} bytes)", file=str(path))
        file_id = int(np.frombuffer(head[:2], "<i2")[0])
        if file_id not in (_WITH_TIME, _WITHOUT_TIME, _NO_COMPRESS, _CHANLEN_IN):
            raise ModeselError(f"not an OpenFAST binary output (file format id {file_id}, expected 1-4)",
                               file=str(path))
        offset = 2
        name_length = 10
        if file_id == _CHANLEN_IN:
            name_length = int(np.frombuffer(head[2:4], "<i2")[0])
            offset = 4
        fh.seek(offset)
        counts = fh.read(8)
        if len(counts) < 8:
            raise ModeselError("truncated OpenFAST binary header", file=str(path))
        channels, steps = (int(v) for v in np.frombuffer(counts, "<i4"))
        if not 0 < channels <= MAX_CHANNELS or steps <= 0 or not 0 < name_length <= MAX_NAME_LENGTH:
            raise ModeselError(f"corrupt OpenFAST binary header: {channels} channels, {steps} time steps, "
                               f"channel names of {name_length} characters", file=str(path))
        offset += 8 + 16                                   # counts, then two float64 time values
        if file_id != _NO_COMPRESS:
            offset += 2 * 4 * channels                     # float32 channel scales and offsets
        fh.seek(offset)
        raw = fh.read(4)
        if len(raw) < 4:
            raise ModeselError("truncated OpenFAST binary header", file=str(path))
        description = int(np.frombuffer(raw, "<i4")[0])
        if not 0 <= description <= size:
            raise ModeselError(f"corrupt OpenFAST binary header: description of {description} bytes",
                               file=str(path))
    expected = offset + 4 + description + 2 * (channels + 1) * name_length
    if file_id == _WITH_TIME:
        expected += 4 * steps
    expected += steps * channels * (8 if file_id == _NO_COMPRESS else 2)
    if expected > size:
        raise ModeselError(f"OpenFAST binary output is {size} bytes but its header ({channels} channels, "
                           f"{steps} time steps) needs {expected} bytes: truncated or corrupt", file=str(path))
    return channels, steps


def read_openfast_output(path) -> pd.DataFrame:
    """Read an OpenFAST .out/.outb file; columns are channel names, units in attrs."""
    path = Path(path)
    if not path.is_file():
        raise ModeselError("OpenFAST output file not found", file=str(path))
    if path.suffix.lower() not in SUFFIXES:
        raise ModeselError(f"not an OpenFAST output file (expected {' or '.join(SUFFIXES)})", file=str(path))
    if path.suffix.lower() == ".outb":
        check_binary_header(path)
    try:
        output = FASTOutputFile(str(path))
        names = [str(n) for n in output.info["attribute_names"]]
        units = [str(u) for u in (output.info.get("attribute_units") or [""] * len(names))]
        data = np.asarray(output.data, dtype=float)
        description = str(output.info.get("description", ""))
    except Exception as exc:  # openfast_io raises bare ValueError/struct.error/... on bad files
        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        text = _text_with_overflow(path) if path.suffix.lower() == ".out" and "*" in reason else None
        if text is None:
            raise ModeselError(f"unreadable OpenFAST output: {reason}", file=str(path)) from None
        names, units, data, description = text
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
    frame.attrs["description"] = description
    return frame


def _text_with_overflow(path):
    """(names, units, data, description) of a text .out whose OutFmt field
    overflowed somewhere (Fortran writes a too-wide number as '*****'), read
    line by line with such a field as NaN: a channel that holds one is then
    refused only where it is compared (the reference's finite-value check),
    not the whole file. None if the file does not have the .out layout."""
    lines = Path(path).read_text(errors="replace").splitlines()
    start = next((i for i, line in enumerate(lines) if line.split()[:1] == ["Time"]), None)
    if start is None or start + 1 >= len(lines):
        return None
    names = lines[start].split()
    units = [u.strip("()") for u in lines[start + 1].split()]
    rows = []
    for line in lines[start + 2:]:
        tokens = line.split()
        if not tokens:
            continue
        if len(tokens) != len(names):
            return None
        try:
            rows.append([np.nan if set(t) == {"*"} else float(t) for t in tokens])
        except ValueError:
            return None
    description = next((line.strip() for line in lines[:start] if line.strip().startswith("Description")), "")
    return names, units, np.array(rows, dtype=float).reshape(-1, len(names)), description


# ------------------------------------------------------------------ linearisation (.lin) files
#: ElastoDyn's internal DOF index (in a .lin state description) -> modesel coordinate name
_ED_DOFS = {"DOF_TFA1": "TFA1", "DOF_TFA2": "TFA2", "DOF_TSS1": "TSS1", "DOF_TSS2": "TSS2",
            "DOF_DrTr": "DrTr", "DOF_GeAz": "GeAz", "DOF_Yaw": "Yaw"}


@dataclass
class OpenFastLinearization:
    """One OpenFAST `.lin` file: the first-order state matrix A of
    dx/dt = A x (+ B u) about its operating point, with x = [q; dq/dt].

    names: modesel name of each coordinate q (TFA1, TSS1, DrTr, B1F1, B2E1,
    GeAz ...), in A's order; rotating: whether the coordinate is in the
    rotating frame (a blade DOF); azimuth [rad] of blade 1 (0 = up) and
    rotor_speed [rad/s] at the linearisation time; time [s]."""

    path: str
    A: np.ndarray
    names: list
    rotating: list
    azimuth: float
    rotor_speed: float
    time: float


def read_openfast_lin(path) -> OpenFastLinearization:
    """Read the state matrix A and the state list of an OpenFAST `.lin` file
    (text, as written by OpenFAST's linearisation, or gzip-compressed
    `.lin.gz`; only ElastoDyn states, i.e. second-order structural DOFs,
    are supported)."""
    import gzip
    path = Path(path)
    if not path.is_file():
        raise ModeselError("OpenFAST linearisation file not found", file=str(path))
    raw = path.read_bytes()
    lines = (gzip.decompress(raw) if path.suffix == ".gz" else raw).decode(errors="replace").splitlines()

    def value(label):
        for line in lines:
            if line.strip().startswith(label):
                return float(line.split(":", 1)[1].split()[0])
        raise ModeselError(f"no '{label}' line", file=str(path))

    n = int(value("Number of continuous states"))
    start = next((i for i, line in enumerate(lines) if line.startswith("Order of continuous states:")), None)
    a_at = next((i for i, line in enumerate(lines) if line.startswith("A:")), None)
    if start is None or a_at is None or n % 2:
        raise ModeselError("not a .lin file with continuous states and an A matrix", file=str(path))
    names, rotating = [], []
    for line in lines[start + 3:start + 3 + n // 2]:
        m = re.search(r"internal DOF index = (DOF_\w+(?:\((\d+),(\d+)\))?)", line)
        if m is None:
            raise ModeselError(f"unsupported state (not an ElastoDyn DOF): {line.strip()[:80]}", file=str(path))
        key = m.group(1)
        if key.startswith(("DOF_BF", "DOF_BE")):
            names.append(f"B{m.group(2)}{'F' if key.startswith('DOF_BF') else 'E'}{m.group(3)}")
        elif key in _ED_DOFS:
            names.append(_ED_DOFS[key])
        else:
            raise ModeselError(f"unsupported ElastoDyn DOF {key}", file=str(path))
        rotating.append(line.split()[2] == "T")
    A = np.array([[float(v) for v in lines[a_at + 1 + i].split()] for i in range(n)])
    if A.shape != (n, n):
        raise ModeselError(f"A is {A.shape}, expected {n} x {n}", file=str(path))
    return OpenFastLinearization(str(path), A, names, rotating, value("Azimuth"), value("Rotor Speed"),
                                 value("Simulation time"))
