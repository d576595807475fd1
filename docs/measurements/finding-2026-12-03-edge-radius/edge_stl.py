"""Writes edge_r1.stl and edge_r2.stl beside this file: the 120 × 80 × 10 mm rectangle with
only its +x top edge (the one the DigiTac replays tap) rounded with a 1 or 2 mm radius,
as the hull of the block's corners and 33 points of the quarter circle at each end. The
first screens ran on these; `object: {edge_radius_mm: …}` (2026-12-03) rounds every top
edge of a convex outline the same way.

    python edge_stl.py
"""

from pathlib import Path

import numpy as np
import trimesh

for radius in (1.0, 2.0):
    points = []
    for y in (-40.0, 40.0):
        points += [(-60.0, y, -10.0), (60.0, y, -10.0), (-60.0, y, 0.0)]
        for phi in np.linspace(0.0, np.pi / 2, 33):
            points.append((60.0 - radius + radius * np.sin(phi), y, -radius + radius * np.cos(phi)))
    trimesh.convex.convex_hull(np.array(points)).export(Path(__file__).with_name(f"edge_r{radius:g}.stl"))
