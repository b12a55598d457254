"""Live Translucency (``transcut.live_start`` / ``live_stop``): after one PRT precompute the
colour attribute follows the material's subsurface inputs and the lights with no button pressed,
each state equal to a fresh PRT bake of it; what the precompute cannot follow (a moved object)
stops it with the reason, a medium it cannot take (another IOR) is reported and changes nothing.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import bpy, require_library
from test_addon import add_light, add_sphere, attribute_rgb, select_only

#: Small enough for a quick precompute of the 10 mm test sphere (482 vertices), fine enough for
#: its marble (σ′t h ≈ 1.7).
PRT_SETTINGS = dict(method="prt", prt_samples=11, prt_terms=512, prt_keep=False)


@pytest.fixture
def prt_scene(scene):
    """The test scene with the PRT settings; the settings back to their defaults afterwards (the
    scene's settings outlive the test)."""
    for key, value in PRT_SETTINGS.items():
        setattr(scene.transcut, key, value)
    yield scene
    for key in PRT_SETTINGS:
        scene.transcut.property_unset(key)


def fresh_bake(obj, name: str = "Fresh") -> np.ndarray:
    """A PRT bake of ``obj`` as the scene is now, into attribute ``name``."""
    settings = bpy.context.scene.transcut
    kept = settings.attribute_name
    settings.attribute_name = name
    try:
        select_only(obj)
        assert bpy.ops.object.transcut_bake() == {"FINISHED"}
    finally:
        settings.attribute_name = kept
    return attribute_rgb(obj, name)


def test_live_follows_the_material_and_the_lights(prt_scene, addon):
    require_library()
    obj = add_sphere()
    sun = add_light("SUN", rotation=(0.3, 0.2, 0.0), energy=3.0)
    select_only(obj)
    assert bpy.ops.transcut.live_start() == {"FINISHED"}
    assert addon.live.active()
    start = attribute_rgb(obj).copy()
    assert np.all(np.isfinite(start)) and start.max() > 0.0
    np.testing.assert_array_equal(start, fresh_bake(obj))

    node = obj.active_material.node_tree.nodes["Principled BSDF"]
    node.inputs["Subsurface Radius"].default_value = (1.2, 0.9, 0.7)
    bpy.context.view_layer.update()
    edited = attribute_rgb(obj).copy()
    assert not np.array_equal(edited, start), "the radius change reached the attribute"
    np.testing.assert_array_equal(edited, fresh_bake(obj))

    sun.rotation_euler = (0.7, -0.4, 0.0)
    bpy.context.view_layer.update()
    relit = attribute_rgb(obj).copy()
    assert not np.array_equal(relit, edited), "the light move reached the attribute"
    np.testing.assert_array_equal(relit, fresh_bake(obj))

    # Read as Cycles does, the IOR is the specular layer's: the attribute scales by its 1 − F0.
    node.inputs["IOR"].default_value = 1.6
    bpy.context.view_layer.update()
    layer = [1.0 - ((n - 1.0) / (n + 1.0)) ** 2 for n in (1.3, 1.6)]
    np.testing.assert_allclose(attribute_rgb(obj), relit * (layer[1] / layer[0]), rtol=1e-6)
    seen = attribute_rgb(obj).copy()

    # A medium the precompute cannot take (another η: the dipole reading keeps the IOR) is
    # reported; the attribute stays.
    obj.transcut.principled_mapping = "DIPOLE"
    bpy.context.view_layer.update()
    assert addon.live.active() and "eta" in addon.live.status()
    np.testing.assert_array_equal(attribute_rgb(obj), seen)

    assert bpy.ops.transcut.live_stop() == {"FINISHED"}
    assert not addon.live.active()
    obj.transcut.principled_mapping = "CYCLES"
    sun.rotation_euler = (0.1, 0.1, 0.0)
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(attribute_rgb(obj), seen, "nothing changes once stopped")


def test_moving_the_object_stops_live_with_the_reason(prt_scene, addon):
    require_library()
    obj = add_sphere()
    add_light("SUN", rotation=(0.3, 0.2, 0.0), energy=3.0)
    select_only(obj)
    assert bpy.ops.transcut.live_start() == {"FINISHED"}
    obj.location.x += 0.5
    bpy.context.view_layer.update()
    assert not addon.live.active()
    assert "moved or changed shape" in addon.live.status()


def test_live_refuses_what_prt_cannot_bake(prt_scene, addon):
    """A heterogeneous or too dense medium fails the precompute with the library's reason and
    leaves the scene as it was (no attribute, live off)."""
    require_library()
    obj = add_sphere()
    add_light("SUN", rotation=(0.3, 0.2, 0.0), energy=3.0)
    obj.transcut.medium_source = "COEFFICIENTS"
    obj.transcut.sigma_a = (0.01, 0.01, 0.01)
    obj.transcut.sigma_s_prime = (40.0, 40.0, 40.0)
    select_only(obj)
    try:
        bpy.ops.transcut.live_start()
        raise AssertionError("a medium too dense for the samples was accepted")
    except RuntimeError as exc:
        assert "too dense" in str(exc)
    assert not addon.live.active()
    assert "SSS" not in obj.data.attributes


# -- the other methods: a kept bake follows lights, media, placement and shape ---------------


def fresh_transcut(scene, obj) -> np.ndarray:
    """A bake of ``obj`` as the scene is now in a new library scene, into attribute "Fresh"."""
    scene.transcut.keep_bakes = False
    try:
        return fresh_bake(obj)
    finally:
        scene.transcut.keep_bakes = True


def close_to(rgb, expect) -> None:
    np.testing.assert_allclose(rgb, expect, rtol=1e-5, atol=1e-6 * float(expect.max()))


def live_sphere(scene) -> tuple:
    """A sphere under a sun, live with the panel's method (TransCut) at a tight tolerance:
    (sphere, sun)."""
    require_library()
    scene.transcut.tolerance = 1e-10
    obj = add_sphere()
    sun = add_light("SUN", rotation=(0.3, 0.2, 0.0), energy=3.0)
    select_only(obj)
    assert bpy.ops.transcut.live_start() == {"FINISHED"}
    return obj, sun


def test_live_transcut_follows_lights_media_placement_and_shape(scene, addon):
    obj, sun = live_sphere(scene)
    session = addon.live._live.worker.session
    assert isinstance(session, addon.kept_native.KeptLive)
    store = session.store
    close_to(attribute_rgb(obj), fresh_transcut(scene, obj))

    sun.rotation_euler = (0.7, -0.4, 0.0)
    bpy.context.view_layer.update()
    assert (session.outcome, store.relights, store.bakes) == ("relit", 1, 1), "a light move only relights"
    close_to(attribute_rgb(obj), fresh_transcut(scene, obj))

    node = obj.active_material.node_tree.nodes["Principled BSDF"]
    node.inputs["Subsurface Radius"].default_value = (1.2, 0.9, 0.7)
    bpy.context.view_layer.update()
    assert (session.outcome, store.meshed, store.bakes) == ("rebaked", (), 1), "a medium change meshes nothing"
    close_to(attribute_rgb(obj), fresh_transcut(scene, obj))

    obj.location.x += 0.5
    bpy.context.view_layer.update()
    assert addon.live.active(), "a moved object stays live"
    assert (session.outcome, store.meshed) == ("rebaked", (obj.name,))
    close_to(attribute_rgb(obj), fresh_transcut(scene, obj))

    # Edit Mode: strokes cost nothing; leaving it meshes the new shape once.
    updates = session.updates
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.transform.resize(value=(1.1, 1.1, 1.1))
    bpy.context.view_layer.update()
    bpy.ops.transform.resize(value=(1.1, 1.0, 1.0))
    bpy.context.view_layer.update()
    assert session.updates == updates, "no update while editing"
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.context.view_layer.update()
    assert session.updates == updates + 1 and store.meshed == (obj.name,), "one update on leaving Edit Mode"
    close_to(attribute_rgb(obj), fresh_transcut(scene, obj))

    assert bpy.ops.transcut.live_stop() == {"FINISHED"}


def test_live_coalesces_quick_changes(scene, addon):
    """Three light moves asked for while an update runs make at most two solves, the last of
    them the newest state's."""
    obj, sun = live_sphere(scene)
    live = addon.live._live
    states = []
    for angle in (0.5, 0.6, 0.7):
        sun.rotation_euler = (angle, -0.4, 0.0)
        states.append(live.state(scene, bpy.context.evaluated_depsgraph_get()))
    worker = live.worker
    for state in states:
        worker.submit(state)
    worker.wait(60.0)
    results, error = worker.take()
    assert error is None
    assert worker.requested == 3 and worker.applied <= 2, (worker.requested, worker.applied)
    live.write(results)
    close_to(attribute_rgb(obj), fresh_transcut(scene, obj))
    assert bpy.ops.transcut.live_stop() == {"FINISHED"}
