"""See the bake: preview materials that show the baked radiance as rendered.

``transcut.preview_bake`` gives every selected mesh that holds the bake's colour attribute a
preview material in each of its material slots: a copy of the slot's material whose Principled
BSDF keeps its specular, coat and sheen layers but has no diffuse, subsurface or transmission
base (Base Color black, Subsurface Weight 0, Transmission Weight 0) and emits the attribute
(a Color Attribute node into Emission Color, Emission Strength 1: an emitter of strength 1 shows
exactly its colour, so the surface shows the baked radiance). The bake is then visible in
Material Preview, EEVEE and Cycles, lit by nothing but itself, with the original highlights on
top. A slot without a material (or a material without a Principled BSDF) gets a new Principled
material of Blender's defaults set up the same way.

The original stays referenced from its preview (the ID property ``transcut_original``, which
counts as a user, so it survives saving and reloading); ``transcut.restore_materials`` puts the
originals back and removes previews nothing else uses. Running the preview again on an object
that shows one updates it (the attribute's name) instead of stacking a copy of a copy. Both
operators are undoable and change nothing when they report an error.
"""

from __future__ import annotations

import bpy

from .mesh_export import principled_node

#: The ID property of a preview material that holds its original (None: the slot was empty).
ORIGINAL = "transcut_original"
#: The ID property marking a preview material (its value: the attribute it shows).
PREVIEW = "transcut_preview"
#: Label of the Color Attribute node a preview adds.
NODE_LABEL = "TransCut Bake"


def is_preview(material) -> bool:
    return material is not None and PREVIEW in material


def _preview_of(original, attribute: str):
    """A new preview material for ``original`` (a material or None) showing ``attribute``."""
    if original is not None and principled_node(original) is not None:
        material = original.copy()
        material.name = f"{original.name} (TransCut Preview)"
    else:
        material = bpy.data.materials.new(f"{original.name if original else 'TransCut'} (TransCut Preview)")
        material.use_nodes = True
    if original is not None:
        material[ORIGINAL] = original
    _show(material, attribute)
    return material


def _show(material, attribute: str) -> None:
    """Sets up ``material``'s Principled BSDF to emit ``attribute`` over its specular layers."""
    material[PREVIEW] = attribute
    tree = material.node_tree
    node = principled_node(material)
    for name, value in (
        ("Base Color", (0.0, 0.0, 0.0, 1.0)),
        ("Subsurface Weight", 0.0),
        ("Transmission Weight", 0.0),
        ("Emission Strength", 1.0),
    ):
        socket = node.inputs[name]
        for link in list(socket.links):
            tree.links.remove(link)
        socket.default_value = value
    colour = next((n for n in tree.nodes if n.type == "VERTEX_COLOR" and n.label == NODE_LABEL), None)
    if colour is None:
        colour = tree.nodes.new("ShaderNodeVertexColor")
        colour.label = NODE_LABEL
        colour.location = (node.location.x - 300.0, node.location.y - 500.0)
    colour.layer_name = attribute
    emission = node.inputs["Emission Color"]
    for link in list(emission.links):
        tree.links.remove(link)
    tree.links.new(colour.outputs["Color"], emission)


def baked_meshes(context, attribute: str) -> list:
    """The selected mesh objects that hold ``attribute``; raises ValueError when there is none."""
    objects = [o for o in context.selected_objects if o.type == "MESH"]
    baked = [o for o in objects if o.data.color_attributes.get(attribute) is not None]
    if not baked:
        raise ValueError(
            f"select baked meshes: none of the selected meshes has the colour attribute '{attribute}' (bake first)"
        )
    return baked


def preview(objects: list, attribute: str) -> int:
    """Gives every slot of ``objects`` a preview material of ``attribute`` (module
    documentation); returns how many slots it set up. A mesh without slots gets one."""
    count = 0
    made: dict = {}  # original material (or None) → its preview, shared by the objects
    for obj in objects:
        if not obj.material_slots:
            obj.data.materials.append(None)
        for slot in obj.material_slots:
            if is_preview(slot.material):
                _show(slot.material, attribute)
            else:
                key = slot.material.name if slot.material is not None else None
                if key not in made:
                    made[key] = _preview_of(slot.material, attribute)
                slot.material = made[key]
            count += 1
    return count


def restore(objects: list) -> int:
    """Puts back the originals of the preview materials in ``objects``' slots and removes the
    previews nothing uses any more; returns how many slots it restored."""
    count = 0
    previews = set()
    for obj in objects:
        for slot in obj.material_slots:
            if is_preview(slot.material):
                previews.add(slot.material.name)
                slot.material = slot.material.get(ORIGINAL)
                count += 1
    for name in previews:
        material = bpy.data.materials.get(name)
        if material is not None and material.users == 0:
            bpy.data.materials.remove(material)
    return count


class TRANSCUT_OT_preview_bake(bpy.types.Operator):
    """Show the bake as rendered: a preview material per slot that emits the baked colour
    attribute under the original specular layer (Material Preview, EEVEE, Cycles)"""

    bl_idname = "transcut.preview_bake"
    bl_label = "Preview Bake"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        attribute = context.scene.transcut.attribute_name
        try:
            objects = baked_meshes(context, attribute)
        except ValueError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        count = preview(objects, attribute)
        self.report({"INFO"}, f"preview of '{attribute}' in {count} material slot(s) of {len(objects)} object(s)")
        return {"FINISHED"}


class TRANSCUT_OT_restore_materials(bpy.types.Operator):
    """Put back the materials the bake preview replaced in the selected objects"""

    bl_idname = "transcut.restore_materials"
    bl_label = "Restore Materials"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        count = restore([o for o in context.selected_objects if o.type == "MESH"])
        if count == 0:
            self.report({"ERROR"}, "no selected object shows a bake preview")
            return {"CANCELLED"}
        self.report({"INFO"}, f"restored {count} material slot(s)")
        return {"FINISHED"}


register, unregister = bpy.utils.register_classes_factory((TRANSCUT_OT_preview_bake, TRANSCUT_OT_restore_materials))
