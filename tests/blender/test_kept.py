"""Kept bakes: a rebake after a light or world change only relights the kept library scene;
after a medium change it re-assembles without meshing; after a geometry change it meshes the
changed object only.

A sphere under a sun: the second bake after the sun moved relights (the store counts no new
bake) and equals a fresh bake of the new scene (Keep Bakes off) to the solver's tolerance; a
third with nothing changed reads the kept radiance. Two spheres: a medium change on one bakes
the kept scene again with every tet mesh kept (the library's statistics say so) and equals a
fresh bake exactly; a modifier toggled on one meshes that one only, also exactly. The kept
scene is closed (the library's count of live scenes says so) when its object is deleted and
when the add-on is disabled.
"""

from __future__ import annotations

import bpy
import numpy as np

from conftest import disable, enable
from test_addon import add_light, add_sphere, attribute_rgb, bake, select_only


def fresh(scene) -> np.ndarray:
    scene.transcut.keep_bakes = False
    try:
        assert bake() == {"FINISHED"}
    finally:
        scene.transcut.keep_bakes = True
    return attribute_rgb(bpy.context.active_object).astype(np.float64)


def test_a_light_or_world_change_only_relights(scene, addon):
    store = addon.kept_native.STORE
    store.bakes = store.relights = 0
    scene.transcut.tolerance = 1e-10
    sphere = add_sphere()
    sun = add_light("SUN", rotation=(0.3, 0.2, 0.0), energy=3.0)
    select_only(sphere)
    assert bake() == {"FINISHED"}
    assert (store.bakes, store.relights, len(store)) == (1, 0, 1)

    sun.rotation_euler = (0.7, -0.4, 0.0)
    bpy.context.view_layer.update()
    assert bake() == {"FINISHED"}
    assert (store.bakes, store.relights) == (1, 1), "the light move re-meshed"
    relit = attribute_rgb(sphere).astype(np.float64)
    expect = fresh(scene)
    np.testing.assert_allclose(relit, expect, rtol=1e-5, atol=1e-6 * expect.max())

    world = bpy.data.worlds.new("Sky")
    world.use_nodes = False
    world.color = (0.2, 0.3, 0.5)
    scene.world = world
    bpy.context.view_layer.update()
    assert bake() == {"FINISHED"}
    assert (store.bakes, store.relights) == (1, 2)
    np.testing.assert_allclose(attribute_rgb(sphere), fresh(scene), rtol=1e-5, atol=1e-6 * expect.max())

    assert bake() == {"FINISHED"}  # nothing changed: the kept radiance
    assert (store.bakes, store.relights) == (1, 2)


def add_lib(addon):
    return addon.library.get(addon.preferences.library_path(bpy.context))


def test_a_medium_or_geometry_change_meshes_only_what_changed(scene, addon):
    store = addon.kept_native.STORE
    store.bakes = store.rebakes = store.relights = 0
    live = add_lib(addon).live_scene_count()
    left, right = add_sphere(), add_sphere(location=(3.0, 0.0, 0.0))
    right.data.materials[0] = left.data.materials[0].copy()  # a material of its own
    add_light("SUN", rotation=(0.3, 0.2, 0.0), energy=3.0)
    select_only(left, right)

    def both():
        return [attribute_rgb(o).astype(np.float64) for o in (left, right)]

    def fresh_both():
        fresh(scene)
        return both()

    assert bake() == {"FINISHED"}
    assert (store.bakes, store.rebakes, set(store.meshed)) == (1, 0, {left.name, right.name})
    assert add_lib(addon).live_scene_count() == live + 1

    node = right.active_material.node_tree.nodes["Principled BSDF"]
    node.inputs["Subsurface Radius"].default_value = (1.2, 0.9, 0.7)
    assert bake() == {"FINISHED"}
    assert (store.bakes, store.rebakes, store.meshed) == (1, 1, ()), "a medium change meshed"
    kept = both()
    expect = fresh_both()
    np.testing.assert_array_equal(kept[0], expect[0])
    np.testing.assert_array_equal(kept[1], expect[1])

    left.modifiers.new("Smooth", "SMOOTH")
    bpy.context.view_layer.update()
    assert bake() == {"FINISHED"}
    assert (store.bakes, store.rebakes, store.meshed) == (1, 2, (left.name,)), "only the changed object meshed"
    kept = both()
    expect = fresh_both()
    np.testing.assert_array_equal(kept[0], expect[0])
    np.testing.assert_array_equal(kept[1], expect[1])
    assert (len(store), add_lib(addon).live_scene_count()) == (1, live + 1)

    bpy.data.objects.remove(left)
    bpy.context.view_layer.update()
    assert len(store) == 0, "the deleted object's scene is closed"
    assert add_lib(addon).live_scene_count() == live, "closed in the library too"


def test_disabling_the_add_on_closes_the_kept_scenes(scene, addon):
    store = addon.kept_native.STORE
    live = add_lib(addon).live_scene_count()
    sphere = add_sphere()
    add_light("SUN", energy=3.0)
    select_only(sphere)
    assert bake() == {"FINISHED"}
    assert (len(store), add_lib(addon).live_scene_count()) == (1, live + 1)
    lib = add_lib(addon)
    disable()
    assert len(store) == 0
    assert lib.live_scene_count() == live
    enable()


def panel_labels(addon) -> list:
    from test_addon import RecordingLayout

    log = []
    addon.ui.VIEW3D_PT_transcut.draw(type("P", (), {"layout": RecordingLayout(log)})(), bpy.context)
    return [text for kind, text in log if kind == "label"]


def test_the_panel_shows_the_last_bake(scene, addon):
    sphere = add_sphere()
    sun = add_light("SUN", rotation=(0.3, 0.2, 0.0), energy=3.0)
    select_only(sphere)
    assert not any(t.startswith("Last bake") for t in panel_labels(addon)), "nothing before a bake"
    assert bake() == {"FINISHED"}
    report = sphere.transcut.last_bake
    assert report.valid and report.outcome == "baked" and report.method == "transcut"
    assert report.seconds > 0.0 and 0.5 * scene.transcut.tets < report.tets < 2 * scene.transcut.tets
    assert min(report.iterations) > 0 and report.clamped_vertices == 0 and not report.mesh_reused
    labels = panel_labels(addon)
    assert any(t.startswith("Last bake:") and "baked (transcut)" in t for t in labels), labels
    assert f"{report.tets:,} tets, iterations {'/'.join(str(i) for i in report.iterations)}" in labels
    baked_iterations = tuple(report.iterations)

    sun.rotation_euler = (0.7, -0.4, 0.0)
    bpy.context.view_layer.update()
    assert bake() == {"FINISHED"}
    assert report.outcome == "relit" and min(report.iterations) > 0
    (kept,) = addon.kept_native.STORE._bakes.values()
    relight = kept.scene.edit_stats(kept.indices[0])["iterations"]
    assert list(report.iterations) == relight, "the relight's iterations, not the bake's"
    assert list(baked_iterations) == kept.scene.stats(kept.indices[0])["iterations"]

    # A strongly absorbing medium on a coarse mesh clamps vertices: the panel warns.
    report.clamped_vertices = 7
    assert "7 vertices clamped at 0: raise Resolution" in panel_labels(addon)


def test_undo_redo_and_a_second_scene(scene, addon):
    """Undo takes a bake back and redo brings it again, and the kept scene still serves the
    next press; the same object baked from a second scene with its own sun is relit, not
    meshed again, and equals a fresh bake there."""
    store = addon.kept_native.STORE
    store.bakes = store.rebakes = store.relights = 0
    scene.transcut.tolerance = 1e-10
    sphere = add_sphere()
    add_light("SUN", rotation=(0.3, 0.2, 0.0), energy=3.0)
    select_only(sphere)
    bpy.ops.ed.undo_push(message="before the bake")
    assert bpy.ops.object.transcut_bake("EXEC_DEFAULT", True) == {"FINISHED"}
    baked = attribute_rgb(bpy.data.objects["Sphere"]).copy()
    bpy.ops.ed.undo()
    assert "SSS" not in bpy.data.objects["Sphere"].data.color_attributes, "undo takes the bake back"
    bpy.ops.ed.redo()
    np.testing.assert_array_equal(attribute_rgb(bpy.data.objects["Sphere"]), baked)
    bpy.ops.ed.undo()
    select_only(bpy.data.objects["Sphere"])
    assert bake() == {"FINISHED"}
    assert (store.bakes, store.relights) == (1, 0), "the kept scene served the press after undo"
    np.testing.assert_array_equal(attribute_rgb(bpy.data.objects["Sphere"]), baked)

    sphere, first = bpy.data.objects["Sphere"], bpy.context.scene  # undo made new RNA
    second = bpy.data.scenes.new("Second")
    try:
        second.unit_settings.scale_length = first.unit_settings.scale_length
        for prop in first.transcut.bl_rna.properties:  # the same bake options
            if prop.identifier != "rna_type" and not prop.is_readonly:
                setattr(second.transcut, prop.identifier, getattr(first.transcut, prop.identifier))
        second.collection.objects.link(sphere)
        data = bpy.data.lights.new("second_sun", "SUN")
        data.energy = 5.0
        light = bpy.data.objects.new("second_sun", data)
        light.rotation_euler = (-0.6, 0.4, 0.0)
        second.collection.objects.link(light)
        layer = second.view_layers[0]
        with bpy.context.temp_override(scene=second, view_layer=layer):
            layer.update()
            for o in layer.objects:
                o.select_set(o == sphere, view_layer=layer)
            layer.objects.active = sphere
            assert bake() == {"FINISHED"}
            assert (store.bakes, store.relights) == (1, 1), "the second scene's sun relights the kept bake"
            relit = attribute_rgb(sphere).astype(np.float64)
            assert not np.allclose(relit, baked), "the second scene's light"
            second.transcut.keep_bakes = False
            assert bake() == {"FINISHED"}
            expect = attribute_rgb(sphere).astype(np.float64)
        np.testing.assert_allclose(relit, expect, rtol=1e-5, atol=1e-6 * expect.max())
    finally:
        bpy.data.scenes.remove(second)
