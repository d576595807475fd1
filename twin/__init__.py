"""TacTip digital twin."""
from twin import gl as _gl  # noqa: F401  (sets the headless GL backend before mujoco loads)
