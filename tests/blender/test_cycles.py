"""The add-on's bake against Cycles' own bake of the same Principled BSDF (issue: the same
inputs, the same look as Cycles).

A sphere of radius 10 mm (an icosphere of 642 vertices, smooth) under one sun, no world. Cycles
bakes the diffuse pass (direct + indirect + colour: since Blender 3.0 the subsurface light is
part of the diffuse passes) with its random walk at 256 samples into a colour attribute; the
add-on bakes the same material with its default reading of the Principled inputs (Cycles').
Over the lit side (n·l > 0.1) the mean colour must agree per channel within the gap between the
two models and the relative RMS difference stay within 15%, for a marble-like material (Random
Walk: marble's colour and diffuse mean free path as Base Color and Subsurface Radius; within 5%)
and a skin-like one (Random Walk (Skin); within 8%). The skin's bound is the diffusion model's
own distance from Cycles' random walk, measured with the solve converged (graded tets, 1.5M):
lit-side mean ratios (1.004, 1.048, 1.068) with TransCut's assembly, (1.005, 1.050, 1.072) with
the fitted one; at 200k uniform tets the paper's assembly read (1.001, 1.030, 1.025) only because
its discretisation error (Lo 7-9% low in skin's blue on the closed-form sphere) cancelled part of
that gap. The former dipole inversion is off by 16-39% on the same marble (asserted, so a
regression to it cannot pass).
"""

from __future__ import annotations

import bpy
import numpy as np
import pytest
from mathutils import Vector

from test_addon import attribute_rgb, evaluated_arrays, select_only

CYCLES_SAMPLES = 256
TETS = 200_000
#: (Base Color, Subsurface Radius in mm, subsurface method).
MATERIALS = {
    "marble": ((0.83, 0.79, 0.75), (8.51, 5.57, 3.95), "RANDOM_WALK"),
    "skin": ((0.80, 0.55, 0.45), (6.0, 2.5, 1.5), "RANDOM_WALK_SKIN"),
}
#: The largest |lit-side mean ratio - 1| per material (module docstring).
MEAN_BOUND = {"marble": 0.05, "skin": 0.08}


def sphere_under_sun(base, radius, method):
    scene = bpy.context.scene
    scene.unit_settings.scale_length = 0.001  # one unit = 1 mm
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=4, radius=10.0)
    obj = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    mat = bpy.data.materials.new("Translucent")
    mat.use_nodes = True
    p = mat.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*base, 1.0)
    p.inputs["Subsurface Weight"].default_value = 1.0
    p.inputs["Subsurface Radius"].default_value = radius
    p.inputs["Subsurface Scale"].default_value = 1.0
    p.subsurface_method = method
    obj.data.materials.append(mat)
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = 3.0
    sun.angle = 0.0
    sun_obj = bpy.data.objects.new("sun", sun)
    sun_obj.rotation_euler = (0.6, 0.3, 0.0)
    scene.collection.objects.link(sun_obj)
    bpy.context.view_layer.update()
    towards_sun = np.array(sun_obj.matrix_world.to_3x3() @ Vector((0.0, 0.0, 1.0)))
    return obj, towards_sun


def cycles_bake(obj) -> np.ndarray:
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = CYCLES_SAMPLES
    scene.cycles.seed = 1
    attr = obj.data.color_attributes.new("Cycles", "FLOAT_COLOR", "POINT")
    obj.data.color_attributes.active_color = attr
    select_only(obj)
    result = bpy.ops.object.bake(type="DIFFUSE", pass_filter={"DIRECT", "INDIRECT", "COLOR"}, target="VERTEX_COLORS")
    assert result == {"FINISHED"}
    return attribute_rgb(obj, "Cycles").astype(np.float64)


def compare(ours, cycles, lit):
    mean = ours[lit].mean(axis=0) / cycles[lit].mean(axis=0)
    rms = np.sqrt(((ours[lit] - cycles[lit]) ** 2).mean(axis=0)) / cycles[lit].mean(axis=0)
    return mean, rms


@pytest.mark.parametrize("name", list(MATERIALS))
def test_bake_looks_like_cycles(scene, lib, name):
    obj, towards_sun = sphere_under_sun(*MATERIALS[name])
    _, _, _, normals = evaluated_arrays(obj)  # object space = world space here
    lit = normals @ towards_sun > 0.1
    assert lit.sum() > 200
    cycles = cycles_bake(obj)
    scene.transcut.tets = TETS
    select_only(obj)
    assert bpy.ops.object.transcut_bake() == {"FINISHED"}
    ours = attribute_rgb(obj).astype(np.float64)
    mean, rms = compare(ours, cycles, lit)
    print(f"\n{name}: lit-side mean ratio {np.round(mean, 3)}, relative RMS {np.round(rms, 3)}")
    assert np.all(np.abs(mean - 1.0) <= MEAN_BOUND[name]), mean
    assert np.all(rms <= 0.15), rms
    if name == "marble":
        obj.transcut.principled_mapping = "DIPOLE"
        assert bpy.ops.object.transcut_bake() == {"FINISHED"}
        dipole, _ = compare(attribute_rgb(obj).astype(np.float64), cycles, lit)
        print(f"marble, dipole inversion: lit-side mean ratio {np.round(dipole, 3)}")
        assert np.all(np.abs(dipole - 1.0) > 0.1), dipole
