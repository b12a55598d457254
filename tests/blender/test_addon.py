"""The Blender add-on, headless: registration, conversions, errors, bakes against the C ABI.

Bakes are small: 15k tets, a 32×16 UV sphere.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from mathutils import Vector

from conftest import ADDON_MODULE, bpy, disable, enable, require_library

TETS = 15_000
TOL = 1e-6
# A sphere of radius 1 unit at 1 cm per unit (10 mm): marble-like mean free paths of about half
# a millimetre (Subsurface Radius in scene units × Scale, over 4π as Cycles' random walk reads
# it: 0.69, 0.57, 0.49 mm), which the tests' 15k tets resolve.
UNIT_SCALE = 0.01
MM_PER_UNIT = 10.0
ARTIST = dict(albedo=(0.83, 0.79, 0.75), radius=(0.87, 0.72, 0.62), scale=1.0, ior=1.3, anisotropy=0.0)
#: The share of the medium's radiance the Principled BSDF's specular layer lets out along the
#: normal, 1 − F0 with F0 = ((IOR − 1)/(IOR + 1))² (Specular IOR Level 0.5, white tint): the
#: add-on writes the library's radiance times this (the direct ABI bakes return the medium's).
SURFACE = 1.0 - ((ARTIST["ior"] - 1.0) / (ARTIST["ior"] + 1.0)) ** 2


# -- scene builders --------------------------------------------------------------------------


def marble_material(name="Marble", weight=1.0):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    p = mat.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*ARTIST["albedo"], 1.0)
    p.inputs["Subsurface Weight"].default_value = weight
    p.inputs["Subsurface Radius"].default_value = ARTIST["radius"]
    p.inputs["Subsurface Scale"].default_value = ARTIST["scale"]
    p.inputs["IOR"].default_value = ARTIST["ior"]
    p.inputs["Subsurface Anisotropy"].default_value = ARTIST["anisotropy"]
    return mat


def add_sphere(location=(0.0, 0.0, 0.0)):
    bpy.context.scene.unit_settings.scale_length = UNIT_SCALE
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=1.0, location=location)
    obj = bpy.context.active_object
    obj.data.materials.append(marble_material())
    return obj


def add_light(kind, location=(0.0, 0.0, 0.0), rotation=(0.0, 0.0, 0.0), **props):
    data = bpy.data.lights.new(f"{kind.lower()}_light", kind)
    for key, value in props.items():
        setattr(data, key, value)
    obj = bpy.data.objects.new(data.name, data)
    obj.location = location
    obj.rotation_euler = rotation
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.update()
    return obj


def select_only(*objs):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    for o in objs:
        o.select_set(True)
    if objs:
        bpy.context.view_layer.objects.active = objs[0]
    bpy.context.view_layer.update()


def evaluated_arrays(obj):
    """The evaluated mesh (modifiers applied): positions, triangles, world matrix."""
    deps = bpy.context.evaluated_depsgraph_get()
    ob_eval = obj.evaluated_get(deps)
    me = ob_eval.to_mesh()
    try:
        pos = np.empty(len(me.vertices) * 3, np.float32)
        me.vertices.foreach_get("co", pos)
        me.calc_loop_triangles()
        tri = np.empty(len(me.loop_triangles) * 3, np.uint32)
        me.loop_triangles.foreach_get("vertices", tri)
        nrm = np.empty(len(me.vertices) * 3, np.float32)
        me.vertices.foreach_get("normal", nrm)
    finally:
        ob_eval.to_mesh_clear()
    m = np.array([list(r) for r in obj.matrix_world], np.float64)
    return pos.reshape(-1, 3), tri.reshape(-1, 3), m, nrm.reshape(-1, 3)


def attribute_rgb(obj, name="SSS"):
    attr = obj.data.attributes[name]
    assert attr.data_type == "FLOAT_COLOR" and attr.domain == "POINT"
    buf = np.empty(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", buf)
    return buf.reshape(-1, 4)[:, :3]


def snapshot():
    """What a failed bake must leave unchanged: per object its mesh, vertices and attributes."""
    out = {"meshes": sorted(m.name for m in bpy.data.meshes)}
    for o in bpy.data.objects:
        if o.type == "MESH":
            co = np.empty(len(o.data.vertices) * 3, np.float32)
            o.data.vertices.foreach_get("co", co)
            out[o.name] = (
                o.data.name,
                len(o.data.vertices),
                sorted(a.name for a in o.data.attributes),
                co.tobytes(),
                len(o.modifiers),
            )
    return out


def bake():
    return bpy.ops.object.transcut_bake()


def world_points(pos, m):
    return pos.astype(np.float64) @ m[:3, :3].T + m[:3, 3]


def luminance(rgb):
    return rgb @ np.array([0.2126, 0.7152, 0.0722])


def assert_matches_direct(lib, obj, lights, rgb):
    pos, tri, m, _ = evaluated_arrays(obj)
    (ref,) = lib.bake([(pos, tri, m, MM_PER_UNIT, ARTIST)], lights, TETS, TOL)
    ref = ref * SURFACE
    assert rgb.shape == ref.shape
    scale = float(np.abs(ref).max())
    assert scale > 0.0
    np.testing.assert_allclose(rgb, ref, rtol=1e-4, atol=1e-4 * scale)


def assert_lit_side_brighter(obj, towards):
    """Vertices whose world normal faces `towards(point)` outshine those facing away."""
    pos, _, m, nrm = evaluated_arrays(obj)
    wp = world_points(pos, m)
    wn = nrm.astype(np.float64) @ np.linalg.inv(m[:3, :3])
    wn /= np.linalg.norm(wn, axis=1, keepdims=True)
    to_light = towards(wp)
    to_light /= np.linalg.norm(to_light, axis=1, keepdims=True)
    cos = np.sum(wn * to_light, axis=1)
    lum = luminance(attribute_rgb(obj).astype(np.float64))
    lit, far = lum[cos > 0.7].mean(), lum[cos < -0.7].mean()
    assert lit > 2.0 * far, (lit, far)


def check_attribute(obj, expected_vertices):
    rgb = attribute_rgb(obj)
    assert rgb.shape == (expected_vertices, 3)
    assert np.all(np.isfinite(rgb))
    assert np.all(rgb >= 0.0)
    assert obj.data.color_attributes.active_color.name == "SSS"
    return rgb


# -- registration ----------------------------------------------------------------------------


def test_registers_from_source_folder(addon):
    assert addon.__name__ == ADDON_MODULE
    assert "transcut_bake" in dir(bpy.ops.object)
    assert "transcut" in bpy.types.Scene.bl_rna.properties
    assert "transcut" in bpy.types.Object.bl_rna.properties
    assert bpy.context.preferences.addons[ADDON_MODULE].preferences is not None
    assert "UNDO" in addon.operators.OBJECT_OT_transcut_bake.bl_options
    assert bpy.context.scene.transcut.attribute_name == "SSS"


def test_unregister_leaves_nothing_behind(addon):
    names = [
        "OBJECT_OT_transcut_bake",
        "VIEW3D_PT_transcut",
        "TranscutSceneSettings",
        "TranscutObjectSettings",
        "TranscutPreferences",
        "PREFERENCES_OT_transcut_reload_library",
    ]
    assert any(hasattr(bpy.types, n) for n in names)
    menu_func = addon.ui.menu_func
    assert menu_func in bpy.types.VIEW3D_MT_object._dyn_ui_initialize()
    disable()
    for n in names:
        assert not hasattr(bpy.types, n), n
    assert "transcut_bake" not in dir(bpy.ops.object)
    assert "transcut_reload_library" not in dir(bpy.ops.preferences)
    assert "transcut" not in bpy.types.Scene.bl_rna.properties
    assert "transcut" not in bpy.types.Object.bl_rna.properties
    assert menu_func not in bpy.types.VIEW3D_MT_object._dyn_ui_initialize()
    assert ADDON_MODULE not in bpy.context.preferences.addons
    enable()  # and it comes back cleanly
    assert "transcut_bake" in dir(bpy.ops.object)


# -- conversions (no library needed) ---------------------------------------------------------


def test_light_unit_conversions(scene, addon):
    lights = addon.lights
    warnings = []
    sun = add_light("SUN", rotation=(math.radians(30), 0.0, 0.0), energy=3.0, color=(1.0, 0.5, 0.25), angle=0.02)
    (spec,) = lights.convert_light(sun.name, sun.data, sun.matrix_world, warnings)
    assert spec.method == "add_sun"
    np.testing.assert_allclose(spec.kwargs["irradiance"], [3.0, 1.5, 0.75])
    np.testing.assert_allclose(
        spec.kwargs["direction"], [0.0, math.sin(math.radians(30)), -math.cos(math.radians(30))], atol=1e-7
    )
    assert spec.kwargs["angular_diameter_deg"] == pytest.approx(math.degrees(0.02))

    point = add_light("POINT", location=(1.0, 2.0, 3.0), energy=1000.0)
    (spec,) = lights.convert_light(point.name, point.data, point.matrix_world, warnings)
    np.testing.assert_allclose(spec.kwargs["intensity"], [1000.0 / (4.0 * math.pi)] * 3)  # 79.577 W/sr
    np.testing.assert_allclose(spec.kwargs["position"], [1.0, 2.0, 3.0])

    spot = add_light("SPOT", energy=100.0, spot_size=math.radians(60), spot_blend=0.25)
    (spec,) = lights.convert_light(spot.name, spot.data, spot.matrix_world, warnings)
    np.testing.assert_allclose(spec.kwargs["intensity"], [100.0 / (4.0 * math.pi)] * 3)
    assert spec.kwargs["cone_half_angle_deg"] == pytest.approx(30.0)
    np.testing.assert_allclose(spec.kwargs["direction"], [0.0, 0.0, -1.0], atol=1e-12)

    area = add_light("AREA", location=(0.0, 0.0, 2.0), energy=150.0, shape="RECTANGLE", size=1.5, size_y=0.8)
    area.scale = (2.0, 1.0, 1.0)
    bpy.context.view_layer.update()
    (spec,) = lights.convert_light(area.name, area.data, area.matrix_world, warnings)
    # A = (2 × 1.5) × 0.8 = 2.4 world units²; L = P/(π A) = 150/(2.4π) = 19.894.
    np.testing.assert_allclose(spec.kwargs["radiance"], [150.0 / (math.pi * 2.4)] * 3)
    np.testing.assert_allclose(spec.kwargs["half_u"], [1.5, 0.0, 0.0])
    # 4|u×v| = A
    np.testing.assert_allclose(np.cross(spec.kwargs["half_u"], spec.kwargs["half_v"]), [0.0, 0.0, -0.6], rtol=1e-6)

    disk = add_light("AREA", energy=10.0, shape="DISK", size=2.0)
    (spec,) = lights.convert_light(disk.name, disk.data, disk.matrix_world, warnings)
    assert spec.method == "add_disc" and spec.kwargs["radius"] == pytest.approx(1.0)
    np.testing.assert_allclose(spec.kwargs["radiance"], [10.0 / (math.pi * math.pi)] * 3)
    assert warnings == []


def test_world_and_unit_scale_conversions(scene, addon):
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.3, 0.4, 0.5, 1.0)
    bg.inputs["Strength"].default_value = 2.0
    (spec,) = addon.lights.world_lights(world, [])
    assert spec.method == "add_environment"
    np.testing.assert_allclose(spec.kwargs["radiance"], [0.6, 0.8, 1.0])

    obj = add_sphere()
    bpy.context.scene.world = world
    job = addon.bake.prepare_job(bpy.context)
    (mesh,) = job.meshes
    assert mesh.mm_per_unit == pytest.approx(MM_PER_UNIT)  # scale_length 0.01 m × 1000
    assert mesh.medium.method == "set_medium_artist"
    np.testing.assert_allclose(mesh.medium.kwargs["radius"], ARTIST["radius"], rtol=1e-6)
    assert mesh.vertex_count == len(obj.data.vertices)


# -- errors: each reports and changes nothing ------------------------------------------------


def expect_error(match):
    before = snapshot()
    with pytest.raises(RuntimeError, match=match):
        bake()
    assert snapshot() == before


def test_error_non_mesh_selected(scene):
    add_sphere()
    sun = add_light("SUN", energy=3.0)
    select_only(sun)
    expect_error("no mesh object selected")


def test_error_empty_mesh(scene):
    add_light("SUN", energy=3.0)
    obj = bpy.data.objects.new("Empty", bpy.data.meshes.new("Empty"))
    bpy.context.scene.collection.objects.link(obj)
    obj.data.materials.append(marble_material())
    select_only(obj)
    expect_error("no faces")


def test_error_zero_scale(scene):
    add_light("SUN", energy=3.0)
    obj = add_sphere()
    obj.scale = (1.0, 0.0, 1.0)
    select_only(obj)
    expect_error("zero scale")


def test_error_attribute_name_taken(scene):
    add_light("SUN", energy=3.0)
    obj = add_sphere()
    select_only(obj)
    obj.data.attributes.new("SSS", "FLOAT", "FACE")
    expect_error("taken by a FLOAT FACE attribute")


def test_error_library_not_found(scene):
    prefs = bpy.context.preferences.addons[ADDON_MODULE].preferences
    missing = "/nonexistent/transcut/libtranscut.so"
    add_light("SUN", energy=3.0)
    select_only(add_sphere())
    prefs.library_path = missing  # reloads: fails softly
    try:
        import importlib

        state = importlib.import_module(ADDON_MODULE + ".library").state
        assert state.lib is None
        assert state.tried == [(missing, "no such file")]
        expect_error("/nonexistent/transcut/libtranscut.so")
    finally:
        prefs.library_path = ""


# -- bakes compared with the C ABI called directly -------------------------------------------


def test_sun_bake_matches_direct_abi(scene, lib):
    obj = add_sphere()
    sun = add_light("SUN", rotation=(math.radians(40), 0.0, math.radians(20)), energy=3.0, color=(1.0, 0.9, 0.8))
    select_only(obj)
    assert bake() == {"FINISHED"}
    rgb = check_attribute(obj, len(obj.data.vertices))
    direction = np.array(sun.matrix_world.to_3x3() @ Vector((0.0, 0.0, -1.0)))
    irradiance = [3.0 * 1.0, 3.0 * 0.9, 3.0 * 0.8]  # W/m²
    assert_matches_direct(lib, obj, [("sun", (direction, irradiance, math.degrees(sun.data.angle)))], rgb)
    assert_lit_side_brighter(obj, lambda p: np.broadcast_to(-direction, p.shape).copy())


def test_point_light_bake_matches_direct_abi(scene, lib):
    obj = add_sphere()
    add_light("POINT", location=(2.0, -1.5, 2.5), energy=500.0)
    select_only(obj)
    assert bake() == {"FINISHED"}
    rgb = check_attribute(obj, len(obj.data.vertices))
    intensity = [500.0 / (4.0 * math.pi)] * 3  # I = P/(4π) W/sr
    assert_matches_direct(lib, obj, [("point", ((2.0, -1.5, 2.5), intensity))], rgb)
    assert_lit_side_brighter(obj, lambda p: np.array([2.0, -1.5, 2.5]) - p)


def test_area_light_bake_matches_direct_abi(scene, lib):
    obj = add_sphere()
    add_light("AREA", location=(0.0, 0.0, 3.0), energy=300.0, shape="RECTANGLE", size=1.5, size_y=0.8)
    select_only(obj)
    assert bake() == {"FINISHED"}
    rgb = check_attribute(obj, len(obj.data.vertices))
    radiance = [300.0 / (math.pi * 1.5 * 0.8)] * 3  # L = P/(π A), emitting down (−Z)
    rect = ((0.0, 0.0, 3.0), (0.75, 0.0, 0.0), (0.0, -0.4, 0.0), radiance)
    assert_matches_direct(lib, obj, [("rect", rect)], rgb)
    assert_lit_side_brighter(obj, lambda p: np.array([0.0, 0.0, 3.0]) - p)


def test_world_colour_bake_matches_direct_abi(scene, lib):
    obj = add_sphere()
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.3, 0.4, 0.5, 1.0)
    bg.inputs["Strength"].default_value = 2.0
    bpy.context.scene.world = world
    select_only(obj)
    assert bake() == {"FINISHED"}
    rgb = check_attribute(obj, len(obj.data.vertices))
    assert_matches_direct(lib, obj, [("env", ((0.6, 0.8, 1.0),))], rgb)
    # Uniform light on a sphere: every vertex nearly the same.
    lum = luminance(rgb.astype(np.float64))
    assert lum.min() > 0.8 * lum.max()


def test_modifiers_applied(scene, lib):
    bpy.context.scene.unit_settings.scale_length = UNIT_SCALE
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    cube = bpy.context.active_object
    cube.data.materials.append(marble_material())
    mod = cube.modifiers.new("Subdivision", "SUBSURF")
    mod.levels = 2
    sun = add_light("SUN", rotation=(math.radians(30), 0.0, 0.0), energy=3.0)
    select_only(cube)
    pos, tri, m, _ = evaluated_arrays(cube)
    assert len(cube.data.vertices) == 8 and pos.shape[0] == 98
    assert bake() == {"FINISHED"}
    assert len(cube.data.vertices) == 98 and len(cube.modifiers) == 0
    rgb = check_attribute(cube, 98)
    direction = np.array(sun.matrix_world.to_3x3() @ Vector((0.0, 0.0, -1.0)))
    (ref,) = lib.bake(
        [(pos, tri, m, MM_PER_UNIT, ARTIST)], [("sun", (direction, [3.0] * 3, math.degrees(sun.data.angle)))], TETS, TOL
    )
    ref = ref * SURFACE
    np.testing.assert_allclose(rgb, ref, rtol=1e-4, atol=1e-4 * float(np.abs(ref).max()))


def test_rebake_reuses_attribute(scene, lib):
    obj = add_sphere()
    add_light("SUN", energy=3.0)
    select_only(obj)
    assert bake() == {"FINISHED"}
    first = attribute_rgb(obj).copy()
    bpy.context.scene.transcut.attribute_name = "SSS"
    assert bake() == {"FINISHED"}
    assert [a.name for a in obj.data.color_attributes] == ["SSS"]
    np.testing.assert_array_equal(attribute_rgb(obj), first)


# -- progress and cancel ---------------------------------------------------------------------


def test_progress_reported_and_cancel_changes_nothing(scene, addon):
    require_library()
    obj = add_sphere()
    add_light("SUN", energy=3.0)
    select_only(obj)
    ctx = bpy.context
    job = addon.bake.prepare_job(ctx)
    lib = addon.library.get()

    runner = addon.bake.BakeRunner(lib, job)
    reports = []
    record = runner.progress
    runner.progress = lambda stage, f: (reports.append((stage, f)), record(stage, f))[1]
    runner.run_here()
    assert runner.error is None and len(runner.results) == 1
    assert reports and all(0.0 <= f <= 1.0 for _, f in reports)

    before = snapshot()
    runner = addon.bake.BakeRunner(lib, job)
    runner.cancel()  # as ESC does: the library's next progress call returns "cancel"
    runner.start()  # on a worker thread, as the modal operator runs it
    assert runner.wait(timeout=120)
    assert runner.results is None
    assert isinstance(runner.error, addon.transcut.TranscutError)
    assert runner.error.status == addon.transcut.TC_CANCELLED
    assert addon.bake.error_message(runner.error) == "bake cancelled; nothing was changed"
    assert snapshot() == before


def test_grading_and_assembly_settings_reach_the_library(scene, addon):
    """Scene > TransCut > Grading and Assembly are passed to a TransCut bake (and to no other
    method's): their defaults are the library's (automatic, "auto", and fitted with the layer),
    uniform is 0 and graded its cubes per size, and a graded bake with the paper's assembly runs
    and differs from the default one."""
    require_library()
    obj = add_sphere()
    add_light("SUN", rotation=(math.radians(30), 0.0, 0.0), energy=3.0)
    select_only(obj)
    ctx = bpy.context
    lib = addon.library.get()
    settings = ctx.scene.transcut
    assert (settings.grading, settings.grading_layers, settings.discretization) == ("AUTO", 1, "FITTED_LAYER")
    before = (settings.tets, settings.method)

    def run():
        job = addon.bake.prepare_job(ctx)
        (rgb,) = addon.bake.run_job(lib, job, None, [])
        return job.options, rgb

    try:
        settings.tets = 20_000
        options, default = run()
        assert (options["grading"], options["discretization"]) == ("auto", "fitted-layer")
        settings.grading = "UNIFORM"
        assert addon.bake.prepare_job(ctx).options["grading"] == 0
        settings.grading, settings.grading_layers, settings.discretization = "GRADED", 2, "TRANSCUT"
        options, paper = run()
        assert (options["grading"], options["discretization"]) == (2, "transcut")
        assert default.shape == paper.shape and not (default == paper).all()
        assert abs(default.mean() / paper.mean() - 1.0) < 0.05
        settings.method = "hierarchical-dipole"
        assert "grading" not in addon.bake.prepare_job(ctx).options
    finally:
        settings.tets, settings.method = before
        settings.grading, settings.grading_layers, settings.discretization = "AUTO", 1, "FITTED_LAYER"


def test_backend_setting_reaches_the_library(scene, addon):
    """Scene > TransCut > Backend is passed to the bake: CPU solves on the CPU; GPU on the
    adapter there is (lavapipe without a GPU; TRANSCUT_GPU_TESTS=skip skips that part, loudly)
    and agrees with the CPU; Auto agrees too and says where it ran. The operator's report names
    the backend."""
    require_library()
    obj = add_sphere()
    add_light("SUN", rotation=(math.radians(30), 0.0, 0.0), energy=3.0)
    select_only(obj)
    ctx = bpy.context
    lib = addon.library.get()
    settings = ctx.scene.transcut
    assert settings.backend == "AUTO"

    def run(backend):
        settings.backend = backend
        job = addon.bake.prepare_job(ctx)
        assert job.options["backend"] == backend.lower()
        infos = []
        (rgb,) = addon.bake.run_job(lib, job, None, infos)
        return rgb, infos[0]

    cpu, info = run("CPU")
    assert (info.backend, info.device, info.fallback) == ("cpu", "", "")
    scale = float(np.abs(cpu).max())
    auto, info = run("AUTO")
    if info.backend == "cpu":
        assert info.fallback, "auto on the CPU says why"
        np.testing.assert_array_equal(auto, cpu)
    else:
        assert info.device and not info.fallback
        np.testing.assert_allclose(auto, cpu, rtol=0, atol=1e-5 * scale)
    if os.environ.get("TRANSCUT_GPU_TESTS") == "skip":
        print("\n**** TRANSCUT_GPU_TESTS=skip: THE ADD-ON'S GPU BACKEND IS NOT TESTED ****\n")
    else:
        gpu, info = run("GPU")
        assert info.backend == "gpu" and info.device and not info.fallback, info
        np.testing.assert_allclose(gpu, cpu, rtol=0, atol=1e-5 * scale)
        assert addon.bake.backend_summary([info]) == f"GPU: {info.device}"
    settings.backend = "CPU"
    assert bake() == {"FINISHED"}
    np.testing.assert_array_equal(check_attribute(obj, len(obj.data.vertices)), cpu)
    assert addon.bake.backend_summary([addon.bake.BackendInfo("cpu")]) == "CPU"


def test_native_editing_bindings(addon):
    """The binding's editing calls reach the library: bake, cut by a plane, read the piece,
    split, move a piece, relight; errors carry their status."""
    require_library()
    tc = addon.transcut
    lib = tc.load()
    bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=12, radius=10.0)
    obj = bpy.context.active_object
    pos, tri, _, _ = evaluated_arrays(obj)
    bpy.data.objects.remove(obj)
    with lib.scene() as s:
        i = s.add_mesh(pos, tri)
        s.add_sun((0.0, 0.0, -1.0), (3.0, 3.0, 3.0))
        s.bake(tets=2000, shadows=0, backend="cpu")
        with pytest.raises(tc.TranscutError) as err:
            s.cut_plane(i, (0.0, 0.0, -50.0), (0.0, 0.0, 1.0))
        assert err.value.status == tc.TC_NOTHING_LEFT
        s.cut_plane(i, (0.0, 0.0, 4.0), (0.0, 0.0, 1.0))
        assert s.edit_stats(i)["cut"] == 1 and s.piece_count(i) == 1
        p, t, rgb = s.piece_mesh(i, 0)
        assert p.shape == rgb.shape and t.shape[1] == 3 and t.max() < len(p)
        assert p[:, 2].max() <= 4.0 + s.edit_stats(i)["cut_max_distance"] + 1e-4
        assert np.all(np.isfinite(rgb)) and rgb.max() > 0.0
        s.cut_plane(i, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), keep_both=True)
        assert s.piece_count(i) == 2
        lift = np.eye(4)
        lift[2, 3] = 5.0  # row-major, like Blender's Matrix
        p1, _, _ = s.piece_mesh(i, 1)
        s.set_piece_transform(i, 1, lift)
        moved, _, _ = s.piece_mesh(i, 1)
        np.testing.assert_allclose(moved[:, 2], p1[:, 2] + 5.0, atol=1e-5)
        s.clear_lights()
        s.add_environment((1.0, 1.0, 1.0))
        s.relight()
        assert s.edit_stats(i)["pieces_solved"] == 2


# -- media sources and world textures --------------------------------------------------------


def test_environment_texture_sky_lights_the_top(scene, addon):
    require_library()
    obj = add_sphere()
    img = bpy.data.images.new("sky", 64, 32, float_buffer=True)
    px = np.full((32, 64, 4), 1.0, np.float32)
    px[16:, :, :3] = 2.0  # Blender stores rows bottom first: rows 16.. are the upper hemisphere
    px[:16, :, :3] = 0.02
    img.pixels.foreach_set(px.reshape(-1))
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    nodes = world.node_tree.nodes
    tex = nodes.new("ShaderNodeTexEnvironment")
    tex.image = img
    world.node_tree.links.new(tex.outputs["Color"], nodes["Background"].inputs["Color"])
    bpy.context.scene.world = world
    (spec,) = addon.lights.world_lights(world, [])
    assert spec.method == "add_environment_image"
    rgb = spec.kwargs["rgb"]
    assert rgb.shape == (32, 64, 3) and rgb[0, 0, 0] == 2.0 and rgb[-1, 0, 0] == pytest.approx(0.02)  # row 0 = top
    select_only(obj)
    assert bake() == {"FINISHED"}
    check_attribute(obj, len(obj.data.vertices))
    assert_lit_side_brighter(obj, lambda p: np.broadcast_to(np.array([0.0, 0.0, 1.0]), p.shape).copy())


def test_preset_and_coefficient_media(scene, addon):
    require_library()
    # Skin's blue channel on this 10 mm sphere needs about 7.5k tets to be resolved with the
    # default assembly (60k with the paper's, below which the bake is refused as TC_UNRESOLVED).
    scene.transcut.tets = 60_000
    obj = add_sphere()
    add_light("SUN", energy=3.0)
    select_only(obj)
    obj.transcut.medium_source = "PRESET"
    obj.transcut.preset = "skin1"
    (mesh,) = addon.bake.prepare_job(bpy.context).meshes
    assert (mesh.medium.method, mesh.medium.kwargs) == ("set_medium_preset", {"name": "skin1"})
    assert bake() == {"FINISHED"}
    skin = attribute_rgb(obj).copy()
    obj.transcut.medium_source = "COEFFICIENTS"  # the defaults are marble's coefficients
    assert bake() == {"FINISHED"}
    marble = attribute_rgb(obj)
    assert np.all(np.isfinite(skin)) and np.all(np.isfinite(marble))
    # Skin absorbs far more than marble: it comes out darker.
    assert luminance(skin.astype(np.float64)).mean() < 0.9 * luminance(marble.astype(np.float64)).mean()


def test_error_material_without_subsurface(scene):
    add_light("SUN", energy=3.0)
    obj = add_sphere()
    obj.data.materials[0].node_tree.nodes["Principled BSDF"].inputs["Subsurface Weight"].default_value = 0.0
    select_only(obj)
    expect_error("Subsurface Weight 0")
    obj.data.materials.clear()
    expect_error("no material with a Principled BSDF")


def test_two_objects_bake_together(scene, lib):
    a = add_sphere(location=(-1.5, 0.0, 0.0))
    b = add_sphere(location=(1.5, 0.0, 0.0))
    sun = add_light("SUN", rotation=(0.0, math.radians(-90), 0.0), energy=3.0)  # travels along +X
    select_only(a, b)
    assert bake() == {"FINISHED"}
    rgb_a, rgb_b = check_attribute(a, len(a.data.vertices)), check_attribute(b, len(b.data.vertices))
    direction = np.array(sun.matrix_world.to_3x3() @ Vector((0.0, 0.0, -1.0)))
    assert direction[0] > 0.99
    objs = []
    for o in (a, b):
        pos, tri, m, _ = evaluated_arrays(o)
        objs.append((pos, tri, m, MM_PER_UNIT, ARTIST))
    ref_a, ref_b = lib.bake(objs, [("sun", (direction, [3.0] * 3, math.degrees(sun.data.angle)))], TETS, TOL)
    for rgb, ref in ((rgb_a, ref_a * SURFACE), (rgb_b, ref_b * SURFACE)):
        np.testing.assert_allclose(rgb, ref, rtol=1e-4, atol=1e-4 * float(np.abs(ref).max()))
    # Sphere a shadows b's lit side: b gets less light than a.
    assert luminance(rgb_b.astype(np.float64)).mean() < 0.8 * luminance(rgb_a.astype(np.float64)).mean()


def test_error_shared_mesh(scene):
    add_light("SUN", energy=3.0)
    a = add_sphere()
    b = bpy.data.objects.new("Twin", a.data)
    bpy.context.scene.collection.objects.link(b)
    select_only(a, b)
    expect_error("share the mesh")


# -- drawing (headless: a recording layout checks every property and operator drawn) --------


class RecordingLayout:
    """Stands in for UILayout: checks each drawn property and operator exists, records labels."""

    def __init__(self, log):
        self.log = log
        self.use_property_split = False
        self.use_property_decorate = False

    def _child(self, *args, **kwargs):
        return RecordingLayout(self.log)

    box = column = row = split = _child

    def prop(self, data, name, **kwargs):
        assert name in data.bl_rna.properties, f"{type(data).__name__} has no property {name!r}"
        self.log.append(("prop", name))

    def label(self, text="", **kwargs):
        self.log.append(("label", text))

    def operator(self, idname, **kwargs):
        category, name = idname.split(".")
        assert name in dir(getattr(bpy.ops, category)), idname
        self.log.append(("operator", idname))

    def separator(self, **kwargs):
        pass


def test_panels_draw(scene, addon):
    obj = add_sphere()
    select_only(obj)
    panel_cls = addon.ui.VIEW3D_PT_transcut
    for source in ("MATERIAL", "PRESET", "COEFFICIENTS"):
        obj.transcut.medium_source = source
        log = []
        fake = type("P", (), {"layout": RecordingLayout(log)})()
        panel_cls.draw(fake, bpy.context)
        assert ("operator", "object.transcut_bake") in log
        assert ("prop", "tets") in log and ("prop", "attribute_name") in log and ("prop", "backend") in log
        assert ("prop", "grading") in log and ("prop", "discretization") in log  # TransCut's
        assert log.index(("prop", "method")) < log.index(("prop", "tets"))  # TransCut's Resolution
        if source == "COEFFICIENTS":
            assert ("prop", "sigma_s_prime") in log

    prefs = bpy.context.preferences.addons[ADDON_MODULE].preferences
    missing = "/nonexistent/libtranscut.so"
    prefs.library_path = missing
    try:
        log = []
        fake = type("P", (), {"layout": RecordingLayout(log), "library_path": missing, "bl_rna": prefs.bl_rna})()
        addon.preferences.TranscutPreferences.draw(fake, bpy.context)
        # The exact path tried and the reason are on screen.
        assert ("label", f"Tried: {missing}") in log and ("label", "    no such file") in log
        assert ("operator", "preferences.transcut_reload_library") in log
    finally:
        prefs.library_path = ""
