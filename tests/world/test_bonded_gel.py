"""The closed-form gel against a finite-element model of it (tests/world/bonded_gel.py:
the gel as a hemisphere bonded to the rigid base at the equator, gmsh + scikit-fem,
quadratic tetrahedra, ν = 0.49 where quadratic elements do not yet lock). The closed form
puts a half-space tangent at every node and keeps the gel's volume by a Lagrange
multiplier; the finite elements have the real body and its base. Both are pressed,
frictionless, onto a flat and onto an edge (`solve_normal`) at the fast level's 2.5 mm
nodes, and their pins and forces compared. No closed-form theory covers a sealed gel in
a dome bonded to a base; this is the check that the approximations hold."""

from __future__ import annotations

import numpy as np
import pytest

from tests.world.bonded_gel import BondedGel
from twin.core.sensor import CameraModel, TacTipGeometry
from twin.world.dome.compliant.compliance import CapSurface, DomeCompliance, skin_on_gel, skinned
from twin.world.dome.compliant.contact import solve_normal

GEOMETRY = TacTipGeometry()
SURFACE = CapSurface(GEOMETRY, 0.0025, 65.0)
SHEET = SURFACE.skin_to(90.0)
SOLID_G, SHELL_G, SKIN_E = 67e3 / 3, 34.1e3 / 3, 6e5  # Pa: the shipped solid and shell (ν = 0.5)
#: (depth m, the object's edge in x m: it covers x ≤ edge): a flat, the edge 6 mm from the
#: centre (the paper's along-edge slides) and through it (contour following)
PRESSES = [(depth, edge) for depth in (0.002, 0.004) for edge in (np.inf, 0.006, 0.0)]
CAMERA = CameraModel()
REST = GEOMETRY.pin_tip_points()
#: the finite-element models take 35–45 s to build: one xdist worker builds them once
pytestmark = pytest.mark.xdist_group("bonded_gel")


@pytest.fixture(scope="module")
def models() -> dict:
    gel = BondedGel.build(GEOMETRY, 0.0025, 0.49)
    out = {}
    for name, shear, skin, bending in (("solid", SOLID_G, 0.0, False), ("shell", SHELL_G, SKIN_E, True)):
        fe = skin_on_gel(SURFACE, SHEET, *gel.on_sheet(SURFACE, SHEET, shear), skin, bending)
        out[name, "fe"] = (fe["nodes"], fe["pins"])
    out["solid", "sealed"] = DomeCompliance(SURFACE, 3 * SOLID_G, 0.5, True).one_off()
    out["solid", "open"] = DomeCompliance(SURFACE, 3 * SOLID_G, 0.5, False).one_off()
    for held in (90.0, 75.0):
        out["shell", f"sealed_{held:g}"] = skinned(SURFACE, 0.5, SHELL_G, SKIN_E, True, True, held)
    out["shell", "open"] = skinned(SURFACE, 0.5, SHELL_G, SKIN_E, True, False, 90.0)
    return out


def _press(nodes: np.ndarray, pins: np.ndarray, depth: float, edge: float) -> tuple[np.ndarray, float]:
    """The pins' image displacement (127, 2) px and the force (N) of a frictionless press
    `depth` into the object's flat top (z = −depth, the tool frame's apex at 0)."""
    normals, points = SURFACE.normals, SURFACE.points
    nodes_on = np.flatnonzero((normals[:, 2] > 0.3) & (points[:, 0] <= edge))
    gap = (-depth - points[nodes_on, 2]) / normals[nodes_on, 2]  # along each node's normal
    block = nodes[np.ix_(nodes_on, range(3), nodes_on, range(3))]  # [source, axis, node, axis]
    inward = np.einsum("ia,jbia,jb->ij", normals[nodes_on], block, normals[nodes_on])
    pressure, _, _ = solve_normal(inward, gap, np.zeros(len(nodes_on)), 1e-10, 20000)
    tips = np.einsum("jbpa,jb->pa", pins[nodes_on], -pressure[:, None] * normals[nodes_on])
    return CAMERA.project_tool_points(REST + tips) - CAMERA.project_tool_points(REST), float(pressure.sum())


def _rms(px: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(px**2, axis=1))))


@pytest.mark.parametrize("depth, edge", PRESSES)
def test_the_sealed_gel_is_the_bonded_gel(models, depth, edge):
    """Measured: the solid's pins 0.55–2.2 px RMS from the finite elements' (9–16 % of
    their 4.6–18 px), its force within 0.9–5.1 %; the shell's 0.14–0.57 px (2.5–4.4 %),
    +0.3–3.7 %. The open half-space, which loses the gel's volume, is 23–43 % (solid) and
    7–18 % (shell) too soft and 1.1–6.5 px away (up to 36 % and 19 %): the sealing, not
    the half-space, carries the agreement. (Finite elements of 1.5 mm took the solid's
    difference on 4 mm taps from about 1.5 to 1.25 px RMS: part of it is theirs.) The
    bounds (pins 20 % and 7 %, force 8 %) sit above the measured values by a margin for
    the mesher; the open half-space fails them."""
    for name, pins_bound in (("solid", 0.2), ("shell", 0.07)):
        reference, force = _press(*models[name, "fe"], depth, edge)
        sealed, sealed_force = _press(*models[name, "sealed" if name == "solid" else "sealed_90"], depth, edge)
        opened, open_force = _press(*models[name, "open"], depth, edge)
        assert _rms(sealed - reference) < pins_bound * _rms(reference), (name, _rms(sealed - reference))
        assert abs(sealed_force / force - 1.0) < 0.08, (name, sealed_force, force)
        assert open_force / force < 0.95 and _rms(opened - reference) > 1.5 * _rms(sealed - reference)


def test_the_base_does_not_hold_the_skin_above_the_equator(models):
    """The gel thins towards the base (R cos θ: 6.8 mm at 70°, 3.5 mm at 80°), and a thin
    bonded layer is stiff. Does that restrain the skin as if the base held it higher up
    (as `skin_held_deg` < 90 does, which is what makes the shell follow contours)? No:
    the bonded gel's shell is 4–9 times closer to the closed-form shell held at the
    equator than to the one held at 75°, and 2–5 times closer than to 80° (measured on
    the 4 mm presses: 0.43–0.57 px RMS, against 2.4–3.9 and 1.3–2.1 px)."""
    for depth, edge in PRESSES[3:]:
        reference, _ = _press(*models["shell", "fe"], depth, edge)
        at_equator, _ = _press(*models["shell", "sealed_90"], depth, edge)
        at_75, _ = _press(*models["shell", "sealed_75"], depth, edge)
        assert _rms(at_75 - reference) > 2.5 * _rms(at_equator - reference), (edge, _rms(at_75 - reference))
