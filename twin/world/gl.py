"""Headless OpenGL selection, made once, just before mujoco or PyOpenGL is first imported.

EGL (Mesa llvmpipe on CPU, or a GPU driver) is the default; OSMesa is the fallback when
no EGL library can be loaded. `TWIN_GL` or `MUJOCO_GL` (egl | osmesa) force a choice.
Both MuJoCo and PyOpenGL read their backend from the environment at import time, so
the two variables must agree and be set first. `import twin` arranges for
`select_gl_backend` to run the first time any code (the twin's, a test's, a user's)
imports mujoco, PyOpenGL or pyrender (twin.__init__); nothing else selects the backend.
"""

from __future__ import annotations

import ctypes
import os

GL_BACKENDS = ("egl", "osmesa")
_LIBRARIES = {"egl": ("libEGL.so.1", "libEGL.so"), "osmesa": ("libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so")}
_selected: str | None = None


def _loadable(backend: str) -> bool:
    for name in _LIBRARIES[backend]:
        try:
            ctypes.CDLL(name)
            return True
        except OSError:
            continue
    return False


def select_gl_backend() -> str:
    """Set MUJOCO_GL and PYOPENGL_PLATFORM consistently (once); returns the backend in use."""
    global _selected
    if _selected is None:
        requested = os.environ.get("TWIN_GL") or os.environ.get("MUJOCO_GL")
        if requested in GL_BACKENDS:
            backend = requested
        else:
            backend = next((b for b in GL_BACKENDS if _loadable(b)), "egl")
        os.environ["MUJOCO_GL"] = backend
        os.environ["PYOPENGL_PLATFORM"] = backend
        _selected = backend
    return _selected


def __getattr__(name: str) -> str:
    if name == "GL_BACKEND":  # the backend in use (selected now if nothing has imported mujoco yet)
        return select_gl_backend()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
