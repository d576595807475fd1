"""The skin at pin resolution: local indentation and the lever-like tilt of the pins.

Why. The flex dome (twin.world.dome.flex) carries its deformation on a coarse grid (10 mm cells at
default fidelity), so its pin field is smooth: pressing near an edge gives a nearly
radially symmetric expansion, and which *side* of the sensor the edge is on — the
orientation the perception must read — barely shows (tap orientation error 59° RMS on
held-out taps, 71–123° with the centre on the object). The real TacTip's pins are
stiff posts on the inside of a rubber skin: where the skin bends at the border of the
contact, the posts tilt and their tips swing sideways by (lever × tilt), a local,
zero-mean pattern that follows the edge. This module computes that pattern.

Model (linear elastic contact at sub-grid resolution, quasi-static, frictionless):
  * the outer skin is sampled by nodes `spacing` apart over a cap of half-angle
    `extent_deg` (it must contain every contact; SensorPhysics checks);
  * the object's penetration δᵢ ≥ 0 of the *undeformed* dome at node i is measured along
    the dome's radius, by rays cast from the sphere centre through the scene's geoms
    (mj_multiRay): any object shape the physics scene holds, meshes included;
  * in contact the skin conforms to the object (inward deflection wᵢ = δᵢ); everywhere
    w = Σⱼ Kᵢⱼ pⱼ with the Boussinesq half-space kernel K ∝ Aⱼ / |xᵢ − xⱼ| (regularised
    over a node's area); the contact pressures p ≥ 0 come from the active-set solution of
    this linear complementarity problem. The *shape* of w does not depend on the elastic
    modulus (it scales out of K and p), so the layer adds no material parameter: forces,
    friction and shear stay the flex's;
  * the skin's outward normal tilts from n to n' = (n + ∇w)/|n + ∇w| (∇w: the surface
    gradient of the inward deflection, averaged over a post's footprint), so a pin tip at
    lever L from the skin's mid-surface moves by −L·(n' − n), at most L·√2 however sharp
    the edge. L = half the skin thickness + the pin length (twin.core.sensor.TacTipGeometry).
The layer is geometric: it depends on the commanded pose only, so it adds no path
dependence (shear comes from the flex's friction) and vanishes out of contact.

Measured on the edge scene (paper's 288 taps to train, held-out taps at θ + 10°, odd
lateral positions, 3 mm): orientation error 59° → 19° RMS; a uniform 2 px image shift
of the held-out taps (the form shear takes) raises it from 11° to 57° without the layer
and from 7° to 9° with it (docs/paper.md, "How the twin gets there").

Frames and units: tool frame, m (docs/conventions.md).
"""

from __future__ import annotations

from functools import lru_cache

import mujoco
import numpy as np

from twin.core.errors import PhysicsError
from twin.core.sensor import TacTipGeometry
from twin.world.dome.flex.grid import hemisphere_rings
from twin.world.dome.rays import rays_into_boxes


class SkinLayer:
    """Pin-tip offsets from the skin's local bending (module docstring).

    geometry: the TacTip's dimensions (m); spacing: node spacing on the outer skin (m);
    extent_deg: half-angle of the modelled cap around the sensor axis (deg).
    """

    def __init__(self, geometry: TacTipGeometry, spacing: float, extent_deg: float) -> None:
        self.radius = geometry.dome_outer_radius
        self.centre_tool = np.array([0.0, 0.0, geometry.sphere_centre_z])
        points = hemisphere_rings(self.radius, geometry.sphere_centre_z, spacing)
        normals = (points - self.centre_tool) / self.radius
        self.extent_deg = float(extent_deg)
        inside = normals[:, 2] >= np.cos(np.radians(extent_deg))
        self.nodes = points[inside]
        self.normals = normals[inside]
        self.rim = np.flatnonzero(
            self.normals[:, 2] < np.cos(np.radians(extent_deg) - spacing / self.radius)
        )  # outer ring
        area = spacing**2
        eps2 = area / (4 * np.pi)  # (half the radius of a disc of one node's area)²
        d = self.nodes[:, None, :] - self.nodes[None, :, :]
        self.kernel = area / np.sqrt(np.sum(d**2, axis=-1) + eps2)
        pin_dirs = geometry.pin_tip_points() - self.centre_tool
        pin_dirs /= np.linalg.norm(pin_dirs, axis=1, keepdims=True)
        roots = self.centre_tool + self.radius * pin_dirs
        t = roots[:, None, :] - self.nodes[None, :, :]
        t -= np.sum(t * pin_dirs[:, None, :], axis=-1, keepdims=True) * pin_dirs[:, None, :]  # tangential part
        # the post is glued to the skin over its base: the slope it follows is averaged over
        # its footprint, so the kernel's gradient is regularised at the pin radius
        eps2_pin = max(eps2, geometry.pin_radius**2)
        grad = -area * t / (np.sum(t**2, axis=-1) + eps2_pin)[..., None] ** 1.5  # ∇ of the kernel at the pin roots
        self.lever = geometry.skin_thickness / 2 + geometry.pin_length
        self.pin_normals = pin_dirs
        #: (127·3, nodes): pressures → surface gradient ∇w of the inward deflection at the pin roots
        self.gradient_matrix = grad.transpose(0, 2, 1).reshape(-1, len(self.nodes))

    def penetration(
        self, model: mujoco.MjModel, data: mujoco.MjData, tool2scene: np.ndarray, exclude_body: int
    ) -> np.ndarray:
        """(nodes,) radial penetration δ ≥ 0 (m) of the undeformed skin into the scene's geoms.

        tool2scene: 4×4 pose of the tool frame in the scene (m); exclude_body: the body
        whose geoms the rays ignore (the TacTip's own rigid base). Flexes are not hit.
        """
        centre = tool2scene[:3, :3] @ self.centre_tool + tool2scene[:3, 3]
        dirs = self.normals @ tool2scene[:3, :3].T
        # only rays that reach a geom's bounding box within the skin's radius can find a
        # penetration, and most nodes face away from the contact: cast just those
        cast = rays_into_boxes(model, data, centre, dirs, self.radius, exclude_body)
        delta = np.zeros(len(self.nodes))
        if not len(cast):
            return delta
        geomid, dist = np.empty(len(cast), np.int32), np.empty(len(cast))
        mujoco.mj_multiRay(
            model,
            data,
            centre,
            dirs[cast].ravel(),
            None,
            1,
            exclude_body,
            geomid,
            dist,
            None,
            len(cast),
            2 * self.radius,
        )
        hit = geomid >= 0
        delta[cast[hit]] = np.maximum(0.0, self.radius - dist[hit])
        return delta

    def pressures(self, delta: np.ndarray, pressed: np.ndarray | None = None) -> np.ndarray:
        """(nodes,) contact pressures p ≥ 0 (kernel units) with w = K·p: w = δ where p > 0,
        w ≥ δ elsewhere (active-set solution of the linear complementarity problem).

        Solved among the nodes with δ > 0 only: a node the object does not reach needs no
        pressure (K ≥ 0, so w ≥ 0 ≥ δ there). pressed: (nodes,) bool, the nodes guessed to
        carry pressure (the last frame's `p > 0`): the active set starts from them instead
        of from every touching node. K is symmetric positive definite, so the problem has
        one solution and the guess changes only how many solves reach it; a guess that
        does not reach it in `_WARM_ITERATIONS` solves is dropped for the cold start."""
        touching = np.flatnonzero(delta > 0)
        full = np.zeros(len(delta))
        if not len(touching):
            return full
        kernel = self.kernel[np.ix_(touching, touching)]
        target = delta[touching]
        everywhere = np.arange(len(touching))
        guess = np.flatnonzero(pressed[touching]) if pressed is not None else everywhere
        if len(guess) and len(guess) < len(touching):
            p = _active_set(kernel, target, guess, _WARM_ITERATIONS)
            if p is not None:
                full[touching] = p
                return full
        p = _active_set(kernel, target, everywhere, 50)
        if p is None:
            raise PhysicsError("skin contact: the active set did not converge in 50 iterations")
        full[touching] = p
        return full

    def pin_offsets(self, delta: np.ndarray, pressures: np.ndarray | None = None) -> np.ndarray:
        """(127, 3) pin-tip offsets (m, tool frame) for the penetrations `delta` (m);
        `pressures`: `pressures(delta)`, when the caller has solved it already."""
        touching = np.flatnonzero(delta > 0)
        if not len(touching):
            return np.zeros_like(self.pin_normals)
        if pressures is None:
            pressures = self.pressures(delta)
        slope = (self.gradient_matrix[:, touching] @ pressures[touching]).reshape(-1, 3)
        tilted = self.pin_normals + slope  # the skin's outward normal n + ∇w (unnormalised)
        tilted /= np.linalg.norm(tilted, axis=1, keepdims=True)
        return -self.lever * (tilted - self.pin_normals)

    def rim_in_contact(self, delta: np.ndarray) -> bool:
        """Whether the contact reaches the rim of the modelled cap (the model no longer holds)."""
        return bool(np.any(delta[self.rim] > 0))


#: solves a guessed active set may take before the cold start takes over (SkinLayer.pressures)
_WARM_ITERATIONS = 10


def _active_set(kernel: np.ndarray, target: np.ndarray, active: np.ndarray, iterations: int) -> np.ndarray | None:
    """p ≥ 0 with K·p = δ on the active nodes and K·p ≥ δ elsewhere, from the active set
    `active` (sorted indices): drop the nodes a solve gives negative pressure, add those
    left short of δ, until neither happens; None if that takes more than `iterations`
    solves."""
    p = np.zeros(len(target))
    for _ in range(iterations):
        if not len(active):
            return None
        pa = np.linalg.solve(kernel[np.ix_(active, active)], target[active])
        if np.any(pa < 0):
            active = active[pa > 0]
            continue
        p[:] = 0.0
        p[active] = pa
        short = np.flatnonzero((p == 0) & (kernel @ p < target))
        if not len(short):
            return p
        active = np.union1d(active, short)
    return None


@lru_cache(maxsize=4)
def skin_layer(geometry: TacTipGeometry, spacing: float, extent_deg: float) -> SkinLayer:
    """The SkinLayer for these dimensions, built once per process (≈ 0.1 s)."""
    return SkinLayer(geometry, spacing, extent_deg)
