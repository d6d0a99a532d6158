"""modesel vs OpenFAST 5.0 on the NREL 5-MW structure (no aero), with the
ElastoDyn-faithful blade model switched on or off, to show each cause's
effect (issue 10):

- parked release (tests/data/openfast_turbine/parked_release): NRMSE over
  30 s (RMS of the difference / range of the reference) of TTDspFA,
  TTDspSS, OoPDefl1-3, IPDefl1-3;
- frequencies vs OpenFAST's linearisation (tests/data/openfast_lin), parked
  and at 12.1 rpm, mode by mode (multi-blade coordinates).

    python3 benchmarks/openfast_structure.py [--no-twist] [--converged]

--no-twist: blade shapes along the pitched axes only ([effects]
structural_twist = false); --converged: modesel's converged quadrature
instead of ElastoDyn's discrete nodes ([effects] elastodyn_nodes = false).
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from modesel.simulation.api import linearize_scene, simulate
from modesel.simulation.coleman import openfast_modes
from modesel.turbine.openfast_output import read_openfast_lin, read_openfast_output
from modesel.simulation.scene import load_scene

DATA = Path(__file__).resolve().parent.parent / "tests" / "data"
CHANNELS = ("TTDspFA", "TTDspSS", "OoPDefl1", "OoPDefl2", "OoPDefl3", "IPDefl1", "IPDefl2", "IPDefl3")


def scene(path, args):
    sc = load_scene(path)
    sc.effects["structural_twist"] = not args.no_twist
    sc.effects["elastodyn_nodes"] = not args.converged
    return sc


def frequencies(deck, lins, args, rpm=None):
    modes, lin = linearize_scene(scene(deck, args), rpm=rpm)
    ref = openfast_modes([read_openfast_lin(p) for p in lins])
    print(f"  {'OpenFAST':>20s}   {'modesel':>20s}   diff")
    for (f0, _, l0), m in zip(ref, modes):
        print(f"  {l0:>10s} {f0:7.4f} Hz   {m.label:>10s} {m.frequency_hz:7.4f} Hz   {100 * (m.frequency_hz / f0 - 1):+6.2f} %")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--no-twist", action="store_true")
    p.add_argument("--converged", action="store_true")
    args = p.parse_args()
    case = DATA / "openfast_turbine" / "parked_release"
    ref = read_openfast_output(case / "parked_release.outb")
    out = simulate(scene(case / "parked_release_ElastoDyn.dat", args), tmax=30.0, dt=0.05).outputs
    print("parked release, NRMSE over 30 s:")
    for ch in CHANNELS:
        y = np.interp(ref["Time"], out["Time"], out[ch])
        print(f"  {ch:9s} {100 * np.sqrt(np.mean((y - ref[ch]) ** 2)) / np.ptp(ref[ch]):6.2f} %")
    print("parked frequencies vs OpenFAST linearisation:")
    frequencies(DATA / "openfast_lin" / "parked" / "parked_lin_ElastoDyn.dat",
                [DATA / "openfast_lin" / "parked" / "parked_lin.1.lin.gz"], args)
    print("12.1 rpm frequencies vs OpenFAST linearisation (12 azimuths, MBC3):")
    frequencies(DATA / "openfast_lin" / "rotating" / "rotating_lin_az0_ElastoDyn.dat",
                sorted((DATA / "openfast_lin" / "rotating").glob("*.lin.gz")), args, rpm=12.1)


if __name__ == "__main__":
    main()
