"""The seam between the scene and its dome models (twin.world.dome.base): nothing outside
twin.world.dome imports a model's subpackage or compares a name with a model's, the
models do not import one another, and every model subpackage has its registry line."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from twin.world.dome.base import PhysicsSettings
from twin.world.dome.registry import DOME_MODELS

TWIN = Path(__file__).resolve().parents[2] / "twin"
DOME = TWIN / "world" / "dome"
#: modules outside twin.world.dome that may import one model, and why
MAY_IMPORT_A_MODEL = {"tools/assets.py": "writes the flex dome's MJCF files (assets/tactip) from its own code"}


def _model_packages() -> list[str]:
    return sorted(p.parent.name for p in DOME.glob("*/__init__.py"))


def _imported(tree: ast.AST) -> list[str]:
    names = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            names += [node.module] + [f"{node.module}.{a.name}" for a in node.names]
    return names


def _branches_on_a_model(tree: ast.AST) -> list[int]:
    """Lines comparing anything with a string that names a dome model (`dome == "flex"`)."""
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            for side in (node.left, *node.comparators):
                values = side.elts if isinstance(side, (ast.Tuple, ast.List, ast.Set)) else [side]
                if any(isinstance(v, ast.Constant) and v.value in DOME_MODELS for v in values):
                    lines.append(node.lineno)
    return lines


def _modules(root: Path):
    for path in sorted(root.rglob("*.py")):
        yield path, ast.parse(path.read_text(encoding="utf-8"))


def test_every_model_subpackage_has_its_registry_line() -> None:
    assert _model_packages() == sorted(DOME_MODELS)
    for name, builder in DOME_MODELS.items():
        assert builder.name == name
        assert issubclass(builder.settings, PhysicsSettings)
        assert set(builder.levels) == {"fast", "default", "reference"}
        assert all(isinstance(p, builder.parameters) for p in builder.levels.values())


def test_no_code_outside_the_dome_package_knows_which_model_runs() -> None:
    models = tuple(f"twin.world.dome.{m}" for m in _model_packages())
    found = []
    for path, tree in _modules(TWIN):
        where = str(path.relative_to(TWIN))
        if path.is_relative_to(DOME):
            continue
        if where not in MAY_IMPORT_A_MODEL:
            found += [f"{where}: imports {n}" for n in _imported(tree) if n.startswith(models)]
        found += [f"{where}:{line}: compares with a dome model's name" for line in _branches_on_a_model(tree)]
    assert not found, "\n".join(found)


@pytest.mark.parametrize("model", _model_packages())
def test_a_model_imports_no_other_model(model: str) -> None:
    others = tuple(f"twin.world.dome.{m}" for m in _model_packages() if m != model)
    found = [
        f"{path.name}: {n}" for path, tree in _modules(DOME / model) for n in _imported(tree) if n.startswith(others)
    ]
    assert not found, found


def test_the_scenario_schema_lists_no_model_s_settings() -> None:
    """Each model owns its `physics` fields; the core scenario holds them as a mapping."""
    source = (TWIN / "core" / "scenario.py").read_text(encoding="utf-8")
    named = [f for b in DOME_MODELS.values() for f in b.settings.model_fields if f in source]
    assert not named, named


def test_the_check_finds_a_branch_and_an_import() -> None:
    """The scan is not blind: it sees the comparisons and imports the seam forbids."""
    tree = ast.parse(
        "from twin.world.dome.flex import DomeParams\nif s.dome == 'compliant':\n    pass\n"
        "ok = kind in ('flex', 'other')\n"
    )
    assert _branches_on_a_model(tree) == [2, 4]
    assert "twin.world.dome.flex" in _imported(tree)
