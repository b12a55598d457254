"""Preview Bake and Restore Materials: the bake shown as rendered, the originals kept.

A baked marble sphere gets a preview material (its Principled BSDF with no diffuse, subsurface
or transmission base, the bake's attribute as emission at strength 1). Cycles renders it: seen
from above with the sun hidden from the render and no world, the image is the attribute itself
(the pole's pixels equal the pole's vertex within 2%); seen from the side with the sun, the lit
top outshines the bottom. Previewing twice updates the one preview; restoring puts the original
back and removes the preview.
"""

from __future__ import annotations

import math
import os
import tempfile

import bpy
import numpy as np
import pytest

from test_addon import add_light, add_sphere, attribute_rgb, bake, select_only

RESOLUTION = 32


def render(scene, location, rotation) -> np.ndarray:
    """A Cycles render (4 samples, orthographic, transparent film) as linear RGBA (rows from the
    bottom)."""
    data = bpy.data.cameras.new("Preview Camera")
    data.type = "ORTHO"
    data.ortho_scale = 2.4
    camera = bpy.data.objects.new("Preview Camera", data)
    camera.location = location
    camera.rotation_euler = rotation
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 4
    scene.render.film_transparent = True
    scene.render.resolution_x = scene.render.resolution_y = RESOLUTION
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "preview.exr")
        scene.render.filepath = path
        bpy.ops.render.render(write_still=True)
        image = bpy.data.images.load(path)
        pixels = np.array(image.pixels[:], dtype=np.float64).reshape(RESOLUTION, RESOLUTION, 4)
        bpy.data.images.remove(image)
    bpy.data.objects.remove(camera)
    bpy.data.cameras.remove(data)
    return pixels


@pytest.fixture
def baked(scene, lib):
    sphere = add_sphere()
    sun = add_light("SUN", energy=3.0)  # travels along −Z: the top is lit
    select_only(sphere)
    assert bake() == {"FINISHED"}
    return sphere, sun


def test_preview_renders_the_bake_and_restore_puts_the_original_back(baked):
    sphere, sun = baked
    scene = bpy.context.scene
    original = sphere.material_slots[0].material
    rgb = attribute_rgb(sphere).astype(np.float64)
    materials = len(bpy.data.materials)

    assert bpy.ops.transcut.preview_bake() == {"FINISHED"}
    preview = sphere.material_slots[0].material
    assert preview is not original and preview["transcut_preview"] == "SSS"
    assert preview["transcut_original"] == original
    assert len(bpy.data.materials) == materials + 1
    node = preview.node_tree.nodes["Principled BSDF"]
    (link,) = node.inputs["Emission Color"].links
    assert link.from_node.type == "VERTEX_COLOR" and link.from_node.layer_name == "SSS"
    assert node.inputs["Emission Strength"].default_value == 1.0
    assert tuple(node.inputs["Base Color"].default_value) == (0.0, 0.0, 0.0, 1.0)
    assert node.inputs["Subsurface Weight"].default_value == 0.0
    # The original is untouched.
    assert original.node_tree.nodes["Principled BSDF"].inputs["Subsurface Weight"].default_value == 1.0

    # From above, lit by nothing: the pole's pixels are the pole's baked radiance.
    sun.hide_render = True
    top = render(scene, (0.0, 0.0, 5.0), (0.0, 0.0, 0.0))
    positions = np.array([v.co for v in sphere.data.vertices])
    pole = rgb[int(np.argmax(positions[:, 2]))]
    centre = top[RESOLUTION // 2 - 1 : RESOLUTION // 2 + 1, RESOLUTION // 2 - 1 : RESOLUTION // 2 + 1, :3]
    print(f"\npole pixels {centre.reshape(-1, 3).mean(axis=0)}, pole vertex {pole}")
    np.testing.assert_allclose(centre.reshape(-1, 3), np.tile(pole, (4, 1)), rtol=0.02)

    # From the side with the sun: the lit top outshines the bottom.
    sun.hide_render = False
    side = render(scene, (0.0, -5.0, 0.0), (math.pi / 2, 0.0, 0.0))
    luminance = side[..., :3] @ np.array([0.2126, 0.7152, 0.0722])
    covered = side[..., 3] > 0.5
    half = RESOLUTION // 2
    lower, upper = luminance[:half][covered[:half]].mean(), luminance[half:][covered[half:]].mean()
    print(f"side view: upper half {upper:.4f}, lower half {lower:.4f}")
    assert upper > 2.0 * lower

    # A second preview updates the first; restoring removes it.
    assert bpy.ops.transcut.preview_bake() == {"FINISHED"}
    assert sphere.material_slots[0].material == preview and len(bpy.data.materials) == materials + 1
    name = preview.name
    assert bpy.ops.transcut.restore_materials() == {"FINISHED"}
    assert sphere.material_slots[0].material == original
    assert len(bpy.data.materials) == materials and bpy.data.materials.get(name) is None


def test_preview_errors_change_nothing(baked):
    sphere, _ = baked
    bare = add_sphere(location=(3.0, 0.0, 0.0))
    select_only(bare)
    before = [s.material for s in bare.material_slots]
    with pytest.raises(RuntimeError, match="bake first"):
        bpy.ops.transcut.preview_bake()
    assert [s.material for s in bare.material_slots] == before
    with pytest.raises(RuntimeError, match="no selected object shows a bake preview"):
        bpy.ops.transcut.restore_materials()
    select_only(sphere)
    assert bpy.ops.transcut.preview_bake() == {"FINISHED"}
