"""TacTip digital twin."""
from twin.world import gl as _gl  # noqa: F401  (sets the headless GL backend before mujoco loads)
