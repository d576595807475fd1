"""The calibrated dome material (twin.core.calibration.DOME_MATERIAL) applied to the dome
model: the one place that knows which model parameter a material name sets."""
from __future__ import annotations

from collections.abc import Mapping

from twin.core.calibration import DOME_MATERIAL
from twin.world.dome.flex import DomeParams

#: material name -> (DomeParams field, factor from the name's unit to SI)
_TO_DOME: dict[str, tuple[str, float]] = {
    "young_kpa": ("young", 1e3),
    "poisson": ("poisson", 1.0),
    "membrane_young_mpa": ("membrane_young", 1e6),
}


def apply_dome_material(params: DomeParams, material: Mapping[str, float]) -> DomeParams:
    """`params` with the named material values (units of DOME_MATERIAL) set."""
    return params.with_(**{_TO_DOME[name][0]: value * _TO_DOME[name][1] for name, value in material.items()})


def dome_material_of(params: DomeParams) -> dict[str, float]:
    """The material values (units of DOME_MATERIAL) of `params`: the defaults a calibration starts from."""
    return {name: getattr(params, field) / factor for name, (field, factor) in _TO_DOME.items()}
