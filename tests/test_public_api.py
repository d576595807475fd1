"""The public API: what `import twin` gives (lazily), and the README's example, run as written."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import twin

README = Path(__file__).resolve().parents[1] / "README.md"


def test_public_names() -> None:
    for name in (
        "load_scenario",
        "make_environment",
        "Pose",
        "PinReader",
        "PerceptionModel",
        "tap_model",
        "ContourFollower",
        "GYM_ID",
        "run_scenario",
    ):
        assert hasattr(twin, name), name
    assert set(twin.__all__) <= set(dir(twin))
    assert set(twin.__all__) == set(twin._PUBLIC)
    assert twin.tap_model.__name__ == "model_for_scenario"


def _fresh_import(code: str, **env: str) -> list[str]:
    """Run `code` in a new interpreter without any GL variables set; returns its printed words."""
    clean = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM", "TWIN_GL")}
    result = subprocess.run(
        [sys.executable, "-c", code],
        env={**clean, **env},
        capture_output=True,
        text=True,
        timeout=300,
        cwd=Path(__file__).resolve().parents[1],
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return result.stdout.split()


def test_import_twin_loads_nothing_until_a_name_is_used() -> None:
    loaded = _fresh_import("import sys, twin; print(*sys.modules)")
    assert not [m for m in loaded if m.startswith("twin.")], loaded
    assert not {"numpy", "mujoco", "gymnasium", "sklearn", "OpenGL"} & set(loaded)
    pose = _fresh_import("import sys, twin; twin.Pose; print(*sys.modules)")
    assert "twin.core.poses" in pose and "mujoco" not in pose and "twin.world.gl" not in pose


def test_gl_backend_is_selected_before_mujoco_loads_and_only_then() -> None:
    """Importing a lower module selects nothing; the first `import mujoco` (here the user's
    own, after twin) selects one backend for both MuJoCo and PyOpenGL."""
    code = (
        "import os, sys, twin.core.scenario; print(os.environ.get('MUJOCO_GL', 'unset')); "
        "import mujoco; print(os.environ['MUJOCO_GL'], os.environ['PYOPENGL_PLATFORM'], *sys.modules)"
    )
    before, mujoco_gl, pyopengl, *loaded = _fresh_import(code)
    assert before == "unset" and mujoco_gl == pyopengl and mujoco_gl in ("egl", "osmesa")
    assert "twin.world.gl" in loaded and "gymnasium" not in loaded
    forced = _fresh_import(
        "import os, twin, mujoco; print(os.environ['MUJOCO_GL'], os.environ['PYOPENGL_PLATFORM'])", TWIN_GL="osmesa"
    )
    assert forced == ["osmesa", "osmesa"]


def test_gym_id_registers_without_the_simulator() -> None:
    code = "import sys, gymnasium, twin; print(twin.GYM_ID in gymnasium.registry, *sys.modules)"
    registered, *loaded = _fresh_import(code)
    assert registered == "True"
    assert not {"twin.runs.gym_env", "twin.world.scene", "mujoco"} & set(loaded)


def test_readme_example_runs(capsys) -> None:
    block = re.search(r"<!-- example: start -->\n```python\n(.*?)```\n<!-- example: end -->", README.read_text(), re.S)
    assert block, "the README's example block is missing"
    code = block.group(1)
    assert len(code.strip().splitlines()) <= 10, "the README promises a 10-line example"
    namespace: dict = {}
    exec(compile(code, str(README), "exec"), namespace)
    assert len(namespace["steps"]) == 15 and all(-180 <= t <= 180 for t in namespace["steps"])
    assert namespace["pins"].shape == (127, 2)
    assert "15 (127, 2)" in capsys.readouterr().out
    namespace["env"].close()
