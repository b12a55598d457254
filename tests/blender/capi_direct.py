"""The C ABI called directly through ctypes, independently of the add-on's binding.

The reference the add-on's bakes are compared with: the same mesh, medium and lights sent
straight to libtranscut with prototypes declared here from ``include/transcut.h``, with the
Blender unit conversions written out again by hand (so a wrong conversion or a wrong struct
layout in the add-on shows up as a mismatch).
"""

from __future__ import annotations

import ctypes
from ctypes import POINTER, Structure, c_char_p, c_double, c_float, c_int32, c_size_t, c_uint32, c_uint64, c_void_p

import numpy as np

D3 = c_double * 3
PD = POINTER(c_double)


#: TC_ARTIST_* by name, written out here (not imported from the binding under test).
ARTIST_MAPPINGS = {"random-walk": 0, "random-walk-skin": 1, "dipole": 2}


class Artist(Structure):
    _fields_ = [
        ("albedo", D3),
        ("radius", D3),
        ("scale", c_double),
        ("ior", c_double),
        ("anisotropy", c_double),
        ("mapping", c_uint32),
    ]


class Options(Structure):
    _fields_ = [
        ("size", c_uint32),
        ("method", c_uint32),
        ("tets", c_uint64),
        ("tolerance", c_double),
        ("max_iterations", c_uint32),
        ("threads", c_uint32),
        ("shadows", c_uint32),
        ("area_samples", c_uint32),
        ("environment_samples", c_uint32),
        ("backend", c_uint32),
        ("method_options", c_void_p),
    ]


class Polygrid(Structure):
    """``TcPolygridOptions``, written out here from the header (not the binding's)."""

    _fields_ = [
        ("size", c_uint32),
        ("resolution", c_uint32),
        ("nodes", c_uint64),
        ("cube_mm", c_double),
        ("stencil", c_uint32),
        ("solver", c_uint32),
        ("edit_solver", c_uint32),
    ]


#: TC_METHOD_POLYGRID and TC_POLYGRID_STENCIL_* by name, written out here.
METHOD_POLYGRID = 4
POLYGRID_STENCILS = {"fem": 0, "finite-volume": 1, "paper-lsq": 2}


Progress = ctypes.CFUNCTYPE(c_int32, c_void_p, c_char_p, c_double)


def d3(v):
    return D3(*[float(x) for x in v])


class Direct:
    """A minimal client: one scene, built call by call."""

    def __init__(self, path: str):
        self.c = c = ctypes.CDLL(path)
        c.tc_last_error_message.restype = c_char_p
        c.tc_scene_create.argtypes = [POINTER(c_void_p)]
        c.tc_scene_destroy.argtypes = [POINTER(c_void_p)]
        c.tc_scene_destroy.restype = None
        c.tc_scene_add_mesh.argtypes = [
            c_void_p,
            POINTER(c_float),
            c_size_t,
            POINTER(c_uint32),
            c_size_t,
            POINTER(c_uint32),
        ]
        c.tc_object_set_transform.argtypes = [c_void_p, c_uint32, POINTER(c_float)]
        c.tc_object_set_scale.argtypes = [c_void_p, c_uint32, c_double]
        c.tc_object_set_medium_artist.argtypes = [c_void_p, c_uint32, POINTER(Artist)]
        c.tc_scene_add_sun.argtypes = [c_void_p, PD, PD, c_double]
        c.tc_scene_add_point.argtypes = [c_void_p, PD, PD]
        c.tc_scene_add_rect.argtypes = [c_void_p, PD, PD, PD, PD, c_int32]
        c.tc_scene_add_environment.argtypes = [c_void_p, PD]
        c.tc_bake_options_init.argtypes = [POINTER(Options), c_size_t]
        c.tc_polygrid_options_init.argtypes = [POINTER(Polygrid), c_size_t]
        c.tc_scene_bake.argtypes = [c_void_p, POINTER(Options), Progress, c_void_p]
        c.tc_object_vertex_count.argtypes = [c_void_p, c_uint32, POINTER(c_size_t)]
        c.tc_object_radiance.argtypes = [c_void_p, c_uint32, POINTER(c_float), c_size_t]
        c.tc_method_count.argtypes = []
        c.tc_method_count.restype = c_uint32
        c.tc_method_name.argtypes = [c_uint32, c_char_p, c_size_t, POINTER(c_size_t)]
        for name in (
            "tc_scene_create",
            "tc_scene_add_mesh",
            "tc_object_set_transform",
            "tc_object_set_scale",
            "tc_object_set_medium_artist",
            "tc_scene_add_sun",
            "tc_scene_add_point",
            "tc_scene_add_rect",
            "tc_scene_add_environment",
            "tc_scene_bake",
            "tc_object_vertex_count",
            "tc_object_radiance",
            "tc_method_name",
            "tc_polygrid_options_init",
        ):
            getattr(c, name).restype = c_int32

    def method_names(self) -> list:
        """The names of the library's methods, by ``tc_method_count`` and ``tc_method_name``."""
        c = self.c
        names = []
        for method in range(c.tc_method_count()):
            needed = c_size_t()
            self.ok(c.tc_method_name(method, None, 0, ctypes.byref(needed)), "method_name size")
            buf = ctypes.create_string_buffer(needed.value)
            self.ok(c.tc_method_name(method, buf, needed.value, None), "method_name")
            names.append(buf.value.decode())
        return names

    def ok(self, status, what):
        if status != 0:
            raise RuntimeError(f"{what}: status {status}: {self.c.tc_last_error_message().decode()}")

    def bake(self, objects, lights, tets, tolerance, shadows=True, polygrid=None, backend=None):
        """objects: [(positions (n,3) f32 object space, triangles (m,3) u32, matrix (4,4) row-major,
        mm_per_unit, artist dict)]; lights: [(kind, args tuple)]. ``polygrid``: None (the
        library's default method), or a dict of ``TcPolygridOptions`` fields (``stencil`` by
        name) to bake with the polygrid method; ``backend``: a ``TC_BACKEND_*`` value or None
        (the default). Returns [radiance (n,3)]."""
        scene = c_void_p()
        self.ok(self.c.tc_scene_create(ctypes.byref(scene)), "create")
        try:
            ids = []
            for pos, tri, matrix, mm, art in objects:
                pos = np.ascontiguousarray(pos, np.float32)
                tri = np.ascontiguousarray(tri, np.uint32)
                out = c_uint32()
                self.ok(
                    self.c.tc_scene_add_mesh(
                        scene,
                        pos.ctypes.data_as(POINTER(c_float)),
                        pos.shape[0],
                        tri.ctypes.data_as(POINTER(c_uint32)),
                        tri.size,
                        ctypes.byref(out),
                    ),
                    "add_mesh",
                )
                col_major = np.ascontiguousarray(np.asarray(matrix, np.float64).T, np.float32)
                self.ok(
                    self.c.tc_object_set_transform(scene, out.value, col_major.ctypes.data_as(POINTER(c_float))),
                    "transform",
                )
                self.ok(self.c.tc_object_set_scale(scene, out.value, mm), "scale")
                a = Artist(
                    d3(art["albedo"]),
                    d3(art["radius"]),
                    art["scale"],
                    art["ior"],
                    art["anisotropy"],
                    ARTIST_MAPPINGS[art.get("mapping", "random-walk")],
                )
                self.ok(self.c.tc_object_set_medium_artist(scene, out.value, ctypes.byref(a)), "artist")
                ids.append((out.value, pos.shape[0]))
            for kind, args in lights:
                if kind == "sun":
                    self.ok(self.c.tc_scene_add_sun(scene, d3(args[0]), d3(args[1]), float(args[2])), kind)
                elif kind == "point":
                    self.ok(self.c.tc_scene_add_point(scene, d3(args[0]), d3(args[1])), kind)
                elif kind == "rect":
                    self.ok(
                        self.c.tc_scene_add_rect(scene, d3(args[0]), d3(args[1]), d3(args[2]), d3(args[3]), 0), kind
                    )
                elif kind == "env":
                    self.ok(self.c.tc_scene_add_environment(scene, d3(args[0])), kind)
                else:
                    raise ValueError(kind)
            opts = Options()
            self.ok(self.c.tc_bake_options_init(ctypes.byref(opts), ctypes.sizeof(opts)), "options")
            opts.tets = tets
            opts.tolerance = tolerance
            opts.shadows = 1 if shadows else 0
            if backend is not None:
                opts.backend = backend
            grid = Polygrid()  # kept alive until tc_scene_bake has returned
            if polygrid is not None:
                self.ok(self.c.tc_polygrid_options_init(ctypes.byref(grid), ctypes.sizeof(grid)), "polygrid options")
                for key, value in polygrid.items():
                    setattr(grid, key, POLYGRID_STENCILS[value] if key == "stencil" else value)
                opts.method = METHOD_POLYGRID
                opts.method_options = ctypes.addressof(grid)
            self.ok(self.c.tc_scene_bake(scene, ctypes.byref(opts), Progress(), None), "bake")
            results = []
            for idx, n in ids:
                count = c_size_t()
                self.ok(self.c.tc_object_vertex_count(scene, idx, ctypes.byref(count)), "vertex_count")
                assert count.value == n
                rgb = np.empty((n, 3), np.float32)
                self.ok(
                    self.c.tc_object_radiance(scene, idx, rgb.ctypes.data_as(POINTER(c_float)), rgb.size), "radiance"
                )
                results.append(rgb)
            return results
        finally:
            self.c.tc_scene_destroy(ctypes.byref(scene))
