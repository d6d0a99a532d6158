"""Helpers shared by the command modules."""
from __future__ import annotations


from modesel.files import atomic_write_text  # noqa: F401  (shared by the commands)


def load_modeset(path):
    """ModeSet from a JSON file (families, counts and parameters checked,
    errors naming the file and field), or None."""
    if path is None:
        return None
    from modesel.candidates.base import check_field_modes
    from modesel.modeset import ModeSet
    modeset = ModeSet.from_json(path)
    for field, fm in modeset.fields.items():
        check_field_modes(field, fm.family, fm.count, fm.params, file=str(path), where=f"fields.{field}")
    return modeset


def positive_float(text: str) -> float:
    import argparse
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text}")
    return value
