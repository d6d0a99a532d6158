"""Export a chosen mode set for other simulators.

Front function: `export_modeset(modeset, turbine, elastodyn_dir=..., json_path=...)`.

- ElastoDyn (`elastodyn_writer`): main, tower and blade input files whose
  mode-shape polynomials are constrained sixth-order fits (`polyfit`, first
  paper eq. 46) of the mode set's shapes, DOF flags set to match.
- JSON (`modeset_json`): the mode set, its shapes sampled on the normalised
  span and their shape integrals, for simulators that take tabulated shapes.

Both start from the same step, `common.field_shapes`: the mode set's shapes
of each field on the turbine.
"""
from __future__ import annotations

from modesel.errors import ModeselError
from modesel.export.common import FIT_STATIONS, FieldShapes, field_shapes, stations, write_text  # noqa: F401
from modesel.export.elastodyn_writer import export_elastodyn
from modesel.export.modeset_json import write_modeset_json

def export_modeset(modeset, turbine_deck, *, elastodyn_dir=None, json_path=None,
                   weighting: str = "uniform", rpm: float = 0.0, source: str | None = None):
    """Export `modeset` for the turbine deck `turbine_deck` (path or 'nrel5mw').

    Returns (ElastoDynExport or None, JSON dict or None). Nothing is written
    before every field's shapes have been evaluated successfully.
    """
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
