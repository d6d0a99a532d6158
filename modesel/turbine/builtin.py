"""Built-in turbines shipped as package data (`modesel/turbine/data/`).

Found with `importlib.resources`, so they work from a wheel as well as from
an editable install.
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

#: built-in turbine name -> (ElastoDyn main file, AeroDyn primary file), package-data relative
BUILTIN_TURBINES = {
    "nrel5mw": ("nrel5mw/NREL5MW_ED_Onshore.dat", "nrel5mw/NREL5MW_AD.dat"),
}


def data_dir() -> Path:
    """The folder holding the bundled decks."""
    return Path(str(resources.files("modesel.turbine") / "data"))


def builtin_elastodyn(name: str) -> Path | None:
    """ElastoDyn main file of a built-in turbine (None if `name` is not one)."""
    entry = BUILTIN_TURBINES.get(name.lower())
    return None if entry is None else data_dir() / entry[0]


def builtin_aerodyn_for(elastodyn_path) -> Path | None:
    """AeroDyn deck bundled with a built-in ElastoDyn deck (None for other decks)."""
    source = Path(elastodyn_path).resolve()
    for ed, ad in BUILTIN_TURBINES.values():
        if source == (data_dir() / ed).resolve():
            return data_dir() / ad
    return None
