"""Helpers shared by the command modules."""
from __future__ import annotations


from modesel.files import atomic_write_text  # noqa: F401  (shared by the commands)


def load_modeset(path):
    """ModeSet from a JSON file, or None."""
    if path is None:
        return None
    from modesel.modeset import ModeSet
    return ModeSet.from_json(path)


def positive_float(text: str) -> float:
    import argparse
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text}")
    return value
