"""Writes rectangle_r1.stl (the shipped rectangle with its top edge rounded 1 mm) and
flower.stl (the shipped flower, sharp) beside this file, in mm: user STL objects for the
fitted dome's contours.

    python objects_stl.py
"""

from pathlib import Path

from twin.world.stimuli.objects import builtin_stimulus, with_edge_radius

here = Path(__file__).parent
for name, radius, out in (("rectangle", 1.0, "rectangle_r1.stl"), ("flower", 0.0, "flower.stl")):
    mesh = with_edge_radius(builtin_stimulus(name), radius).mesh.copy()
    mesh.apply_scale(1000.0)  # the object's mesh is in metres
    mesh.export(here / out)
