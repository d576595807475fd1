"""The compliant dome as the registry holds it: its scenario `physics` settings (units,
bounds, conversion to CompliantParams' SI fields) and its builder
(twin.world.dome.base.DomeBuilder)."""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np
from pydantic import Field

from twin.core.calibration import DOME_MATERIAL
from twin.core.errors import UserError
from twin.core.sensor import CameraModel, TacTipGeometry
from twin.core.validation import bounded
from twin.world.dome.base import PhysicsSettings
from twin.world.dome.compliant.closest import add_probe
from twin.world.dome.compliant.compliance import CapSurface, DomeCompliance
from twin.world.dome.compliant.physics import COMPLIANT_LEVELS, PLAIN_SOLID, CompliantParams, CompliantPhysics
from twin.world.dome.material import apply_dome_material


class CompliantSettings(PhysicsSettings):
    """The compliant dome's scenario `physics`: overrides of the fidelity level's CompliantParams."""

    surface_spacing_mm: float | None = bounded(
        0.5, 10, "mm", "node spacing on the dome's surface (default 1.8 at fidelity default)", None
    )
    membrane_young_mpa: float | None = bounded(
        0,
        10,
        "MPa",
        "skin membrane's Young's modulus (twin.world.dome.compliant.compliance; default 0.2347), 0 = off",
        None,
    )
    gel_young_kpa: float | None = bounded(
        1,
        1000,
        "kPa",
        "the gel's Young's modulus (the skin and gel as one solid without a membrane; default 18.78)",
        None,
    )
    skin_bending: bool | None = Field(
        default=None,
        description="the skin membrane also resists bending, a thin shell of its "
        "modulus and thickness (default true; needs membrane_young_mpa > 0 here or in the "
        "calibration's dome_material)",
    )
    increment_mm: float | None = bounded(
        0.05,
        5,
        "mm",
        "the largest tool motion per contact increment "
        "(the friction path's resolution; default 0.5 at fidelity default)",
        None,
    )
    gel_enclosed: bool | None = Field(
        default=None,
        description="the gel is sealed in the dome and keeps its volume (default true); "
        "false = an open elastic half-space, the body of the closed-form contact checks",
    )
    skin_held_deg: float | None = bounded(
        *DOME_MATERIAL["skin_held_deg"][1:3], "deg", DOME_MATERIAL["skin_held_deg"][3] + "; default 75", None
    )
    skin_bending_mpa: float | None = bounded(
        0.01,
        50,
        "MPa",
        "the shell's bending modulus, D = E t³ / 12(1 − ν²) with this E (default 0.4068; needs skin_bending: true)",
        None,
    )
    skin_tension_n_m: float | None = bounded(
        *DOME_MATERIAL["skin_tension_n_m"][1:3],
        "N/m",
        "the skin's pretension over the sealed gel (twin.world.dome.compliant.compliance."
        "tension_stiffness; default 0; needs membrane_young_mpa > 0 here or in the calibration's dome_material)",
        None,
    )
    skin_thickening: float | None = bounded(
        *DOME_MATERIAL["skin_thickening"][1:3],
        "–",
        DOME_MATERIAL["skin_thickening"][3]
        + " (twin.world.dome.compliant.compliance.skin_thickness; default 1: uniform; needs membrane_young_mpa > 0 "
        "here or in the calibration's dome_material)",
        None,
    )
    pin_lever_mm: float | None = bounded(
        *DOME_MATERIAL["pin_lever_mm"][1:3],
        "mm",
        "the lever the skin's turn swings a pin tip by (twin.world.dome.compliant.compliance.post_tips; "
        "default 1.55; 2 = the pins' length); with pins_in_gel, how far below the skin the tips move with the gel",
        None,
    )

    pins_in_gel: bool | None = Field(
        default=None,
        description="the pin tips move with the gel pin_lever_mm below the skin "
        "(twin.world.dome.compliant.compliance.pin_tips_in_gel) instead of as posts turning with it "
        "(default false)",
    )
    tip_sway_mm_per_n: float | None = bounded(
        *DOME_MATERIAL["tip_sway_mm_per_n"][1:3],
        "mm/N",
        DOME_MATERIAL["tip_sway_mm_per_n"][3] + " (twin.world.dome.compliant.compliance.sway_block; default 0.1342)",
        None,
    )
    adhesion_kpa: float | None = bounded(
        *DOME_MATERIAL["adhesion_kpa"][1:3],
        "kPa",
        DOME_MATERIAL["adhesion_kpa"][3] + " (twin.world.dome.compliant.contact.friction_bound; default 0)",
        None,
    )

    edge_friction_ratio: float | None = bounded(
        *DOME_MATERIAL["edge_friction_ratio"][1:3],
        "–",
        DOME_MATERIAL["edge_friction_ratio"][3] + " (twin.world.dome.compliant.physics; default 1)",
        None,
    )

    apex_radius_mm: float | None = bounded(
        *DOME_MATERIAL["apex_radius_mm"][1:3],
        "mm",
        "the radius of curvature of the outer profile the object meets, a sphere through the apex "
        "(twin.world.dome.compliant.physics.apex_lift; default 30; 20 = the dome's own)",
        None,
    )

    edge_within_node: bool | None = Field(
        default=None,
        description="a node whose disc a face's edge crosses takes contact over the part of "
        "its disc on the face (twin.world.dome.compliant.cut_nodes), so an edge is placed within "
        "a node (default false: contact at whole nodes, an edge to within half a spacing)",
    )

    finite_sliding: bool | None = Field(
        default=None,
        description="each node meets the object where friction has dragged it, its gap to the object's "
        "closest point (twin.world.dome.compliant.closest), so a node dragged over an edge leaves the "
        "face (default false: the face under its rest point holds it; needs edge_within_node false)",
    )

    def changes(self) -> dict[str, Any]:
        """The settings given, as CompliantParams fields (SI)."""
        changes = {
            "spacing": None if self.surface_spacing_mm is None else self.surface_spacing_mm * 1e-3,
            "enclosed": self.gel_enclosed,
            "skin_bending": self.skin_bending,
            "young": None if self.gel_young_kpa is None else self.gel_young_kpa * 1e3,
            "membrane_young": None if self.membrane_young_mpa is None else self.membrane_young_mpa * 1e6,
            "step_length": None if self.increment_mm is None else self.increment_mm * 1e-3,
            "skin_held_deg": self.skin_held_deg,
            "skin_tension": self.skin_tension_n_m,
            "skin_thickening": self.skin_thickening,
            "bending_young": None if self.skin_bending_mpa is None else self.skin_bending_mpa * 1e6,
            "pin_lever": None if self.pin_lever_mm is None else self.pin_lever_mm * 1e-3,
            "pins_in_gel": self.pins_in_gel,
            "tip_sway": None if self.tip_sway_mm_per_n is None else self.tip_sway_mm_per_n * 1e-3,
            "adhesion": None if self.adhesion_kpa is None else self.adhesion_kpa * 1e3,
            "edge_friction": self.edge_friction_ratio,
            "apex_radius": None if self.apex_radius_mm is None else self.apex_radius_mm * 1e-3,
            "edge_within_node": self.edge_within_node,
            "finite_sliding": self.finite_sliding,
        }
        return {k: v for k, v in changes.items() if v is not None}


class CompliantBuilder:
    """The compliant contact model (twin.world.dome.compliant.physics): no MuJoCo body, rays
    against the object's collision pieces."""

    name = "compliant"
    parameters = CompliantParams
    levels: Mapping[str, CompliantParams] = COMPLIANT_LEVELS
    settings = CompliantSettings
    #: the plain solid without the skin (PLAIN_SOLID), 1 mm increments (the default's are
    #: 0.5 mm), an edge placed within a node (the default's contact is at whole nodes), and
    #: finite sliding (the default's is small)
    presets: Mapping[str, Mapping[str, Any]] = {
        "plain_solid": PLAIN_SOLID,
        "increment_1mm": {"increment_mm": 1.0},
        "edge_within_node": {"edge_within_node": True},
        "finite_sliding": {"finite_sliding": True},
    }
    quasi_static = True

    def params(
        self, fidelity: str, settings: CompliantSettings, material: Mapping[str, float], source: str
    ) -> CompliantParams:
        params = self.levels[fidelity].with_(**settings.changes())
        if material:
            params = apply_dome_material(params, material)
        if params.skin_bending and not params.membrane_young:
            raise UserError(
                f"{source}: physics.skin_bending (true unless set false) needs the skin membrane, "
                "membrane_young_mpa > 0 in `physics` or in the calibration's dome_material; with "
                "membrane_young_mpa: 0 set skin_bending: false too"
            )
        if settings.skin_bending_mpa is not None and not params.skin_bending:
            raise UserError(f"{source}: physics.skin_bending_mpa needs physics.skin_bending: true")
        if params.finite_sliding and params.edge_within_node:
            raise UserError(f"{source}: physics.finite_sliding needs whole nodes, physics.edge_within_node: false")
        if not params.skin_bending:
            params = params.with_(bending_young=None)  # the level's shell modulus, with its shell turned off
        on_the_membrane = {
            "skin_tension_n_m": (params.skin_tension, 0.0),
            "skin_thickening": (params.skin_thickening, 1.0),
        }
        for name, (value, without) in on_the_membrane.items():
            if value != without and not params.membrane_young:
                raise UserError(
                    f"{source}: {name} = {value:g} (in `physics` or the calibration's dome_material) needs the "
                    "skin membrane, membrane_young_mpa > 0 in `physics` or in the calibration's dome_material "
                    "(neither sets it)"
                )
        return params

    def add_to_scene(self, spec: mujoco.MjSpec, params: CompliantParams, friction: bool) -> None:
        if params.finite_sliding:
            add_probe(spec)
        return None

    def start(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        handles: None,
        params: CompliantParams,
        *,
        friction: float,
        name: str,
        start_tool2world: np.ndarray,
        stimulus2world: np.ndarray,
        work2world: np.ndarray,
        camera: CameraModel,
    ) -> CompliantPhysics:
        return CompliantPhysics(
            model, data, params, friction, name, start_tool2world, stimulus2world=stimulus2world, work2world=work2world
        )

    def precompute(self, params: CompliantParams) -> tuple[float, float]:
        """Computing and storing the influence matrices (DomeCompliance.one_off: the sealed
        gel's once per surface and ν, a skinned dome's once per surface and materials), and
        what a run pays at its first contact once they are stored (DomeCompliance.precompute)."""
        compliance = DomeCompliance(CapSurface(TacTipGeometry(), params.spacing, params.extent_deg), *params.material)
        t0 = time.perf_counter()
        compliance.one_off(refresh=True)
        computed = time.perf_counter() - t0
        t0 = time.perf_counter()
        compliance.precompute()
        return computed, time.perf_counter() - t0

    def resolution(self, params: CompliantParams) -> dict[str, Any]:
        return {"cellcount": f"{params.spacing * 1e3:g} mm nodes", "timestep_s": None, "settle_px": None}


COMPLIANT = CompliantBuilder()
