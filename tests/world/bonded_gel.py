"""A finite-element reference for the compliant dome's gel: the gel as what it is, a
hemisphere bonded to the sensor's rigid base at the equator, meshed by gmsh and solved
by scikit-fem (quadratic tetrahedra, linear elasticity). It has none of the closed-form
model's approximations (a half-space tangent at every node, the volume kept by a
Lagrange multiplier) and all of the geometry, so the tests compare the two."""

from __future__ import annotations

import math
import signal
from dataclasses import dataclass

import gmsh
import numpy as np
import skfem
from scipy import sparse
from scipy.sparse.linalg import splu
from skfem.models.elasticity import lame_parameters, linear_elasticity

from twin.core.sensor import TacTipGeometry
from twin.world.dome.compliant.compliance import DISC_RULE, CapSurface, SkinSheet, post_tips


@dataclass
class BondedGel:
    """The gel's stiffness at G = 1 Pa, factorised, on a mesh `size` (m) fine at the dome's
    surface; `free`: the degrees of freedom not held by the base."""

    geometry: TacTipGeometry
    size: float
    poisson: float
    basis: skfem.CellBasis
    free: np.ndarray
    factor: object

    @classmethod
    def build(cls, geometry: TacTipGeometry, size: float, poisson: float, inner_size: float = 0.005) -> BondedGel:
        radius, centre_z = geometry.dome_outer_radius, geometry.sphere_centre_z
        # gmsh's initialize sets SIGINT to its default action (undone by no finalize of gmsh
        # 4.15) and SIGPIPE too: a worker that then writes to a closed pipe, or a held Ctrl-C
        # handed on, would be killed outright (tests/conftest.py checks every test for it)
        sigpipe = signal.getsignal(signal.SIGPIPE)
        gmsh.initialize(interruptible=False)
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.model.add("gel")
            ball = gmsh.model.occ.addSphere(0.0, 0.0, centre_z, radius)
            upper = gmsh.model.occ.addBox(-2 * radius, -2 * radius, centre_z, 4 * radius, 4 * radius, 2 * radius)
            gmsh.model.occ.intersect([(3, ball)], [(3, upper)])
            gmsh.model.occ.synchronize()
            dome = [tag for dim, tag in gmsh.model.getEntities(2) if gmsh.model.getType(dim, tag) != "Plane"]
            field = gmsh.model.mesh.field
            distance = field.add("Distance")
            field.setNumbers(distance, "SurfacesList", dome)
            grading = field.add("Threshold")
            field.setNumber(grading, "InField", distance)
            for name, value in (("SizeMin", size), ("SizeMax", inner_size), ("DistMin", 0.001), ("DistMax", 0.008)):
                field.setNumber(grading, name, value)
            field.setAsBackgroundMesh(grading)
            for option in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
                gmsh.option.setNumber(f"Mesh.{option}", 0)
            gmsh.model.mesh.generate(3)
            tags, coords, _ = gmsh.model.mesh.getNodes()
            _, _, connectivity = gmsh.model.mesh.getElements(3)
        finally:
            gmsh.finalize()
            signal.signal(signal.SIGPIPE, sigpipe)
        index = np.zeros(int(tags.max()) + 1, int)
        index[tags.astype(int)] = np.arange(len(tags))
        tets = index[connectivity[0].astype(int)].reshape(-1, 4)
        used = np.unique(tets)
        renumber = np.full(len(tags), -1)
        renumber[used] = np.arange(len(used))
        mesh = skfem.MeshTet(
            np.ascontiguousarray(coords.reshape(-1, 3)[used].T), np.ascontiguousarray(renumber[tets].T)
        )
        basis = skfem.Basis(mesh, skfem.ElementVector(skfem.ElementTetP2()))
        stiffness = skfem.asm(linear_elasticity(*lame_parameters(2.0 * (1.0 + poisson), poisson)), basis)  # G = 1 Pa
        free = np.setdiff1d(np.arange(basis.N), basis.get_dofs(lambda x: np.abs(x[2] - centre_z) < 1e-9).all())
        return cls(geometry, size, poisson, basis, free, splu(stiffness[free][:, free].tocsc(), permc_spec="COLAMD"))

    def probe(self, points: np.ndarray) -> sparse.csr_matrix:
        """(3P, free) the displacement at points (rows [point, axis]), each taken 0.2 mm
        inside the faceted mesh."""
        centre = np.array([0.0, 0.0, self.geometry.sphere_centre_z])
        offset = points - centre
        distance = np.linalg.norm(offset, axis=1, keepdims=True)
        inside = centre + offset * np.minimum(distance, self.geometry.dome_outer_radius - 2e-4) / distance
        inside[:, 2] = np.maximum(inside[:, 2], centre[2] + 2e-4)
        by_axis = self.basis.probes(inside.T).tocsr()  # rows [axis, point]
        order = (np.arange(3)[None, :] * len(points) + np.arange(len(points))[:, None]).ravel()
        return by_axis[order][:, self.free]

    def on_sheet(self, surface: CapSurface, sheet: SkinSheet, shear_modulus: float) -> tuple[np.ndarray, np.ndarray]:
        """The gel's compliance on the sheet's nodes ((3K, 3K) m/N, each node's force spread
        over its disc by DISC_RULE, as the closed-form kernel) and the pin tips' ((381, 3K),
        the posts of `post_tips` on this gel): `skin_on_gel`'s inputs."""
        radius = math.sqrt(surface.area / math.pi)
        spread = sum(
            weight * self.probe(sheet.points + radius * (x * sheet.frames[:, 1] + y * sheet.frames[:, 2]))
            for x, y, weight in DISC_RULE
        )
        displacement = self.factor.solve(np.asarray(spread.T.todense())) / shear_modulus  # (free, 3K)
        gel = spread @ displacement
        count = len(sheet.points)
        pins = post_tips(self.geometry, lambda points: (self.probe(points) @ displacement).reshape(-1, 3, count, 3))
        return 0.5 * (gel + gel.T), pins.reshape(-1, 3 * count)
