"""The dome models a scenario can name (`dome:`): one line per model, name → builder
(twin.world.dome.base.DomeBuilder). Adding a model is a subpackage of twin.world.dome
exporting a builder, and its line here."""

from __future__ import annotations

from twin.world.dome.base import DomeBuilder, DomeParameters
from twin.world.dome.compliant import COMPLIANT
from twin.world.dome.flex import FLEX

DOME_MODELS: dict[str, DomeBuilder] = {
    FLEX.name: FLEX,
    COMPLIANT.name: COMPLIANT,
}


def builder_of(params: DomeParameters) -> DomeBuilder:
    """The builder of the model whose parameters `params` are."""
    return next(b for b in DOME_MODELS.values() if isinstance(params, b.parameters))
