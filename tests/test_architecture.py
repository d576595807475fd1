"""The package's shape: layers that show the pipeline, no import cycles, imports at the top.

The layer rule itself is the import-linter contract in pyproject.toml ([tool.importlinter]):
twin.tools > twin.analysis > twin.runs | hardware > twin.control > twin.sensing > twin.world > twin.core.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: imported where they are used: optional extras that a default install may lack
OPTIONAL = {"ray", "cri"}


def test_import_contracts_hold() -> None:
    lint = Path(sys.executable).with_name("lint-imports")
    result = subprocess.run([str(lint), "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]
    assert "broken" in result.stdout and " 0 broken" in result.stdout


def _function_level_imports(path: Path) -> list[str]:
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for inner in ast.walk(node):
                if isinstance(inner, ast.Import):
                    names = [a.name for a in inner.names]
                elif isinstance(inner, ast.ImportFrom):
                    names = [inner.module or ""]
                else:
                    continue
                if not any(n.split(".")[0] in OPTIONAL for n in names):
                    found.append(f"{path.relative_to(ROOT)}:{inner.lineno} {', '.join(names)}")
    return found


def test_imports_sit_at_module_top() -> None:
    """Hidden imports inside functions hid an import cycle once; only optional extras may
    be imported where they are used."""
    files = sorted((ROOT / "twin").rglob("*.py")) + sorted((ROOT / "hardware").rglob("*.py"))
    inside = [hit for f in files for hit in _function_level_imports(f)]
    assert not inside, "imports inside functions:\n" + "\n".join(inside)


#: every twin.core module, imported together
CORE = ", ".join(f"twin.core.{p.stem}" for p in sorted((ROOT / "twin" / "core").glob("*.py")) if p.stem != "__init__")


@pytest.mark.parametrize("modules", ["hardware.safety", CORE], ids=["hardware.safety", "twin.core"])
def test_layers_hold_at_run_time(modules: str) -> None:
    """Importing a low module loads no layer above it and none of the simulator's libraries
    (twin's package import is lazy: twin/__init__.py), so no GL selection or gym registration."""
    code = f"import sys, {modules}; print(*sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    loaded = set(result.stdout.split())
    assert not loaded & {"mujoco", "sklearn", "gymnasium", "OpenGL", "pyrender", "numba", "cv2"}, sorted(loaded)
    above = sorted(
        m
        for m in loaded
        if m.startswith(("twin.world", "twin.sensing", "twin.control", "twin.runs", "twin.tools", "twin.analysis"))
    )
    assert not above, above


def _imported_modules(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    return names


def test_analysis_draws_nothing() -> None:
    """twin.analysis computes what the runs mean; its figures are drawn by the command line
    (twin.tools), so a plot never sits inside the logic a test or a script calls."""
    files = sorted((ROOT / "twin" / "analysis").rglob("*.py"))
    assert files
    drawing = [
        str(f.relative_to(ROOT)) for f in files if any(n.split(".")[0] == "matplotlib" for n in _imported_modules(f))
    ]
    assert not drawing, "matplotlib imported in twin.analysis (draw in twin.tools): " + ", ".join(drawing)
