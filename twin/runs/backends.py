"""The environment factory: a scenario's backend behind the Environment interface.

`sim` is the MuJoCo twin (twin.runs.sim_env). Other backends are plug-ins found through
the `twin.backends` entry-point group (pyproject.toml): the real rig registers
`hardware = "hardware.env:HardwareEnvironment"`, so the twin never imports the hardware
package and a lab can add its own rig the same way. A backend class provides
`from_scenario(scenario, config_path)`.
"""

from __future__ import annotations

from importlib.metadata import entry_points

from twin.core.environment import Environment
from twin.core.errors import UserError
from twin.core.scenario import Scenario
from twin.runs.sim_env import SimEnvironment

ENTRY_POINT_GROUP = "twin.backends"


def backend_names() -> list[str]:
    """Every backend a scenario can name: sim and the registered plug-ins."""
    return ["sim", *sorted(ep.name for ep in entry_points(group=ENTRY_POINT_GROUP))]


def make_environment(scenario: Scenario, seed: int | None = None, hardware_config: str | None = None) -> Environment:
    """The scenario's backend. `seed` (sim) overrides the scenario's seed;
    `hardware_config` overrides the scenario's `hardware_config` file."""
    if scenario.backend == "sim":
        return SimEnvironment(scenario, seed=seed)
    found = [ep for ep in entry_points(group=ENTRY_POINT_GROUP) if ep.name == scenario.backend]
    if not found:
        raise UserError(
            f"{scenario.source}: field 'backend': no backend {scenario.backend!r} is installed "
            f"(known: {', '.join(backend_names())})"
        )
    return found[0].load().from_scenario(scenario, hardware_config)
