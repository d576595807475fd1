"""Headless OpenGL selection. Import this before mujoco or pyrender anywhere.

EGL (Mesa llvmpipe on CPU, or a GPU driver) is the default; OSMesa is the fallback.
Both MuJoCo and PyOpenGL read their backend from the environment at import time, so
the two variables must agree and be set first (DESIGN §5).
"""
from __future__ import annotations

import os

GL_BACKENDS = ("egl", "osmesa")


def select_gl_backend() -> str:
    """Set MUJOCO_GL and PYOPENGL_PLATFORM consistently; returns the backend in use."""
    backend = os.environ.get("TWIN_GL") or os.environ.get("MUJOCO_GL") or "egl"
    if backend not in GL_BACKENDS:
        backend = "egl"
    os.environ["MUJOCO_GL"] = backend
    os.environ["PYOPENGL_PLATFORM"] = backend
    return backend


GL_BACKEND = select_gl_backend()
