"""Stimulus geometry: built-in meshes, convex collision pieces, contour helpers, user files."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import shapely
import trimesh

from twin.core.errors import UserError
from twin.tools.assets import DEFAULT_ASSET_DIR, generate_assets
from twin.world.stimuli import BUILTINS, MATERIALS, load_stimulus
from twin.world.stimuli.outlines import MM

NAMES = list(BUILTINS)


@pytest.fixture(scope="module")
def stims():
    return {n: load_stimulus(n) for n in NAMES}


def test_six_builtins_with_known_materials(stims):
    assert NAMES == ["rectangle", "large_circle", "small_circle", "flower", "spiral", "tape_measure"]
    for s in stims.values():
        assert s.material in MATERIALS
        assert s.friction == MATERIALS[s.material].friction
        assert s.thickness_mm >= 6.0


@pytest.mark.parametrize("name", NAMES)
def test_mesh_watertight_and_volume_matches_outline(stims, name):
    s = stims[name]
    assert s.mesh.is_watertight and s.mesh.is_winding_consistent
    expected = s.outline.area * s.thickness_mm * MM**3
    assert s.mesh.volume > 0
    assert s.mesh.volume == pytest.approx(expected, rel=0.01)
    zmin, zmax = s.mesh.bounds[:, 2]
    assert zmax == pytest.approx(0.0, abs=1e-12)
    assert zmin == pytest.approx(-s.thickness_mm * MM)


@pytest.mark.parametrize("name", NAMES)
def test_collision_pieces_are_convex_and_tile_the_outline(stims, name):
    s = stims[name]
    pieces = s.collision_pieces()
    assert 1 <= len(pieces) < 200
    polys = []
    for verts in pieces:
        hull = trimesh.convex.convex_hull(verts)
        poly2d = shapely.MultiPoint(verts[:, :2] / MM).convex_hull
        polys.append(poly2d)
        # a convex prism equals the hull of its vertices
        prism_volume = poly2d.area * s.thickness_mm * MM**3
        assert hull.volume == pytest.approx(prism_volume, rel=1e-6)
        assert np.ptp(verts[:, 2]) == pytest.approx(s.thickness_mm * MM)
    total = sum(p.area for p in polys)
    assert total == pytest.approx(s.outline.area, rel=1e-6)
    union = shapely.union_all(polys)
    assert union.area == pytest.approx(s.outline.area, rel=1e-6)  # no overlaps, no gaps
    assert union.symmetric_difference(s.outline).area < 1e-6 * s.outline.area


def test_non_convex_objects_are_split(stims):
    assert len(stims["flower"].collision_pieces()) > 5
    assert len(stims["spiral"].collision_pieces()) > 20
    for n in ("rectangle", "large_circle", "small_circle", "tape_measure"):
        assert len(stims[n].collision_pieces()) == 1


@pytest.mark.parametrize("name", NAMES)
def test_pieces_compile_in_mujoco_without_warnings(stims, name):
    spec = mujoco.MjSpec()
    geoms = stims[name].add_to_spec(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert model.ngeom == len(geoms) == len(stims[name].collision_pieces())
    assert [w.number for w in data.warning] == [0] * len(data.warning)
    assert model.geom_friction[0, 0] == pytest.approx(stims[name].friction)


def test_stored_assets_equal_fresh_generation(tmp_path):
    written = generate_assets(tmp_path)
    fresh = {p.relative_to(tmp_path) for p in written}
    stored = {p.relative_to(DEFAULT_ASSET_DIR) for p in DEFAULT_ASSET_DIR.rglob("*") if p.is_file()}
    assert fresh <= stored, "assets missing: run `python -m twin.tools.assets`"
    for rel in sorted(fresh):
        assert (tmp_path / rel).read_bytes() == (DEFAULT_ASSET_DIR / rel).read_bytes(), (
            f"{rel} is stale: run `python -m twin.tools.assets`"
        )
    stl = (DEFAULT_ASSET_DIR / "flower" / "flower.stl").read_bytes()
    assert b"MIT" in stl[:80] and not stl.startswith(b"solid")
    assert "Copyright (c) 2026 tactip-twin contributors" in (DEFAULT_ASSET_DIR / "LICENSE").read_text()


@pytest.mark.parametrize("name", NAMES)
def test_stored_stl_is_the_mesh_in_mm(stims, name):
    mesh = trimesh.load_mesh(DEFAULT_ASSET_DIR / name / f"{name}.stl")
    assert mesh.is_watertight
    assert mesh.volume == pytest.approx(stims[name].mesh.volume / MM**3, rel=1e-5)


def test_circle_normals_are_radial_and_contour_lies_on_the_edge(stims):
    s = stims["large_circle"]
    n_vertices = len(s.outline.exterior.coords) - 1
    pts = s.contour(2.0)
    assert np.allclose(pts[0], s.start_point_mm)
    assert s.distance_to_contour(pts).max() < 1e-9
    radial = np.degrees(np.arctan2(pts[:, 1], pts[:, 0]))
    err = (s.outward_normal_deg(pts) - radial + 180) % 360 - 180
    assert np.abs(err).max() <= 180 / n_vertices + 1e-6
    # off the edge: outside points 5 mm out, inside points 5 mm in
    unit = pts / np.linalg.norm(pts, axis=1, keepdims=True)
    for offset in (5.0, -5.0):
        q = pts + offset * unit
        assert np.allclose(s.signed_distance_mm(q), offset, atol=0.06)
        err = (s.outward_normal_deg(q) - radial + 180) % 360 - 180
        assert np.abs(err).max() <= 180 / n_vertices + 1e-6


def test_rectangle_normals_edges_and_corner(stims):
    s = stims["rectangle"]
    assert s.start_point_mm == (0.0, -40.0)
    assert s.start_direction_deg == pytest.approx(0.0)
    got = s.outward_normal_deg([[0, -40], [60, 0], [0, 40], [-60, 0], [70, 50], [0, -30], [60, -40]])
    assert got == pytest.approx([-90, 0, 90, 180, 45, -90, -45])
    assert s.distance_to_contour([[70, 50], [0, 0]]) == pytest.approx([np.hypot(10, 10), 40])
    assert s.signed_distance_mm([[0, -49.9], [0, -34]]) == pytest.approx([9.9, -6])


@pytest.mark.parametrize("name", NAMES)
def test_contour_is_ccw_and_starts_on_the_edge(stims, name):
    s = stims[name]
    pts = s.contour(1.0)
    assert s.distance_to_contour([s.start_point_mm])[0] < 1e-9
    assert np.allclose(pts[0], s.start_point_mm)
    assert shapely.Polygon(pts).exterior.is_ccw
    steps = np.hypot(*np.diff(pts, axis=0).T)
    assert steps.max() <= 1.05
    assert len(pts) == pytest.approx(s.perimeter_mm, abs=1)


def test_spiral_is_open_from_outer_to_inner_end(stims):
    s = stims["spiral"]
    assert s.is_open and s.end_point_mm is not None
    path = s.trace_path(1.0)
    assert np.allclose(path[0], s.start_point_mm) and np.allclose(path[-1], s.end_point_mm)
    radius = np.hypot(*path.T)
    assert radius[0] > 75 and radius[-1] < 30  # winds inwards
    # counter-clockwise: polar angle increases by about two turns
    turned = np.sum(np.diff(np.unwrap(np.arctan2(path[:, 1], path[:, 0]))))
    assert turned == pytest.approx(4 * np.pi, abs=0.5)
    assert s.distance_to_contour(path).max() < 1e-9
    for name in set(NAMES) - {"spiral"}:
        assert not stims[name].is_open and stims[name].end_point_mm is None


def test_flower_has_concave_and_convex_edges(stims):
    s = stims["flower"]
    hull = s.outline.convex_hull
    assert hull.area > 1.02 * s.outline.area  # concave between the petals
    bounds = s.outline.bounds
    assert bounds[3] == pytest.approx(58.0)  # petal tip at +y


def test_user_stl_round_trip(tmp_path):
    box = trimesh.creation.box(extents=(40.0, 30.0, 12.0))
    box.apply_translation((100.0, 50.0, 6.0))  # corner-ish origin, as CAD files often are
    path = tmp_path / "box.stl"
    box.export(path)
    s = load_stimulus(path)
    assert s.name == "box" and s.source == str(path)
    assert s.thickness_mm == pytest.approx(12.0)
    assert s.outline.area == pytest.approx(1200.0)
    assert s.outline.bounds == pytest.approx((-20, -15, 20, 15))
    assert s.source_offset_mm == pytest.approx((100.0, 50.0, 12.0))
    assert s.mesh.bounds == pytest.approx(np.array([[-20, -15, -12], [20, 15, 0]]) * MM)
    assert s.collision == "convex" and len(s.collision_pieces()) == 1
    assert s.start_point_mm == pytest.approx((0.0, -15.0))
    assert s.friction == MATERIALS["pla"].friction


def test_user_non_convex_stl_uses_prism_pieces(tmp_path):
    path = DEFAULT_ASSET_DIR / "flower" / "flower.stl"
    ref = load_stimulus("flower")
    moved = load_stimulus(path)  # re-centred on the bounding-box centre (the flower is not symmetric in y)
    assert moved.source_offset_mm == pytest.approx((0.0, (58.0 - 49.561571728) / 2, 0.0), abs=1e-4)
    s = load_stimulus(path, material="abs", friction=0.3, recentre=False)
    assert s.collision == "prism" and s.friction == 0.3 and s.material == "abs"
    assert s.outline.area == pytest.approx(ref.outline.area, rel=1e-3)
    assert s.outline.symmetric_difference(ref.outline.buffer(0)).area < 1e-3 * ref.outline.area
    assert sum(shapely.Polygon(p).area for p in s.convex_outlines) == pytest.approx(s.outline.area)


def test_stl_in_metres_needs_units(tmp_path):
    path = tmp_path / "small.stl"
    trimesh.creation.box(extents=(0.04, 0.03, 0.01)).export(path)
    with pytest.raises(UserError, match="implausible size.*metres"):
        load_stimulus(path)
    assert load_stimulus(path, stl_units="m").outline.area == pytest.approx(1200.0)


def test_broken_stl_names_the_file(tmp_path):
    box = trimesh.creation.box(extents=(40.0, 30.0, 12.0))
    broken = trimesh.Trimesh(box.vertices, box.faces[1:], process=False)
    path = tmp_path / "broken.stl"
    broken.export(path)
    with pytest.raises(UserError, match=r"broken mesh .*broken\.stl: not watertight \(3 open edges\)"):
        load_stimulus(path)
    garbage = tmp_path / "garbage.stl"
    garbage.write_bytes(b"\x00" * 10)
    with pytest.raises(UserError, match="garbage.stl"):
        load_stimulus(garbage)


def test_outline_csv_round_trip(stims):
    s = load_stimulus(DEFAULT_ASSET_DIR / "tape_measure" / "outline.csv", thickness_mm=38.0, material="abs")
    ref = stims["tape_measure"]
    assert s.outline.equals_exact(ref.outline, 1e-6)
    assert s.mesh.volume == pytest.approx(ref.mesh.volume)
    assert s.start_point_mm == pytest.approx(ref.start_point_mm)


def test_outline_csv_comments_and_recentre(tmp_path):
    path = tmp_path / "l_shape.csv"
    path.write_text("# an L\nx,y\n0,0\n60,0\n60,20\n20,20\n20,50\n0,50\n0,0\n")
    s = load_stimulus(path, thickness_mm=10)
    assert s.outline.area == pytest.approx(60 * 20 + 20 * 30)
    assert s.source_offset_mm == pytest.approx((30.0, 25.0, 0.0))
    assert len(s.collision_pieces()) == 2


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("x,y\n0,0\n10,0\nten,10\n0,10\n", r"bad\.csv line 4: expected 'x,y'"),
        ("0,0\n10,0\n10,10,3\n", r"bad\.csv line 3: expected two finite numbers"),
        ("0,0\n10,0\n", r"bad\.csv: needs at least 3 vertices, got 2"),
        ("0,0\n20,20\n20,0\n0,20\n", r"bad\.csv: not a simple polygon \(edge line 1→2 crosses edge line 3→4\)"),
        ("0,0\n10,0\n20,0\n", r"bad\.csv: zero area"),
        ("0,0\n1,0\n1,1\n", r"bad\.csv: implausible size 1 mm"),
    ],
)
def test_malformed_outline_csv_names_file_and_line(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(UserError, match=match):
        load_stimulus(path, thickness_mm=10)


def test_bad_specs_raise_user_errors(tmp_path):
    with pytest.raises(UserError, match="unknown stimulus 'hexagon'"):
        load_stimulus("hexagon")
    with pytest.raises(UserError, match="does not exist"):
        load_stimulus(tmp_path / "missing.stl")
    ok = tmp_path / "tri.csv"
    ok.write_text("0,0\n30,0\n0,30\n")
    with pytest.raises(UserError, match="thickness_mm is required"):
        load_stimulus(ok)
    with pytest.raises(UserError, match="unknown material 'steel'"):
        load_stimulus(ok, thickness_mm=5, material="steel")


def _top_height_mm(mesh: trimesh.Trimesh, x_mm: float, y_mm: float) -> float:
    """The top surface's height (mm) of a convex mesh (m) above (x, y): the lowest of its
    upward facets' planes there."""
    n = mesh.face_normals
    d = np.einsum("ij,ij->i", n, mesh.triangles[:, 0])
    up = n[:, 2] > 1e-9
    return float(np.min((d[up] - n[up, 0] * x_mm * MM - n[up, 1] * y_mm * MM) / n[up, 2])) / MM


@pytest.mark.parametrize(("name", "radius_mm"), [("rectangle", 1.0), ("rectangle", 2.5), ("large_circle", 1.5)])
def test_a_rounded_top_edge_is_a_quarter_circle_across_the_side(stims, name, radius_mm):
    """Across the side at the outline's +x extreme, the top falls as the quarter circle
    z = −r + √(r² − u²), u the distance past the flat's end (within 5 µm: its 32 facets),
    the flat stays at z = 0, and the solid is one closed convex piece of the same outline
    and thickness."""
    from twin.world.stimuli.objects import with_edge_radius

    sharp = stims[name]
    rounded = with_edge_radius(sharp, radius_mm)
    mesh = rounded.mesh
    assert len(rounded.collision_pieces()) == 1 and mesh.is_watertight and mesh.is_convex
    np.testing.assert_allclose(mesh.bounds, sharp.mesh.bounds, atol=1e-9)
    edge = sharp.outline.bounds[2]
    for x in np.linspace(edge - 2 * radius_mm, edge - 1e-6, 25):
        u = max(0.0, x - (edge - radius_mm))
        assert _top_height_mm(mesh, x, 0.0) == pytest.approx(-radius_mm + np.sqrt(radius_mm**2 - u**2), abs=5e-3)
    assert with_edge_radius(sharp, 0.0) is sharp


#: the centroid of the material a quarter-circle fillet of radius r takes off a square edge,
#: from either face, over r: (10 − 3π) / (3 (4 − π))
FILLET_CENTROID = (10.0 - 3.0 * np.pi) / (3.0 * (4.0 - np.pi))


def test_a_rounded_non_convex_outline_loses_the_fillet_pappus_gives_and_is_round_across_its_sides(stims, tmp_path):
    """The flower rounded by 1.5 mm loses what Pappus gives a fillet swept along a closed
    outline, r²(1 − π/4)(P − 2π x̄), x̄ the fillet's centroid from the side (within 0.5 %:
    the polygon's facets), and its mesh reads back from STL closed. Its collision pieces
    hold the same volume to 0.01 %: they neither overlap nor leave gaps along their cuts.
    Across the side, along each vertex's bisector, a ray down onto them as MuJoCo compiles
    them meets the quarter circle: within 5 µm at the petals' (convex) vertices; in the
    hollows never below it, and above it by at most 0.1 mm, where a piece's hull spans the
    kink of the inset outline."""
    from twin.world.stimuli.objects import with_edge_radius

    r = 1.5
    sharp = stims["flower"]
    rounded = with_edge_radius(sharp, r)
    lost_mm3 = (sharp.mesh.volume - rounded.mesh.volume) / MM**3
    fillet = r**2 * (1.0 - np.pi / 4.0) * (sharp.outline.exterior.length - 2.0 * np.pi * FILLET_CENTROID * r)
    assert lost_mm3 == pytest.approx(fillet, rel=5e-3)
    path = tmp_path / "rounded.stl"
    rounded.mesh.export(path)
    assert trimesh.load_mesh(path).is_watertight
    pieces = [trimesh.convex.convex_hull(v) for v in rounded.collision_pieces()]
    assert len(pieces) > 1
    assert sum(p.volume for p in pieces) == pytest.approx(rounded.mesh.volume, rel=1e-4)

    spec = mujoco.MjSpec()
    rounded.add_to_spec(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    hit = np.zeros(1, np.int32)
    ring = np.asarray(sharp.outline.exterior.coords)[:-1]
    misses = {"convex": [], "concave": []}
    for k in range(0, len(ring), 3):
        before, at, after = ring[k - 1], ring[k], ring[(k + 1) % len(ring)]
        t1, t2 = (at - before) / np.linalg.norm(at - before), (after - at) / np.linalg.norm(after - at)
        inward = np.array([-(t1 + t2)[1], (t1 + t2)[0]]) / np.linalg.norm(t1 + t2)  # left of a CCW ring
        turn = t1[0] * t2[1] - t1[1] * t2[0]
        for d in np.linspace(0.01, 2 * r, 12):
            # 1 µm along the side: a ray exactly through a vertex's mitre, an edge of a piece's
            # hull, can pass between its facets in MuJoCo (a point of zero measure)
            x, y = at + d * inward + 1e-3 * t1
            # the ray the compliant dome casts, down onto the pieces as MuJoCo holds them
            drop_m = mujoco.mj_ray(
                model, data, np.array([x * MM, y * MM, 0.01]), np.array([0.0, 0.0, -1.0]), None, 1, -1, hit
            )
            top_mm = (0.01 - drop_m) / MM
            u = max(0.0, r - sharp.outline.exterior.distance(shapely.Point(x, y)))
            misses["convex" if turn > 0 else "concave"].append(top_mm - (-r + np.sqrt(r**2 - u**2)))
    assert np.max(np.abs(misses["convex"])) < 5e-3
    assert -5e-3 < np.min(misses["concave"]) and np.max(misses["concave"]) < 0.1


def test_a_rounded_l_shaped_outline_loses_what_pappus_gives_along_its_mitred_path(tmp_path):
    """An L-shaped outline from a CSV file (five convex corners, one concave, a vertex
    midway along a side), rounded by 1.5 mm: the sections are mitred, so the fillet sweeps
    along the outline inset by its centroid x̄, whose length is P − 2x̄ Σ tan(turn / 2)
    = P − 8x̄ (each 90° corner ±1), and the solid loses r²(1 − π/4)(P − 8x̄) (within
    0.5 %: the quarter circle's 32 facets). Its mesh reads back from STL closed."""
    from twin.world.stimuli.objects import with_edge_radius

    path = tmp_path / "ell.csv"
    path.write_text("x,y\n0,0\n20,0\n40,0\n40,15\n15,15\n15,35\n0,35\n")
    sharp = load_stimulus(path, thickness_mm=8.0)
    r = 1.5
    rounded = with_edge_radius(sharp, r)
    assert len(rounded.collision_pieces()) > 1
    lost_mm3 = (sharp.mesh.volume - rounded.mesh.volume) / MM**3
    path_mm = sharp.outline.exterior.length - 8.0 * FILLET_CENTROID * r
    assert lost_mm3 == pytest.approx(r**2 * (1.0 - np.pi / 4.0) * path_mm, rel=5e-3)
    rounded.mesh.export(tmp_path / "ell.stl")
    assert trimesh.load_mesh(tmp_path / "ell.stl").is_watertight


def test_an_stl_object_is_rounded_as_the_prism_of_its_outline(stims, tmp_path):
    """A user STL of the flower, rounded by 1 mm, is the built-in flower rounded by 1 mm:
    the same volume (to 0.1 %), in rounded pieces."""
    from twin.world.stimuli.objects import with_edge_radius

    path = tmp_path / "flower.stl"
    stims["flower"].mesh.copy().apply_scale(1.0 / MM).export(path)
    from_file, built_in = (with_edge_radius(s, 1.0) for s in (load_stimulus(path), stims["flower"]))
    assert from_file.mesh.volume == pytest.approx(built_in.mesh.volume, rel=1e-3)
    assert len(from_file.collision_pieces()) > 1 and from_file.edge_radius_mm == 1.0


def test_an_edge_radius_is_refused_where_it_cannot_round_the_object(stims, tmp_path):
    from twin.world.stimuli.objects import with_edge_radius

    with pytest.raises(UserError, match="beyond the object's thickness"):
        with_edge_radius(stims["rectangle"], 10.5)
    with pytest.raises(UserError, match=r"object spiral: edge radius 4 mm: .* or half its width"):
        with_edge_radius(stims["spiral"], 4.0)
