"""Settings: per scene (the method and its options, what a bake produces and how precisely) and
per object (its medium).

``Scene.transcut`` and ``Object.transcut`` attach at register and detach at unregister.
"""

from __future__ import annotations

import bpy
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    FloatVectorProperty,
    IntProperty,
    IntVectorProperty,
    PointerProperty,
    StringProperty,
)

from . import library, transcut

#: The library's measured presets (``tc_medium_preset`` names; Jensen et al. 2001, and jade).
PRESET_NAMES = (
    "apple",
    "chicken1",
    "chicken2",
    "cream",
    "ketchup",
    "marble",
    "potato",
    "skimmilk",
    "skin1",
    "skin2",
    "wholemilk",
    "jade",
)
#: The preset menu's items (name, label, description).
PRESET_ITEMS = tuple((n, n.capitalize(), f"Measured '{n}'") for n in PRESET_NAMES)


#: The Method menu's labels of the library's method names (others: the name in title case).
METHOD_LABELS = {
    "transcut": "TransCut",
    "hierarchical-dipole": "Hierarchical Dipole",
    "radiosity": "Radiosity",
    "prt": "PRT",
    "polygrid": "Polygrid",
}

#: TransCut's gradings: automatic (``TC_GRADING_AUTO``), uniform (0) or graded (Cubes per Size).
GRADING_ITEMS = (
    (
        "AUTO",
        "Automatic",
        "Graded where the medium's boundary layer is thinner than two uniform tetrahedra at this Resolution "
        "(skin's blue, ketchup), uniform elsewhere",
    ),
    ("UNIFORM", "Uniform", "One tetrahedron size everywhere: a cut exposes tetrahedra as fine as the surface's"),
    (
        "GRADED",
        "Graded",
        "The finest tetrahedra near the surface, sizes doubling inwards: the same Resolution gives a finer "
        "surface, but a cut exposes the coarser interior",
    ),
)

#: TransCut's assemblies (``Scene.bake(discretization=...)`` names, upper case with ``_``).
DISCRETIZATION_ITEMS = (
    ("TRANSCUT", "TransCut", "The paper's assembly (cotangent weights, lumped mass)"),
    (
        "FITTED_LAYER",
        "Fitted + layer",
        "Fitted, and each surface vertex's absorption taken from the boundary layer under it: the most "
        "accurate at usual tetrahedron counts, same solve cost (default)",
    ),
    (
        "FITTED",
        "Fitted",
        "Each edge's stiffness exponentially fitted to the boundary layer: more accurate than the paper's where "
        "the tetrahedra are coarse against the diffusion length (skin's blue, ketchup); converges at second order",
    ),
    ("CONSISTENT_FEM", "Consistent FEM", "The P1 finite-element reference (consistent mass)"),
)

#: The polygrid's stencils (``Scene.bake(polygrid_stencil=...)`` names, upper case with ``_``).
POLYGRID_STENCIL_ITEMS = (
    (
        "FEM",
        "FEM",
        "P1 finite elements on the grid cells' tetrahedra (TransCut's assembly): second order on skewed cells; "
        "the bake can be relit and edited",
    ),
    (
        "FINITE_VOLUME",
        "Finite Volume",
        "Two-point fluxes between the grid nodes: exactly conservative, accurate on nearly cubic cells only; "
        "no edits after the bake",
    ),
    (
        "PAPER_LSQ",
        "Paper (least squares)",
        "Wang et al.'s own weights, for comparison: biased where the material changes, not consistent on skewed "
        "cells; no edits after the bake",
    ),
)

#: Translucent radiosity's iterations (``Scene.bake(iteration=...)`` names, upper case with ``_``).
RADIOSITY_ITERATION_ITEMS = (
    ("JACOBI", "Jacobi", "Every patch from the last sweep (Sheng et al.'s); sweep k adds bounce k + 1"),
    (
        "GAUSS_SEIDEL",
        "Gauss-Seidel",
        "Opaque patches from the values already updated in the sweep: about half the sweeps (and half the "
        "translucent objects' diffusion solves) of Jacobi; Bounces needs Jacobi",
    ),
)

#: The hierarchical dipole's modes (``Scene.bake(mode=...)`` names, upper case with ``_``).
DIPOLE_MODE_ITEMS = (
    ("ON_THE_FLY", "On the Fly", "Traverse the cluster trees afresh at every update, storing no links (least memory)"),
    ("RENDER", "Render", "Keep the links: a relight only gathers; a deformation relinks everything"),
    (
        "INCREMENTAL",
        "Incremental",
        "Keep the links and relink only what moved after a deformation (Bake Animation's frames)",
    ),
)

#: The hierarchical dipole's refinement oracles (``Scene.bake(oracle=...)`` names, upper case with ``_``).
DIPOLE_ORACLE_ITEMS = (
    (
        "OPENING_ANGLE",
        "Opening Angle",
        "Link two clusters whole when their radii sum below θ × their distance (the Opening Angle below)",
    ),
    (
        "PAPER",
        "Paper",
        "Mertens et al. 2003's solid-angle test (Epsilon 1, Epsilon 2), for reproducing the paper: "
        "0.5-5.5% off the exact sum where the opening angle 0.4 is 0.04%",
    ),
)

#: The edge rules of the near field's analytic triangle form factor (``Scene.bake(rule=...)``).
DIPOLE_RULE_ITEMS = (
    ("GL3", "Gauss-Legendre", "3-point Gauss-Legendre per edge segment: within 1.2e-4 of brute-force cubature"),
    ("PAPER", "Paper", "The paper's midpoint rule (its eq. 17): 3-17% off away from the receiver"),
)

#: Where the hierarchical dipole evaluates the radiance (``Scene.bake(receivers=...)``).
DIPOLE_RECEIVERS_ITEMS = (
    ("VERTICES", "Vertices", "At every vertex, along its area-weighted normal"),
    ("FACES", "Faces", "At every triangle's centroid (the paper's), averaged onto the vertices by area"),
)

# Blender keeps only pointers to the strings of dynamic enum items: every list handed out stays
# referenced here (one per distinct set of methods, so repeated draws return the same list).
_method_items: dict = {}


def method_items(_settings, _context) -> list:
    """The Method menu's items: the loaded library's methods (``Library.methods``), TransCut
    alone when none is loaded. Identifiers are the library's names, item numbers its
    ``TC_METHOD_*`` values, so a stored choice keeps meaning the same method."""
    lib = library.state.lib
    methods = tuple(lib.methods()) if lib is not None else transcut.scene.TRANSCUT_ONLY
    items = _method_items.get(methods)
    if items is None:
        items = _method_items[methods] = [
            (name, METHOD_LABELS.get(name, name.replace("-", " ").title()), description, number)
            for number, (name, description) in enumerate(methods)
        ]
    return items


class TranscutSceneSettings(bpy.types.PropertyGroup):
    method: EnumProperty(
        name="Method",
        description="The subsurface method that bakes (the methods of the loaded library)",
        items=method_items,
        default=transcut.TC_METHOD_TRANSCUT,
    )
    attribute_name: StringProperty(
        name="Attribute",
        description="Name of the FLOAT_COLOR point attribute the bake writes (and makes active)",
        default="SSS",
    )
    tets: IntProperty(
        name="Resolution",
        description="TransCut: target number of tetrahedra per object (more: finer detail, slower bake)",
        default=100_000,
        min=1_000,
        soft_max=2_000_000,
    )
    grading: EnumProperty(
        name="Grading",
        description="TransCut: how tetrahedron sizes vary through each object",
        items=GRADING_ITEMS,
        default="AUTO",
    )
    grading_layers: IntProperty(
        name="Cubes per Size",
        description=(
            "TransCut, graded: cubes of each size before the size doubles inwards "
            "(1 gives the finest surface for a Resolution and is the most accurate for every preset medium)"
        ),
        default=1,
        min=1,
        max=transcut.TC_MAX_GRADING_LAYERS,
        soft_max=4,
    )
    discretization: EnumProperty(
        name="Assembly",
        description="TransCut: how the diffusion equation is discretised on the tetrahedra",
        items=DISCRETIZATION_ITEMS,
        default="FITTED_LAYER",
    )
    tolerance: FloatProperty(
        name="Tolerance",
        description="Relative residual at which the solver stops (smaller: more precise, slower)",
        default=1e-6,
        min=1e-12,
        max=1e-1,
        precision=8,
    )
    dipole_theta: FloatProperty(
        name="Opening Angle",
        description=(
            "Hierarchical dipole: θ of the opening-angle oracle; two clusters are linked whole when their radii "
            "sum below θ × their distance (smaller: more accurate, slower; 0.6 fast, 0.3 accurate)"
        ),
        default=0.4,
        min=0.05,
        max=1.0,
        precision=2,
    )
    dipole_oracle: EnumProperty(
        name="Oracle",
        description="Hierarchical dipole: the test that decides which clusters are linked whole",
        items=DIPOLE_ORACLE_ITEMS,
        default="OPENING_ANGLE",
    )
    dipole_eps1: FloatProperty(
        name="Epsilon 1",
        description=(
            "Hierarchical dipole, paper oracle: how differently (in solid angle) a receiver cluster's children may "
            "see an emitter before the cluster is opened (smaller: more accurate, slower)"
        ),
        default=0.05,
        min=1e-4,
        soft_max=1.0,
        precision=3,
    )
    dipole_eps2: FloatProperty(
        name="Epsilon 2",
        description=(
            "Hierarchical dipole, paper oracle: the largest solid angle area/distance² under which an emitter "
            "cluster is linked whole (smaller: more accurate, slower)"
        ),
        default=0.05,
        min=1e-4,
        soft_max=1.0,
        precision=3,
    )
    dipole_rule: EnumProperty(
        name="Edge Rule",
        description="Hierarchical dipole: the edge rule of the near field's analytic triangle form factor",
        items=DIPOLE_RULE_ITEMS,
        default="GL3",
    )
    dipole_receivers: EnumProperty(
        name="Receivers",
        description="Hierarchical dipole: where the radiance is evaluated",
        items=DIPOLE_RECEIVERS_ITEMS,
        default="VERTICES",
    )
    dipole_mode: EnumProperty(
        name="Mode",
        description="Hierarchical dipole: when the links between the cluster trees are made",
        items=DIPOLE_MODE_ITEMS,
        default="INCREMENTAL",
    )
    dipole_budget: IntProperty(
        name="Budget",
        description=(
            "Hierarchical dipole, incremental mode: relink at most about this many links per frame, oldest first, "
            "keeping the others as they were (the error decays once the motion stops); 0: no limit"
        ),
        default=0,
        min=0,
        soft_max=10_000_000,
    )
    radiosity_patch_size: FloatProperty(
        name="Patch Size",
        description=(
            "Radiosity: the longest patch edge on the surrounding (opaque) objects; their meshes are refined to it "
            "so a two-triangle floor can carry a shadow and colour bleeding (smaller: finer, slower). "
            "0: the scene's bounding-box diagonal / 80"
        ),
        default=0.0,
        min=0.0,
        soft_max=10.0,
        subtype="DISTANCE",
        unit="LENGTH",
    )
    radiosity_rays: IntProperty(
        name="Rays per Patch",
        description="Radiosity: rays cast from each patch for the form factors (more: less noise, slower)",
        default=512,
        min=1,
        max=transcut.TC_MAX_RAYS_PER_PATCH,
        soft_max=8192,
    )
    radiosity_iteration: EnumProperty(
        name="Iteration",
        description="Radiosity: how the light is passed between the patches",
        items=RADIOSITY_ITERATION_ITEMS,
        default="JACOBI",
    )
    radiosity_bounces: IntProperty(
        name="Bounces",
        description=(
            "Radiosity: exactly this many bounces of light (1: the lights and the emission only, no inter-reflection), "
            "whatever the tolerance; needs the Jacobi iteration. 0: until the Radiosity Tolerance"
        ),
        default=0,
        min=0,
        max=transcut.TC_MAX_RADIOSITY_ITERATIONS,
        soft_max=50,
    )
    radiosity_tolerance: FloatProperty(
        name="Radiosity Tolerance",
        description="Radiosity: the estimated relative error in power at which the bounces stop",
        default=1e-3,
        min=1e-9,
        max=0.5,
        precision=6,
    )
    radiosity_write_surroundings: BoolProperty(
        name="Write Surroundings",
        description=(
            "Radiosity: also write the radiance of the visible meshes around the selection (the surfaces the bake "
            "treats as opaque diffuse) into their colour attribute of the same name: their lighting with the "
            "translucent objects' shadows and colour bleeding. Off: only the selected objects change"
        ),
        default=True,
    )
    prt_samples: IntProperty(
        name="Samples (log2)",
        description=(
            "PRT: log2 of the irradiance samples on the surface (16: 65536). More resolve denser media and sharper "
            "shadows; the precompute and the transfer grow with them"
        ),
        default=16,
        min=8,
        max=18,
    )
    prt_terms: IntProperty(
        name="Terms per Vertex",
        description=(
            "PRT: Haar coefficients kept per vertex (about 3 bytes each). Fewer relight faster and are less "
            "accurate under sharp light"
        ),
        default=1024,
        min=16,
        max=65536,
    )
    prt_basis: EnumProperty(
        name="Basis",
        description="PRT: the PCA basis of the dipole profile",
        items=(
            ("16", "16 Functions", "Accurate for every measured medium, dense ones included (default)"),
            ("12", "12 Functions", "The paper's basis: media up to 5/mm"),
        ),
        default="16",
    )
    prt_keep: BoolProperty(
        name="Keep Precomputes",
        description=(
            "PRT: save each object's precompute in a cache folder (next to the .blend file in transcut_cache/prt, "
            "else a temporary folder) and read it back when the same mesh, placement and options are baked again, "
            "so a rebake or Live Translucency starts at once"
        ),
        default=True,
    )
    polygrid_nodes: IntProperty(
        name="Grid Nodes",
        description=(
            "Polygrid: target number of grid nodes per object (more: finer detail, slower bake); with the Cells per "
            "Cube it sets the polycube's cube size unless Cube Size is set"
        ),
        default=200_000,
        min=8,
        max=transcut.TC_MAX_POLYGRID_NODES,
        soft_min=1_000,
        soft_max=2_000_000,
    )
    polygrid_cube: FloatProperty(
        name="Cube Size",
        description=(
            "Polygrid: the edge of the polycube's cubes (made smaller where the polycube would change the object's "
            "topology or the grid fold). 0: from the Grid Nodes"
        ),
        default=0.0,
        min=0.0,
        soft_max=10.0,
        subtype="DISTANCE",
        unit="LENGTH",
    )
    polygrid_resolution: IntProperty(
        name="Cells per Cube",
        description="Polygrid: grid cells along each cube edge (the paper uses 12 to 32)",
        default=8,
        min=1,
        max=transcut.TC_MAX_POLYGRID_RESOLUTION,
        soft_max=32,
    )
    polygrid_stencil: EnumProperty(
        name="Stencil",
        description="Polygrid: the discretisation of the diffusion equation on the grid",
        items=POLYGRID_STENCIL_ITEMS,
        default="FEM",
    )
    keep_bakes: BoolProperty(
        name="Keep Bakes",
        description=(
            "Keep each bake's tetrahedra and solution, so that baking the same objects again after a light "
            "or world change only relights them (no re-meshing); any other change bakes afresh"
        ),
        default=True,
    )
    kept_tets: IntProperty(
        name="Kept Tetrahedra",
        description="Most tetrahedra kept over all kept bakes (about 1 KB each); the least recently used go first",
        default=2_000_000,
        min=0,
    )
    shadows: BoolProperty(
        name="Shadows",
        description="Objects shadow the lights (each other and themselves)",
        default=True,
    )
    backend: EnumProperty(
        name="Backend",
        description="Where the diffusion solve runs",
        items=(
            ("AUTO", "Auto", "The GPU when a hardware GPU exists, else the CPU (a software Vulkan device is not used)"),
            ("CPU", "CPU", "The CPU (always available)"),
            ("GPU", "GPU", "The GPU, also a software device such as lavapipe; the bake fails when there is none"),
        ),
        default="AUTO",
    )
    apply_modifiers: BoolProperty(
        name="Apply Modifiers",
        description=(
            "When the modifiers change the vertex count, replace the mesh by the evaluated one "
            "(modifiers applied) so the attribute has a value per baked vertex; off: such objects "
            "are an error"
        ),
        default=True,
    )


#: Where a medium comes from (EnumProperty items).
MEDIUM_SOURCES = {
    "MATERIAL": ("MATERIAL", "Material", "Principled BSDF subsurface inputs of the object's material"),
    "PRESET": ("PRESET", "Preset", "A measured material"),
    "COEFFICIENTS": ("COEFFICIENTS", "Coefficients", "Absorption and reduced scattering coefficients in 1/mm"),
}


def medium_properties(
    description: str, sources: tuple, preset: str, sigma_a: tuple, sigma_s_prime: tuple, update=None
) -> dict:
    """The properties that choose a medium, as class annotations: ``medium_source`` (one of
    ``sources``, the first the default), ``preset`` and the coefficients ``sigma_a`` and
    ``sigma_s_prime``, with the given defaults, each calling ``update`` when it changes. Shared
    by ``Object.transcut`` and the paint operator."""
    return {
        "medium_source": EnumProperty(
            name="Medium",
            description=description,
            items=tuple(MEDIUM_SOURCES[s] for s in sources),
            default=sources[0],
            update=update,
        ),
        "preset": EnumProperty(name="Preset", items=PRESET_ITEMS, default=preset, update=update),
        "sigma_a": FloatVectorProperty(
            name="Absorption",
            description="Absorption coefficient σa per RGB channel, 1/mm",
            size=3,
            min=0.0,
            default=sigma_a,
            precision=5,
            update=update,
        ),
        "sigma_s_prime": FloatVectorProperty(
            name="Reduced Scattering",
            description="Reduced scattering coefficient σ′s per RGB channel, 1/mm",
            size=3,
            min=0.0,
            default=sigma_s_prime,
            precision=4,
            update=update,
        ),
    }


def draw_medium(layout, settings, coefficients: tuple = ("sigma_a", "sigma_s_prime")) -> None:
    """Draws a medium choice made by :func:`medium_properties`: the source, then the preset, the
    ``coefficients`` properties, or what a material gives."""
    layout.prop(settings, "medium_source")
    if settings.medium_source == "PRESET":
        layout.prop(settings, "preset")
    elif settings.medium_source == "COEFFICIENTS":
        for name in coefficients:
            layout.prop(settings, name)
    else:
        layout.label(text="Principled BSDF subsurface inputs")
        if hasattr(settings, "principled_mapping"):
            layout.prop(settings, "principled_mapping")


def _tag_owner(settings, _context) -> None:
    """Tags the object owning ``settings`` for the depsgraph, so its update handlers (Live
    Translucency) see a change made in the panel or by a script."""
    settings.id_data.update_tag()


class TranscutBakeReport(bpy.types.PropertyGroup):
    """What the last bake of the object did (``bake.record_bake``; the panel shows it)."""

    __annotations__ = {
        "valid": BoolProperty(name="Baked", description="Whether the object has been baked", default=False),
        "seconds": FloatProperty(
            name="Time", description="Wall time of the last bake's library work", unit="TIME_ABSOLUTE"
        ),
        "outcome": StringProperty(name="Outcome", description="baked, rebaked (a kept scene), relit or kept"),
        "method": StringProperty(name="Method", description="The method that baked it"),
        "tets": IntProperty(name="Tetrahedra", description="Tetrahedra solved on (0 for a method without)"),
        "iterations": IntVectorProperty(name="Iterations", description="Solver iterations per channel", size=3),
        "clamped_vertices": IntProperty(
            name="Clamped Vertices",
            description="Vertices whose diffusion radiance came out negative and was clamped to 0 (very absorbing "
            "media on coarse meshes: raise Resolution)",
        ),
        "mesh_reused": BoolProperty(name="Tets Kept", description="The tetrahedra were kept from the previous bake"),
    }


class TranscutObjectSettings(bpy.types.PropertyGroup):
    __annotations__ = {
        **medium_properties(
            "Where the object's scattering medium comes from",
            ("MATERIAL", "PRESET", "COEFFICIENTS"),
            preset="marble",
            sigma_a=(0.0021, 0.0041, 0.0071),
            sigma_s_prime=(2.19, 2.62, 3.00),
            update=_tag_owner,
        ),
        "principled_mapping": EnumProperty(
            name="Read As",
            description="How the Principled BSDF's Base Color and Subsurface Radius become a medium",
            items=(
                (
                    "CYCLES",
                    "Cycles",
                    "As Cycles renders them (Random Walk, Christensen-Burley: radius/4π is the mean free path; "
                    "Random Walk (Skin): the radius is a diffusion length), under the specular layer: "
                    "the bake looks like Cycles' own",
                ),
                (
                    "DIPOLE",
                    "Dipole Inversion",
                    "The radius is the reduced mean free path and a thick slab reflects Base Color in the classical "
                    "dipole at the IOR (Jensen et al. 2001), as libtranscut before Cycles' mapping",
                ),
            ),
            default="CYCLES",
            update=_tag_owner,
        ),
        "eta": FloatProperty(
            name="IOR", description="Refractive index", default=1.3, min=1.0, max=3.99, update=_tag_owner
        ),
        "g": FloatProperty(
            name="Anisotropy",
            description="Scattering anisotropy g",
            default=0.0,
            min=-0.99,
            max=0.99,
            update=_tag_owner,
        ),
        "last_bake": PointerProperty(type=TranscutBakeReport),
    }


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(
    (TranscutSceneSettings, TranscutBakeReport, TranscutObjectSettings)
)


def register():
    _register_classes()
    bpy.types.Scene.transcut = PointerProperty(type=TranscutSceneSettings)
    bpy.types.Object.transcut = PointerProperty(type=TranscutObjectSettings)


def unregister():
    del bpy.types.Object.transcut
    del bpy.types.Scene.transcut
    _unregister_classes()
