"""The sweep's settings: the default scenario with one knob turned each (dome resolution,
time step, settle tolerance, render resolution, anti-aliasing, each effect on or off, the
compliant dome's levels and skins), the full set and the smoke check's five."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from twin.core.errors import UserError
from twin.core.scenario import scenario_from_dict
from twin.world.dome.registry import DOME_MODELS

if TYPE_CHECKING:
    from twin.core.scenario import Scenario

BASE_EFFECTS: tuple[str, ...] = ("contact", "friction", "render")
#: the base scenario's dome model (a row without a `dome` column ran it; unlabelled in pareto.png)
BASE_DOME = "flex"
REFERENCE = "reference"
DEFAULT = "default"
#: Each dome model's accuracy reference (its reference level, exact projected pins): a
#: setting's pin error is measured against the reference of its own dome — the two models'
#: pins are not one another's truth, so their pin errors are never compared.
COMPLIANT_REFERENCE = "compliant_reference"
REFERENCES: dict[str, str] = {"flex": REFERENCE, "compliant": COMPLIANT_REFERENCE}


@dataclass(frozen=True)
class Setting:
    """One point of the sweep: the default scenario with one knob turned.

    name: short id (CSV `setting`); knob: which knob it turns (groups the table).
    fidelity: the dome model's fidelity level (its builder's `levels`, twin.world.dome.registry).
    physics: scenario `physics` overrides
    (cellcount [i, j, k], timestep_s s, settle_px px, surface_spacing_mm mm, skin_spacing_mm mm,
    gel_enclosed, increment_mm mm, …; the dome model's settings, twin.world.dome.registry). dome: the scenario's dome model ('flex' or 'compliant').
    effects: scenario effects. camera: scenario `sensor.camera` overrides (width px,
    height px, msaa samples, noise_std grey levels, renderer). note: what the setting shows.
    pins_comparable: False where the setting changes the dome's material model (a skin over
    the compliant gel): its pins are then not an approximation of its dome's reference, and
    it gets no pin error (its time, θ, l and contour figures stand).
    """

    name: str
    knob: str
    fidelity: str = "default"
    physics: dict = field(default_factory=dict)
    effects: tuple[str, ...] = BASE_EFFECTS
    camera: dict = field(default_factory=dict)
    note: str = ""
    dome: str = BASE_DOME
    pins_comparable: bool = True

    @property
    def renders(self) -> bool:
        return "render" in self.effects

    @property
    def output(self) -> str:
        """Output kind: 'frames' (rendered and tracked) or 'pins' (projected)."""
        return "frames" if self.renders else "pins"

    def scenario(self, protocol: dict, seed: int = 0) -> Scenario:
        """The scenario of this setting on the rectangle with `protocol` (a protocol dict)."""

        data = {
            "name": f"sweep_{self.name}",
            "object": {"name": "rectangle"},
            "dome": self.dome,
            "placement": {"position_mm": [400, 0], "yaw_deg": 0},
            "fidelity": self.fidelity,
            "physics": dict(self.physics),
            "effects": list(self.effects),
            "sensor": {"camera": dict(self.camera)},
            "seed": seed,
            "protocol": protocol,
        }
        return scenario_from_dict(data, f"<sweep setting {self.name}>")


def _default_settle_px() -> float:
    return DOME_MODELS["flex"].levels["default"].settle_px


def full_settings() -> list[Setting]:
    """Every knob that matters, one at a time (the reference first: it runs longest).

    The time steps 0.01 / 0.04 s bracket the default 0.02 s (twin.world.dome.flex notes 0.04 s
    oscillating on the flower's slivers; the probe's rectangle has none)."""
    no_render = ("contact", "friction")
    s0 = _default_settle_px()
    return [
        Setting(
            REFERENCE,
            "reference",
            "reference",
            effects=no_render,
            note="reference fidelity, exact projected pins: the accuracy reference",
        ),
        Setting("reference_render", "fidelity", "reference", note="reference physics, rendered and tracked"),
        Setting("fast", "fidelity", "fast"),
        Setting(DEFAULT, "default", "default", note="the shipped defaults (fidelity default, 640×480, no MSAA)"),
        Setting("dt_0.01", "time step", physics={"timestep_s": 0.01}),
        Setting("dt_0.04", "time step", physics={"timestep_s": 0.04}),
        Setting("settle_x0.5", "settle tolerance", physics={"settle_px": s0 * 0.5}),
        Setting("settle_x2", "settle tolerance", physics={"settle_px": s0 * 2.0}),
        Setting("grid_3x3x2", "dome resolution", physics={"cellcount": [3, 3, 2]}),
        Setting("grid_5x5x2", "dome resolution", physics={"cellcount": [5, 5, 2]}),
        Setting(
            "skin_off",
            "skin layer",
            physics={"skin_spacing_mm": 0.0},
            note="no sub-grid skin layer (twin.world.dome.flex.skin)",
        ),
        Setting("skin_1mm", "skin layer", physics={"skin_spacing_mm": 1.0}),
        Setting(
            "membrane_off", "skin membrane", physics={"membrane_young_mpa": 0.0}, note="gel only (twin.world.dome.flex)"
        ),
        Setting("render_off", "render", effects=no_render, note="pins projected, no frames"),
        Setting("fast_render_off", "render", "fast", effects=no_render, note="fast physics, pins projected"),
        Setting("cam_320x240", "render resolution", camera={"width": 320, "height": 240}),
        Setting("cam_1280x960", "render resolution", camera={"width": 1280, "height": 960}),
        Setting("msaa_4", "anti-aliasing", camera={"msaa": 4}),
        Setting(
            "gl_renderer",
            "renderer",
            camera={"renderer": "gl"},
            note="MuJoCo's OpenGL renderer for the unlit frames the silhouette renderer draws by default",
        ),
        Setting(
            "fast_128x128",
            "render resolution",
            "fast",
            camera={"width": 128, "height": 128},
            note="fast physics, 128×128 frames: the cheapest rendered observation",
        ),
        Setting("lighting", "effect", effects=BASE_EFFECTS + ("lighting",)),
        Setting("camera_noise", "effect", effects=BASE_EFFECTS + ("camera_noise",)),
        Setting("friction_off", "effect", effects=("contact", "render"), note="no shear"),
        Setting("arm_dynamics", "effect", effects=BASE_EFFECTS + ("arm_dynamics",)),
        # the compliant dome (twin.world.dome.compliant): its levels and effects, pin errors
        # against its own reference
        Setting(
            COMPLIANT_REFERENCE,
            "compliant dome",
            "reference",
            effects=no_render,
            dome="compliant",
            note="compliant reference level (1 mm nodes, 0.25 mm increments), exact projected pins: its accuracy reference",
        ),
        Setting("compliant_fast", "compliant dome", "fast", dome="compliant", note="2.5 mm nodes, 1 mm increments"),
        Setting(
            "compliant_default", "compliant dome", "default", dome="compliant", note="1.8 mm nodes, 0.5 mm increments"
        ),
        Setting(
            "compliant_render_off",
            "compliant dome",
            "default",
            effects=no_render,
            dome="compliant",
            note="compliant, pins projected",
        ),
        Setting(
            "compliant_friction_off",
            "compliant dome",
            "default",
            effects=("contact", "render"),
            dome="compliant",
            note="compliant, no tangential problem",
        ),
        Setting(
            "compliant_open_gel",
            "compliant dome",
            "default",
            physics={"gel_enclosed": False},
            dome="compliant",
            note="compliant, the gel as an open half-space (not sealed)",
        ),
        Setting(
            "compliant_increment_1mm",
            "compliant increment",
            "default",
            physics={"increment_mm": 1.0},
            dome="compliant",
            note="compliant, 1.8 mm nodes, 1 mm increments (the default's are 0.5 mm)",
        ),
        Setting(
            "compliant_plain_solid",
            "compliant skin",
            "default",
            physics=dict(DOME_MODELS["compliant"].presets["plain_solid"]),  # the model's own, through the registry
            dome="compliant",
            pins_comparable=False,
            note="compliant, the plain solid: one 67 kPa solid without the skin (no pin error: "
            "another material than compliant_reference)",
        ),
    ]


def quick_settings() -> list[Setting]:
    """The smoke check's five: reference, fast, default, default with projected pins, default with 4× MSAA."""
    by_name = {s.name: s for s in full_settings()}
    return [by_name[n] for n in (REFERENCE, "fast", DEFAULT, "render_off", "msaa_4")]


def named_settings(names: list[str]) -> list[Setting]:
    """The full sweep's settings called `names`, in that order (`twin bench sweep
    --settings`); UserError naming any unknown name, or none given."""
    known = {s.name: s for s in full_settings()}
    unknown = [name for name in names if name not in known]
    if unknown or not names:
        raise UserError(
            f"--settings: no sweep setting {', '.join(map(repr, unknown)) or 'given'}; known: {', '.join(known)}"
        )
    return [known[name] for name in names]
