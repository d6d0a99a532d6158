"""What every exporter starts from: the mode set's shapes of each field on
the turbine (`field_shapes`: `modesel.candidates.mode_shapes` with the field
context of `modesel.candidates.context.field_context`), the normalised
stations they are sampled at, and the one-line-error file writer."""
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
