"""Subsurface methods: the binding's list and choice of method and TransCut's solvers
(``Library.methods``, ``Scene.bake(method=, solver=, edit_solver=)``), and the Method menu of
``Scene.transcut`` that the bake and the editing operators pass to the library.

The methods expected are the library's own, read by the tests' independent client
(capi_direct: ``tc_method_count`` and ``tc_method_name`` through its own prototypes).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from mathutils import Vector

from conftest import bpy, require_library
from test_addon import (
    TETS,
    TOL,
    add_light,
    add_sphere,
    assert_matches_direct,
    attribute_rgb,
    evaluated_arrays,
    select_only,
    snapshot,
)
from test_edit_ops import add_plane_cutter, add_stroke

#: How far two converged solves may differ: both stop at the relative residual TOL, so their
#: radiance agrees to a small multiple of TOL (measured: about 1 × TOL for this sphere).
SOLVER_AGREEMENT = 10.0 * TOL


@pytest.fixture
def sphere_arrays():
    """The test sphere (32 × 16 UV sphere, radius 1) as arrays, without a Blender object."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=1.0)
    obj = bpy.context.active_object
    pos, tri, _, _ = evaluated_arrays(obj)
    mesh = obj.data
    bpy.data.objects.remove(obj)
    bpy.data.meshes.remove(mesh)
    return pos, tri


def marble_scene(tclib, pos, tri):
    """A scene of the sphere in marble (1 cm per unit) under a sun; returns (scene, object)."""
    s = tclib.scene()
    i = s.add_mesh(pos, tri)
    s.set_scale(i, 10.0)
    s.set_medium_preset(i, "marble")
    s.add_sun((0.3, 0.2, -1.0), (3.0, 3.0, 3.0))
    return s, i


def baked(tclib, pos, tri, **options) -> tuple:
    """(radiance, per-channel iterations) of a CPU bake of the marble sphere with ``options``."""
    s, i = marble_scene(tclib, pos, tri)
    with s:
        s.bake(tets=TETS, tolerance=TOL, backend="cpu", **options)
        return s.radiance(i), s.stats(i)["iterations"]


# -- the binding -----------------------------------------------------------------------------


def test_library_lists_its_methods(addon, lib):
    tclib = addon.library.get()
    methods = tclib.methods()
    names = lib.method_names()
    assert names and names[0] == "transcut"
    assert [name for name, _ in methods] == names
    assert all(description for _, description in methods)
    for number, name in enumerate(names):
        assert tclib.method_number(name.upper()) == number


def test_a_library_without_the_method_functions_has_transcut(addon):
    """What a library older than ``tc_method_count`` is taken to have: TransCut alone, by the
    same name and description as the library gives it."""
    require_library()
    tc = addon.transcut
    current = addon.library.get()
    older = tc.Library(current.path)  # its own prototypes, so the shared one stays whole
    older.optional_missing += ["tc_method_count", "tc_method_name", "tc_method_description", "tc_method_from_name"]
    assert older.methods() == current.methods()[:1] == [("transcut", tc.scene.TRANSCUT_ONLY[0][1])]
    assert older.method_number(" TransCut ") == tc.TC_METHOD_TRANSCUT
    with pytest.raises(tc.TranscutError) as err:
        older.method_number("nonsense")
    assert err.value.status == tc.TC_NOT_FOUND and "'nonsense'" in str(err.value) and "transcut" in str(err.value)


def test_unknown_methods_and_solvers_are_errors(addon, lib, sphere_arrays):
    tc = addon.transcut
    tclib = addon.library.get()
    count = len(lib.method_names())
    s, _ = marble_scene(tclib, *sphere_arrays)
    with s:
        with pytest.raises(tc.TranscutError) as err:
            s.bake(method="nonsense", tets=2000)
        assert err.value.status == tc.TC_NOT_FOUND
        assert "'nonsense'" in str(err.value) and "transcut" in str(err.value)
        # A method number reaches TcBakeOptions.method: the library refuses one it lacks.
        with pytest.raises(tc.TranscutError) as err:
            s.bake(method=count, tets=2000)
        assert err.value.status == tc.TC_INVALID_ARGUMENT and "method" in err.value.message
        with pytest.raises(ValueError, match="options of transcut"):
            s.bake(method=count, solver="pcg")
        with pytest.raises(ValueError, match="ssor-pcg"):
            s.bake(solver="gauss")
        # Solver values reach the library through TcBakeOptions.method_options.
        for option in ("solver", "edit_solver"):
            with pytest.raises(tc.TranscutError) as err:
                s.bake(tets=2000, **{option: 99})
            assert err.value.status == tc.TC_INVALID_ARGUMENT
            assert f"method_options->{option} = 99" in err.value.message
        # So does the grading: above TC_MAX_GRADING_LAYERS the library names it; a negative
        # one is refused before the call.
        with pytest.raises(tc.TranscutError) as err:
            s.bake(tets=2000, grading=tc.TC_MAX_GRADING_LAYERS + 1)
        assert err.value.status == tc.TC_INVALID_ARGUMENT
        assert f"method_options->grading = {tc.TC_MAX_GRADING_LAYERS + 1}" in err.value.message
        with pytest.raises(ValueError, match="grading"):
            s.bake(tets=2000, grading=-1)
        with pytest.raises(ValueError, match="'auto' or a whole number"):
            s.bake(tets=2000, grading="graded")
        with pytest.raises(ValueError, match="options of transcut"):
            s.bake(method="hierarchical-dipole", grading=1)
        # The discretization by name or value; an unknown name before the call, a value after.
        with pytest.raises(ValueError, match="consistent-fem"):
            s.bake(tets=2000, discretization="galerkin")
        with pytest.raises(tc.TranscutError) as err:
            s.bake(tets=2000, discretization=7)
        assert "method_options->discretization = 7" in err.value.message


def test_pcg_bake_agrees_with_the_default_solver(addon, sphere_arrays):
    """The default bake solver is SSOR-PCG (bit for bit); Jacobi PCG is another solver (more
    iterations in every channel) whose radiance agrees within the solver tolerance."""
    require_library()
    tclib = addon.library.get()
    default, default_iterations = baked(tclib, *sphere_arrays)
    ssor, ssor_iterations = baked(tclib, *sphere_arrays, method="transcut", solver="ssor-pcg")
    pcg, pcg_iterations = baked(tclib, *sphere_arrays, solver="PCG")
    np.testing.assert_array_equal(ssor, default)
    assert ssor_iterations == default_iterations
    assert all(p > d for p, d in zip(pcg_iterations, default_iterations, strict=True)), (
        pcg_iterations,
        default_iterations,
    )
    scale = float(np.abs(default).max())
    assert scale > 0.0
    difference = float(np.abs(pcg - default).max())
    assert difference <= SOLVER_AGREEMENT * scale, difference / scale


def test_edit_solver_reaches_the_relight(addon, sphere_arrays):
    """``edit_solver`` chooses the solver of the edits after the bake: a relight with Jacobi PCG
    takes other iteration counts than the default's and agrees within the solver tolerance."""
    require_library()
    tclib = addon.library.get()

    def relit(**options):
        s, i = marble_scene(tclib, *sphere_arrays)
        with s:
            s.bake(tets=TETS, tolerance=TOL, backend="cpu", **options)
            s.clear_lights()
            s.add_sun((-0.5, 0.1, -1.0), (2.0, 2.5, 3.0))
            s.relight()
            return s.radiance(i), s.edit_stats(i)["iterations"]

    default, default_iterations = relit()
    pcg, pcg_iterations = relit(edit_solver="pcg")
    assert pcg_iterations != default_iterations
    scale = float(np.abs(default).max())
    assert float(np.abs(pcg - default).max()) <= SOLVER_AGREEMENT * scale


# -- the Method menu -------------------------------------------------------------------------


def listed_items(settings) -> list:
    """The identifiers Blender offers for ``settings.method``, as its error for an unknown one
    lists them (RNA's ``enum_items`` is empty for items from a function)."""
    with pytest.raises(TypeError) as err:
        settings.method = "no such method"
    (listed,) = re.findall(r"not found in \((.*)\)", str(err.value))
    return re.findall(r"'([^']*)'", listed)


def test_method_menu_lists_exactly_the_library_methods(scene, addon, lib):
    settings = scene.transcut
    names = lib.method_names()
    items = addon.properties.method_items(settings, bpy.context)
    assert [item[0] for item in items] == names
    assert [item[3] for item in items] == list(range(len(names)))  # the TC_METHOD_* values
    assert items[0][1] == "TransCut" and all(item[2] for item in items)
    assert listed_items(settings) == names
    assert settings.method == "transcut"  # the default
    # Blender keeps pointers to the item strings: the same list stays referenced and is reused.
    assert addon.properties.method_items(settings, bpy.context) is items


def test_method_menu_without_the_library_offers_transcut(scene, addon):
    state = addon.library.state
    settings = scene.transcut
    settings.method = "transcut"
    loaded = state.lib
    state.lib = None
    try:
        items = addon.properties.method_items(settings, bpy.context)
        assert [(item[0], item[3]) for item in items] == [("transcut", 0)]
        assert listed_items(settings) == ["transcut"]
        assert settings.method == "transcut"
    finally:
        state.lib = loaded
    assert settings.method == "transcut"


def test_a_stored_method_the_library_lacks_is_an_error(scene, addon, lib):
    """A scene saved with a method this library does not have (its number is stored) bakes
    nothing and says so."""
    obj = add_sphere()
    add_light("SUN", energy=3.0)
    select_only(obj)
    scene.transcut["method"] = len(lib.method_names())
    try:
        assert scene.transcut.method == ""
        before = snapshot()
        with pytest.raises(RuntimeError, match="Method chosen in the TransCut panel"):
            bpy.ops.object.transcut_bake()
        assert snapshot() == before
    finally:
        del scene.transcut["method"]  # the scene outlives the test
    assert scene.transcut.method == "transcut"


@pytest.fixture
def bake_methods(addon, monkeypatch):
    """The ``method`` of every ``Scene.bake`` call, recorded as the call goes on to the library."""
    calls = []
    bake = addon.transcut.Scene.bake

    def recording(self, *args, **kwargs):
        calls.append(kwargs.get("method"))
        return bake(self, *args, **kwargs)

    monkeypatch.setattr(addon.transcut.Scene, "bake", recording)
    return calls


def test_bake_operator_passes_the_method(scene, lib, bake_methods):
    """A bake with the method chosen equals the default bake, which matches the C ABI called
    directly with the library's default method. Keep Bakes off: every press bakes (with it on
    the second would read the kept bake, test_kept.py)."""
    scene.transcut.keep_bakes = False
    obj = add_sphere()
    sun = add_light("SUN", rotation=(math.radians(30), 0.0, 0.0), energy=3.0)
    select_only(obj)
    assert bpy.ops.object.transcut_bake() == {"FINISHED"}
    default = attribute_rgb(obj).copy()
    scene.transcut.method = lib.method_names()[0]
    assert bpy.ops.object.transcut_bake() == {"FINISHED"}
    assert bake_methods == ["transcut", "transcut"]
    np.testing.assert_array_equal(attribute_rgb(obj), default)
    direction = np.array(sun.matrix_world.to_3x3() @ Vector((0.0, 0.0, -1.0)))
    assert_matches_direct(lib, obj, [("sun", (direction, [3.0] * 3, math.degrees(sun.data.angle)))], default)


def test_editing_operators_pass_the_method(scene, lib, bake_methods):
    obj = add_sphere()
    add_light("SUN", energy=3.0)
    scene.transcut.method = "transcut"
    select_only(add_plane_cutter(), obj)
    assert bpy.ops.transcut.cut_with_object() == {"FINISHED"}
    cut = next(o for o in bpy.data.objects if o.name == "Sphere.cut")
    stroke = add_stroke([(0.0, 0.0, 0.97), (0.3, 0.0, 0.92)])
    select_only(stroke, cut)
    assert bpy.ops.transcut.paint_medium(radius=0.1, preset="apple") == {"FINISHED"}
    assert bake_methods == ["transcut", "transcut"]
