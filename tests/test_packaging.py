"""The wheel is self-contained: built, installed into a fresh virtual environment outside
the repository, it checks and runs a scenario from another directory (assets and
scenarios are package data, caches go to the user cache directory)."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TINY = """name: tiny_render
object: {name: rectangle}
effects: [contact, friction]
protocol: {kind: render, poses: [[0, 0, -5, 0, 0, 0], [0, -30, 2, 0, 0, 0]]}
"""


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
    _run([uv, "export", "--frozen", "--no-dev", "--no-emit-project", "--no-hashes", "-q", "-o", dist / "req.txt"],
         cwd=ROOT)
    venv = tmp_path / "venv"
    _run([uv, "venv", "-q", "--python", sys.executable, venv], cwd=tmp_path)
    _run([uv, "pip", "install", "-q", "--python", venv / "bin" / "python", "-r", dist / "req.txt", "--no-deps", wheel],
         cwd=tmp_path)
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
