"""Airfoil polars: lift, drag and pitching-moment coefficients versus angle of attack.

`PolarSet` stacks all airfoils of a blade on one common angle grid, so the
coefficients of any element are found by one bisection on that grid plus a
row offset for its airfoil. The lookup is a compiled (numba) scalar kernel,
`polar_coefficients`, called from inside the compiled BEM root solve (which runs at
every right-hand-side evaluation of the time integrator); `Polar.coefficients`
is its numpy reference on the raw table (tests/test_twins.py).

Interpolation is linear in the angle of attack, as AeroDyn does for
`InterpOrd = 1` / "default". The common grid is the union of all tables'
angles, so resampling each table onto it is exact (a piecewise-linear
function is unchanged when breakpoints are added). Angles are wrapped to
[-pi, pi) before lookup; tables that do not span the full circle are held
constant beyond their ends (np.interp clamping).

Files are read with openfast-io (`InputReader_OpenFAST.read_AeroDynPolar`),
first table of each file (AeroDyn AFTabMod = 1). That reader is positional
and expects a `BL_file` line and no inline shape coordinates; AirfoilInfo
(OpenFAST 5.0's AirfoilInfo.f90) takes files without the optional BL_file
line and with NumCoords > 0 coordinate rows (as the r-test's AOC airfoils),
so such files are read by keyword instead (`_keyword_table`: the first
NumAlf rows after the first NumAlf line).
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
from numba import njit

from modesel.errors import ModeselError


@dataclass(frozen=True)
class Polar:
    """One airfoil table. `alpha` [rad] strictly increasing; `cl`, `cd`, `cm` [-]
    (cm about the quarter chord, positive nose up)."""

    alpha: np.ndarray
    cl: np.ndarray
    cd: np.ndarray
    cm: np.ndarray
    name: str = ""

    def coefficients(self, alpha):
        """(cl, cd, cm) at angles of attack `alpha` [rad]: linear interpolation
        in this table after wrapping to [-pi, pi), held beyond its ends (the
        numpy reference of the compiled `PolarSet.coefficients`)."""
        a = (np.asarray(alpha, float) + np.pi) % (2.0 * np.pi) - np.pi
        return tuple(np.interp(a, self.alpha, c) for c in (self.cl, self.cd, self.cm))


class PolarSet:
    """Several polars on one common angle grid.

    `coefficients(alpha, index)` returns (cl, cd, cm) for arrays of angles of
    attack [rad] and 0-based polar indices (broadcast together).
    """

    def __init__(self, polars):
        polars = list(polars)
        if not polars:
            raise ModeselError("at least one airfoil polar is needed")
        for p in polars:
            if len(p.alpha) < 2 or np.any(np.diff(p.alpha) <= 0):
                raise ModeselError("angles of attack must be strictly increasing "
                                   "with at least 2 rows", file=p.name or None, field="Alpha")
        self.polars = tuple(polars)
        grid = np.unique(np.concatenate([p.alpha for p in polars]))
        self.grid = grid
        self.size = grid.size
        table = np.empty((3, len(polars), grid.size))
        for k, p in enumerate(polars):
            for c, values in enumerate((p.cl, p.cd, p.cm)):
                table[c, k] = np.interp(grid, p.alpha, values)
        slope = np.zeros_like(table)
        slope[:, :, :-1] = np.diff(table, axis=2) / np.diff(grid)
        # flattened (coefficient, polar * grid) layout
        self._value = np.ascontiguousarray(table.reshape(3, -1))
        self._slope = np.ascontiguousarray(slope.reshape(3, -1))

    def __len__(self) -> int:
        return len(self.polars)

    def offsets(self, index) -> np.ndarray:
        """Row offsets (index * grid size) of 0-based polar indices, as the
        compiled kernels (`polar_coefficients`) take them."""
        index = np.asarray(index, dtype=np.int64)
        if index.size and (index.min() < 0 or index.max() >= len(self.polars)):
            raise ModeselError(f"airfoil index out of range 0..{len(self.polars) - 1}",
                               field="BlAFID")
        return index * self.size

    @property
    def arrays(self):
        """(grid, value, slope): the tables as `polar_coefficients` takes them."""
        return self.grid, self._value, self._slope

    def coefficients(self, alpha, index):
        """(cl, cd, cm) at angles of attack `alpha` [rad] for polar `index` (0-based)."""
        alpha, index = np.broadcast_arrays(np.asarray(alpha, float), np.asarray(index))
        offset = np.ascontiguousarray(self.offsets(index).ravel())
        out = _lookup_many(np.ascontiguousarray(alpha, dtype=float).ravel(), offset,
                           self.grid, self._value, self._slope)
        return tuple(c.reshape(alpha.shape) for c in out)


@njit(cache=True)
def polar_coefficients(alpha, offset, grid, value, slope):
    """(cl, cd, cm) at angle of attack `alpha` [rad] (compiled, scalar).

    Wraps alpha to [-pi, pi) (an angle already there is taken as it is: the
    wrap's float modulo would cost a third of the lookup), clamps it to the
    grid, finds the interval by bisection and interpolates linearly in the
    rows starting at `offset`.
    """
    a = alpha
    if not (-np.pi <= a < np.pi):               # NaN too: it stays NaN
        a = (alpha + np.pi) % (2.0 * np.pi) - np.pi
    n = grid.size
    if a <= grid[0]:
        a = grid[0]
    elif a >= grid[n - 1]:
        a = grid[n - 1]
    lo, hi = 0, n - 1
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if grid[mid] <= a:
            lo = mid
        else:
            hi = mid
    j = offset + lo
    d = a - grid[lo]
    return (value[0, j] + slope[0, j] * d, value[1, j] + slope[1, j] * d,
            value[2, j] + slope[2, j] * d)


@njit(cache=True)
def _lookup_many(alpha, offset, grid, value, slope):
    out = np.empty((3, alpha.size))
    for i in range(alpha.size):
        out[0, i], out[1, i], out[2, i] = polar_coefficients(alpha[i], offset[i], grid,
                                                             value, slope)
    return out


def _input_lines(path) -> list:
    """The tokens of each line of an OpenFAST input file that is not blank or a
    comment ('!' first, as OpenFAST's ProcessComFile drops them)."""
    with open(path, errors="replace") as fh:
        return [line.split() for line in fh if line.strip() and not line.lstrip().startswith("!")]


def _positional_layout(lines) -> bool:
    """Whether openfast-io's positional reader takes an airfoil file of
    `lines` (`_input_lines`): a BL_file line and NumCoords 0 (module doc)."""
    labels = {t[1].lower(): t[0] for t in lines[:8] if len(t) > 1}
    try:
        return "bl_file" in labels and int(float(labels.get("numcoords", "0"))) == 0
    except ValueError:
        return False


def _keyword_table(path, lines, columns) -> tuple:
    """(alpha [rad], Cl, Cd, Cm) of the first table of AirfoilInfo file `path`
    of `lines` (`_input_lines`) read by keyword (module doc): the NumAlf rows
    after its first NumAlf line, columns as `read_polars` takes them."""
    width = max(columns)
    for k, tokens in enumerate(lines):
        if len(tokens) > 1 and tokens[1].lower() == "numalf":
            n = int(tokens[0])
            rows = [row[:width] for row in lines[k + 1:k + 1 + n]]
            if n < 1 or len(rows) < n or any(len(row) < width for row in rows):
                raise ModeselError(f"the table has fewer than NumAlf = {n} rows of {width} columns", file=path,
                                   field="NumAlf")
            table = np.array(rows, dtype=float)
            cm = table[:, columns[3] - 1] if columns[3] > 0 else np.zeros(n)
            return np.radians(table[:, columns[0] - 1]), table[:, columns[1] - 1], table[:, columns[2] - 1], cm
    raise ModeselError("no NumAlf line (the length of the airfoil table)", file=path, field="NumAlf")


def read_polars(paths, columns=(1, 2, 3, 4)) -> PolarSet:
    """Read AeroDyn airfoil files (first table each) with openfast-io.

    `columns`: 1-based columns of alpha, Cl, Cd, Cm (AeroDyn InCol_Alfa,
    InCol_Cl, InCol_Cd, InCol_Cm; Cm column 0 = no Cm, taken as zero).
    Angles in the files are in degrees; returned in rad.
    """
    from openfast_io.FAST_reader import InputReader_OpenFAST

    paths = [os.path.abspath(p) for p in paths]
    for p in paths:
        if not os.path.isfile(p):
            raise ModeselError("airfoil file not found", file=p, field="AFNames")
    reader = InputReader_OpenFAST()
    ad = reader.fst_vt["AeroDyn"]
    ad.update(NumAFfiles=len(paths), AFNames=paths, InCol_Alfa=int(columns[0]),
              InCol_Cl=int(columns[1]), InCol_Cd=int(columns[2]),
              InCol_Cm=int(columns[3]), InCol_Cpmin=0)
    polars = []
    for path in paths:
        ad["AFNames"] = [path]
        ad["NumAFfiles"] = 1
        try:
            lines = _input_lines(path)
            if _positional_layout(lines):
                reader.read_AeroDynPolar()
                table = ad["af_data"][0][0]
                alpha = np.radians(np.asarray(table["Alpha"], float))
                cl = np.asarray(table["Cl"], float)
                cd = np.asarray(table["Cd"], float)
                cm = (np.asarray(table["Cm"], float) if columns[3] > 0
                      else np.zeros_like(alpha))
            else:
                alpha, cl, cd, cm = _keyword_table(path, lines, columns)
        except ModeselError:
            raise
        except Exception as exc:  # openfast-io raises bare ValueError/IndexError
            raise ModeselError(f"cannot read airfoil table ({type(exc).__name__}: {exc})",
                               file=path) from exc
        if not (np.all(np.isfinite(cl)) and np.all(np.isfinite(cd)) and np.all(np.isfinite(cm))):
            raise ModeselError("non-numeric coefficient in airfoil table", file=path)
        polars.append(Polar(alpha, cl, cd, cm, name=path))
    return PolarSet(polars)
