"""The wheel is self-contained: built, installed into a fresh virtual environment outside
the repository, it checks and runs a scenario from another directory (assets and
scenarios are package data, caches go to the user cache directory). Its requirements are
compatible ranges that hold the exact tested set locked in uv.lock."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[1]
TINY = """name: tiny_render
object: {name: rectangle}
effects: [contact, friction]
protocol: {kind: render, poses: [[0, 0, -5, 0, 0, 0], [0, -30, 2, 0, 0, 0]]}
"""


def _requirements() -> list[Requirement]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = project.get("optional-dependencies", {}).values()
    return [Requirement(r) for r in [*project["dependencies"], *(r for extra in extras for r in extra)]]


def test_requirements_are_ranges_that_hold_the_locked_versions() -> None:
    """Exact pins break `pip install` next to anything else: each requirement is a range with
    a floor and a ceiling, the version uv.lock tested lies inside it, and uv.lock was made
    from these very ranges (not from older ones)."""
    lock = tomllib.loads((ROOT / "uv.lock").read_text())
    locked = {p["name"]: p["version"] for p in lock["package"]}
    project = next(p for p in lock["package"] if p.get("source", {}).get("editable") == ".")
    recorded = {r["name"]: r.get("specifier", "") for r in project["metadata"]["requires-dist"]}
    requirements = _requirements()
    assert len(requirements) >= 20
    for req in requirements:
        operators = {spec.operator for spec in req.specifier}
        assert operators == {">=", "<"}, f"{req}: want a range such as 'numpy>=2.4,<3'"
        assert req.specifier.contains(locked[req.name]), f"{req}: uv.lock has {req.name} {locked[req.name]}"
        assert req.specifier == type(req.specifier)(recorded[req.name]), (
            f"{req}: run `uv lock` (it has {recorded[req.name]})"
        )


def _uv() -> str:
    local = ROOT / ".tools" / "bin" / "uv"  # installed by the README's commands
    found = str(local) if local.exists() else shutil.which("uv")
    assert found, "uv not found: run the README's set-up command (bash .ci/bootstrap.sh test)"
    return found


def _run(args: list, cwd: Path, env: dict | None = None, timeout: float = 600) -> subprocess.CompletedProcess:
    result = subprocess.run([str(a) for a in args], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert result.returncode == 0, f"{' '.join(map(str, args))}\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
    return result


@pytest.mark.slow
def test_wheel_installs_and_runs_outside_the_repository(tmp_path: Path) -> None:
    uv = _uv()
    dist, work = tmp_path / "dist", tmp_path / "elsewhere"
    work.mkdir()
    _run([uv, "build", "--wheel", "-q", "-o", dist], cwd=ROOT)
    wheel = next(dist.glob("tactip_twin-*.whl"))
    # the locked dependency set (pyrender's PyOpenGL pin overridden as in pyproject.toml)
    _run(
        [uv, "export", "--frozen", "--no-dev", "--no-emit-project", "--no-hashes", "-q", "-o", dist / "req.txt"],
        cwd=ROOT,
    )
    venv = tmp_path / "venv"
    _run([uv, "venv", "-q", "--python", sys.executable, venv], cwd=tmp_path)
    _run(
        [uv, "pip", "install", "-q", "--python", venv / "bin" / "python", "-r", dist / "req.txt", "--no-deps", wheel],
        cwd=tmp_path,
    )
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env.update(TWIN_CACHE=str(tmp_path / "cache"), MUJOCO_GL=env.get("MUJOCO_GL", "egl"))
    env["PYOPENGL_PLATFORM"] = env["MUJOCO_GL"]
    located = _run([venv / "bin" / "python", "-c", "import twin; print(twin.__file__)"], cwd=work, env=env)
    assert str(venv) in located.stdout and str(ROOT) not in located.stdout
    (work / "tiny.yaml").write_text(TINY)
    checked = _run([venv / "bin" / "twin", "check", "contour_flower", "tiny.yaml"], cwd=work, env=env)
    assert "contour_flower" in checked.stdout and "tiny.yaml: ok" in checked.stdout
    _run([venv / "bin" / "twin", "run", "tiny.yaml", "--out", "run", "--workers", "1", "--quiet"], cwd=work, env=env)
    samples = (work / "run" / "samples.jsonl").read_text().splitlines()
    assert len(samples) == 2
