"""Selected mesh objects → arrays and media for the library, checked before anything is baked.

Every check that could fail happens here, before the bake and before any write, so a failed
bake leaves the scene exactly as it was. Arrays move with ``foreach_get`` into NumPy buffers.

Units: positions stay in object space and the object's world matrix goes to the library
(``tc_object_set_transform``), so the baked mesh is the world-space evaluated mesh. One scene
unit is ``scene.unit_settings.scale_length`` metres, so mm_per_unit = scale_length × 1000.
The Principled BSDF's Subsurface Radius × Subsurface Scale is a length in scene (world) units,
converted by the library with that mm_per_unit (``tc_object_set_medium_artist``). Every object
of a bake gets that one mm_per_unit, so the radiosity method's rule that all its objects share a
scale always holds.

Principled inputs are read the way Cycles reads them (``Object.transcut.principled_mapping``
CYCLES, the default): Random Walk and Christensen–Burley through the library's ``random-walk``
mapping (the radius over 4π is the reduced mean free path, the medium index-matched, a thick slab
reflects Base Color), Random Walk (Skin) through ``random-walk-skin`` (its radius a diffusion
length at the Subsurface IOR). Cycles puts the Principled BSDF's specular layer over the
subsurface part, so along the normal it lets 1 − F0 of it out, F0 = ((IOR − 1)/(IOR + 1))² ×
2 × Specular IOR Level × Specular Tint (the layer's albedo at normal incidence, within 0.4% of
Cycles' rough one); :attr:`MediumSpec.surface` carries it and :meth:`MediumSpec.seen` applies it
to everything written. DIPOLE reads them as the classical dipole's inversion at the IOR, whose
medium carries its own Fresnel boundary (surface 1).

Translucent radiosity (:func:`surroundings`): the visible meshes around the selected ones become
opaque diffuse objects, in world space as the translucent ones are (their evaluated mesh, n-gons
triangulated as Blender's loop triangles). Their material is read from the active material's
Principled BSDF: albedo ρ = Base Color × (1 − Metallic), clamped to [0, :data:`DIFFUSE_ALBEDO_MAX`]
(the library needs ρ < 1; the metallic part reflects specularly, which the method does not
model, so it is taken as absorbed), and emission M = π × Emission Color × Emission Strength: a
Blender emitter of strength S and colour c has radiance S·c (strength 1 shows exactly its colour,
the unit of the world's Background too), while the library's emission is an exitance, M = π L
for a Lambertian emitter (alone it has radiance M/π). A plain Emission shader as the surface is
ρ = 0 and M = π × Color × Strength; no Principled BSDF (or no material): ρ = :data:`DEFAULT_ALBEDO`
grey, no emission. Specular, sheen, coat and transmission lobes are not modelled (a glass object
is an opaque diffuse surface; a warning says so).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Base Color is the diffuse reflectance the medium must reproduce; the conversion needs it in
#: the open interval (0, 1), so it is clamped to [ALBEDO_MIN, ALBEDO_MAX].
ALBEDO_MIN = 1e-3
ALBEDO_MAX = 0.999
#: A diffuse surface's albedo (Base Color × (1 − Metallic)) is clamped to [0, DIFFUSE_ALBEDO_MAX]:
#: the library needs each channel below 1 (a closed room of albedo 1 would never converge).
DIFFUSE_ALBEDO_MAX = 0.999
#: The albedo of a surrounding object without a Principled BSDF: Blender's default grey.
DEFAULT_ALBEDO = (0.8, 0.8, 0.8)


class BakeError(Exception):
    """A problem with the user's scene or settings; the message is shown as it is."""


@dataclass
class MediumSpec:
    """How to set an object's medium: ``getattr(transcut.Scene, method)(obj, **kwargs)``;
    ``surface``: the share per channel of the medium's radiance that the material's surface
    layer lets out along the normal (module documentation), applied by :meth:`seen`."""

    method: str
    kwargs: dict
    source: str  # e.g. "material 'Marble'" or "preset marble"
    surface: tuple = (1.0, 1.0, 1.0)

    def seen(self, rgb: np.ndarray) -> np.ndarray:
        """The radiance a viewer sees along the normal: the library's (the medium's) through
        the surface layer."""
        if self.surface == (1.0, 1.0, 1.0):
            return rgb
        return rgb * np.asarray(self.surface, dtype=rgb.dtype)


@dataclass
class MeshJob:
    """One object to bake."""

    object_name: str
    positions: np.ndarray  # float32 (n, 3), object space, evaluated mesh
    triangles: np.ndarray  # uint32 (m, 3)
    matrix_world: np.ndarray  # float64 (4, 4) row-major
    mm_per_unit: float
    medium: MediumSpec
    original_vertex_count: int
    replace_mesh: bool  # modifiers change the vertex count: write on a mesh of the evaluated object
    warnings: list = field(default_factory=list)

    @property
    def vertex_count(self) -> int:
        return int(self.positions.shape[0])


@dataclass
class DiffuseJob:
    """One surrounding object of a radiosity bake: an opaque diffuse surface."""

    object_name: str
    positions: np.ndarray  # float32 (n, 3), object space, evaluated mesh
    triangles: np.ndarray  # uint32 (m, 3)
    matrix_world: np.ndarray  # float64 (4, 4) row-major
    mm_per_unit: float
    albedo: list  # ρ per RGB channel, in [0, DIFFUSE_ALBEDO_MAX]
    emission: list  # exitance M per RGB channel (π × Blender's emitted radiance)
    source: str  # e.g. "material 'Floor'" or "default grey"
    original_vertex_count: int
    write: bool  # its radiance goes into its colour attribute (see surroundings)

    @property
    def vertex_count(self) -> int:
        return int(self.positions.shape[0])


def mm_per_unit(scene) -> float:
    """Millimetres per scene unit: unit scale (metres per unit) × 1000."""
    return float(scene.unit_settings.scale_length) * 1000.0


def principled_node(material):
    """The Principled BSDF feeding the material's output, else the first one in its tree."""
    if material is None or not material.use_nodes or material.node_tree is None:
        return None
    tree = material.node_tree
    output = tree.get_output_node("ALL")
    if output is not None and output.inputs["Surface"].is_linked:
        node = output.inputs["Surface"].links[0].from_node
        if node.type == "BSDF_PRINCIPLED":
            return node
    return next((n for n in tree.nodes if n.type == "BSDF_PRINCIPLED"), None)


def _input(node, name: str, warnings: list, owner: str):
    socket = node.inputs[name]
    if socket.is_linked:
        warnings.append(f"{owner}: '{name}' is linked to a node; its unlinked value is used")
    return socket.default_value


#: The library's artist mapping of each Principled BSDF subsurface method, as Cycles reads it.
CYCLES_MAPPINGS = {"BURLEY": "random-walk", "RANDOM_WALK": "random-walk", "RANDOM_WALK_SKIN": "random-walk-skin"}


def specular_layer_transmission(node, warnings: list, owner: str) -> tuple:
    """1 − F0 per channel of the Principled BSDF's specular layer at normal incidence (module
    documentation), each in [0, 1]."""
    ior = float(_input(node, "IOR", warnings, owner))
    level = float(_input(node, "Specular IOR Level", warnings, owner))
    tint = np.array(_input(node, "Specular Tint", warnings, owner)[:3], dtype=np.float64)
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2 * 2.0 * max(level, 0.0) * np.clip(tint, 0.0, None)
    return tuple(float(x) for x in np.clip(1.0 - f0, 0.0, 1.0))


def material_medium(obj, warnings: list) -> MediumSpec:
    """Artist parameters of the object's first material with a Principled BSDF whose
    Subsurface Weight is above 0, read as ``obj.transcut.principled_mapping`` says (module
    documentation)."""
    candidates = []
    for slot in obj.material_slots:
        node = principled_node(slot.material)
        if node is not None:
            candidates.append((slot.material, node))
    if not candidates:
        raise BakeError(
            f"'{obj.name}' has no material with a Principled BSDF; add one or choose a preset or "
            "coefficients in the TransCut panel"
        )
    chosen = next(((m, n) for m, n in candidates if n.inputs["Subsurface Weight"].default_value > 0.0), None)
    if chosen is None:
        raise BakeError(
            f"'{obj.name}': material '{candidates[0][0].name}' has Subsurface Weight 0; nothing scatters "
            "below the surface (raise it, or choose a preset or coefficients in the TransCut panel)"
        )
    material, node = chosen
    owner = f"'{obj.name}' material '{material.name}'"
    if len({m.name for m, _ in candidates}) > 1:
        warnings.append(f"'{obj.name}' has several materials; '{material.name}' is used for the whole object")
    weight = float(_input(node, "Subsurface Weight", warnings, owner))
    if weight < 1.0:
        warnings.append(f"{owner}: Subsurface Weight {weight:.3g} < 1; the bake is the subsurface part alone")
    base = np.array(_input(node, "Base Color", warnings, owner)[:3], dtype=np.float64)
    albedo = np.clip(base, ALBEDO_MIN, ALBEDO_MAX)
    radius = [float(x) for x in _input(node, "Subsurface Radius", warnings, owner)[:3]]
    if min(radius) <= 0.0:
        raise BakeError(f"{owner}: every Subsurface Radius channel must be > 0, got {tuple(radius)}")
    scale = float(_input(node, "Subsurface Scale", warnings, owner))
    if scale <= 0.0:
        raise BakeError(f"{owner}: Subsurface Scale must be > 0, got {scale}")
    ior_name = "Subsurface IOR" if node.subsurface_method == "RANDOM_WALK_SKIN" else "IOR"
    ior = float(_input(node, ior_name, warnings, owner))
    if not 1.0 <= ior < 4.0:
        raise BakeError(f"{owner}: {ior_name} must be in [1, 4), got {ior}")
    anisotropy = float(_input(node, "Subsurface Anisotropy", warnings, owner))
    if obj.transcut.principled_mapping == "DIPOLE":
        mapping, surface = "dipole", (1.0, 1.0, 1.0)
    else:
        mapping, surface = CYCLES_MAPPINGS[node.subsurface_method], specular_layer_transmission(node, warnings, owner)
    return MediumSpec(
        "set_medium_artist",
        dict(albedo=albedo.tolist(), radius=radius, scale=scale, ior=ior, anisotropy=anisotropy, mapping=mapping),
        f"material '{material.name}'",
        surface,
    )


def object_medium(obj, warnings: list) -> MediumSpec:
    """The medium the object's TransCut settings ask for."""
    settings = obj.transcut
    if settings.medium_source == "PRESET":
        return MediumSpec("set_medium_preset", dict(name=settings.preset), f"preset {settings.preset}")
    if settings.medium_source == "COEFFICIENTS":
        return MediumSpec(
            "set_medium",
            dict(
                sigma_a=list(settings.sigma_a),
                sigma_s_prime=list(settings.sigma_s_prime),
                eta=settings.eta,
                g=settings.g,
            ),
            "coefficients",
        )
    return material_medium(obj, warnings)


def matrix_array(matrix) -> np.ndarray:
    """A 4×4 ``mathutils.Matrix`` as float64 (4, 4), row-major."""
    return np.array([list(row) for row in matrix], dtype=np.float64)


def world_matrix(obj) -> np.ndarray:
    """The object's world matrix as float64 (4, 4), row-major; BakeError when it is not finite or
    collapses space (a zero scale)."""
    m = matrix_array(obj.matrix_world)
    if not np.all(np.isfinite(m)):
        raise BakeError(f"'{obj.name}' has a non-finite transform (location, rotation or scale)")
    a = m[:3, :3]
    norms = np.linalg.norm(a, axis=0)
    if norms.min() == 0.0 or abs(float(np.linalg.det(a))) <= 1e-9 * float(np.prod(norms)):
        raise BakeError(f"'{obj.name}' has zero scale (its world matrix is singular)")
    return m


def to_world(points: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """Object-space ``points`` (n, 3) mapped by a (4, 4) row-major matrix: float64 (n, 3)."""
    return np.asarray(points, dtype=np.float64).reshape(-1, 3) @ matrix[:3, :3].T + matrix[:3, 3]


def evaluated_triangles(obj, depsgraph) -> tuple:
    """The evaluated mesh of ``obj`` (modifiers applied) in object space: float32 positions
    (n, 3), uint32 triangles (m, 3) and float32 triangle normals (m, 3)."""
    ob_eval = obj.evaluated_get(depsgraph)
    mesh = ob_eval.to_mesh()
    try:
        positions = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", positions)
        mesh.calc_loop_triangles()
        triangles = np.empty(len(mesh.loop_triangles) * 3, dtype=np.uint32)
        mesh.loop_triangles.foreach_get("vertices", triangles)
        normals = np.empty(len(mesh.loop_triangles) * 3, dtype=np.float32)
        mesh.loop_triangles.foreach_get("normal", normals)
    finally:
        ob_eval.to_mesh_clear()
    return positions.reshape(-1, 3), triangles.reshape(-1, 3), normals.reshape(-1, 3)


def check_attribute_name(mesh, name: str, obj_name: str) -> None:
    """The attribute may be new, or an existing FLOAT_COLOR point attribute (a re-bake)."""
    if not name.strip():
        raise BakeError("the attribute name is empty")
    existing = mesh.attributes.get(name)
    if existing is not None and (existing.data_type != "FLOAT_COLOR" or existing.domain != "POINT"):
        raise BakeError(
            f"'{obj_name}': the name '{name}' is taken by a {existing.data_type} {existing.domain} "
            "attribute; choose another attribute name"
        )


def gather_mesh(obj, depsgraph, scene, settings, warnings: list, animated: bool = False) -> MeshJob:
    """The evaluated mesh of one object (modifiers applied), its matrix and medium.

    ``animated``: the first pose of an animation (Bake Animation), whose mesh is never replaced
    (its modifiers play the animation), so a vertex count the modifiers change is no error here
    (``replace_mesh`` stays False)."""
    if obj.type != "MESH":
        raise BakeError(f"'{obj.name}' is a {obj.type.lower()}, not a mesh")
    matrix = world_matrix(obj)
    check_attribute_name(obj.data, settings.attribute_name, obj.name)
    positions, triangles, _ = evaluated_triangles(obj, depsgraph)
    n = len(positions)
    if triangles.size == 0:
        raise BakeError(f"'{obj.name}' has no faces ({n} vertices, 0 triangles); nothing to bake")
    if not np.all(np.isfinite(positions)):
        raise BakeError(f"'{obj.name}' has non-finite vertex coordinates")
    original = len(obj.data.vertices)
    replace = n != original and not animated
    if replace and not settings.apply_modifiers:
        raise BakeError(
            f"'{obj.name}': its modifiers change the vertex count ({original} → {n}); enable "
            "Apply Modifiers to bake the evaluated mesh"
        )
    obj_warnings: list = []
    medium = object_medium(obj, obj_warnings)
    warnings.extend(obj_warnings)
    return MeshJob(
        object_name=obj.name,
        positions=positions,
        triangles=triangles,
        matrix_world=matrix,
        mm_per_unit=mm_per_unit(scene),
        medium=medium,
        original_vertex_count=original,
        replace_mesh=replace,
    )


def selected_meshes(context) -> list:
    """The selected mesh objects; an error when there is none."""
    selected = list(context.selected_objects)
    meshes = [o for o in selected if o.type == "MESH"]
    if not meshes:
        if selected:
            names = ", ".join(f"'{o.name}' ({o.type.lower()})" for o in selected[:5])
            raise BakeError(f"no mesh object selected (selected: {names}); select the mesh objects to bake")
        raise BakeError("no object selected; select the mesh objects to bake")
    return meshes


def gather(context, warnings: list, objects: list | None = None, animated: bool = False) -> list:
    """MeshJobs for ``objects`` (default: the selected meshes); ``animated`` as for
    :func:`gather_mesh`."""
    scene = context.scene
    settings = scene.transcut
    depsgraph = context.evaluated_depsgraph_get()
    objs = objects if objects is not None else selected_meshes(context)
    owners: dict = {}
    for o in objs:
        other = owners.setdefault(o.data.name, o.name)
        if other != o.name:
            raise BakeError(
                f"'{other}' and '{o.name}' share the mesh '{o.data.name}', which can hold one bake; "
                "make them single user (Object ▸ Relations ▸ Make Single User) or bake one at a time"
            )
    return [gather_mesh(o, depsgraph, scene, settings, warnings, animated) for o in objs]


# -- translucent radiosity: the surroundings -------------------------------------------------


def _emission_of(node, colour: str, strength: str, warnings: list, owner: str) -> list:
    """M = π × colour × strength of a node's emission inputs (module docs)."""
    c = np.array(_input(node, colour, warnings, owner)[:3], dtype=np.float64)
    m = np.pi * float(_input(node, strength, warnings, owner)) * c
    return np.where(np.isfinite(m), np.maximum(m, 0.0), 0.0).tolist()


def diffuse_material(obj, warnings: list) -> tuple:
    """(albedo, emission, source) of a surrounding object from its active material (module docs)."""
    material = obj.active_material
    if material is None:
        return list(DEFAULT_ALBEDO), [0.0, 0.0, 0.0], "no material: default grey"
    owner = f"'{obj.name}' material '{material.name}'"
    if len({s.material.name for s in obj.material_slots if s.material is not None}) > 1:
        warnings.append(f"'{obj.name}' has several materials; its active one, '{material.name}', is used for all of it")
    node = principled_node(material)
    if node is None:
        tree = material.node_tree if material.use_nodes else None
        output = tree.get_output_node("ALL") if tree is not None else None
        surface = output.inputs["Surface"] if output is not None else None
        if surface is not None and surface.is_linked and surface.links[0].from_node.type == "EMISSION":
            emission = _emission_of(surface.links[0].from_node, "Color", "Strength", warnings, owner)
            return [0.0, 0.0, 0.0], emission, f"material '{material.name}' (Emission)"
        warnings.append(f"{owner} has no Principled BSDF; it reflects as diffuse grey {DEFAULT_ALBEDO[0]}")
        return list(DEFAULT_ALBEDO), [0.0, 0.0, 0.0], f"material '{material.name}' (no Principled BSDF: default grey)"
    base = np.array(_input(node, "Base Color", warnings, owner)[:3], dtype=np.float64)
    metallic = float(np.clip(_input(node, "Metallic", warnings, owner), 0.0, 1.0))
    albedo = np.clip(np.nan_to_num(base * (1.0 - metallic)), 0.0, DIFFUSE_ALBEDO_MAX)
    if float(_input(node, "Transmission Weight", warnings, owner)) > 0.0:
        warnings.append(f"{owner}: transmission is not modelled; the object is an opaque diffuse surface")
    emission = _emission_of(node, "Emission Color", "Emission Strength", warnings, owner)
    return albedo.tolist(), emission, f"material '{material.name}'"


def _hidden_from_render(obj, hidden_collections: set) -> bool:
    if obj.hide_render:
        return True
    collections = list(obj.users_collection)
    return bool(collections) and all(c.name in hidden_collections for c in collections)


def _render_hidden_collections(scene) -> set:
    """The names of the scene's collections that do not render (their own or a parent's flag)."""
    hidden: set = set()

    def walk(collection, parent_hidden: bool) -> None:
        hide = parent_hidden or collection.hide_render
        if hide:
            hidden.add(collection.name)
        for child in collection.children:
            walk(child, hide)

    walk(scene.collection, False)
    return hidden


def surroundings(context, translucent: list, warnings: list) -> list:
    """The DiffuseJobs of a radiosity bake: every mesh object of the view layer that is visible
    in the viewport (``visible_get``) and renders (neither it nor all its collections hidden from
    render), except the ``translucent`` ones (the selection), each an opaque diffuse surface
    (module docs). Instances (collection instances, particles) are not included.

    An object that cannot be sent (no faces, a singular transform, non-finite coordinates) is
    left out with a warning: it is not what the user asked to bake. Its radiance is written to
    its colour attribute (``write``) when the scene's Write Surroundings is on and that is safe:
    not when its mesh also belongs to another baked object, is linked from a library, its
    modifiers change its vertex count (its modifiers are never applied) or the attribute name
    is taken by another kind of attribute; each of those says so in a warning and the object
    still lights the others."""
    scene = context.scene
    settings = scene.transcut
    view_layer = context.view_layer
    depsgraph = context.evaluated_depsgraph_get()
    chosen = {o.name for o in translucent}
    hidden = _render_hidden_collections(scene)
    objects = [
        o
        for o in view_layer.objects
        if o.type == "MESH"
        and o.name not in chosen
        and o.visible_get(view_layer=view_layer)
        and not _hidden_from_render(o, hidden)
    ]
    users: dict = {}
    for o in [*translucent, *objects]:
        users[o.data.name] = users.get(o.data.name, 0) + 1
    jobs = []
    for obj in objects:
        try:
            matrix = world_matrix(obj)
        except BakeError as exc:
            warnings.append(f"{exc}; left out of the radiosity bake")
            continue
        positions, triangles, _ = evaluated_triangles(obj, depsgraph)
        if triangles.size == 0:
            warnings.append(f"'{obj.name}' has no faces; left out of the radiosity bake")
            continue
        if not np.all(np.isfinite(positions)):
            warnings.append(f"'{obj.name}' has non-finite vertex coordinates; left out of the radiosity bake")
            continue
        albedo, emission, source = diffuse_material(obj, warnings)
        original = len(obj.data.vertices)
        write = bool(settings.radiosity_write_surroundings)
        why = None
        if write and users[obj.data.name] > 1:
            why = f"its mesh '{obj.data.name}' belongs to another baked object too"
        elif write and obj.data.library is not None:
            why = f"its mesh is linked from the library '{obj.data.library.filepath}'"
        elif write and len(positions) != original:
            why = f"its modifiers change its vertex count ({original} → {len(positions)})"
        elif write:
            try:
                check_attribute_name(obj.data, settings.attribute_name, obj.name)
            except BakeError as exc:
                why = str(exc).split(": ", 1)[-1]
        if why is not None:
            warnings.append(f"'{obj.name}': its radiance is not written ({why}); it still lights the bake")
            write = False
        jobs.append(
            DiffuseJob(
                object_name=obj.name,
                positions=positions,
                triangles=triangles,
                matrix_world=matrix,
                mm_per_unit=mm_per_unit(scene),
                albedo=albedo,
                emission=emission,
                source=source,
                original_vertex_count=original,
                write=write,
            )
        )
    return jobs
