"""`ModeSet`: which family, how many modes and which shape parameters per field.

Fields are the flexible fields of the turbine (`vocabulary.FIELDS`):
`tower_fa`, `tower_ss`, `tower_torsion`, `blade_flap`, `blade_edge`.
A field absent from a ModeSet keeps the scene's default (or is rigid when
the scene does not free it).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from modesel.errors import ModeselError, unknown_name
from modesel.vocabulary import FIELDS   # the flexible fields (also read from here)


@dataclass(frozen=True)
class FieldModes:
    """Assumed modes of one field: `count` shapes of `family` with `params`."""

    family: str
    count: int
    params: dict = field(default_factory=dict)

    def __post_init__(self):
        if not isinstance(self.count, int) or isinstance(self.count, bool) or self.count < 1:
            raise ModeselError(f"count must be an integer >= 1, got {self.count!r}", field="count")

    def label(self) -> str:
        extra = ",".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                         for k, v in sorted(self.params.items()))
        return f"{self.family}:{self.count}" + (f"({extra})" if extra else "")


@dataclass(frozen=True)
class ModeSet:
    """Mapping field -> FieldModes. Serialises to/from JSON."""

    fields: dict = field(default_factory=dict)

    def __post_init__(self):
        for name in self.fields:
            if name not in FIELDS:
                raise unknown_name("field", name, FIELDS, field="fields")

    def __getitem__(self, name: str) -> FieldModes:
        return self.fields[name]

    def __contains__(self, name: str) -> bool:
        return name in self.fields

    def get(self, name, default=None):
        return self.fields.get(name, default)

    def label(self) -> str:
        """Human-readable, e.g. 'tower_fa=clamped:2 blade_flap=fem:3'."""
        return " ".join(f"{f}={self.fields[f].label()}" for f in FIELDS if f in self.fields)

    def to_dict(self) -> dict:
        return {"fields": {f: {"family": m.family, "count": m.count, "params": dict(m.params)}
                           for f, m in self.fields.items()}}

    @classmethod
    def from_dict(cls, data: dict, *, file=None) -> "ModeSet":
        if not isinstance(data, dict) or not isinstance(data.get("fields"), dict):
            raise ModeselError("a mode set must be an object with a 'fields' object", file=file, field="fields")
        out = {}
        for name, spec in data["fields"].items():
            if name not in FIELDS:
                raise unknown_name("field", name, FIELDS, file=file, field="fields")
            if not isinstance(spec, dict) or "family" not in spec or "count" not in spec:
                raise ModeselError("needs 'family' and 'count'", file=file, field=f"fields.{name}")
            if not isinstance(spec["family"], str):
                raise ModeselError(f"must be a family name, got {spec['family']!r}", file=file,
                                   field=f"fields.{name}.family")
            if not isinstance(spec.get("params", {}), dict):
                raise ModeselError(f"must be a table of parameter values, got {spec['params']!r}",
                                   file=file, field=f"fields.{name}.params")
            try:
                out[name] = FieldModes(str(spec["family"]), spec["count"], dict(spec.get("params", {})))
            except ModeselError as exc:
                raise ModeselError(exc.message, file=file, field=f"fields.{name}.count") from None
        return cls(out)

    @classmethod
    def from_json(cls, path: str | Path) -> "ModeSet":
        path = Path(path)
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise ModeselError("mode-set file not found", file=str(path)) from None
        except json.JSONDecodeError as exc:
            raise ModeselError(f"not valid JSON ({exc.msg} at line {exc.lineno})", file=str(path)) from None
        except (OSError, UnicodeDecodeError) as exc:
            raise ModeselError(f"cannot read the mode-set file: {exc}", file=str(path)) from None
        return cls.from_dict(data, file=str(path))
