"""The public API: what `import twin` gives, and the README's example, run as written."""
from __future__ import annotations

import re
from pathlib import Path

import twin

README = Path(__file__).resolve().parents[1] / "README.md"


def test_public_names() -> None:
    for name in ("load_scenario", "make_environment", "Pose", "PinReader", "PerceptionModel", "tap_model",
                 "ContourFollower", "GYM_ID", "run_scenario"):
        assert hasattr(twin, name), name
    assert set(twin.__all__) <= set(dir(twin))


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
