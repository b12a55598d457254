"""Bake Texture: the bake into an image through the UV map.

A UV sphere (Blender's primitive, with its UV map) under a sun: the texture sampled bilinearly
at each vertex's UV (where the four texels around it lie on the surface) equals the per-vertex
bake within 1%; every texel within Margin of an island is filled (the seams padded); the
OpenEXR file reads back linear; an object without a UV map is refused with nothing created.
"""

from __future__ import annotations

import os
import subprocess
import tempfile

import bpy
import numpy as np
import pytest

from conftest import library_path, require_library
from test_addon import add_light, add_sphere, attribute_rgb, bake, select_only

SIZE = 512


def texture(name="Sphere SSS") -> np.ndarray:
    """The image's pixels as (height, width, 4), rows from the top."""
    image = bpy.data.images[name]
    w, h = image.size
    px = np.empty(w * h * 4, dtype=np.float32)
    image.pixels.foreach_get(px)
    return px.reshape(h, w, 4)[::-1]


def vertex_uvs(obj) -> tuple:
    """(vertex index, u, v) of every loop of the mesh's UV map."""
    mesh = obj.data
    verts = np.empty(len(mesh.loops), dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", verts)
    uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    mesh.uv_layers.active.uv.foreach_get("vector", uv)
    return verts, uv.reshape(-1, 2)


def bilinear(img: np.ndarray, u: float, v: float):
    """The image at UV (u, v) between its four nearest texel centres, or None unless all four
    are filled (alpha 1)."""
    h, w = img.shape[:2]
    x, y = u * w - 0.5, (1.0 - v) * h - 0.5
    x0, y0 = int(np.floor(x)), int(np.floor(y))
    if not (0 <= x0 < w - 1 and 0 <= y0 < h - 1):
        return None
    block = img[y0 : y0 + 2, x0 : x0 + 2]
    if np.any(block[..., 3] < 1.0):
        return None
    fx, fy = x - x0, y - y0
    top = block[0, 0, :3] * (1 - fx) + block[0, 1, :3] * fx
    bottom = block[1, 0, :3] * (1 - fx) + block[1, 1, :3] * fx
    return top * (1 - fy) + bottom * fy


@pytest.fixture
def sunlit_sphere(scene, lib):
    sphere = add_sphere()
    add_light("SUN", rotation=(0.6, 0.3, 0.0), energy=3.0)
    select_only(sphere)
    return sphere


def test_texture_at_vertex_uvs_is_the_vertex_bake(sunlit_sphere):
    sphere = sunlit_sphere
    assert bake() == {"FINISHED"}
    per_vertex = attribute_rgb(sphere).astype(np.float64)
    assert bpy.ops.object.transcut_bake_texture(resolution=SIZE, margin=4) == {"FINISHED"}
    img = texture().astype(np.float64)
    assert img.shape == (SIZE, SIZE, 4)
    verts, uvs = vertex_uvs(sphere)
    peak = per_vertex.max()
    worst, compared = 0.0, 0
    for vert, (u, v) in zip(verts, uvs, strict=True):
        sample = bilinear(img, u, v)
        if sample is None:
            continue
        expect = per_vertex[vert]
        worst = max(worst, float(np.max(np.abs(sample - expect) / np.maximum(expect, 0.05 * peak))))
        compared += 1
    print(f"\n{compared} vertex UVs: texture within {worst:.4f} of the per-vertex bake")
    assert compared > 1000
    assert worst < 0.01


def test_margin_pads_every_island_and_the_exr_reads_back_linear(sunlit_sphere):
    assert bpy.ops.object.transcut_bake_texture(resolution=128, margin=0) == {"FINISHED"}
    bare = texture()[..., 3] == 1.0
    with tempfile.TemporaryDirectory() as folder:
        template = os.path.join(folder, "{object}_SSS")
        assert bpy.ops.object.transcut_bake_texture(resolution=128, margin=6, filepath=template) == {"FINISHED"}
        padded = texture()
        filled = padded[..., 3] == 1.0
        # Every texel within 6 (Chebyshev) of an island is filled; islands keep their texels.
        h, w = bare.shape
        grown = np.zeros_like(bare)
        for dy in range(-6, 7):
            for dx in range(-6, 7):
                shifted = np.zeros_like(bare)
                ys, yd = slice(max(dy, 0), h + min(dy, 0)), slice(max(-dy, 0), h + min(-dy, 0))
                xs, xd = slice(max(dx, 0), w + min(dx, 0)), slice(max(-dx, 0), w + min(-dx, 0))
                shifted[yd, xd] = bare[ys, xs]
                grown |= shifted
        assert np.array_equal(filled, grown), (int(filled.sum()), int(grown.sum()))
        assert filled.sum() > bare.sum()
        path = os.path.join(folder, "Sphere_SSS.exr")
        assert os.path.isfile(path)
        loaded = bpy.data.images.load(path)
        try:
            px = np.empty(128 * 128 * 4, dtype=np.float32)
            loaded.pixels.foreach_get(px)
            back = px.reshape(128, 128, 4)[::-1]
        finally:
            bpy.data.images.remove(loaded)
    np.testing.assert_allclose(back, padded, rtol=1e-3, atol=1e-6)


def test_an_object_without_a_uv_map_is_refused(sunlit_sphere):
    sphere = sunlit_sphere
    sphere.data.uv_layers.remove(sphere.data.uv_layers[0])
    sphere.data.update()
    bpy.context.view_layer.update()
    assert not sphere.data.uv_layers
    images = len(bpy.data.images)
    with pytest.raises(RuntimeError, match="has no UV map"):
        bpy.ops.object.transcut_bake_texture(resolution=64)
    assert len(bpy.data.images) == images


def read_obj_uv_map(path) -> tuple:
    """The triangles (vertex indices) and the UV of each corner of a triangulated OBJ file."""
    uvs, triangles, corner_uvs = [], [], []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if parts and parts[0] == "vt":
                uvs.append((float(parts[1]), float(parts[2])))
            elif parts and parts[0] == "f":
                corners = [tuple(int(i) - 1 for i in c.split("/")[:2]) for c in parts[1:]]
                assert len(corners) == 3, "exported triangulated"
                triangles.append([v for v, _ in corners])
                corner_uvs.append([uvs[t] for _, t in corners])
    return np.array(triangles, dtype=np.uint32), np.array(corner_uvs, dtype=np.float32)


def test_the_cli_and_the_c_abi_bake_the_same_texture(scene, addon):
    """`transcut bake --uv-texture` and `tc_object_bake_texture` (through the add-on's binding)
    on the same OBJ, medium, scale, sun and tets write the same image."""
    require_library()
    cli = os.path.join(os.path.dirname(library_path()), "transcut")
    if not os.path.isfile(cli):
        if os.environ.get("TRANSCUT_REQUIRE_LIB") == "1":
            pytest.fail(f"the CLI {cli} is not built (cargo build -p transcut-cli)")
        pytest.skip(f"the CLI {cli} is not built")
    select_only(add_sphere())
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "ball.obj")
        exr = os.path.join(folder, "ball.exr")
        bpy.ops.wm.obj_export(
            filepath=path,
            export_selected_objects=True,
            export_triangulated_mesh=True,
            export_uv=True,
            export_normals=False,
            export_materials=False,
        )
        sun, size, margin = (0.3, -1.0, -0.5), 64, 2
        subprocess.run(
            [cli, "bake", path, "--medium", "marble", "--scale", "10", "--tets", "15000", "--backend", "cpu"]
            + ["--light", "sun:dir=0.3,-1,-0.5,irradiance=3", "--uv-texture", str(size)]
            + ["--texture-margin", str(margin), "-o", exr],
            check=True,
            capture_output=True,
        )
        loaded = bpy.data.images.load(exr)
        try:
            px = np.empty(size * size * 4, dtype=np.float32)
            loaded.pixels.foreach_get(px)
            from_cli = px.reshape(size, size, 4)[::-1]
        finally:
            bpy.data.images.remove(loaded)

        lib = addon.library.get(library_path())
        s = lib.scene()
        try:
            ball = s.add_mesh_file(path)
            s.set_medium_preset(ball, "marble")
            s.set_scale(ball, 10.0)
            s.add_sun(sun, (3.0, 3.0, 3.0))
            s.bake(tets=15_000, backend="cpu")
            triangles, uvs = read_obj_uv_map(path)
            from_abi = s.bake_texture(ball, triangles, uvs, size, size, margin)
        finally:
            s.close()
    assert from_abi.shape == from_cli.shape == (size, size, 4)
    # The sphere's UV map covers the square: every texel filled, the sunlit side brighter.
    assert np.all(from_abi[..., 3] == 1.0)
    assert from_abi[..., 0].max() > 4.0 * np.median(from_abi[..., 0]) > 0.0
    np.testing.assert_array_equal(from_cli, from_abi)
