"""Write the reduced reference of an OpenFAST run: the named channels of
CASE.outb as CASE_reference.csv (a name row, then a unit row; read with
pandas.read_csv(path, header=[0, 1])).

    python3 reduce.py CASE/CASE.outb Time,TTDspFA,...
"""
import sys
from pathlib import Path

from modesel.turbine.openfast_output import read_openfast_output

outb, channels = Path(sys.argv[1]), sys.argv[2].split(",")
frame = read_openfast_output(outb)
units = frame.attrs.get("units", {})
target = outb.with_name(outb.stem + "_reference.csv")
with open(target, "w") as fh:
    fh.write(",".join(channels) + "\n")
    fh.write(",".join(units.get(c, "-") for c in channels) + "\n")
    for row in frame[channels].itertuples(index=False):
        fh.write(",".join(f"{v:.7g}" for v in row) + "\n")
print(target, target.stat().st_size, "bytes")
