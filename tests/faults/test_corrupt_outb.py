"""A corrupt or truncated .outb is refused from its header, before any large
allocation, with one line naming the file (issue 13: a random-bytes .outb
used to take 70 s and 3.1 GB before MemoryError)."""
from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from modesel.errors import ModeselError
from modesel.turbine.openfast_output import read_openfast_output

GOOD = Path(__file__).resolve().parents[1] / "data" / "openfast_free_decay" / "tower_fa_ss_shaft" / "Main_Spar_ED.outb"


def _variant(tmp_path, name, data: bytes) -> Path:
    path = tmp_path / name
    path.write_bytes(data)
    return path


def test_good_file_still_reads():
    frame = read_openfast_output(GOOD)
    assert list(frame.columns)[0] == "Time" and len(frame) == 401


# (a file longer than its header promises is read, not refused: OpenFAST 5.0 leaves one when it
# writes over a longer run's .outb; tests/test_openfast_output.py)
@pytest.mark.parametrize("case", ["random", "truncated", "huge_counts", "zero", "bad_id"])
def test_corrupt_binary_is_one_line_error_without_allocation(tmp_path, case):
    good = GOOD.read_bytes()
    rng = np.random.default_rng(7)
    if case == "random":
        data = rng.integers(0, 256, 3_000_000, dtype=np.uint8).tobytes()
        data = np.int16(1).tobytes() + data[2:]            # a valid id, garbage after it
    elif case == "truncated":
        data = good[:-100]
    elif case == "huge_counts":
        data = good[:2] + np.int32(90_000).tobytes() + np.int32(2_000_000_000).tobytes() + good[10:]
    elif case == "zero":
        data = b""
    else:
        data = np.int16(77).tobytes() + good[2:]
    path = _variant(tmp_path, f"{case}.outb", data)
    start = time.perf_counter()
    with pytest.raises(ModeselError) as info:
        read_openfast_output(path)
    assert time.perf_counter() - start < 5.0
    message = str(info.value)
    assert "\n" not in message and str(path) in message


def test_cli_reference_with_corrupt_outb_exits_2(tmp_path, capsys):
    """Through the study: the reference file is named, exit code 2, no traceback."""
    from modesel.cli import main
    repo = Path(__file__).resolve().parents[2]
    case = tmp_path / "case"
    shutil.copytree(repo / "studies" / "data" / "openfast_free_decay" / "tower_fa_ss_shaft", case)
    outb = case / "Main_Spar_ED.outb"
    outb.write_bytes(outb.read_bytes()[: os.path.getsize(outb) // 2])
    study = (repo / "studies" / "tower_free_decay.toml").read_text()
    study = study.replace("data/openfast_free_decay/tower_fa_ss_shaft", str(case).replace("\\", "/"))
    (tmp_path / "study.toml").write_text(study)
    rc = main(["run", str(tmp_path / "study.toml"), "--out", str(tmp_path / "out"), "--n-trials", "1"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "Main_Spar_ED.outb" in err and "Traceback" not in err and len(err.splitlines()) == 1
