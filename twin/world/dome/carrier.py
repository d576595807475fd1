"""The stimulus carrier: the free body that carries every object geom in a dome model's
physics scene (the scene is built in the tool frame, the sensor still at the origin).
Shared by the dome models (twin.world.dome.flex drives it by velocity, twin.world.dome.compliant
poses it for its rays)."""

from __future__ import annotations

import mujoco

#: Mass (kg) and rotational inertia (kg·m²) of the kinematic stimulus carrier. It is driven
#: by prescribing its velocity every step (twin.world.dome.flex.physics), so it must be heavy enough that
#: the contact forces (≤ tens of N) don't deflect it measurably within one step.
CARRIER_MASS = 1.0e4
CARRIER_INERTIA = 25.0


def add_stimulus_carrier(spec: mujoco.MjSpec, name: str = "stimulus") -> mujoco.MjsBody:
    """Add the body that carries every stimulus geom: free joint, heavy, gravity-compensated.

    The physics scene is built in the *tool frame*: the TacTip sits still at the world
    origin (``add_tactip(spec, spec.worldbody, ...)``), and the stimuli move around it —
    twin.world.dome.flex.physics.SensorPhysics prescribes this body's velocity each step so that its pose
    in the tool frame is inv(tool2world) · stimulus2world along the commanded path
    ("arm dynamics off": the sensor follows the commanded pose exactly). Add the stimulus
    geoms to the returned body with their poses in the lab world frame (the body's frame
    *is* the world frame when the tool frame coincides with it).

    Why this way round (measured with MuJoCo 4.0, 2 cores):
      * a mocap sensor mount has a pose but no velocity; the dome's node bodies are its
        children, so a move teleports the whole dome and contacts never see the slip —
        friction then produced no shear at all (mean pin shift 2 nm over a 4 mm slide);
      * a free-jointed, velocity-driven sensor mount shears correctly but makes the flex
        nodes "articulated attachments", whose stiffness MuJoCo must pull back through the
        attachment Jacobians: 2.3 ms per step instead of ≈ 0.45 ms with a static dome.
    Quasi-static contact mechanics are frame-invariant (gravity is compensated on the
    dome and the carrier), so moving the world around a still sensor gives the same pins.
    """
    body = spec.worldbody.add_body(name=name, gravcomp=1.0)
    body.add_freejoint(name=f"{name}_free")
    body.explicitinertial = True
    body.mass = CARRIER_MASS
    body.inertia = [CARRIER_INERTIA] * 3
    return body
