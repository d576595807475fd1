"""The calibrated dome material (twin.core.calibration.DOME_MATERIAL) applied to the dome
models: the one place that knows which model parameter a material name sets."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields

from twin.core.calibration import DOME_MATERIAL
from twin.core.errors import UserError
from twin.core.sensor import TacTipGeometry
from twin.world.dome.base import DomeParameters

#: material name -> (model parameter field, factor from the name's unit to SI)
_TO_DOME: dict[str, tuple[str, float]] = {
    "young_kpa": ("young", 1e3),
    "poisson": ("poisson", 1.0),
    "membrane_young_mpa": ("membrane_young", 1e6),
    "skin_held_deg": ("skin_held_deg", 1.0),
    "skin_bending_mpa": ("bending_young", 1e6),
    "skin_tension_n_m": ("skin_tension", 1.0),
    "skin_thickening": ("skin_thickening", 1.0),
    "pin_lever_mm": ("pin_lever", 1e-3),
    "apex_radius_mm": ("apex_radius", 1e-3),
    "tip_sway_mm_per_n": ("tip_sway", 1e-3),
    "adhesion_kpa": ("adhesion", 1e3),
    "edge_friction_ratio": ("edge_friction", 1.0),
}
#: model fields unset (None) until given, and the field whose value they take meanwhile
_FALLBACK = {"bending_young": "membrane_young"}
#: model fields unset (None) until given, and the value (SI) they stand for meanwhile
_UNSET = {"pin_lever": TacTipGeometry().pin_length}
#: material names that mean something only when the model has an effect switched on
_NEEDS = {"skin_bending_mpa": "skin_bending"}
assert set(_TO_DOME) == set(DOME_MATERIAL)

Params = DomeParameters


def material_names(params: Params) -> list[str]:
    """The material names this dome model has."""
    have = {f.name for f in fields(params)}
    return [
        name
        for name, (field, _) in _TO_DOME.items()
        if field in have and (name not in _NEEDS or getattr(params, _NEEDS[name]))
    ]


def _value(params: Params, field: str) -> float:
    value = getattr(params, field)
    if value is not None:
        return value
    return _UNSET[field] if field in _UNSET else getattr(params, _FALLBACK[field])


def apply_dome_material(params: Params, material: Mapping[str, float]) -> Params:
    """`params` with the named material values (units of DOME_MATERIAL) set; UserError for
    a name this dome model does not have or a value it cannot take."""
    names = material_names(params)
    for name in material:
        if name in _NEEDS and name not in names and hasattr(params, _NEEDS[name]):
            raise UserError(f"dome material {name!r} needs physics.{_NEEDS[name]}: true in the scenario")
        if name not in names:
            raise UserError(
                f"dome material {name!r} has no meaning for the {type(params).__name__} dome model "
                f"(it has {', '.join(names)})"
            )
    if material.get("poisson", 0.0) > params.max_poisson:
        raise UserError(
            f"dome material poisson = {material['poisson']} is beyond the {type(params).__name__} dome "
            f"model's ν ≤ {params.max_poisson}"
        )
    return params.with_(**{_TO_DOME[name][0]: value * _TO_DOME[name][1] for name, value in material.items()})


def dome_material_of(params: Params) -> dict[str, float]:
    """The material values (units of DOME_MATERIAL) of `params`: the defaults a calibration starts from."""
    return {name: _value(params, _TO_DOME[name][0]) / _TO_DOME[name][1] for name in material_names(params)}
