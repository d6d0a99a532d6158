"""Hostile user text never becomes code: a scene name that closes the
generated module's docstring, or a comment, is written as data (issue 13)."""
from __future__ import annotations

import importlib.util
from pathlib import Path

from modesel.cli import main

REPO = Path(__file__).resolve().parents[2]
HOSTILE = 'x""";import os;os.system("touch PWNED");"""\nimport os; os.system("touch PWNED2") #\\input{/etc/passwd}\\'


def _hostile_scene(tmp_path: Path) -> Path:
    text = (REPO / "studies" / "scenes" / "paper_2dof_tower_shaft.toml").read_text()
    lines = [ln for ln in text.splitlines() if not ln.startswith(("name", "description"))]
    name = HOSTILE.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
    scene = tmp_path / "hostile.toml"
    scene.write_text(f'name = "{name}"\ndescription = "{name}"\n' + "\n".join(lines) + "\n")
    return scene


def test_derive_python_with_hostile_name_imports_without_running_it(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scene = _hostile_scene(tmp_path)
    py, tex = tmp_path / "eom.py", tmp_path / "eom.tex"
    assert main(["derive", str(scene), "--python", str(py), "--latex", str(tex)]) == 0
    spec = importlib.util.spec_from_file_location("eom_hostile", py)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert not (tmp_path / "PWNED").exists() and not (tmp_path / "PWNED2").exists()
    assert module.SCENE_NAME == HOSTILE
    assert module.mass_matrix([0.0, 0.0], [0.0, 0.0]).shape == (2, 2)
    latex = tex.read_text()
    assert "\\input{" not in latex          # the backslash is escaped, no TeX command runs
