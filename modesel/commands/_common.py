"""Helpers shared by the command modules."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from modesel.errors import ModeselError


def load_modeset(path):
    """ModeSet from a JSON file, or None."""
    if path is None:
        return None
    from modesel.modeset import ModeSet
    return ModeSet.from_json(path)


def atomic_write_text(path, text: str):
    """Write `text` to `path` atomically (temp file + rename)."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.exists():
        raise ModeselError("output folder does not exist", file=str(parent))
    if not os.access(parent, os.W_OK):
        raise ModeselError("output folder is not writable", file=str(parent))
    fd, tmp = tempfile.mkstemp(dir=parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def positive_float(text: str) -> float:
    import argparse
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text}")
    return value
