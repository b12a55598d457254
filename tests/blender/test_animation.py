"""The hierarchical dipole in the add-on, headless: the Method menu's dipole in the bake operator,
"Bake Animation" (``transcut.bake_animation``) of a mesh deformed by an armature, the cache it
writes and the ``frame_change_post`` handler that plays it back.

The animated mesh: a UV sphere (32 × 16, 482 vertices) stretched to 0.6 × 0.6 × 1.5 units at
1 cm per unit, skinned to a two-bone armature (weights blended over the middle), its upper bone
bending by 60° over frames 1–10; marble coefficients at η = 1.3, a sun from the side (no angle,
so every bake samples it alike).
"""

from __future__ import annotations

import math
import os
import re
import types

import numpy as np
import pytest
from mathutils import Matrix, Vector

from conftest import bpy, disable, enable, require_library
from test_addon import MM_PER_UNIT, UNIT_SCALE, RecordingLayout, add_light, attribute_rgb, evaluated_arrays, select_only
from test_addon import snapshot as mesh_snapshot

DIPOLE = "hierarchical-dipole"
FRAMES = range(1, 11)
SIGMA_A = (0.0021, 0.0041, 0.0071)
SIGMA_S_PRIME = (2.19, 2.62, 3.00)
CACHE = "transcut_cache"  # not the add-on's constant: the test names the property itself
PROPERTY = "transcut_animation"
#: How close a frame played back from Bake Animation's cache is to a fresh bake of its pose,
#: relative to the peak: the incremental bake refits and relinks the trees of the first pose,
#: the fresh one builds its own; the cache stores float16.
PLAYBACK_TOLERANCE = 1e-2


def add_body():
    """The stretched sphere in marble coefficients (the object settings' defaults at η = 1.3)."""
    bpy.context.scene.unit_settings.scale_length = UNIT_SCALE
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=1.0)
    body = bpy.context.active_object
    body.name = "Body"
    body.data.transform(Matrix.Diagonal((0.6, 0.6, 1.5, 1.0)))
    body.transcut.medium_source = "COEFFICIENTS"
    body.transcut.sigma_a = SIGMA_A
    body.transcut.sigma_s_prime = SIGMA_S_PRIME
    body.transcut.eta = 1.3
    return body


def add_rig(body):
    """A two-bone armature skinning ``body``, the upper bone bending 60° about X over FRAMES."""
    scene = bpy.context.scene
    arm = bpy.data.armatures.new("Rig")
    rig = bpy.data.objects.new("Rig", arm)
    scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    lower = arm.edit_bones.new("lower")
    lower.head, lower.tail = (0.0, 0.0, -1.5), (0.0, 0.0, 0.0)
    upper = arm.edit_bones.new("upper")
    upper.head, upper.tail = (0.0, 0.0, 0.0), (0.0, 0.0, 1.5)
    upper.parent, upper.use_connect = lower, True
    bpy.ops.object.mode_set(mode="OBJECT")
    co = np.empty(len(body.data.vertices) * 3, np.float32)
    body.data.vertices.foreach_get("co", co)
    weight = np.clip((co.reshape(-1, 3)[:, 2] + 0.4) / 0.8, 0.0, 1.0)
    groups = body.vertex_groups.new(name="lower"), body.vertex_groups.new(name="upper")
    for i, w in enumerate(weight):
        if w < 1.0:
            groups[0].add([i], float(1.0 - w), "REPLACE")
        if w > 0.0:
            groups[1].add([i], float(w), "REPLACE")
    body.modifiers.new("Armature", "ARMATURE").object = rig
    bone = rig.pose.bones["upper"]
    bone.rotation_mode = "XYZ"
    bone.rotation_euler = (0.0, 0.0, 0.0)
    bone.keyframe_insert("rotation_euler", frame=FRAMES[0])
    bone.rotation_euler = (math.radians(60.0), 0.0, 0.0)
    bone.keyframe_insert("rotation_euler", frame=FRAMES[-1])
    scene.frame_start, scene.frame_end, scene.frame_step = FRAMES[0], FRAMES[-1], 1
    return rig


@pytest.fixture
def rigged(scene, addon):
    """(body, sun) in a scene whose frame range is FRAMES; the frame range, the armature's data
    and actions and the cache files are gone afterwards."""
    require_library()
    body = add_body()
    add_rig(body)
    sun = add_light("SUN", rotation=(math.radians(70.0), 0.0, math.radians(20.0)), energy=3.0, angle=0.0)
    select_only(body)
    scene.frame_set(FRAMES[0])
    yield body, sun
    clean_animation()


def clean_animation():
    """Removes the cache files, the objects, armatures and actions; the frame range back to 1–250."""
    for obj in bpy.data.objects:
        info = obj.get(PROPERTY)
        if info is not None and os.path.isfile(bpy.path.abspath(info["cache"])):
            os.remove(bpy.path.abspath(info["cache"]))
    scene = bpy.context.scene  # the fixture's may be gone (an undo replaces the data)
    scene.frame_start, scene.frame_end = 1, 250
    scene.frame_set(1)
    for collection in (bpy.data.objects, bpy.data.armatures, bpy.data.actions):
        for item in list(collection):
            collection.remove(item)


@pytest.fixture
def keyed_sun(scene, addon):
    """(body, sun): the body standing still, the sun's strength keyframed from 1 at the first of
    FRAMES to 3 at the last; cleaned up as ``rigged``."""
    require_library()
    body = add_body()
    sun = add_light("SUN", rotation=(math.radians(70.0), 0.0, math.radians(20.0)), energy=1.0, angle=0.0)
    sun.data.keyframe_insert("energy", frame=FRAMES[0])
    sun.data.energy = 3.0
    sun.data.keyframe_insert("energy", frame=FRAMES[-1])
    scene.frame_start, scene.frame_end, scene.frame_step = FRAMES[0], FRAMES[-1], 1
    select_only(body)
    scene.frame_set(FRAMES[0])
    yield body, sun
    clean_animation()
    for light in list(bpy.data.lights):
        bpy.data.lights.remove(light)


def sun_light(sun) -> tuple:
    """The sun as the library takes it, as it is at the current frame: (direction, irradiance,
    angular diameter in degrees)."""
    direction = np.array(sun.matrix_world.to_3x3() @ Vector((0.0, 0.0, -1.0)))
    return direction, [sun.data.energy * c for c in sun.data.color], math.degrees(sun.data.angle)


def fresh_dipole(tclib, obj, sun, **options) -> np.ndarray:
    """A dipole bake (``options``: its own) of ``obj``'s evaluated mesh as it is now (this pose
    alone), through the binding."""
    pos, tri, m, _ = evaluated_arrays(obj)
    with tclib.scene() as s:
        i = s.add_mesh(pos, tri)
        s.set_transform(i, m)
        s.set_scale(i, MM_PER_UNIT)
        s.set_medium(i, SIGMA_A, SIGMA_S_PRIME, 1.3, 0.0)
        s.add_sun(*sun_light(sun))
        s.bake(method=DIPOLE, **options)
        return s.radiance(i)


def cache_of(obj) -> dict:
    info = obj[PROPERTY]
    path = bpy.path.abspath(info["cache"])
    with np.load(path) as data:
        return {"path": path, **{k: data[k] for k in data.files}}


def assert_close_to_peak(rgb, ref, tolerance=PLAYBACK_TOLERANCE):
    peak = float(np.abs(ref).max())
    assert peak > 0.0
    worst = float(np.abs(rgb.astype(np.float64) - ref).max()) / peak
    assert worst <= tolerance, worst


def bake_animation():
    return bpy.ops.transcut.bake_animation()


# -- registration and drawing (no library needed) ----------------------------------------------


def handlers_of(addon) -> list:
    name = addon.animation_ops.transcut_frame_change.__name__
    return [h for h in bpy.app.handlers.frame_change_post if getattr(h, "__name__", "") == name]


def test_registers_the_operator_and_the_handler_and_unregister_removes_them(addon):
    assert "bake_animation" in dir(bpy.ops.transcut)
    assert "UNDO" in addon.animation_ops.TRANSCUT_OT_bake_animation.bl_options
    assert handlers_of(addon) == [addon.animation_ops.transcut_frame_change]
    assert hasattr(addon.animation_ops.transcut_frame_change, "_bpy_persistent")  # kept across file loads
    disable()
    assert handlers_of(addon) == []
    assert "bake_animation" not in dir(bpy.ops.transcut)
    assert not hasattr(bpy.types, "TRANSCUT_OT_bake_animation")
    mod = enable()
    assert len(handlers_of(mod)) == 1


def test_panel_draws_the_dipole_options_and_bake_animation(scene, addon):
    body = add_body()
    select_only(body)
    settings = scene.transcut
    panel = addon.ui.VIEW3D_PT_transcut

    def drawn():
        log = []
        panel.draw(type("P", (), {"layout": RecordingLayout(log)})(), bpy.context)
        return log

    log = drawn()
    assert ("operator", "transcut.bake_animation") in log
    assert ("prop", "tets") in log and ("prop", "dipole_theta") not in log
    settings.method = DIPOLE
    try:
        log = drawn()
        assert ("prop", "dipole_theta") in log and ("prop", "dipole_mode") in log
        assert ("prop", "tets") not in log and ("prop", "backend") not in log
        assert log.index(("prop", "method")) < log.index(("prop", "dipole_theta"))
        for name in ("dipole_oracle", "dipole_rule", "dipole_receivers", "dipole_budget"):
            assert ("prop", name) in log, name
        assert ("prop", "dipole_eps1") not in log and ("prop", "dipole_eps2") not in log
        # The paper oracle shows its thresholds instead of the opening angle; the budget is the
        # incremental mode's.
        settings.dipole_oracle = "PAPER"
        settings.dipole_mode = "RENDER"
        log = drawn()
        assert ("prop", "dipole_eps1") in log and ("prop", "dipole_eps2") in log
        assert ("prop", "dipole_theta") not in log and ("prop", "dipole_budget") not in log
        assert log.index(("prop", "dipole_oracle")) < log.index(("prop", "dipole_eps1"))
        assert ("operator", "transcut.bake_animation") in log and ("operator", "object.transcut_bake") in log
    finally:
        settings.method = "transcut"
        settings.property_unset("dipole_oracle")
        settings.property_unset("dipole_mode")
    items = addon.properties.method_items(settings, bpy.context)
    if DIPOLE in [item[0] for item in items]:
        assert next(item[1] for item in items if item[0] == DIPOLE) == "Hierarchical Dipole"


def test_bake_animation_errors_change_nothing(scene, addon):
    body = add_body()
    scene.frame_set(4)
    select_only()
    before = mesh_snapshot()
    with pytest.raises(RuntimeError, match="select the translucent mesh"):
        bake_animation()
    select_only(body)
    require_library()
    with pytest.raises(RuntimeError, match="no lights"):
        bake_animation()
    assert mesh_snapshot() == before
    assert scene.frame_current == 4 and PROPERTY not in body.keys()
    scene.frame_set(1)


# -- the bake operator with the dipole ---------------------------------------------------------


def test_bake_operator_bakes_with_the_dipole(scene, addon):
    require_library()
    body = add_body()
    sun = add_light("SUN", rotation=(math.radians(40.0), 0.0, 0.0), energy=3.0, angle=0.0)
    select_only(body)
    settings = scene.transcut
    settings.method = DIPOLE
    settings.dipole_theta = 0.5
    settings.dipole_mode = "RENDER"
    try:
        job = addon.bake.prepare_job(bpy.context)
        assert job.options == dict(
            method=DIPOLE, shadows=1, oracle="opening-angle", theta=0.5, rule="gl3", receivers="vertices", mode="render"
        )
        assert bpy.ops.object.transcut_bake() == {"FINISHED"}
    finally:
        settings.method = "transcut"
        settings.property_unset("dipole_theta")
        settings.property_unset("dipole_mode")
    # The same as the binding's bake of the same mesh, medium, sun and options.
    ref = fresh_dipole(addon.library.get(), body, sun, theta=0.5, mode="render")
    np.testing.assert_allclose(attribute_rgb(body), ref, rtol=1e-6, atol=1e-7)
    assert body.data.color_attributes.active_color.name == "SSS"


DIPOLE_SETTINGS = (
    "dipole_theta",
    "dipole_oracle",
    "dipole_eps1",
    "dipole_eps2",
    "dipole_rule",
    "dipole_receivers",
    "dipole_mode",
    "dipole_budget",
)


@pytest.fixture
def dipole_settings(scene):
    """The scene's TransCut settings with the hierarchical dipole chosen; back to the defaults after."""
    scene.transcut.method = DIPOLE
    yield scene.transcut
    scene.transcut.method = "transcut"
    for name in DIPOLE_SETTINGS:
        scene.transcut.property_unset(name)


def panel_bake(addon, body) -> tuple:
    """The bake the panel's settings ask for, through the job the operators make: (radiance,
    the binding's dipole_stats, the job's bake options)."""
    job = addon.bake.prepare_job(bpy.context, [body])
    scene, (index,) = addon.bake.build_scene(addon.library.get(), job)
    with scene:
        scene.bake(**job.options)
        return scene.radiance(index), scene.dipole_stats(index), job.options


def test_the_panels_dipole_options_reach_the_bake(dipole_settings, addon):
    require_library()
    body = add_body()
    add_light("SUN", rotation=(math.radians(40.0), 0.0, 0.0), energy=3.0, angle=0.0)
    select_only(body)
    settings = dipole_settings
    rgb0, stats0, options = panel_bake(addon, body)
    assert options["oracle"] == "opening-angle" and options["budget"] == 0  # incremental, no limit
    assert stats0["receivers"] == 482 and stats0["links"] > stats0["triangles"] == 960
    # A coarser opening angle: fewer links.
    settings.dipole_theta = 0.75
    _, stats, options = panel_bake(addon, body)
    assert options["theta"] == 0.75 and stats["links"] < stats0["links"]
    settings.property_unset("dipole_theta")
    # The paper oracle with its thresholds (and no theta): other links; coarser thresholds, fewer.
    settings.dipole_oracle = "PAPER"
    _, fine, options = panel_bake(addon, body)
    assert "theta" not in options and (options["eps1"], options["eps2"]) == pytest.approx((0.05, 0.05))
    settings.dipole_eps1 = settings.dipole_eps2 = 0.5
    _, coarse, options = panel_bake(addon, body)
    assert options["oracle"] == "paper" and options["eps1"] == options["eps2"] == 0.5
    assert fine["links"] != stats0["links"] and coarse["links"] < fine["links"]
    settings.property_unset("dipole_oracle")
    # Face centroids: one receiver per triangle.
    settings.dipole_receivers = "FACES"
    _, stats, _ = panel_bake(addon, body)
    assert stats["receivers"] == stats["triangles"] == 960
    settings.property_unset("dipole_receivers")
    # The paper's edge rule: the same links, another near field.
    settings.dipole_rule = "PAPER"
    rgb, stats, options = panel_bake(addon, body)
    assert options["rule"] == "paper" and stats["links"] == stats0["links"]
    assert float(np.abs(rgb - rgb0).max()) > 1e-3 * float(rgb0.max())
    settings.property_unset("dipole_rule")
    # Render mode: no budget sent.
    settings.dipole_mode = "RENDER"
    assert "budget" not in panel_bake(addon, body)[2]


def test_the_panels_budget_reaches_the_incremental_updates(dipole_settings, addon):
    """A budget caps the links a deformation relinks: subtrees stay linked to the old pose."""
    require_library()
    body = add_body()
    add_light("SUN", rotation=(math.radians(40.0), 0.0, 0.0), energy=3.0, angle=0.0)
    select_only(body)
    lib = addon.library.get()

    def stale_after_a_stretch(budget: int) -> int:
        dipole_settings.dipole_budget = budget
        job = addon.bake.prepare_job(bpy.context, [body], method=DIPOLE, animated=True)
        assert job.options["mode"] == "incremental" and job.options["budget"] == budget
        baker = addon.animation_native.AnimationBaker(lib, job)
        try:
            mesh = job.meshes[0]
            baker.frame(mesh.positions, mesh.triangles)
            baker.frame(mesh.positions * np.array([1.0, 1.0, 1.3], np.float32), mesh.triangles)
            return baker.scene.dipole_stats(baker.index)["stale_tasks"]
        finally:
            baker.close()

    assert stale_after_a_stretch(0) == 0
    assert stale_after_a_stretch(100) > 0


def test_the_bake_operator_bakes_with_the_panels_paper_oracle_and_face_receivers(dipole_settings, addon):
    require_library()
    body = add_body()
    sun = add_light("SUN", rotation=(math.radians(40.0), 0.0, 0.0), energy=3.0, angle=0.0)
    select_only(body)
    dipole_settings.dipole_oracle = "PAPER"
    dipole_settings.dipole_eps1 = 0.25
    dipole_settings.dipole_eps2 = 0.125
    dipole_settings.dipole_receivers = "FACES"
    dipole_settings.dipole_rule = "PAPER"
    assert bpy.ops.object.transcut_bake() == {"FINISHED"}
    tclib = addon.library.get()
    options = dict(oracle="paper", eps1=0.25, eps2=0.125, receivers="faces", rule="paper", mode="incremental")
    np.testing.assert_allclose(attribute_rgb(body), fresh_dipole(tclib, body, sun, **options), rtol=1e-6, atol=1e-7)
    default = fresh_dipole(tclib, body, sun)
    assert float(np.abs(attribute_rgb(body) - default).max()) > 1e-3 * float(default.max())


# -- Bake Animation ----------------------------------------------------------------------------


def test_bake_animation_plays_back_each_frames_pose(rigged, addon):
    body, sun = rigged
    scene = bpy.context.scene
    assert scene.transcut.dipole_mode == "INCREMENTAL"  # the default: the trees refitted per frame
    scene.frame_set(3)  # the operator comes back here
    before = mesh_snapshot()
    assert bake_animation() == {"FINISHED"}
    assert scene.frame_current == 3
    after = mesh_snapshot()
    assert after["Body"][3] == before["Body"][3] and after["Body"][1] == before["Body"][1]  # vertices kept
    assert len(body.modifiers) == 1  # the armature plays on

    cache = cache_of(body)
    # Unsaved: in the session's temporary folder, named after the object.
    assert os.path.dirname(cache["path"]) == addon.animation_ops._temp_folder
    assert os.path.basename(cache["path"]) == "Body.npz"
    assert body[PROPERTY]["attribute"] == "SSS" and body[PROPERTY]["frames"] == len(FRAMES)
    assert list(cache["frames"]) == list(FRAMES)
    assert cache["radiance"].dtype == np.float16 and cache["radiance"].shape == (len(FRAMES), 482, 3)
    assert list(cache["vertex_counts"]) == [482] * len(FRAMES)
    # The frame it came back to is in the attribute.
    np.testing.assert_array_equal(attribute_rgb(body), cache["radiance"][2].astype(np.float32))

    tclib = addon.library.get()
    shown = {}
    for k in FRAMES:
        scene.frame_set(k)  # the handler writes frame k's radiance
        shown[k] = attribute_rgb(body).copy()
        np.testing.assert_array_equal(shown[k], cache["radiance"][k - FRAMES[0]].astype(np.float32))
        assert_close_to_peak(shown[k], fresh_dipole(tclib, body, sun, theta=scene.transcut.dipole_theta))
    # The bend changes the light: the first and last frames differ by far more than the tolerance.
    first, last = shown[FRAMES[0]], shown[FRAMES[-1]]
    assert float(np.abs(last - first).max()) > 10.0 * PLAYBACK_TOLERANCE * float(first.max())


def test_the_modal_run_equals_the_synchronous_one(rigged, addon):
    """The modal path (each frame evaluated at a timer tick, its library part on a worker thread,
    ``step``) bakes the same frames as ``execute``'s loop, bit for bit."""
    body, _ = rigged
    ctx = bpy.context
    ops = addon.animation_ops
    lib = addon.library.get()
    job = addon.bake.prepare_job(ctx, [body], method=DIPOLE, animated=True)

    def run(modal: bool) -> list:
        runner = ops.AnimationRunner(lib, job, list(FRAMES), (1, 0.0))
        try:
            if modal:
                runner.start()
                for _ in range(100_000):
                    runner.step(ctx)
                    if runner.done():
                        break
                    runner.wait(0.01)
            else:
                runner.run_here()
        finally:
            runner.close()
        assert runner.error is None and runner.done()
        assert runner.baked_frames == list(FRAMES) and runner.baker.bakes == 1
        return runner.radiance

    for a, b in zip(run(False), run(True), strict=True):
        np.testing.assert_array_equal(a, b)
    ctx.scene.frame_set(1)


@pytest.mark.parametrize("where", ["before the frame", "inside the library call"])
def test_a_cancel_keeps_the_frames_before_and_leaves_the_mesh(rigged, addon, monkeypatch, where):
    body, sun = rigged
    scene = bpy.context.scene
    runner_cls = addon.animation_ops.AnimationRunner
    record = runner_cls.progress
    stages = []

    def cancelling(self, stage, fraction):
        stages.append(stage)
        at_five = stage.startswith("frame 5 ")
        if where == "inside the library call":
            at_five = at_five and ":" in stage  # "frame 5 (5/10): <the library's stage>"
        return record(self, stage, fraction) or at_five

    monkeypatch.setattr(runner_cls, "progress", cancelling)
    # What was there before: a colour the bake never writes, at frame 2.
    attr = body.data.color_attributes.new("SSS", "FLOAT_COLOR", "POINT")
    attr.data.foreach_set("color", np.full(len(body.data.vertices) * 4, 0.5, np.float32))
    scene.frame_set(2)
    before = mesh_snapshot()
    with pytest.raises(
        RuntimeError, match=r"cancelled at frame 5; frames 1–4 \(4\) kept in .*the mesh was not changed"
    ):
        bake_animation()
    assert any(s.startswith("frame 5 (5/10): ") for s in stages) == (where == "inside the library call")
    assert not any(s.startswith("frame 6") for s in stages)
    # The mesh is untouched, and the frame is back where it was.
    assert scene.frame_current == 2
    assert mesh_snapshot() == before
    np.testing.assert_array_equal(attribute_rgb(body), 0.5)
    # The frames before the cancel are kept, and the timeline plays them.
    cache = cache_of(body)
    assert list(cache["frames"]) == [1, 2, 3, 4] and cache["radiance"].shape == (4, 482, 3)
    scene.frame_set(3)
    played = attribute_rgb(body).copy()
    np.testing.assert_array_equal(played, cache["radiance"][2].astype(np.float32))
    assert_close_to_peak(played, fresh_dipole(addon.library.get(), body, sun, theta=scene.transcut.dipole_theta))
    scene.frame_set(7)  # not baked: the attribute stays as it was
    np.testing.assert_array_equal(attribute_rgb(body), played)


def test_a_failure_keeps_the_frames_before_and_leaves_the_mesh(rigged, addon, monkeypatch):
    body, _ = rigged
    scene = bpy.context.scene
    runner_cls = addon.animation_ops.AnimationRunner
    evaluate = runner_cls._evaluate

    def failing(self, context, frame):
        if frame == 6:
            raise addon.mesh_export.BakeError("the pose of frame 6 is broken")
        return evaluate(self, context, frame)

    monkeypatch.setattr(runner_cls, "_evaluate", failing)
    before = mesh_snapshot()
    with pytest.raises(RuntimeError, match=r"frame 6 is broken \(at frame 6\); frames 1–5 \(5\) kept in .*not changed"):
        bake_animation()
    assert mesh_snapshot() == before and "SSS" not in body.data.attributes
    assert scene.frame_current == FRAMES[0]
    assert list(cache_of(body)["frames"]) == [1, 2, 3, 4, 5]
    scene.frame_set(2)
    assert "SSS" in body.data.attributes  # the timeline plays the frames kept


def test_undo_takes_back_the_attribute_and_the_property(rigged, addon):
    bpy.ops.ed.undo_push(message="before the animation bake")
    # As from the UI: a script's operator call pushes an undo step only when asked to.
    assert bpy.ops.transcut.bake_animation("EXEC_DEFAULT", True) == {"FINISHED"}
    body = bpy.data.objects["Body"]
    assert PROPERTY in body.keys() and "SSS" in body.data.attributes
    path = cache_of(body)["path"]
    bpy.ops.ed.undo()
    body = bpy.data.objects["Body"]
    assert PROPERTY not in body.keys() and "SSS" not in body.data.attributes
    bpy.ops.ed.redo()
    body = bpy.data.objects["Body"]
    assert PROPERTY in body.keys() and "SSS" in body.data.attributes
    assert cache_of(body)["path"] == path


def test_the_handler_leaves_other_attributes_and_vertex_counts_alone(rigged, addon):
    body, _ = rigged
    scene = bpy.context.scene
    assert bake_animation() == {"FINISHED"}
    ops = addon.animation_ops
    assert ops.apply_frame(body, 4)
    # Another kind of attribute under the name: not overwritten.
    name = body[PROPERTY]["attribute"]
    body.data.attributes.remove(body.data.attributes[name])
    body.data.attributes.new(name, "FLOAT", "FACE")
    assert not ops.apply_frame(body, 5)
    assert body.data.attributes[name].data_type == "FLOAT"
    body.data.attributes.remove(body.data.attributes[name])
    # A missing attribute is made (and made active); a frame not baked writes nothing.
    assert ops.apply_frame(body, 5) and body.data.color_attributes.active_color.name == name
    assert not ops.apply_frame(body, 99)
    # A cache of another vertex count than the mesh's is not shown.
    path = cache_of(body)["path"]
    ops.animation_native.write_cache(path, [5], [np.ones((10, 3), np.float32)], body.name, name)
    ops._memo.pop(path, None)
    kept = attribute_rgb(body).copy()
    scene.frame_set(5)
    np.testing.assert_array_equal(attribute_rgb(body), kept)


def test_the_baker_bakes_again_when_the_topology_changes(addon):
    """animation_native.AnimationBaker (no bpy): frames of the same topology move the bake's
    vertices; another vertex count or other triangles make a new bake, which equals a fresh one."""
    require_library()
    from test_dipole import icosphere

    native, mesh_export, lights = addon.animation_native, addon.mesh_export, addon.lights
    lib = addon.library.get()
    coarse, fine = icosphere(10.0, 2), icosphere(10.0, 3)
    medium = mesh_export.MediumSpec(
        "set_medium", dict(sigma_a=SIGMA_A, sigma_s_prime=SIGMA_S_PRIME, eta=1.3, g=0.0), "coefficients"
    )
    mesh = mesh_export.MeshJob("ball", coarse[0], coarse[1], np.eye(4), 1.0, medium, len(coarse[0]), False)
    sky = lights.LightSpec("add_environment", dict(radiance=(1.0, 1.0, 1.0)), "sky")
    job = addon.bake.BakeJob([mesh], [sky], dict(method=DIPOLE, shadows=0, mode="incremental"), "SSS")
    baker = native.AnimationBaker(lib, job)
    try:
        baker.frame(*coarse)
        assert baker.bakes == 1
        stretched = coarse[0] * np.array([1.0, 1.0, 1.3], np.float32)
        moved = baker.frame(stretched, coarse[1])
        assert baker.bakes == 1 and moved.shape == (len(coarse[0]), 3)
        baker.frame(coarse[0], coarse[1][::-1].copy())  # the same count, other triangles
        assert baker.bakes == 2
        rgb = baker.frame(*fine)
        assert baker.bakes == 3 and rgb.shape == (len(fine[0]), 3)
        fresh = native.AnimationBaker(lib, job)
        try:
            np.testing.assert_array_equal(fresh.frame(*fine), rgb)
        finally:
            fresh.close()
        # A cancelled frame leaves the bake at the last frame that succeeded.
        with pytest.raises(addon.transcut.TranscutError) as err:
            baker.frame(fine[0] * 1.2, fine[1], lambda stage, f: True)
        assert err.value.status == addon.transcut.TC_CANCELLED
        np.testing.assert_array_equal(baker.scene.radiance(baker.index), rgb)
    finally:
        baker.close()


def test_cache_files_round_trip(addon, tmp_path):
    native = addon.animation_native
    a = np.random.default_rng(1).random((6, 3)).astype(np.float32)
    b = np.random.default_rng(2).random((4, 3)).astype(np.float32)
    path = str(tmp_path / "sub" / "x.npz")
    native.write_cache(path, [3, 4], [a, b], "x", "SSS")
    assert os.listdir(tmp_path / "sub") == ["x.npz"]  # no temporary file left
    cache = native.read_cache(path)
    assert list(cache.frames) == [3, 4] and list(cache.vertex_counts) == [6, 4]
    assert (cache.object_name, cache.attribute) == ("x", "SSS")
    np.testing.assert_array_equal(cache.frame(3), a.astype(np.float16).astype(np.float32))
    np.testing.assert_array_equal(cache.frame(4), b.astype(np.float16).astype(np.float32))
    assert cache.frame(5) is None
    np.savez(str(tmp_path / "other.npz"), frames=np.arange(3))
    with pytest.raises(KeyError):
        native.read_cache(str(tmp_path / "other.npz"))


# -- animated lights ---------------------------------------------------------------------------

#: float16's smallest subnormal step: below 2^-14 the cache's values are this far apart, so the
#: relative tolerance alone cannot hold there.
FLOAT16_STEP = 2.0**-24
#: float16 keeps 11 bits: a cached value is within 2^-11 (4.9e-4) of what was baked.
CACHE_RTOL = 2e-3


def test_bake_animation_follows_a_keyframed_sun(keyed_sun, addon):
    """A static mesh under a sun whose strength is keyframed 1 → 3: each frame's cached radiance
    is the bake of that frame's sun (the operator starts at frame 5, where the sun is neither)."""
    body, sun = keyed_sun
    scene = bpy.context.scene
    scene.frame_set(5)
    assert bake_animation() == {"FINISHED"}
    cache = cache_of(body)
    assert list(cache["frames"]) == list(FRAMES)
    tclib = addon.library.get()
    energies = []
    for k in FRAMES:
        scene.frame_set(k)
        energies.append(sun.data.energy)
        single = fresh_dipole(tclib, body, sun)
        np.testing.assert_allclose(
            cache["radiance"][k - FRAMES[0]].astype(np.float32), single, rtol=CACHE_RTOL, atol=FLOAT16_STEP
        )
    assert energies[0] == pytest.approx(1.0) and energies[-1] == pytest.approx(3.0)
    assert len(set(energies)) == len(FRAMES)  # every frame its own strength
    # The dipole is linear in the light: the last frame is three times the first.
    first, last = (cache["radiance"][i].astype(np.float64) for i in (0, -1))
    lit = first > 1e-3 * first.max()
    np.testing.assert_allclose(last[lit] / first[lit], 3.0, rtol=2 * CACHE_RTOL)


def test_bake_animation_follows_a_turning_recoloured_sun_on_a_deforming_mesh(rigged, addon):
    """The sun turns and changes colour while the mesh bends: each frame relights and deforms,
    and is the bake of its own pose under its own sun."""
    body, sun = rigged
    scene = bpy.context.scene
    sun.keyframe_insert("rotation_euler", frame=FRAMES[0])
    sun.data.keyframe_insert("color", frame=FRAMES[0])
    sun.rotation_euler = (math.radians(30.0), 0.0, math.radians(-60.0))
    sun.data.color = (1.0, 0.4, 0.2)
    sun.keyframe_insert("rotation_euler", frame=FRAMES[-1])
    sun.data.keyframe_insert("color", frame=FRAMES[-1])
    scene.frame_set(FRAMES[0])
    assert bake_animation() == {"FINISHED"}
    cache = cache_of(body)
    tclib = addon.library.get()
    for k in FRAMES:
        scene.frame_set(k)
        assert_close_to_peak(cache["radiance"][k - FRAMES[0]], fresh_dipole(tclib, body, sun))
    # The colour reached the bake: red over blue grows from the first frame to the last.
    first, last = cache["radiance"][0].astype(np.float64), cache["radiance"][-1].astype(np.float64)
    assert last[:, 0].sum() / last[:, 2].sum() > 3.0 * first[:, 0].sum() / first[:, 2].sum()


def test_the_baker_relights_only_when_the_lights_change(addon):
    """animation_native.AnimationBaker (no bpy): a frame with other lights relights the bake
    before moving its vertices and equals a fresh bake of that pose and light; the same lights
    again do not relight."""
    require_library()
    from test_dipole import icosphere

    native, mesh_export, lights = addon.animation_native, addon.mesh_export, addon.lights
    lib = addon.library.get()
    pos, tri = icosphere(10.0, 3)
    medium = mesh_export.MediumSpec(
        "set_medium", dict(sigma_a=SIGMA_A, sigma_s_prime=SIGMA_S_PRIME, eta=1.3, g=0.0), "coefficients"
    )
    mesh = mesh_export.MeshJob("ball", pos, tri, np.eye(4), 1.0, medium, len(pos), False)

    def sun(irradiance: float, direction=(0.0, -1.0, -1.0)) -> list:
        return [lights.LightSpec("add_sun", dict(direction=list(direction), irradiance=[irradiance] * 3), "sun")]

    job = addon.bake.BakeJob([mesh], sun(1.0), dict(method=DIPOLE, shadows=1, mode="incremental"), "SSS")

    def fresh(positions, light) -> np.ndarray:
        baker = native.AnimationBaker(lib, job)
        try:
            return baker.frame(positions, tri, lights=light)
        finally:
            baker.close()

    baker = native.AnimationBaker(lib, job)
    try:
        first = baker.frame(pos, tri)  # the job's lights
        assert (baker.bakes, baker.relights) == (1, 0)
        assert native.same_lights(baker.lights, sun(1.0))
        again = baker.frame(pos, tri, lights=sun(1.0))  # equal lights from another gathering
        assert baker.relights == 0
        np.testing.assert_allclose(again, first, rtol=1e-6, atol=1e-9)
        brighter = baker.frame(pos, tri, lights=sun(2.5))
        assert (baker.bakes, baker.relights) == (1, 1)
        np.testing.assert_allclose(brighter, 2.5 * first, rtol=1e-5, atol=1e-9)
        # Moved and lit from elsewhere at once: the fresh bake of that pose under that sun.
        stretched = pos * np.array([1.0, 1.0, 1.3], np.float32)
        turned = sun(2.0, (1.0, 0.0, -1.0))
        moved = baker.frame(stretched, tri, lights=turned)
        assert (baker.bakes, baker.relights) == (1, 2)
        assert_close_to_peak(moved, fresh(stretched, turned), tolerance=2e-3)
        # A cancelled relight leaves the bake lit as it was, and the next frame relights even
        # under the bake's own lights (the library holds its results back until a relight).
        with pytest.raises(addon.transcut.TranscutError) as err:
            baker.frame(stretched, tri, lambda stage, f: True, lights=sun(5.0))
        assert err.value.status == addon.transcut.TC_CANCELLED
        assert native.same_lights(baker.lights, turned) and baker.relights == 2
        np.testing.assert_allclose(baker.frame(stretched, tri, lights=turned), moved, rtol=1e-6, atol=1e-9)
        assert baker.relights == 3
        np.testing.assert_allclose(
            baker.frame(stretched, tri, lights=sun(4.0, (1.0, 0.0, -1.0))), 2.0 * moved, rtol=1e-5, atol=1e-9
        )
    finally:
        baker.close()


# -- a re-bake that stops keeps the previous cache ---------------------------------------------


class ModalStub:
    """Stands in for the operator instance, which only Blender makes, to drive
    ``transcut.bake_animation`` through its modal path headless: the operator class's own
    ``_runner_for``, ``modal`` (timer ticks and ESC), ``_end_ui``, ``_finish`` and ``_failure``,
    bound to this object, whose ``report`` records."""

    def __init__(self, op_cls):
        self.reports: list = []
        self._runner = None
        self._timer = None
        self.what = op_cls.what
        for name in ("_runner_for", "modal", "_end_ui", "_finish", "_failure"):
            setattr(self, name, types.MethodType(getattr(op_cls, name), self))

    def report(self, kind, text):
        self.reports.append((set(kind), text))

    def run(self, context, escape_after: int | None = None) -> set:
        """Starts as ``invoke`` does (no window: no timer), then sends timer ticks, and ESC once
        ``escape_after`` frames are baked, until the operator is done."""
        runner = self._runner = self._runner_for(context)
        runner.start()
        tick = types.SimpleNamespace(type="TIMER", value="NOTHING")
        esc = types.SimpleNamespace(type="ESC", value="PRESS")
        for _ in range(1_000_000):
            if escape_after is not None and len(runner.baked_frames) >= escape_after and not runner.cancelled:
                assert self.modal(context, esc) == {"RUNNING_MODAL"}
                assert runner.cancelled  # the flag ESC sets
            result = self.modal(context, tick)
            if result != {"RUNNING_MODAL"}:
                return result
            runner.wait(0.005)
        raise AssertionError("the modal run did not finish")


def cache_files(path: str) -> list:
    return sorted(os.listdir(os.path.dirname(path)))


def test_esc_during_a_rebake_keeps_the_previous_cache(rigged, addon):
    body, sun = rigged
    scene = bpy.context.scene
    ops = addon.animation_ops
    assert bake_animation() == {"FINISHED"}
    old = cache_of(body)
    old_property = body[PROPERTY].to_dict()
    files = cache_files(old["path"])
    # A re-bake under a brighter sun would cache other values: a mix would show.
    sun.data.energy = 6.0
    scene.frame_set(2)
    stub = ModalStub(ops.TRANSCUT_OT_bake_animation)
    assert stub.run(bpy.context, escape_after=4) == {"CANCELLED"}
    assert 4 <= len(stub._runner.baked_frames) < len(FRAMES)  # stopped part way
    (kind, text) = stub.reports[-1]
    assert kind == {"ERROR"}
    assert re.search(r"animation bake cancelled at frame \d+; previous cache kept \(frames 1–10 \(10\) in ", text), text
    assert "were discarded and the mesh was not changed" in text
    # The cache, its property and its folder as they were; the timeline plays the old frames.
    now = cache_of(body)
    assert now["path"] == old["path"] and cache_files(old["path"]) == files
    for key in ("frames", "vertex_counts", "radiance"):
        np.testing.assert_array_equal(now[key], old[key])
    assert body[PROPERTY].to_dict() == old_property
    assert scene.frame_current == 2 and body.name not in ops._suspended
    scene.frame_set(7)
    np.testing.assert_array_equal(attribute_rgb(body), old["radiance"][6].astype(np.float32))
    # A re-bake that finishes replaces the cache: twice the old one under twice the sun.
    assert bake_animation() == {"FINISHED"}
    new = cache_of(body)
    assert new["path"] == old["path"] and cache_files(old["path"]) == files
    np.testing.assert_allclose(
        new["radiance"].astype(np.float64), 2.0 * old["radiance"].astype(np.float64), rtol=CACHE_RTOL, atol=FLOAT16_STEP
    )


def test_a_failed_rebake_keeps_the_previous_cache(rigged, addon, monkeypatch):
    body, _ = rigged
    runner_cls = addon.animation_ops.AnimationRunner
    assert bake_animation() == {"FINISHED"}
    old = cache_of(body)
    evaluate = runner_cls._evaluate

    def failing(self, context, frame):
        if frame == 6:
            raise addon.mesh_export.BakeError("the pose of frame 6 is broken")
        return evaluate(self, context, frame)

    monkeypatch.setattr(runner_cls, "_evaluate", failing)
    with pytest.raises(RuntimeError, match=r"frame 6 is broken \(at frame 6\); previous cache kept \(frames 1–10"):
        bake_animation()
    now = cache_of(body)
    np.testing.assert_array_equal(now["frames"], old["frames"])
    np.testing.assert_array_equal(now["radiance"], old["radiance"])


def test_a_cancel_flag_set_between_frames_keeps_the_previous_cache(rigged, addon, monkeypatch):
    """The flag ESC sets (``runner.cancel()``), set on the synchronous path after frame 3."""
    body, sun = rigged
    runner_cls = addon.animation_ops.AnimationRunner
    assert bake_animation() == {"FINISHED"}
    old = cache_of(body)
    record = runner_cls._record

    def cancel_after_three(self, frame, rgb):
        record(self, frame, rgb)
        if len(self.baked_frames) == 3:
            self.cancel()

    monkeypatch.setattr(runner_cls, "_record", cancel_after_three)
    sun.data.energy = 6.0
    with pytest.raises(RuntimeError, match=r"cancelled at frame 4; previous cache kept \(frames 1–10 \(10\)"):
        bake_animation()
    np.testing.assert_array_equal(cache_of(body)["radiance"], old["radiance"])
