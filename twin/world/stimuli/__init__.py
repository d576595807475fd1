"""Stimuli: the paper's six objects and user STL / outline objects (object frame in
`twin.world.stimuli.objects`)."""

from twin.world.stimuli.objects import BUILTINS, MATERIALS, Material, Stimulus, builtin_stimulus, load_stimulus

__all__ = ["BUILTINS", "MATERIALS", "Material", "Stimulus", "builtin_stimulus", "load_stimulus"]
