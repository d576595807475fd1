#!/usr/bin/env bash
# One-step set-up + run. Usage:  bash .ci/bootstrap.sh demo|test [extra args]
#   demo  installs what is missing, then runs the main job (`twin demo`)
#   test  installs what is missing, builds the docs site (mkdocs --strict), then runs the test suite
# Installs: Debian packages for headless OpenGL (EGL + OSMesa fallback), uv (pinned),
# and the locked Python environment in .venv (all extras: robot client, Ray; dev tools).
set -euo pipefail
cd "$(dirname "$0")/.."

UV_VERSION=0.13.9
GL_PACKAGES=(libegl1 libegl-mesa0 libgl1-mesa-dri libopengl0 libgl1 libglx0 libosmesa6
             libglu1-mesa libxcursor1 libxft2 libxinerama1 libxrender1 libgomp1   # gmsh's shared library
             xvfb)  # a virtual display, so the suite tests `twin view` headless
job=${1:-}
case "$job" in demo|test) shift ;; *) echo "usage: bash .ci/bootstrap.sh demo|test [args]" >&2; exit 2 ;; esac

say() { printf '[bootstrap] %s\n' "$*" >&2; }
die() { printf '[bootstrap] ERROR: %s\n' "$*" >&2; exit 2; }

# 1. Python 3.11
PY=$(command -v python3.11 || true)
if [ -z "$PY" ]; then
  if command -v python3 >/dev/null && python3 -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then PY=$(command -v python3); fi
fi
[ -n "$PY" ] || die "Python 3.11 not found. On Debian 12: apt-get install python3 python3-venv"

# 2. Headless GL system libraries
missing=()
for pkg in "${GL_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if ! "$PY" -c 'import venv, ensurepip' 2>/dev/null; then missing+=(python3-venv); fi
if [ ${#missing[@]} -gt 0 ]; then
  say "installing system packages: ${missing[*]}"
  if [ "$(id -u)" = 0 ]; then SUDO=""; elif command -v sudo >/dev/null; then SUDO="sudo"; else
    die "missing system packages: ${missing[*]} (run as root or install them: apt-get install ${missing[*]})"; fi
  $SUDO apt-get update -qq || die "apt-get update failed; install by hand: apt-get install ${missing[*]}"
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null \
    || die "could not install ${missing[*]}; install them by hand"
fi

# 3. uv (pinned), in a private tool venv so no system Python is modified
UV=.tools/bin/uv
if ! { [ -x "$UV" ] && "$UV" --version | grep -q "$UV_VERSION"; }; then
  say "installing uv $UV_VERSION into .tools/"
  "$PY" -m venv .tools || die "python3 -m venv failed (apt-get install python3-venv)"
  .tools/bin/pip install -q "uv==$UV_VERSION" || die "could not install uv from PyPI (network?)"
fi

# 4. The locked environment (pyrender's PyOpenGL pin is overridden in pyproject.toml)
# --compile-bytecode: imports stay fast where PYTHONDONTWRITEBYTECODE is set (CI, containers)
"$UV" sync --locked --all-extras --group dev --compile-bytecode --python "$PY" -q || die "uv sync failed (see above)"

export MUJOCO_GL=${MUJOCO_GL:-egl} PYOPENGL_PLATFORM=${PYOPENGL_PLATFORM:-${MUJOCO_GL:-egl}}
case "$job" in
  demo) exec .venv/bin/twin demo "$@" ;;
  test)
    # lint (pyflakes, bugbear, import order) and format, as configured in pyproject.toml
    .venv/bin/ruff check . && .venv/bin/ruff format --check . \
      || die "ruff: fix with .venv/bin/ruff check --fix . && .venv/bin/ruff format ."
    # the docs site: a broken link, anchor, snippet or API reference is a warning, and --strict fails on it
    NO_MKDOCS_2_WARNING=1 .venv/bin/mkdocs build --strict || die "the docs do not build (mkdocs build --strict, above)"
    set +e
    # a test that takes its worker down fails the run, naming the test, instead of a new
    # worker: pytest-xdist 3.8.0's loadgroup scheduler can then wait forever (its issue 1323)
    .venv/bin/python -m pytest -n 2 --dist loadgroup --max-worker-restart 0 "$@"
    rc=$?
    [ $rc -eq 5 ] && { echo "no tests were collected" >&2; exit 1; }
    exit $rc ;;
esac
