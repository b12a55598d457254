"""Selected mesh objects → arrays and media for the library, checked before anything is baked.

Every check that could fail happens here, before the bake and before any write, so a failed
bake leaves the scene exactly as it was. Arrays move with ``foreach_get`` into NumPy buffers.

Units: positions stay in object space and the object's world matrix goes to the library
(``tc_object_set_transform``), so the baked mesh is the world-space evaluated mesh. One scene
unit is ``scene.unit_settings.scale_length`` metres, so mm_per_unit = scale_length × 1000.
The Principled BSDF's Subsurface Radius × Subsurface Scale is a length in scene (world) units,
converted by the library with that mm_per_unit (``tc_object_set_medium_artist``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Base Color is the diffuse reflectance the medium must reproduce; the conversion needs it in
#: the open interval (0, 1), so it is clamped to [ALBEDO_MIN, ALBEDO_MAX].
ALBEDO_MIN = 1e-3
ALBEDO_MAX = 0.999


class BakeError(Exception):
    """A problem with the user's scene or settings; the message is shown as it is."""


@dataclass
class MediumSpec:
    """How to set an object's medium: ``getattr(transcut.Scene, method)(obj, **kwargs)``."""

    method: str
    kwargs: dict
    source: str  # e.g. "material 'Marble'" or "preset marble"


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


def material_medium(obj, warnings: list) -> MediumSpec:
    """Artist parameters of the object's first material with a Principled BSDF whose
    Subsurface Weight is above 0."""
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
    return MediumSpec(
        "set_medium_artist",
        dict(albedo=albedo.tolist(), radius=radius, scale=scale, ior=ior, anisotropy=anisotropy),
        f"material '{material.name}'",
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
