"""OpenFAST output reader: binary .outb from a real OpenFAST run, text .out in
OpenFAST's layout, and the same data through both formats."""
from pathlib import Path

import numpy as np
import pytest

from modesel.errors import ModeselError
from modesel.turbine.openfast_output import read_openfast_output

DATA = Path(__file__).parent / "data" / "openfast_free_decay" / "tower_fa_ss_shaft"
OUTB = DATA / "Main_Spar_ED.outb"


def write_text_output(path, names, units, data, description="test"):
    """A .out file in OpenFAST's text layout: 6 header lines, channel names
    on line 7, units in parentheses on line 8, tab-separated numbers."""
    lines = ["", f"Predictions were generated on 01-Jan-2024 at 00:00:00 using OpenFAST", "", "",
             f"Description from the FAST input file: {description}", "",
             "\t".join(names), "\t".join(f"({u})" for u in units)]
    lines += ["\t".join(f"{v:.9E}" for v in row) for row in data]
    Path(path).write_text("\n".join(lines) + "\n")


def test_binary_free_decay_run():
    df = read_openfast_output(OUTB)
    assert list(df.columns) == ["Time", "Azimuth", "Q_TFA1", "Q_TSS1"]
    assert len(df) == 401
    assert df["Time"].iloc[0] == 0.0 and df["Time"].iloc[-1] == pytest.approx(4.0)
    assert np.allclose(np.diff(df["Time"]), 0.01)
    # the deck starts the decay from TTDspFA = 2 m and TTDspSS = -2 m: Q_TFA1 = 2,
    # and Q_TSS1 = +2 (ElastoDyn's side-side modal coordinate points along -y)
    assert df["Q_TFA1"].iloc[0] == pytest.approx(2.0, abs=1e-6)   # single-precision file
    assert df["Q_TSS1"].iloc[0] == pytest.approx(2.0, abs=1e-6)
    assert df.attrs["units"] == {"Time": "s", "Azimuth": "deg", "Q_TFA1": "m", "Q_TSS1": "m"}
    assert "OpenFAST" in df.attrs["description"]


def test_text_output_hand_written(tmp_path):
    t = np.linspace(0.0, 1.0, 11)
    data = np.column_stack([t, 360.0 * t, 0.5 * np.cos(2 * np.pi * t), 12.1 + 0 * t])
    path = tmp_path / "run.out"
    write_text_output(path, ["Time", "Azimuth", "TTDspFA", "RotSpeed"], ["s", "deg", "m", "rpm"], data)
    df = read_openfast_output(path)
    assert list(df.columns) == ["Time", "Azimuth", "TTDspFA", "RotSpeed"]
    assert df.attrs["units"] == {"Time": "s", "Azimuth": "deg", "TTDspFA": "m", "RotSpeed": "rpm"}
    assert np.allclose(df.to_numpy(), data, rtol=1e-9)


def test_text_and_binary_agree(tmp_path):
    binary = read_openfast_output(OUTB)
    path = tmp_path / "Main_Spar_ED.out"
    write_text_output(path, list(binary.columns), [binary.attrs["units"][c] for c in binary.columns],
                      binary.to_numpy())
    text = read_openfast_output(path)
    assert list(text.columns) == list(binary.columns)
    assert text.attrs["units"] == binary.attrs["units"]
    assert np.allclose(text.to_numpy(), binary.to_numpy(), rtol=1e-8, atol=1e-12)


def test_missing_file_is_named(tmp_path):
    with pytest.raises(ModeselError, match="nothing.outb"):
        read_openfast_output(tmp_path / "nothing.outb")


def test_wrong_suffix(tmp_path):
    path = tmp_path / "run.csv"
    path.write_text("Time,a\n0,1\n")
    with pytest.raises(ModeselError, match="run.csv"):
        read_openfast_output(path)


def test_non_numeric_text_output(tmp_path):
    path = tmp_path / "bad.out"
    write_text_output(path, ["Time", "Q_TFA1"], ["s", "m"], [[0.0, 1.0]])
    path.write_text(path.read_text() + "0.01\tnot-a-number\n")
    with pytest.raises(ModeselError, match="bad.out.*unreadable"):
        read_openfast_output(path)


def test_text_output_with_an_overflowed_field(tmp_path):
    """OpenFAST writes a number too wide for OutFmt as '**********' (a sweep
    with OutFmt F10.3: RtAeroMxh and three others overflowed). The whole file
    was refused; now that field reads as NaN, the other channels as written,
    and a study comparing the overflowed channel is refused there (its
    finite-value check names the file and channel)."""
    path = tmp_path / "wide.out"
    write_text_output(path, ["Time", "Q_TFA1", "RtAeroMxh"], ["s", "m", "N-m"], [[0.0, 1.0, 5.0]])
    path.write_text(path.read_text() + "0.01\t0.5\t**********\n")
    df = read_openfast_output(path)
    assert df["Q_TFA1"].tolist() == [1.0, 0.5] and df["RtAeroMxh"].iloc[0] == 5.0
    assert np.isnan(df["RtAeroMxh"].iloc[1])
    assert df.attrs["units"]["RtAeroMxh"] == "N-m"


def test_truncated_binary_output(tmp_path):
    path = tmp_path / "cut.outb"
    path.write_bytes(OUTB.read_bytes()[:200])
    with pytest.raises(ModeselError, match="cut.outb"):
        read_openfast_output(path)


def test_binary_output_written_over_a_longer_one(tmp_path):
    """OpenFAST 5.0 writes an .outb over an existing file without shortening it:
    a 10-s run in the folder of a 30-s one left 91296 bytes, of which its header
    promised 33808 (the rest the old run's tail). The file is read as the header
    says, the same as without the tail; fewer bytes than promised stay an error."""
    clean = read_openfast_output(OUTB)
    path = tmp_path / "rerun.outb"
    path.write_bytes(OUTB.read_bytes() + bytes(range(256)) * 40)
    stale = read_openfast_output(path)
    assert stale.shape == clean.shape and np.array_equal(stale.to_numpy(), clean.to_numpy())
    path.write_bytes(OUTB.read_bytes()[:-1])
    with pytest.raises(ModeselError, match="rerun.outb.*truncated or corrupt"):
        read_openfast_output(path)
