"""Translucent radiosity: the binding (``Scene.add_diffuse_mesh`` and the diffuse setters,
``Scene.material``, ``Scene.bake(method="radiosity", ...)``, ``Scene.radiosity_stats``) and the
bake operator with the Radiosity method, which sends the visible meshes around the selection
as opaque diffuse surfaces and writes their radiance too.

The references, in closed form:

- **An emissive enclosure of albedo 0** (tests/c/radiosity_room.c's room): it reflects nothing,
  so its radiosity is its emission M and its radiance exactly M/π at every vertex, whatever it
  holds. A translucent ball inside it sees radiance M/π in every direction: the uniform
  irradiance M, which is what a constant environment of radiance M/π gives. TransCut's
  unshadowed constant environment is exact (q = π L (1 − F_ext)); radiosity's irradiance goes
  through the ray-cast form factors, whose rows in a closed scene are balanced to sum to 1 but
  of which a little lands on the ball itself (its tets' faceted boundary sees itself). So the
  two agree to the form factors, not to rounding: measured 1.6e-4 at worst per vertex and
  3e-6 on average (20 000 tets, 256 rays).
- **A floor far from the ball under a sun**: Lo = ρ E cos θ / π plus the little light the ball
  sends back, with ρ = Base Color × (1 − Metallic).
- **An emissive floor of albedo 0** in Blender: Blender's emission of colour c and strength S
  has radiance c·S; the add-on sends the exitance M = π c S, so the floor's attribute is c·S.
"""

from __future__ import annotations

import ctypes
import math

import numpy as np
import pytest

from conftest import bpy, library_path, require_library
from test_addon import (
    RecordingLayout,
    add_light,
    add_sphere,
    attribute_rgb,
    evaluated_arrays,
    select_only,
    snapshot,
    world_points,
)
from test_dipole import icosphere
from test_native_header import binding as tc

#: A closed cube of half-side h (tests/c/radiosity_room.c): 8 corners, 12 triangles.
CUBE_TRIANGLES = np.array(
    [0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4, 2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5],
    np.uint32,
).reshape(-1, 3)
EMISSION = np.array([1.0, 0.5, 0.25])
ROOM_TETS = 20_000
#: How far the ball in the emissive room may be from its TransCut bake under the equivalent
#: sky, per vertex and on average (measured 1.6e-4 and 3e-6: the module docs).
BALL_PER_VERTEX = 1e-3
BALL_MEAN = 3e-5


def cube(h: float) -> np.ndarray:
    return np.array([[h if i & 1 else -h, h if i & 2 else -h, h if i & 4 else -h] for i in range(8)], np.float32)


@pytest.fixture(scope="module")
def tclib():
    require_library()
    return tc.load(library_path())


@pytest.fixture(scope="module")
def ball():
    return icosphere(10.0, 3)  # R = 10 mm at the default 1 mm per unit


def object_count(s) -> int:
    out = ctypes.c_uint32()
    s.lib.call("tc_scene_object_count", s._h(), ctypes.byref(out))
    return int(out.value)


def room_scene(tclib, ball, albedo=(0.0, 0.0, 0.0)):
    """The marble ball in the 60 mm room emitting EMISSION from its inside; (scene, ball, room)."""
    s = tclib.scene()
    b = s.add_mesh(*ball)
    s.set_medium_preset(b, "marble")
    r = s.add_diffuse_mesh(cube(30.0), CUBE_TRIANGLES, albedo, emission=EMISSION, sides="back")
    s.set_name(r, "room")
    return s, b, r


ROOM_BAKE = dict(
    method="radiosity",
    tets=ROOM_TETS,
    tolerance=1e-8,
    backend="cpu",
    patch_size=12.0,
    rays=256,
    radiosity_tolerance=1e-4,
)


# -- the binding -----------------------------------------------------------------------------


def test_radiosity_options_defaults_and_names(tclib):
    r = tclib.default_radiosity_options()
    assert r.size == ctypes.sizeof(tc.TcRadiosityOptions)
    assert (r.iteration, r.patch_size_mm, r.rays_per_patch, r.bounces) == (tc.TC_RADIOSITY_JACOBI, 0.0, 512, 0)
    assert (r.grading, r.discretization) == (tc.TC_GRADING_AUTO, tc.TC_DISCRETIZATION_FITTED_LAYER)
    assert tclib.method_number("radiosity") == tc.TC_METHOD_RADIOSITY
    assert tc.RADIOSITY_ITERATIONS == {"jacobi": 0, "gauss-seidel": 1, "bicgstab": 2}
    assert tc.SIDES == {"both": tc.TC_SIDES_BOTH, "front": tc.TC_SIDES_FRONT, "back": tc.TC_SIDES_BACK}


def test_an_emissive_room_of_albedo_0_matches_its_closed_forms(tclib, ball):
    """The room's Lo = M/π exactly; the ball's is its TransCut bake under a sky of radiance M/π
    (module docs); the scene's statistics are consistent; and Gauss–Seidel gives the same."""
    s, b, r = room_scene(tclib, ball)
    with s:
        assert (s.material(b), s.material(r)) == ("translucent", "diffuse")
        with pytest.raises(tc.TranscutError) as err:
            s.radiosity_stats()
        assert err.value.status == tc.TC_NOT_BAKED
        s.bake(**ROOM_BAKE)
        room, lit = s.radiance(r), s.radiance(b)
        stats = s.radiosity_stats()
        s.bake(**ROOM_BAKE, iteration="Gauss_Seidel")
        gauss_seidel = s.radiance(b)
    np.testing.assert_allclose(room, np.broadcast_to(EMISSION / np.pi, room.shape), rtol=1e-6)
    assert set(stats) == {f for f, _ in tc.TcRadiosityStats._fields_} - {"size"}
    assert stats["patches"] > stats["translucent_patches"] > 0 and stats["covered_patches"] == 0
    assert stats["form_factor_bytes"] == 8 * stats["nonzeros"] > 0
    assert stats["patch_size_mm"] == 12.0 and stats["iterations"] >= 1
    assert stats["estimated_error"] < 1e-4 and stats["energy_defect"] < 1e-2
    with tclib.scene() as sky:
        i = sky.add_mesh(*ball)
        sky.set_medium_preset(i, "marble")
        sky.add_environment(EMISSION / np.pi)
        sky.bake(tets=ROOM_TETS, tolerance=1e-8, backend="cpu", shadows=0)
        want = sky.radiance(i).astype(np.float64)
    rel = lit / want - 1.0
    worst, mean = np.abs(rel).max(), np.abs(rel.mean(axis=0)).max()
    print(f"\nball in the room against the sky: worst {worst:.2e}, mean {mean:.2e}")
    assert worst < BALL_PER_VERTEX and mean < BALL_MEAN
    np.testing.assert_allclose(gauss_seidel, lit, rtol=BALL_PER_VERTEX)


def test_the_translucent_objects_take_grading_and_discretization(tclib, ball):
    """grading and discretization reach the translucent ball of a radiosity bake: the default
    is the fitted assembly with the layer on uniform tets (the same bake, bit for bit, when named), and the
    paper's assembly and a graded mesh each change the ball's radiance."""
    s, b, _ = room_scene(tclib, ball)
    with s:
        s.bake(**ROOM_BAKE)
        default = s.radiance(b)
        s.bake(**ROOM_BAKE, grading=0, discretization="fitted-layer")
        np.testing.assert_array_equal(s.radiance(b), default)
        s.bake(**ROOM_BAKE, discretization="transcut")
        paper = s.radiance(b)
        s.bake(**ROOM_BAKE, grading=1)
        graded = s.radiance(b)
    for other in (paper, graded):
        change = np.abs(other / default - 1.0).max()
        assert 1e-6 < change < 0.05, change


def test_inter_reflection_and_one_bounce(tclib, ball):
    """Albedo 0.5 (set_albedo after the add): the walls light each other, above M/π; one bounce
    is the emission alone, M/π again."""
    s, _, r = room_scene(tclib, ball)
    with s:
        s.set_albedo(r, (0.5, 0.5, 0.5))
        s.bake(**ROOM_BAKE)
        assert np.all(s.radiance(r) > 1.2 * EMISSION / np.pi)
        s.bake(**ROOM_BAKE, bounces=1)
        np.testing.assert_allclose(s.radiance(r), np.broadcast_to(EMISSION / np.pi, (8, 3)), rtol=1e-6)
        assert s.radiosity_stats()["iterations"] <= 1


def test_edit_albedo_and_emission_re_solve_the_baked_scene(tclib, ball):
    """edit_albedo after a bake equals baking with that albedo (which the scene then has),
    edit_emission likewise; a translucent object and a value out of range are refused with
    nothing changed."""
    s, b, r = room_scene(tclib, ball)
    with s:
        s.set_albedo(r, (0.5, 0.5, 0.5))
        s.bake(**ROOM_BAKE)
        before = s.radiance(b)
        with pytest.raises(tc.TranscutError) as err:
            s.edit_albedo(b, (0.5, 0.5, 0.5))
        assert err.value.status == tc.TC_INVALID_ARGUMENT and "translucent" in str(err.value)
        with pytest.raises(tc.TranscutError) as err:
            s.edit_albedo(r, (0.5, 1.0, 0.5))
        assert err.value.status == tc.TC_INVALID_ARGUMENT and "albedo" in str(err.value)
        np.testing.assert_array_equal(s.radiance(b), before)
        s.edit_albedo(r, (0.7, 0.3, 0.1))
        s.edit_emission(r, 2.0 * EMISSION)
        edited = s.radiance(b), s.radiance(r)
        s.bake(**ROOM_BAKE)
        rebaked = s.radiance(b), s.radiance(r)
    for e, f in zip(edited, rebaked, strict=True):
        np.testing.assert_allclose(e, f, rtol=1e-3, atol=1e-3 * float(np.abs(f).max()))
    assert not np.allclose(edited[0], before, rtol=0.05)


def test_bad_diffuse_input_is_named_and_adds_nothing(tclib, ball):
    s, b, r = room_scene(tclib, ball)
    with s:
        for albedo in ((1.0, 0.5, 0.5), (0.5, float("nan"), 0.5)):
            with pytest.raises(tc.TranscutError) as err:
                s.add_diffuse_mesh(cube(40.0), CUBE_TRIANGLES, albedo)
            assert err.value.status == tc.TC_INVALID_ARGUMENT and "albedo" in err.value.message
        with pytest.raises(ValueError, match="emission must be finite and >= 0"):
            s.add_diffuse_mesh(cube(40.0), CUBE_TRIANGLES, (0.5,) * 3, emission=(0.0, -1.0, 0.0))
        with pytest.raises(ValueError, match="unknown sides 'sideways' \\(known: both, front, back\\)"):
            s.add_diffuse_mesh(cube(40.0), CUBE_TRIANGLES, (0.5,) * 3, sides="sideways")
        with pytest.raises(ValueError, match="unknown sides 3"):
            s.add_diffuse_mesh(cube(40.0), CUBE_TRIANGLES, (0.5,) * 3, sides=3)
        with pytest.raises(ValueError, match="albedo needs 3 values"):
            s.add_diffuse_mesh(cube(40.0), CUBE_TRIANGLES, (0.5, 0.5))
        with pytest.raises(tc.TranscutError) as err:
            s.add_diffuse_mesh(cube(40.0), CUBE_TRIANGLES.reshape(-1)[:35], (0.5,) * 3)
        assert err.value.status == tc.TC_INVALID_MESH
        assert object_count(s) == 2
        # Each kind refuses the other's setters, by name.
        with pytest.raises(tc.TranscutError) as err:
            s.set_albedo(b, (0.5, 0.5, 0.5))
        assert err.value.status == tc.TC_INVALID_ARGUMENT and "translucent" in err.value.message
        with pytest.raises(tc.TranscutError) as err:
            s.set_medium_preset(r, "marble")
        assert "diffuse" in err.value.message and "room" in err.value.message
        with pytest.raises(tc.TranscutError) as err:
            s.set_emission(r, (1.0, float("inf"), 0.0))
        assert err.value.status == tc.TC_INVALID_ARGUMENT and "emission" in err.value.message
        with pytest.raises(ValueError, match="unknown sides"):
            s.set_sides(r, "inside")
        # Only radiosity bakes a diffuse object.
        with pytest.raises(tc.TranscutError) as err:
            s.bake(tets=2000, backend="cpu")
        assert err.value.status == tc.TC_UNSUPPORTED and "radiosity" in err.value.message
        assert "room" in err.value.message


def test_radiosity_options_are_checked(tclib, ball):
    s, _, _ = room_scene(tclib, ball)
    with s:
        with pytest.raises(ValueError, match="patch_size, rays are options of radiosity, not of method 'transcut'"):
            s.bake(patch_size=5.0, rays=64)
        with pytest.raises(ValueError, match="bounces is an option of radiosity, not of method 'hierarchical-dipole'"):
            s.bake(method="hierarchical-dipole", bounces=2)
        with pytest.raises(ValueError, match="theta is an option of hierarchical-dipole, not of method 'radiosity'"):
            s.bake(method="radiosity", theta=0.5)
        with pytest.raises(ValueError, match="options of transcut"):
            s.bake(method="radiosity", edit_solver="pcg")
        with pytest.raises(
            ValueError, match="unknown iteration 'southwell' \\(known: jacobi, gauss-seidel, bicgstab\\)"
        ):
            s.bake(method="radiosity", iteration="southwell")
        for key, value, match in (("rays", -1, r"rays must be in \[0, 2\^32\)"), ("bounces", 2.5, "whole number")):
            with pytest.raises(ValueError, match=match):
                s.bake(method="radiosity", **{key: value})
        # What the binding passes on, the library checks and names (its field names).
        for key, value, field in (
            ("rays", 0, "rays_per_patch = 0"),
            ("patch_size", -1.0, "patch_size_mm"),
            ("radiosity_tolerance", 0.0, "tolerance"),
            ("solver", 99, "solver = 99"),
            ("iteration", 7, "iteration = 7"),
            ("grading", tc.TC_MAX_GRADING_LAYERS + 1, f"grading = {tc.TC_MAX_GRADING_LAYERS + 1}"),
            ("discretization", 7, "discretization = 7"),
        ):
            with pytest.raises(tc.TranscutError) as err:
                s.bake(method="radiosity", tets=2000, **{key: value})
            assert err.value.status == tc.TC_INVALID_ARGUMENT and f"method_options->{field}" in err.value.message
        with pytest.raises(tc.TranscutError) as err:
            s.bake(method="radiosity", tets=2000, iteration="gauss-seidel", bounces=2)
        assert "bounces" in err.value.message and "JACOBI" in err.value.message
        with pytest.raises(tc.TranscutError) as err:
            s.radiosity_stats()
        assert err.value.status == tc.TC_NOT_BAKED


def test_radiosity_stats_after_another_method_are_unsupported(tclib, ball):
    with tclib.scene() as s:
        i = s.add_mesh(*ball)
        s.set_medium_preset(i, "marble")
        s.add_environment((1.0, 1.0, 1.0))
        s.bake(tets=2000, backend="cpu", shadows=0)
        with pytest.raises(tc.TranscutError) as err:
            s.radiosity_stats()
        assert err.value.status == tc.TC_UNSUPPORTED


# -- the add-on ------------------------------------------------------------------------------

RED = (0.8, 0.1, 0.1)
SUN_TILT = math.radians(20.0)
SUN_STRENGTH = 3.0


def principled(name: str, base=RED, metallic: float = 0.0, emission=(0.0, 0.0, 0.0), strength: float = 0.0):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    p = mat.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*base, 1.0)
    p.inputs["Metallic"].default_value = metallic
    p.inputs["Emission Color"].default_value = (*emission, 1.0)
    p.inputs["Emission Strength"].default_value = strength
    return mat


def add_floor(name="Floor", material=None, size=8.0, location=(0.0, 0.0, 0.0)):
    """A 20 × 20 grid (441 vertices) of ``size`` units, normals up, below the test sphere."""
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=20, y_subdivisions=20, size=size, location=location)
    obj = bpy.context.active_object
    obj.name = obj.data.name = name
    if material is not None:
        obj.data.materials.append(material)
    return obj


#: The scene settings these tests change, put back after each (the scene outlives a test).
SETTINGS = (
    "method",
    "attribute_name",
    "radiosity_patch_size",
    "radiosity_rays",
    "radiosity_iteration",
    "radiosity_bounces",
    "radiosity_tolerance",
    "radiosity_write_surroundings",
)


@pytest.fixture
def radiosity_scene(scene):
    """The empty test scene; its TransCut settings are restored afterwards."""
    require_library()
    saved = {name: getattr(scene.transcut, name) for name in SETTINGS}
    yield scene
    for name, value in saved.items():
        setattr(scene.transcut, name, value)


@pytest.fixture
def red_floor(radiosity_scene):
    """The marble sphere 1.2 units above a red floor under a sun tilted 20°, radiosity chosen with
    2.5 mm patches and 256 rays (1 unit = 1 cm); (sphere, floor)."""
    scene = radiosity_scene
    sphere = add_sphere(location=(0.0, 0.0, 1.2))
    floor = add_floor(material=principled("Red"))
    add_light("SUN", rotation=(SUN_TILT, 0.0, 0.0), energy=SUN_STRENGTH)
    settings = scene.transcut
    settings.method = "radiosity"
    settings.radiosity_patch_size = 0.25
    settings.radiosity_rays = 256
    select_only(sphere)
    return sphere, floor


def floor_world(floor) -> np.ndarray:
    pos, _, m, _ = evaluated_arrays(floor)
    return world_points(pos, m)


def far_corners(floor) -> np.ndarray:
    """The floor's vertices farthest from the sphere (over 5 units away in x–y)."""
    xy = floor_world(floor)[:, :2]
    return np.linalg.norm(xy, axis=1) > 5.0


def under_sphere(floor) -> np.ndarray:
    """The floor's vertices in the sphere's shadow (the sun tilted 20° about x: the shadow's
    centre is 1.2 tan 20° from the origin along y)."""
    xy = floor_world(floor)[:, :2]
    centre = np.array([0.0, 1.2 * math.tan(SUN_TILT)])
    return np.linalg.norm(xy - centre, axis=1) < 0.5


def underside(sphere) -> np.ndarray:
    _, _, _, nrm = evaluated_arrays(sphere)
    return nrm[:, 2] < -0.7


def test_surroundings_are_the_visible_unselected_meshes(red_floor, addon):
    """Hidden objects (viewport, render, a collection off in renders) stay out, a mesh shared
    with another baked object lights the bake without being written, every object of the job
    has the scene's one mm_per_unit, and the albedo and emission are read as documented."""
    sphere, floor = red_floor
    wall = add_floor("Wall", principled("Steel", base=(0.6, 0.6, 0.6), metallic=0.5), location=(0.0, 6.0, 4.0))
    wall.rotation_euler = (math.radians(90.0), 0.0, 0.0)
    lamp = add_floor("Lamp", principled("Glow", base=(0.0, 0.0, 0.0), emission=(1.0, 0.5, 0.2), strength=2.0))
    lamp.location = (0.0, 0.0, 6.0)
    grey = add_floor("Plain", location=(9.0, 0.0, 0.0))
    twin = bpy.data.objects.new("Twin", floor.data)  # a linked duplicate of the floor
    bpy.context.scene.collection.objects.link(twin)
    twin.location = (0.0, -9.0, 0.0)
    hidden = add_floor("Hidden", location=(20.0, 0.0, 0.0))
    hidden.hide_set(True)
    unrendered = add_floor("Unrendered", location=(30.0, 0.0, 0.0))
    unrendered.hide_render = True
    off = bpy.data.collections.new("Off")
    bpy.context.scene.collection.children.link(off)
    off.hide_render = True
    offstage = add_floor("Offstage", location=(40.0, 0.0, 0.0))
    for c in list(offstage.users_collection):
        c.objects.unlink(offstage)
    off.objects.link(offstage)
    select_only(sphere)
    job = addon.bake.prepare_job(bpy.context)
    by_name = {d.object_name: d for d in job.diffuse}
    assert sorted(by_name) == ["Floor", "Lamp", "Plain", "Twin", "Wall"]
    assert [m.object_name for m in job.meshes] == [sphere.name]
    (scale,) = {d.mm_per_unit for d in job.diffuse} | {m.mm_per_unit for m in job.meshes}
    assert scale == pytest.approx(10.0)
    np.testing.assert_allclose(by_name["Floor"].albedo, RED)
    np.testing.assert_allclose(by_name["Wall"].albedo, (0.3, 0.3, 0.3))
    np.testing.assert_allclose(by_name["Lamp"].emission, np.pi * 2.0 * np.array([1.0, 0.5, 0.2]))
    assert by_name["Lamp"].albedo == [0.0, 0.0, 0.0] and by_name["Floor"].emission == [0.0, 0.0, 0.0]
    assert by_name["Plain"].albedo == [0.8, 0.8, 0.8] and by_name["Plain"].source.startswith("no material")
    assert [n for n, d in by_name.items() if not d.write] == ["Floor", "Twin"]
    assert any("'Twin': its radiance is not written" in w and "belongs to another" in w for w in job.warnings)
    assert job.options["patch_size"] == pytest.approx(2.5) and job.options["rays"] == 256
    assert job.options["iteration"] == "jacobi" and job.options["tets"] == bpy.context.scene.transcut.tets
    # An albedo at or above 1 (a base colour above 1) is clamped below 1.
    bright = principled("Bright", base=(1.5, 1.0, 0.2))
    grey.data.materials.append(bright)
    job = addon.bake.prepare_job(bpy.context)
    (plain,) = [d for d in job.diffuse if d.object_name == "Plain"]
    assert plain.albedo == [0.999, 0.999, pytest.approx(0.2)]
    # The other methods send no surroundings.
    bpy.context.scene.transcut.method = "transcut"
    assert addon.bake.prepare_job(bpy.context).diffuse == []


def bake_floor(scene, sphere, floor, method: str, attribute: str = "SSS") -> tuple:
    scene.transcut.method = method
    scene.transcut.attribute_name = attribute
    select_only(sphere)
    assert bpy.ops.object.transcut_bake() == {"FINISHED"}
    return attribute_rgb(sphere, attribute).copy(), (
        attribute_rgb(floor, attribute).copy() if attribute in floor.data.attributes else None
    )


def test_the_floor_is_shadowed_and_bleeds_red_onto_the_sphere(red_floor, radiosity_scene, addon):
    """Radiosity writes the floor: in the sphere's shadow it is darker than far away, where it
    is ρ E cos θ / π plus a little from the sphere; the sphere's underside is redder than
    TransCut's (which sees no floor); with Metallic 0.5 the far floor is half as bright."""
    sphere, floor = red_floor
    scene = radiosity_scene
    alone, none = bake_floor(scene, sphere, floor, "transcut")
    assert none is None  # TransCut leaves the floor as it was
    lit, rgb = bake_floor(scene, sphere, floor, "radiosity")
    assert rgb.shape == (len(floor.data.vertices), 3) and np.all(np.isfinite(rgb)) and np.all(rgb >= 0.0)
    far, shadow, down = far_corners(floor), under_sphere(floor), underside(sphere)
    direct = np.array(RED) * SUN_STRENGTH * math.cos(SUN_TILT) / math.pi
    far_mean = rgb[far].mean(axis=0)
    shadow_mean = rgb[shadow].mean(axis=0)
    gain = lit[down].mean(axis=0) / alone[down].mean(axis=0)
    print(
        f"\nfar floor {far_mean} (ρE cos/π {direct}), in the shadow {shadow_mean}; "
        f"underside gain over TransCut {gain}, top {lit[~down].mean(axis=0) / alone[~down].mean(axis=0)}"
    )
    assert far.sum() >= 8 and shadow.sum() >= 4
    np.testing.assert_allclose(far_mean, direct, rtol=0.02)  # measured: 0.3% above
    assert np.all(far_mean >= direct * (1.0 - 0.01))  # the sphere only adds
    assert np.all(shadow_mean < 0.5 * far_mean)
    redder = (lit[down, 0].mean() / lit[down, 1].mean()) / (alone[down, 0].mean() / alone[down, 1].mean())
    print(f"underside R/G, radiosity over TransCut: {redder}")
    # The floor reflects green and blue alike; the sphere alone lets the least blue through, so
    # blue's relative gain says little: red gains more than green.
    assert gain[0] > 10.0 and gain[0] > gain[1]
    assert redder > 2.0

    # Base Color × (1 − Metallic): Metallic 0.5 halves the far floor (the sphere's share aside).
    floor.data.materials[0].node_tree.nodes["Principled BSDF"].inputs["Metallic"].default_value = 0.5
    _, half = bake_floor(scene, sphere, floor, "radiosity", "Half")
    ratio = half[far].mean(axis=0) / far_mean
    print(f"metallic 0.5 / 0: {ratio}")
    np.testing.assert_allclose(ratio, 0.5, rtol=0.01)


def test_report_shows_the_radiosity_statistics(red_floor, addon):
    sphere, floor = red_floor
    job = addon.bake.prepare_job(bpy.context)
    runner = addon.bake.BakeRunner(addon.library.get(), job)
    runner.run_here()
    assert runner.error is None and len(runner.results) == 2
    stats = runner.radiosity
    assert stats["patches"] > stats["translucent_patches"] > 0 and stats["patch_size_mm"] == pytest.approx(2.5)
    summary = addon.operators.OBJECT_OT_transcut_bake._write(None, bpy.context, runner)
    assert f"{stats['patches']} patches ({stats['translucent_patches']} translucent)" in summary
    assert f"{stats['iterations']} sweep(s), estimated error" in summary
    assert "1 surrounding object(s) (1 written)" in summary, summary
    assert "SSS" in floor.data.attributes and "SSS" in sphere.data.attributes


def test_an_emissive_floor_shows_its_colour_times_strength(radiosity_scene, addon):
    """No lights, no world: an emitter of colour c, strength S and albedo 0 lights the sphere
    and has radiance c·S exactly (the add-on sends M = π c S; the library returns M/π)."""
    scene = radiosity_scene
    sphere = add_sphere(location=(0.0, 0.0, 1.2))
    glow = (0.9, 0.6, 0.3)
    floor = add_floor(material=principled("Glow", base=(0.0, 0.0, 0.0), emission=glow, strength=2.5))
    scene.transcut.method = "radiosity"
    scene.transcut.radiosity_rays = 128
    select_only(sphere)
    assert bpy.ops.object.transcut_bake() == {"FINISHED"}
    np.testing.assert_allclose(attribute_rgb(floor), np.broadcast_to(2.5 * np.array(glow), (441, 3)), rtol=1e-5)
    lit = attribute_rgb(sphere)
    assert np.all(lit[underside(sphere)] > 0.0)
    # The same scene with TransCut has nothing to light it.
    scene.transcut.method = "transcut"
    before = snapshot()
    with pytest.raises(RuntimeError, match="no lights"):
        bpy.ops.object.transcut_bake()
    assert snapshot() == before


def test_write_surroundings_off_writes_the_selection_only(red_floor, radiosity_scene):
    sphere, floor = red_floor
    scene = radiosity_scene
    scene.transcut.radiosity_write_surroundings = False
    assert bpy.ops.object.transcut_bake() == {"FINISHED"}
    assert "SSS" in sphere.data.attributes and "SSS" not in floor.data.attributes


def test_a_failed_radiosity_bake_changes_nothing(red_floor, radiosity_scene, addon):
    """A patch size the library refuses (it names the floor and patch_size_mm), a cancel, and the
    editing operators (which cannot edit a radiosity bake) leave every object as it was."""
    sphere, floor = red_floor
    scene = radiosity_scene
    scene.transcut.radiosity_patch_size = 1e-7
    before = snapshot()
    with pytest.raises(RuntimeError, match=r"\(Floor\).*patch_size_mm"):
        bpy.ops.object.transcut_bake()
    assert snapshot() == before
    scene.transcut.radiosity_patch_size = 0.25
    runner = addon.bake.BakeRunner(addon.library.get(), addon.bake.prepare_job(bpy.context))
    runner.cancel()
    runner.run_here()
    assert runner.error.status == addon.transcut.TC_CANCELLED and runner.results is None
    assert snapshot() == before
    select_only(floor, sphere)  # the floor as the cutter
    with pytest.raises(RuntimeError, match="Cut with Object cannot edit a radiosity bake"):
        bpy.ops.transcut.cut_with_object()
    assert snapshot() == before
    with pytest.raises(addon.mesh_export.BakeError, match="Paint Medium cannot edit a radiosity bake"):
        addon.bake.check_editable(bpy.context, "Paint Medium")


def test_panel_and_options_of_radiosity(red_floor, addon):
    """The panel shows radiosity's settings after TransCut's five (Bounces with Jacobi only);
    the bake options carry them, the patch size in mm, and the translucent objects' grading and
    assembly."""
    settings = bpy.context.scene.transcut
    radiosity = [
        "radiosity_patch_size",
        "radiosity_rays",
        "radiosity_iteration",
        "radiosity_bounces",
        "radiosity_tolerance",
        "radiosity_write_surroundings",
    ]
    for iteration, shown in (("JACOBI", radiosity), ("GAUSS_SEIDEL", [n for n in radiosity if "bounces" not in n])):
        settings.radiosity_iteration = iteration
        log = []
        addon.ui.VIEW3D_PT_transcut.draw(type("P", (), {"layout": RecordingLayout(log)})(), bpy.context)
        props = [name for kind, name in log if kind == "prop"]
        assert [n for n in props if n.startswith("radiosity_")] == shown
        assert props.index("tets") < props.index("grading") < props.index("discretization") < props.index("backend")
        assert props.index("backend") < props.index("radiosity_patch_size")
    settings.radiosity_iteration = "JACOBI"
    options = addon.bake.bake_options(settings, "radiosity", 10.0)
    assert options["bounces"] == 0 and options["radiosity_tolerance"] == pytest.approx(1e-3)
    assert (settings.grading, options["grading"], options["discretization"]) == ("AUTO", "auto", "fitted-layer")
    settings.radiosity_bounces = 3
    settings.radiosity_iteration = "GAUSS_SEIDEL"
    options = addon.bake.bake_options(settings, "radiosity", 10.0)
    assert options["iteration"] == "gauss-seidel" and options["bounces"] == 0  # bounces need Jacobi
