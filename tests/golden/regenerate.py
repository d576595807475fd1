"""Regenerate the golden images for the current GL backend:

    MUJOCO_GL=egl    .venv/bin/python tests/golden/regenerate.py
    MUJOCO_GL=osmesa .venv/bin/python tests/golden/regenerate.py

Only after checking by eye that the new image is right (tests/golden/<backend>/).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import cv2  # noqa: E402

from tests.golden.frames import GOLDEN_FRAMES  # noqa: E402
from twin.world import gl  # noqa: E402


def main() -> None:
    out = Path(__file__).resolve().parent / gl.GL_BACKEND
    out.mkdir(exist_ok=True)
    for name, make in GOLDEN_FRAMES.items():
        cv2.imwrite(str(out / f"{name}.png"), make()[..., ::-1])
        print(f"wrote {out / name}.png")


if __name__ == "__main__":
    main()
