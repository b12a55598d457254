"""Editing operators: ``bpy.ops.transcut.cut_with_object()`` and ``bpy.ops.transcut.paint_medium()``.

Both bake the selected objects exactly as ``object.transcut_bake`` does (the same gathering of
meshes, media, lights and settings; :mod:`bake`), apply the edit in the library
(:mod:`edit_native`), and write the result:

- **Cut with Object**: the ACTIVE object is the cutter, the other selected meshes are cut. A flat
  cutter (every vertex on one plane, e.g. Blender's Plane) cuts by its plane: the side its face
  normal points into (the Plane's local +Z) is removed; "Flip" removes the other side. Any other
  mesh is a solid cutter (closed, world space): its inside is removed. "Keep Both Sides" removes
  nothing and keeps each side as a piece; the library splits the tetrahedra by the side of their
  centroid (so the pieces fit back together exactly), so a split boundary is within about one
  tetrahedron of the cutter rather than relaxed onto it. "Separate Parts" then splits every
  piece into its connected parts (the library's fracture). Each piece becomes a NEW mesh object
  "<object>.cut" (Blender numbers further ones ".cut.001", …) in the original's collections, its
  vertices in world space (identity matrix), its radiance in the bake's colour attribute, with
  the original's materials and TransCut medium settings so it can be baked again, and what the
  cut guaranteed in the custom property "transcut_cut" (tets removed, the largest distance of
  the snapped vertices from the cutter, the worst and the enforced minimum dihedral angle). The
  original is hidden (viewport and render), not deleted; the cutter is left as it is.
- **Paint Medium**: the ACTIVE object is a curve: its evaluated shape (world space, resampled
  to at most a quarter of the radius between points) is the stroke; the selected meshes get
  the chosen medium (a preset's or the given σa, σ′s; each object keeps its own η and g) blended
  in with a Gaussian of the given radius and strength, and their colour attribute is rewritten
  with the re-solved radiance.

Run from the UI (``invoke``) an edit is modal like the bake: the library works on a thread, the
progress shows in the cursor and status bar, ESC cancels (through the library's progress
callbacks: during the bake and inside each cut or paint call). From a script or in background mode
(``execute``) it runs on the main thread between ``progress_begin`` and ``progress_end``.
Nothing in Blender changes unless every object was edited; errors are reported (ERROR, with the
library's message; a script sees them as bpy's RuntimeError), never left to escape as Python
exceptions. Both operators register with undo. ``poll`` checks only Object Mode and the loaded
library, so a wrong selection gets a message saying what to select instead of a greyed button.
"""

from __future__ import annotations

import bpy
import numpy as np
from bpy.props import BoolProperty, FloatProperty

from . import bake, edit_native, library, preferences
from .mesh_export import BakeError, evaluated_triangles, to_world, world_matrix
from .operators import RunnerOperator
from .properties import TranscutObjectSettings, draw_medium, medium_properties


def world_mesh(obj, depsgraph) -> tuple:
    """The evaluated mesh of ``obj`` in world space: float64 positions (n, 3), uint32
    triangles (m, 3), float64 face normals (m, 3) (world space, unit). BakeError when its world
    matrix is not finite or has a zero scale."""
    m = world_matrix(obj)
    co, tri, nrm = evaluated_triangles(obj, depsgraph)
    with np.errstate(all="ignore"):
        normals = nrm.astype(np.float64) @ np.linalg.inv(m[:3, :3])  # (M⁻¹)ᵀ n, row-wise
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return to_world(co, m), tri, normals


def cutter_edit(cutter, depsgraph, keep_both: bool, flip: bool, separate: bool = False):
    """The library cut a cutter object stands for: a :class:`edit_native.PlaneCut` when its
    vertices lie on one plane (the side its face normal points into removed; ``flip``: the
    other), else a :class:`edit_native.MeshCut` (its inside removed)."""
    if cutter.type != "MESH":
        raise BakeError(
            f"the cutter '{cutter.name}' is a {cutter.type.lower()}; the cutter (the active object) must be "
            "a mesh: a plane, or a closed mesh"
        )
    pos, tri, normals = world_mesh(cutter, depsgraph)
    if len(tri) == 0:
        raise BakeError(f"the cutter '{cutter.name}' has no faces")
    if not np.all(np.isfinite(pos)):
        raise BakeError(f"the cutter '{cutter.name}' has non-finite vertex coordinates")
    if edit_native.is_planar(pos):
        point, normal = edit_native.plane_of_points(pos, normals, flip)
        return edit_native.PlaneCut(point, normal, keep_both, separate)
    return edit_native.MeshCut(pos.astype(np.float32), tri, keep_both, separate)


def stroke_points(curve, depsgraph, spacing: float) -> np.ndarray:
    """The evaluated curve in world space as points at most ``spacing`` apart (every edge of its
    evaluated polyline resampled; the order does not matter to a paint). BakeError when its
    world matrix is not finite or has a zero scale."""
    m = world_matrix(curve)
    ob_eval = curve.evaluated_get(depsgraph)
    me = ob_eval.to_mesh()
    try:
        co = np.empty(len(me.vertices) * 3, np.float32)
        me.vertices.foreach_get("co", co)
        edges = np.empty(len(me.edges) * 2, np.int64)
        me.edges.foreach_get("vertices", edges)
    finally:
        ob_eval.to_mesh_clear()
    pos = to_world(co, m)
    edges = edges.reshape(-1, 2)
    if len(edges) == 0:
        return pos
    parts = [edit_native.resample_polyline(pos[[a, b]], spacing) for a, b in edges]
    return np.unique(np.concatenate(parts), axis=0)


def write_pieces(context, job: bake.BakeJob, run: edit_native.EditRun) -> list:
    """One new mesh object per piece (world space), the originals hidden; returns the new objects.

    Checks first (the originals still exist), then creates everything.
    """
    originals = []
    for mesh_job in job.meshes:
        obj = bpy.data.objects.get(mesh_job.object_name)
        if obj is None:
            raise BakeError(f"'{mesh_job.object_name}' was removed during the cut")
        originals.append(obj)
    for res in run.results:
        for piece in res.pieces:
            if not (np.all(np.isfinite(piece.positions)) and np.all(np.isfinite(piece.radiance))):
                raise BakeError(f"'{res.object_name}': the library returned non-finite values")
    name = job.attribute_name
    created = []
    for obj, res in zip(originals, run.results, strict=True):
        for piece in res.pieces:
            mesh = bpy.data.meshes.new(f"{obj.name}.cut")
            mesh.from_pydata(piece.positions.tolist(), [], piece.triangles.tolist())
            mesh.validate(clean_customdata=False)
            for mat in obj.data.materials:
                mesh.materials.append(mat)
            attr = mesh.color_attributes.new(name, "FLOAT_COLOR", "POINT")
            rgba = np.ones((len(mesh.vertices), 4), np.float32)
            rgba[:, :3] = piece.radiance
            attr.data.foreach_set("color", rgba.reshape(-1))
            mesh.color_attributes.active_color = attr
            mesh.color_attributes.render_color_index = mesh.color_attributes.active_color_index
            mesh.update()
            new = bpy.data.objects.new(mesh.name, mesh)
            for coll in obj.users_collection:
                coll.objects.link(new)
            for key in TranscutObjectSettings.__annotations__:
                if key != "last_bake":  # the medium carries over; the bake report is the source's
                    setattr(new.transcut, key, getattr(obj.transcut, key))
            # What the cut guaranteed (custom property "transcut_cut"; distances in scene units).
            st = res.stats
            new["transcut_cut"] = {
                "source": obj.name,
                "removed_tets": int(st.get("cut_removed_tets", 0)),
                "max_distance": float(st.get("cut_max_distance", 0.0)),
                "min_dihedral_degrees": float(st.get("cut_min_dihedral_degrees", 0.0)),
                "bound_degrees": float(st.get("cut_bound_degrees", 0.0)),
            }
            created.append(new)
        obj.hide_set(True)
        obj.hide_render = True
        obj.select_set(False)
    for o in context.selected_objects:
        o.select_set(False)
    for new in created:
        new.select_set(True)
    if created:
        context.view_layer.objects.active = created[0]
    return created


class _EditOperator(RunnerOperator):
    """What both editing operators share besides the run (:class:`operators.RunnerOperator`):
    ``poll`` checks only the mode and the library, so a wrong selection gets a message saying
    what to select instead of a greyed button."""

    @classmethod
    def poll(cls, context):
        if context.mode != "OBJECT":
            cls.poll_message_set("works in Object Mode")
            return False
        if library.state.lib is None:
            cls.poll_message_set("libtranscut is not loaded (see the add-on preferences)")
            return False
        return True


def _targets(context, active, what: str) -> list:
    targets = [o for o in context.selected_objects if o != active and o.type == "MESH"]
    if not targets:
        tool = "cutter" if what == "cut" else "curve"
        raise BakeError(f"select the mesh object(s) to {what} as well as the active {tool}")
    return targets


class TRANSCUT_OT_cut_with_object(_EditOperator, bpy.types.Operator):
    """Cut the selected translucent meshes with the active object (a plane: the side its normal points to is removed; a closed mesh: its inside), baking the result into new objects"""  # noqa: E501

    bl_idname = "transcut.cut_with_object"
    bl_label = "Cut with Object"
    what = "cut"

    keep_both: BoolProperty(
        name="Keep Both Sides",
        description="Remove nothing: split along the cutter and make each side its own object",
        default=False,
    )
    separate: BoolProperty(
        name="Separate Parts",
        description="Make every connected part left by the cut its own object (a fracture), not one object per side",
        default=False,
    )
    flip: BoolProperty(
        name="Flip",
        description="Plane cutter: remove the side opposite its normal (local −Z of a Plane) instead",
        default=False,
    )

    def _runner_for(self, context):
        cutter = context.active_object
        if cutter is None:
            raise BakeError(
                "no cutter: make the cutter (a plane or a closed mesh) the active object and also select the "
                "objects to cut"
            )
        depsgraph = context.evaluated_depsgraph_get()
        edit = cutter_edit(cutter, depsgraph, self.keep_both, self.flip, self.separate)
        targets = _targets(context, cutter, "cut")
        bake.check_editable(context, "Cut with Object")
        lib = library.get(preferences.library_path(context))
        edit_native.require(lib, edit_native.CUT_FUNCTIONS, "Cut with Object")
        job = bake.prepare_job(context, targets)
        return edit_native.EditRunner(lib, job, edit)

    def _write(self, context, runner) -> str:
        run = runner.results
        created = write_pieces(context, runner.job, run)
        parts = []
        for res in run.results:
            st = res.stats
            if runner.edit.keep_both:
                parts.append(f"'{res.object_name}' split into {len(res.pieces)} piece(s), cut {res.edit_ms:.0f} ms")
                continue
            parts.append(
                f"'{res.object_name}' → {len(res.pieces)} piece(s), {st.get('cut_removed_tets', 0)} tets removed, "
                f"cut surface within {st.get('cut_max_distance', 0.0):.3g} of the cutter, min dihedral "
                f"{st.get('cut_min_dihedral_degrees', 0.0):.1f}° (bound {st.get('cut_bound_degrees', 0.0):.1f}°), "
                f"cut {res.edit_ms:.0f} ms"
            )
        return f"cut: {len(created)} new object(s); " + "; ".join(parts) + f"; bake {run.bake_ms:.0f} ms"


class TRANSCUT_OT_paint_medium(_EditOperator, bpy.types.Operator):
    """Paint a medium into the selected baked meshes along the active curve and re-bake their colour attribute"""

    bl_idname = "transcut.paint_medium"
    bl_label = "Paint Medium"
    what = "paint"

    __annotations__ = {
        "radius": FloatProperty(
            name="Radius",
            description="Gaussian radius of the stroke's influence, scene units",
            default=0.1,
            min=1e-6,
            soft_max=10.0,
            subtype="DISTANCE",
        ),
        "strength": FloatProperty(
            name="Strength",
            description="Weight of the painted medium on the stroke (0: nothing, 1: replaced)",
            default=1.0,
            min=0.0,
            max=1.0,
            subtype="FACTOR",
        ),
        **medium_properties(
            "The medium to paint (its η and g are each object's own)",
            ("PRESET", "COEFFICIENTS"),
            preset="ketchup",
            sigma_a=(0.5, 0.5, 0.5),
            sigma_s_prime=(2.0, 2.0, 2.0),
        ),
    }

    def draw(self, _context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "radius")
        layout.prop(self, "strength")
        draw_medium(layout, self)

    def _paint_coefficients(self, lib) -> tuple:
        if self.medium_source == "PRESET":
            m = lib.medium_preset(self.preset)
            return tuple(m.sigma_a), tuple(m.sigma_s_prime)
        values = (*self.sigma_a, *self.sigma_s_prime, self.radius, self.strength)
        if not all(np.isfinite(values)):
            raise BakeError("the paint's coefficients, radius and strength must be finite")
        return tuple(self.sigma_a), tuple(self.sigma_s_prime)

    def _runner_for(self, context):
        curve = context.active_object
        if curve is None or curve.type != "CURVE":
            what = "nothing is active" if curve is None else f"'{curve.name}' is a {curve.type.lower()}"
            raise BakeError(f"the stroke must be a curve object, made active ({what}); also select the meshes to paint")
        if not (np.isfinite(self.radius) and np.isfinite(self.strength)):
            raise BakeError("the paint's radius and strength must be finite")
        depsgraph = context.evaluated_depsgraph_get()
        points = stroke_points(curve, depsgraph, self.radius / 4.0)
        if len(points) == 0:
            raise BakeError(f"the curve '{curve.name}' has no points")
        if not np.all(np.isfinite(points)):
            raise BakeError(f"the curve '{curve.name}' has non-finite points")
        targets = _targets(context, curve, "paint")
        bake.check_editable(context, "Paint Medium")
        lib = library.get(preferences.library_path(context))
        edit_native.require(lib, edit_native.PAINT_FUNCTIONS, "Paint Medium")
        sigma_a, sigma_s_prime = self._paint_coefficients(lib)
        job = bake.prepare_job(context, targets)
        media = [edit_native.medium_coefficients(lib, m.medium, m.mm_per_unit) for m in job.meshes]
        edit = edit_native.Paint(points, self.radius, sigma_a, sigma_s_prime, self.strength)
        return edit_native.EditRunner(lib, job, edit, media)

    def _write(self, context, runner) -> str:
        run = runner.results
        bake.write_results(context, runner.job, [r.radiance for r in run.results])
        parts = [
            f"'{r.object_name}': {r.stats.get('tets_changed', 0)} tets painted, {r.stats.get('rows_rebuilt', 0)} rows "
            f"rebuilt, paint {r.edit_ms:.0f} ms"
            for r in run.results
        ]
        return (
            f"painted {len(run.results)} object(s) into '{runner.job.attribute_name}' "
            f"({len(runner.edit.points)} stroke points); " + "; ".join(parts) + f"; bake {run.bake_ms:.0f} ms"
        )


register, unregister = bpy.utils.register_classes_factory((TRANSCUT_OT_cut_with_object, TRANSCUT_OT_paint_medium))
