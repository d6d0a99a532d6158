"""`modesel derive SCENE [--python OUT.py] [--latex OUT.tex] [--small-angle ORDER] [--modeset MS.json]`

Derive the equations of motion M(q) qdd = F(q, qd, t, u) of a small model
symbolically (SymPy, Kane's method, first paper sections 2 and 4) and write
them as a Python module (mass_matrix, forcing, linear_matrices and the
PARAMETERS dict of the numeric engine's values) and/or a LaTeX document.
SCENE is a TOML scene or ElastoDyn deck whose model is one of the small
models (tower modes with shaft/platform DOFs, or blade modes on a rigid
tower; no torsion, no aerodynamics, at most 9 DOFs).
--small-angle: ORDER (Taylor order in the shaft tilt and the tower-top
slopes) or group=order pairs, e.g. 'tilt=1,slope=2,pitch=1' (the paper's
choice for the floating model); default: exact equations.
"""
from __future__ import annotations

import time
from pathlib import Path

from modesel.commands._common import atomic_write_text, load_modeset
from modesel.errors import ModeselError


def register(sub):
    p = sub.add_parser("derive", help="symbolic equations of motion of a small model (Python, LaTeX)",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("scene", help="TOML scene, ElastoDyn main file (.dat) or OpenFAST .fst")
    p.add_argument("--python", metavar="OUT.py", help="write a Python module with M, F and the linear matrices")
    p.add_argument("--latex", metavar="OUT.tex", help="write a LaTeX document with M, F and the parameters")
    p.add_argument("--small-angle", metavar="ORDER", dest="small_angle",
                   help="Taylor order for small angles: N, or group=order,... (groups tilt, slope, pitch)")
    p.add_argument("--modeset", help="mode-set JSON overriding the scene's shapes")
    p.set_defaults(func=run)


def run(args) -> int:
    from modesel.multibody import linearize as lin
    from modesel.simulation.api import load_scene
    from modesel.simulation.symbolic import derive_scene
    from modesel.multibody.symbolic.approximations import parse_orders
    from modesel.multibody.symbolic.export import latex_source, python_source

    orders = parse_orders(args.small_angle)          # bad input -> one-line error before any work
    for path in (args.python, args.latex):
        if path and not (Path(path).parent if str(Path(path).parent) else Path(".")).is_dir():
            raise ModeselError("output folder does not exist", file=str(Path(path).parent))
    scene = load_scene(args.scene)
    model = derive_scene(scene, load_modeset(args.modeset), small_angle=orders)
    d = model.derivation
    print(f"{model.name}: q = ({', '.join(d.free)}), {len(model.table.params)} parameters, "
          f"derived in {sum(model.seconds.values()):.2f} s"
          + (f" (small angles: {', '.join(f'{k}={v}' for k, v in orders.items())})" if orders else ""))
    M0, C0, K0 = model.linear_matrices()
    modes = lin.modes(lin.LinearModel(list(d.free), M0, C0, K0))
    if modes:
        print("linearised at q = qd = 0: " + ", ".join(f"{m.frequency_hz:.4f} Hz ({m.label})" for m in modes))
    for path, make in ((args.python, python_source), (args.latex, latex_source)):
        if path:
            start = time.perf_counter()
            atomic_write_text(path, make(model))
            print(f"wrote {path} ({time.perf_counter() - start:.2f} s)")
    if not (args.python or args.latex):
        print("(give --python OUT.py and/or --latex OUT.tex to write the equations)")
    return 0
