"""The flex dome: MuJoCo's flex grid with the pins as vertices (twin.world.dome.flex.grid),
stepped quasi-statically (twin.world.dome.flex.physics), with the sub-grid skin layer
(twin.world.dome.flex.skin). `FLEX` is its builder (twin.world.dome.registry)."""

from twin.world.dome.flex.builder import FLEX, FlexSettings
from twin.world.dome.flex.grid import (
    FIDELITY_LEVELS,
    DomeParams,
    TacTipHandles,
    add_tactip,
    configure_options,
    pin_tips_tool,
    tactip_mjcf,
)
from twin.world.dome.flex.physics import SensorPhysics

__all__ = [
    "FIDELITY_LEVELS",
    "FLEX",
    "DomeParams",
    "FlexSettings",
    "SensorPhysics",
    "TacTipHandles",
    "add_tactip",
    "configure_options",
    "pin_tips_tool",
    "tactip_mjcf",
]
