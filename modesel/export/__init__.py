"""Export a chosen mode set for other simulators.

Front function: `export_modeset(modeset, turbine, elastodyn_dir=..., json_path=...)`.

- ElastoDyn (`elastodyn_writer`): main, tower and blade input files whose
  mode-shape polynomials are constrained sixth-order fits (`polyfit`, first
  paper eq. 46) of the mode set's shapes, DOF flags set to match.
- JSON (`modeset_json`): the mode set, its shapes sampled on the normalised
  span and their shape integrals, for simulators that take tabulated shapes.

Both start from the same step, `field_shapes`: the mode set's shapes of each
field on the turbine (`modesel.candidates.mode_shapes` with the field context
of `modesel.candidates.context.field_context`).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from modesel.candidates.base import FieldContext, ShapeSet, get_family
from modesel.errors import ModeselError

FIT_STATIONS = 201     # normalised stations x = 0, 0.005, ..., 1 for fits and JSON samples


@dataclass(frozen=True)
class FieldShapes:
    """The shapes one field of a mode set describes on one turbine."""

    field: str
    family: str
    count: int
    params: dict
    context: FieldContext

    def sample(self, x) -> ShapeSet:
        """Shapes (tip-normalised) and their x-derivatives at normalised stations x."""
        return get_family(self.family).shapes(x, self.count, self.context, **self.params)


def stations(n: int = FIT_STATIONS) -> np.ndarray:
    return np.linspace(0.0, 1.0, n)


def write_text(path, text: str):
    """Write an output file; an OS error becomes a one-line ModeselError."""
    path = Path(path)
    try:
        path.write_text(text)
    except OSError as exc:
        raise ModeselError(f"cannot write file ({exc.strerror})", file=str(path)) from None


def field_shapes(modeset, turbine, *, rpm: float = 0.0, source: str | None = None) -> dict:
    """{field: FieldShapes} for every field of `modeset`, validated now.

    `rpm` is the rotor speed for blade fields [rpm] (centrifugal stiffening of
    shape families that use it); `source` names the mode-set file in errors.
    """
    from modesel.candidates.context import field_context

    out = {}
    for name, modes in modeset.fields.items():
        try:
            get_family(modes.family)
            context = field_context(turbine, name, rotor_speed=float(rpm) * np.pi / 30.0)
            shapes = FieldShapes(name, modes.family, modes.count, dict(modes.params), context)
            shapes.sample(stations(5))          # bad parameter or count -> error now
        except ModeselError as exc:
            where = f"fields.{name}." + (exc.field or "family")
            raise ModeselError(exc.message, file=source or exc.file, field=where) from None
        out[name] = shapes
    return out


def export_modeset(modeset, turbine_deck, *, elastodyn_dir=None, json_path=None,
                   weighting: str = "uniform", rpm: float = 0.0, source: str | None = None):
    """Export `modeset` for the turbine deck `turbine_deck` (path or 'nrel5mw').

    Returns (ElastoDynExport or None, JSON dict or None). Nothing is written
    before every field's shapes have been evaluated successfully.
    """
    from modesel.export.elastodyn_writer import export_elastodyn
    from modesel.export.modeset_json import write_modeset_json
    from modesel.turbine.elastodyn import load_turbine

    if elastodyn_dir is None and json_path is None:
        raise ModeselError("nothing to export: give an ElastoDyn output folder and/or a JSON file")
    turbine = load_turbine(turbine_deck)
    shapes = field_shapes(modeset, turbine, rpm=rpm, source=source)
    report = None
    if elastodyn_dir is not None:
        report = export_elastodyn(modeset, shapes, turbine, elastodyn_dir, weighting=weighting)
    data = None
    if json_path is not None:
        data = write_modeset_json(modeset, shapes, turbine, json_path, rpm=rpm)
    return report, data
