"""Kept bakes: a rebake after a light or world change only relights the kept library scene.

A sphere under a sun: the second bake after the sun moved relights (the store counts no new
bake) and equals a fresh bake of the new scene (Keep Bakes off) to the solver's tolerance; a
third with nothing changed reads the kept radiance; a medium change or a modifier toggled bakes
afresh; the kept scene is closed when its object is deleted and when the add-on is disabled.
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

    node = sphere.active_material.node_tree.nodes["Principled BSDF"]
    node.inputs["Subsurface Radius"].default_value = (1.2, 0.9, 0.7)
    assert bake() == {"FINISHED"}
    assert store.bakes == 2, "a medium change bakes afresh"
    sphere.modifiers.new("Smooth", "SMOOTH")
    bpy.context.view_layer.update()
    assert bake() == {"FINISHED"}
    assert store.bakes == 3, "a geometry change bakes afresh"
    assert len(store) == 1

    bpy.data.objects.remove(sphere)
    bpy.context.view_layer.update()
    assert len(store) == 0, "the deleted object's scene is closed"


def test_disabling_the_add_on_closes_the_kept_scenes(scene, addon):
    store = addon.kept_native.STORE
    sphere = add_sphere()
    add_light("SUN", energy=3.0)
    select_only(sphere)
    assert bake() == {"FINISHED"}
    assert len(store) == 1
    disable()
    assert len(store) == 0
    enable()
