"""ctypes mirror of the libtranscut C ABI (``include/transcut.h``).

This module is self-contained (it needs only the standard library and NumPy, never ``bpy``), so
the same file is shipped as the ``transcut`` Python package (``scripts/package-addon.py`` copies
it into the wheel as ``transcut/__init__.py`` beside the shared library) and works with a plain
``pip install`` outside Blender.

Finding the library (:func:`library_candidates`, first existing file wins):

1. the ``TRANSCUT_LIB`` environment variable (a full path to the shared library);
2. the folder of this file (the wheel's package folder, or an extension folder that bundles it);
3. the folder of an installed ``transcut`` package (the wheel the Blender extension carries);
4. a development checkout: ``../target/release`` then ``../target/debug`` beside this file.

Every function prototype (``argtypes``/``restype``) is declared once, when the library is loaded.
Every call's status is checked; a failure raises :class:`TranscutError` carrying the status code,
its name and the library's thread-local message (``tc_last_error_message``), read on the thread
that made the call. Scenes are freed by :meth:`Scene.close` (also on ``with`` exit and at garbage
collection).

Example (a unit cube of marble lit by a white sky)::

    import numpy as np, transcut
    lib = transcut.load()
    with lib.scene() as scene:
        obj = scene.add_mesh(positions, triangles)     # float32 (n, 3), uint32 (m, 3)
        scene.set_scale(obj, 10.0)                      # 10 mm per unit
        scene.set_medium_preset(obj, "marble")
        scene.add_environment((1.0, 1.0, 1.0))
        scene.bake(tets=20000)
        rgb = scene.radiance(obj)                       # float32 (n, 3), linear RGB
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
import sys
from ctypes import (
    CFUNCTYPE,
    POINTER,
    Structure,
    c_char_p,
    c_double,
    c_float,
    c_int32,
    c_size_t,
    c_uint32,
    c_uint64,
    c_uint8,
    c_void_p,
)
from typing import Callable, Optional, Sequence

import numpy as np

__all__ = [
    "ABI_MAJOR",
    "STATUS_NAMES",
    "Library",
    "LibraryNotFound",
    "Scene",
    "TcArtistMedium",
    "TcBakeOptions",
    "TcBakeStats",
    "TcEditStats",
    "TcMedium",
    "TcMediumEdit",
    "TranscutError",
    "library_candidates",
    "library_file_name",
    "load",
]

#: The ABI major version this binding was written against (``tc_version() >> 16``).
ABI_MAJOR = 0

# Status codes (values fixed by the C ABI; only ever appended).
TC_OK = 0
TC_NULL_POINTER = 1
TC_INVALID_ARGUMENT = 2
TC_INVALID_HANDLE = 3
TC_BUFFER_TOO_SHORT = 4
TC_INVALID_MESH = 5
TC_MESHING_FAILED = 6
TC_SOLVE_FAILED = 7
TC_NOT_FOUND = 8
TC_IO_ERROR = 9
TC_CANCELLED = 10
TC_NOT_BAKED = 11
TC_INTERNAL_ERROR = 12
TC_BUSY = 13
TC_GPU_UNAVAILABLE = 14
TC_NOTHING_LEFT = 15

STATUS_NAMES = {
    TC_OK: "TC_OK",
    TC_NULL_POINTER: "TC_NULL_POINTER",
    TC_INVALID_ARGUMENT: "TC_INVALID_ARGUMENT",
    TC_INVALID_HANDLE: "TC_INVALID_HANDLE",
    TC_BUFFER_TOO_SHORT: "TC_BUFFER_TOO_SHORT",
    TC_INVALID_MESH: "TC_INVALID_MESH",
    TC_MESHING_FAILED: "TC_MESHING_FAILED",
    TC_SOLVE_FAILED: "TC_SOLVE_FAILED",
    TC_NOT_FOUND: "TC_NOT_FOUND",
    TC_IO_ERROR: "TC_IO_ERROR",
    TC_CANCELLED: "TC_CANCELLED",
    TC_NOT_BAKED: "TC_NOT_BAKED",
    TC_INTERNAL_ERROR: "TC_INTERNAL_ERROR",
    TC_BUSY: "TC_BUSY",
    TC_GPU_UNAVAILABLE: "TC_GPU_UNAVAILABLE",
    TC_NOTHING_LEFT: "TC_NOTHING_LEFT",
}

TC_METHOD_TRANSCUT = 0

# TcBakeOptions.backend: where the diffusion solve runs; TcBakeStats.backend_used: 1 or 2.
TC_BACKEND_DEFAULT = 0  # TRANSCUT_BACKEND (cpu, gpu, auto), else auto
TC_BACKEND_CPU = 1
TC_BACKEND_GPU = 2  # TC_GPU_UNAVAILABLE when no adapter can be used
TC_BACKEND_AUTO = 3  # a hardware GPU if there is one, else the CPU (tc_object_backend_fallback says why)

#: ``backend`` option names accepted by :meth:`Scene.bake` (besides the integer values).
BACKENDS = {"default": TC_BACKEND_DEFAULT, "cpu": TC_BACKEND_CPU, "gpu": TC_BACKEND_GPU, "auto": TC_BACKEND_AUTO}

# TcMediumEdit.region and .op (tc_object_edit_medium).
TC_REGION_ALL = 0
TC_REGION_SPHERE = 1
TC_REGION_DEPTH = 2
TC_REGION_MASK = 3
TC_MEDIUM_ASSIGN = 0
TC_MEDIUM_SCALE = 1
TC_MEDIUM_ADD = 2


class TcMedium(Structure):
    """``TcMedium``: physical coefficients in mm⁻¹ per RGB channel, relative index η, anisotropy g."""

    _fields_ = [
        ("sigma_a", c_double * 3),
        ("sigma_s_prime", c_double * 3),
        ("eta", c_double),
        ("g", c_double),
    ]


class TcArtistMedium(Structure):
    """``TcArtistMedium``: Principled-BSDF style parameters (radius in scene units)."""

    _fields_ = [
        ("albedo", c_double * 3),
        ("radius", c_double * 3),
        ("scale", c_double),
        ("ior", c_double),
        ("anisotropy", c_double),
    ]


class TcBakeOptions(Structure):
    """``TcBakeOptions`` (starts with its own ``size``; filled by ``tc_bake_options_default``)."""

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
    ]


class TcBakeStats(Structure):
    """``TcBakeStats`` (the caller sets ``size`` before ``tc_object_stats``)."""

    _fields_ = [
        ("size", c_uint32),
        ("tets", c_uint64),
        ("vertices", c_uint64),
        ("iterations", c_uint32 * 3),
        ("meshing_ms", c_double),
        ("assembly_ms", c_double),
        ("source_ms", c_double),
        ("solve_ms", c_double),
        ("total_ms", c_double),
        ("clamped_vertices", c_uint64),
        ("backend_used", c_uint32),
    ]


class TcMediumEdit(Structure):
    """``TcMediumEdit`` (``tc_object_edit_medium``; set ``size``)."""

    _fields_ = [
        ("size", c_uint32),
        ("region", c_uint32),
        ("center", c_double * 3),
        ("radius", c_double),
        ("min_mm", c_double),
        ("max_mm", c_double),
        ("mask", POINTER(c_uint8)),
        ("mask_len", c_size_t),
        ("op", c_uint32),
        ("sigma_a", c_double * 3),
        ("sigma_s_prime", c_double * 3),
    ]


class TcEditStats(Structure):
    """``TcEditStats`` (``tc_object_edit_stats``; the caller sets ``size``)."""

    _fields_ = [
        ("size", c_uint32),
        ("pieces_solved", c_uint32),
        ("iterations", c_uint32 * 3),
        ("cut", c_uint32),
        ("rows_rebuilt", c_uint64),
        ("tets_changed", c_uint64),
        ("source_ms", c_double),
        ("assembly_ms", c_double),
        ("hierarchy_ms", c_double),
        ("solve_ms", c_double),
        ("total_ms", c_double),
        ("cut_removed_tets", c_uint64),
        ("cut_removed_vertices", c_uint64),
        ("cut_moved_vertices", c_uint64),
        ("cut_surface_vertices", c_uint64),
        ("cut_max_distance", c_double),
        ("cut_min_dihedral_degrees", c_double),
        ("cut_bound_degrees", c_double),
    ]


class _TcScene(Structure):
    """Opaque ``TcScene``."""


_ScenePtr = POINTER(_TcScene)

#: ``typedef int32_t (*TcProgressFn)(void *user, const char *stage, double fraction)``;
#: a non-zero return cancels the bake.
TcProgressFn = CFUNCTYPE(c_int32, c_void_p, c_char_p, c_double)

_d3 = POINTER(c_double)
_f = POINTER(c_float)
_u32 = POINTER(c_uint32)

# name: (restype, argtypes). TcStatus is a transparent int32_t.
# What the Blender add-on needs: a library without one of these is refused at load.
_REQUIRED = {
    "tc_version": (c_uint32, []),
    "tc_version_string": (c_char_p, []),
    "tc_last_error_message": (c_char_p, []),
    "tc_scene_create": (c_int32, [POINTER(_ScenePtr)]),
    "tc_scene_destroy": (None, [POINTER(_ScenePtr)]),
    "tc_scene_add_mesh": (c_int32, [_ScenePtr, _f, c_size_t, _u32, c_size_t, _u32]),
    "tc_object_set_transform": (c_int32, [_ScenePtr, c_uint32, _f]),
    "tc_object_set_scale": (c_int32, [_ScenePtr, c_uint32, c_double]),
    "tc_object_vertex_count": (c_int32, [_ScenePtr, c_uint32, POINTER(c_size_t)]),
    "tc_medium_preset": (c_int32, [c_char_p, POINTER(TcMedium)]),
    "tc_object_set_medium": (c_int32, [_ScenePtr, c_uint32, POINTER(TcMedium)]),
    "tc_object_set_medium_preset": (c_int32, [_ScenePtr, c_uint32, c_char_p]),
    "tc_object_set_medium_artist": (c_int32, [_ScenePtr, c_uint32, POINTER(TcArtistMedium)]),
    "tc_scene_add_sun": (c_int32, [_ScenePtr, _d3, _d3, c_double]),
    "tc_scene_add_point": (c_int32, [_ScenePtr, _d3, _d3]),
    "tc_scene_add_spot": (c_int32, [_ScenePtr, _d3, _d3, _d3, c_double, c_double]),
    "tc_scene_add_rect": (c_int32, [_ScenePtr, _d3, _d3, _d3, _d3, c_int32]),
    "tc_scene_add_disc": (c_int32, [_ScenePtr, _d3, _d3, c_double, _d3, c_int32]),
    "tc_scene_add_environment": (c_int32, [_ScenePtr, _d3]),
    "tc_scene_add_environment_image": (c_int32, [_ScenePtr, _f, c_size_t, c_size_t, c_double]),
    "tc_bake_options_default": (None, [POINTER(TcBakeOptions)]),
    "tc_scene_bake": (c_int32, [_ScenePtr, POINTER(TcBakeOptions), TcProgressFn, c_void_p]),
    "tc_object_radiance": (c_int32, [_ScenePtr, c_uint32, _f, c_size_t]),
}
# The rest of the header: bound when the library has them; calling a missing one raises.
_OPTIONAL = {
    "tc_status_name": (c_char_p, [c_int32]),
    "tc_scene_object_count": (c_int32, [_ScenePtr, POINTER(c_uint32)]),
    "tc_scene_light_count": (c_int32, [_ScenePtr, POINTER(c_uint32)]),
    "tc_object_set_name": (c_int32, [_ScenePtr, c_uint32, c_char_p]),
    "tc_scene_add_mesh_file": (c_int32, [_ScenePtr, c_char_p, _u32]),
    "tc_scene_add_tet_mesh": (c_int32, [_ScenePtr, _f, c_size_t, _u32, c_size_t, _u32, _u32]),
    "tc_medium_from_artist": (c_int32, [POINTER(TcArtistMedium), c_double, POINTER(TcMedium)]),
    "tc_object_set_media_table": (c_int32, [_ScenePtr, c_uint32, POINTER(TcMedium), c_size_t]),
    "tc_object_set_media_per_tet": (c_int32, [_ScenePtr, c_uint32, _f, _f, c_size_t, c_double, c_double]),
    "tc_object_set_medium_voxels": (
        c_int32,
        [_ScenePtr, c_uint32, _u32, _d3, _d3, _f, c_size_t, c_double, c_double],
    ),
    "tc_object_set_medium_voxel_file": (c_int32, [_ScenePtr, c_uint32, c_char_p, c_double, c_double]),
    "tc_scene_add_environment_file": (c_int32, [_ScenePtr, c_char_p, c_double]),
    "tc_scene_clear_lights": (c_int32, [_ScenePtr]),
    "tc_object_stats": (c_int32, [_ScenePtr, c_uint32, POINTER(TcBakeStats)]),
    "tc_object_device": (c_int32, [_ScenePtr, c_uint32, c_char_p, c_size_t, POINTER(c_size_t)]),
    "tc_object_backend_fallback": (c_int32, [_ScenePtr, c_uint32, c_char_p, c_size_t, POINTER(c_size_t)]),
    # Editing (after a bake).
    "tc_scene_relight": (c_int32, [_ScenePtr, TcProgressFn, c_void_p]),
    "tc_object_tet_count": (c_int32, [_ScenePtr, c_uint32, POINTER(c_size_t)]),
    "tc_object_edit_medium": (c_int32, [_ScenePtr, c_uint32, POINTER(TcMediumEdit)]),
    "tc_object_paint": (c_int32, [_ScenePtr, c_uint32, _d3, c_size_t, c_double, POINTER(TcMedium), c_double]),
    "tc_object_cut_plane": (c_int32, [_ScenePtr, c_uint32, _d3, _d3, c_int32]),
    "tc_object_cut_stroke": (c_int32, [_ScenePtr, c_uint32, _d3, _d3, c_size_t, c_int32]),
    "tc_object_cut_mesh": (c_int32, [_ScenePtr, c_uint32, _f, c_size_t, _u32, c_size_t, c_int32]),
    "tc_object_fracture": (c_int32, [_ScenePtr, c_uint32, _u32]),
    "tc_object_recombine": (c_int32, [_ScenePtr, c_uint32, _u32]),
    "tc_object_piece_count": (c_int32, [_ScenePtr, c_uint32, _u32]),
    "tc_object_set_piece_transform": (c_int32, [_ScenePtr, c_uint32, c_uint32, _d3]),
    "tc_object_piece_transform": (c_int32, [_ScenePtr, c_uint32, c_uint32, _d3]),
    "tc_object_piece_sizes": (c_int32, [_ScenePtr, c_uint32, c_uint32, POINTER(c_size_t), POINTER(c_size_t)]),
    "tc_object_piece_mesh": (c_int32, [_ScenePtr, c_uint32, c_uint32, _f, c_size_t, _u32, c_size_t, _f, c_size_t]),
    "tc_object_edit_stats": (c_int32, [_ScenePtr, c_uint32, POINTER(TcEditStats)]),
}


class TranscutError(RuntimeError):
    """A libtranscut call failed: ``status`` (int), ``status_name`` and the library's message."""

    def __init__(self, status: int, call: str, message: str):
        self.status = status
        self.status_name = STATUS_NAMES.get(status, f"status {status}")
        self.call = call
        self.message = message
        super().__init__(f"{call}: {message or self.status_name} ({self.status_name})")


class LibraryNotFound(OSError):
    """The shared library could not be loaded: ``tried`` lists ``(path, reason)`` per candidate."""

    def __init__(self, tried: Sequence[tuple[str, str]]):
        self.tried = list(tried)
        lines = "; ".join(f"{p}: {why}" for p, why in self.tried) or "no candidate path"
        super().__init__(f"libtranscut could not be loaded ({lines})")


def library_file_name(platform: str = sys.platform) -> str:
    """The shared library's file name on ``platform`` (``sys.platform`` spelling)."""
    if platform.startswith("win"):
        return "transcut.dll"
    if platform == "darwin":
        return "libtranscut.dylib"
    return "libtranscut.so"


def library_candidates() -> list[str]:
    """The paths tried in order (see the module docs), without duplicates."""
    name = library_file_name()
    here = os.path.dirname(os.path.abspath(__file__))
    paths = []
    env = os.environ.get("TRANSCUT_LIB")
    if env:
        paths.append(os.path.abspath(env))
    paths.append(os.path.join(here, name))
    try:
        spec = importlib.util.find_spec("transcut")
    except (ImportError, ValueError):
        spec = None
    if spec is not None and spec.submodule_search_locations:
        for folder in spec.submodule_search_locations:
            paths.append(os.path.join(os.path.abspath(folder), name))
    root = os.path.dirname(here)
    paths.append(os.path.join(root, "target", "release", name))
    paths.append(os.path.join(root, "target", "debug", name))
    seen = set()
    return [p for p in paths if not (p in seen or seen.add(p))]


def load(path: Optional[str] = None) -> "Library":
    """Loads the library from ``path`` (else ``TRANSCUT_LIB``), or from the first default
    candidate that exists. An explicit path or ``TRANSCUT_LIB`` is the only one tried.

    Raises :class:`LibraryNotFound` naming every path tried and why it failed (missing file,
    loader error, ABI version mismatch).
    """
    if not path and os.environ.get("TRANSCUT_LIB"):
        path = os.environ["TRANSCUT_LIB"]
    candidates = [os.path.abspath(path)] if path else library_candidates()
    tried = []
    for candidate in candidates:
        if not os.path.isfile(candidate):
            tried.append((candidate, "no such file"))
            # An explicit path or TRANSCUT_LIB that is missing is an error of its own; keep
            # looking only through the default locations.
            if path:
                break
            continue
        try:
            return Library(candidate)
        except (OSError, AttributeError, TranscutError) as exc:
            tried.append((candidate, str(exc)))
            if path:
                break
    raise LibraryNotFound(tried)


def _vec3(values, what: str):
    arr = (c_double * 3)()
    vals = [float(v) for v in values]
    if len(vals) != 3:
        raise ValueError(f"{what} needs 3 values, got {len(vals)}")
    for i, v in enumerate(vals):
        arr[i] = v
    return arr


class Library:
    """A loaded libtranscut: the ``CDLL`` with every prototype declared, and its version."""

    def __init__(self, path: str):
        self.path = os.path.abspath(path)
        self.cdll = ctypes.CDLL(self.path)
        missing = []
        self.optional_missing = []
        for table, absent in ((_REQUIRED, missing), (_OPTIONAL, self.optional_missing)):
            for name, (restype, argtypes) in table.items():
                try:
                    fn = getattr(self.cdll, name)
                except AttributeError:
                    absent.append(name)
                    continue
                fn.restype = restype
                fn.argtypes = argtypes
        if missing:
            raise AttributeError(f"{self.path} lacks {', '.join(missing)} (not a libtranscut build?)")
        self.version = int(self.cdll.tc_version())
        self.version_string = (self.cdll.tc_version_string() or b"").decode("utf-8", "replace")
        if self.version >> 16 != ABI_MAJOR:
            raise OSError(
                f"{self.path} is libtranscut {self.version_string}; this binding needs ABI major "
                f"version {ABI_MAJOR}"
            )

    def has(self, name: str) -> bool:
        """Whether the library exports the C function ``name``."""
        return hasattr(self.cdll, name) and name not in self.optional_missing

    def function(self, name: str):
        """The C function ``name`` (prototype declared); AttributeError naming it if absent."""
        if name in self.optional_missing:
            raise AttributeError(f"{self.path} ({self.version_string}) has no {name}")
        return getattr(self.cdll, name)

    def last_error_message(self) -> str:
        """``tc_last_error_message()`` of the calling thread ('' when none)."""
        msg = self.cdll.tc_last_error_message()
        return msg.decode("utf-8", "replace") if msg else ""

    def check(self, status: int, call: str) -> None:
        """Raises :class:`TranscutError` unless ``status`` is ``TC_OK``."""
        if status != TC_OK:
            raise TranscutError(int(status), call, self.last_error_message())

    def medium_preset(self, name: str) -> TcMedium:
        """The named measured medium (``tc_medium_preset``)."""
        out = TcMedium()
        self.check(self.cdll.tc_medium_preset(name.encode("utf-8"), ctypes.byref(out)), "tc_medium_preset")
        return out

    def default_bake_options(self) -> TcBakeOptions:
        """``tc_bake_options_default``."""
        options = TcBakeOptions()
        self.cdll.tc_bake_options_default(ctypes.byref(options))
        return options

    def scene(self) -> "Scene":
        """A new empty scene (``tc_scene_create``); use it in a ``with`` block or call ``close``."""
        return Scene(self)


class Scene:
    """A ``TcScene`` handle. Object indices are the ``uint32_t`` the ``add_*`` calls return."""

    def __init__(self, lib: Library):
        self.lib = lib
        self._c = lib.cdll
        self._handle = _ScenePtr()
        lib.check(self._c.tc_scene_create(ctypes.byref(self._handle)), "tc_scene_create")

    def close(self) -> None:
        """Frees the scene (``tc_scene_destroy``); later calls are errors, a second close is a no-op."""
        if getattr(self, "_handle", None):
            self._c.tc_scene_destroy(ctypes.byref(self._handle))
        self._handle = _ScenePtr()

    def __enter__(self) -> "Scene":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:  # interpreter shutdown: the library may already be gone
            pass

    def _h(self):
        if not self._handle:
            raise ValueError("the scene was closed")
        return self._handle

    def _check(self, status: int, call: str) -> None:
        self.lib.check(status, call)

    # -- objects ---------------------------------------------------------------------------

    def add_mesh(self, positions, triangles) -> int:
        """Adds a triangle mesh: ``positions`` (n, 3) and ``triangles`` (m, 3) vertex indices.

        The arrays are copied by the library; returns the new object's index.
        """
        pos = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1)
        tri = np.ascontiguousarray(triangles, dtype=np.uint32).reshape(-1)
        out = c_uint32()
        self._check(
            self._c.tc_scene_add_mesh(
                self._h(),
                pos.ctypes.data_as(_f),
                pos.size // 3,
                tri.ctypes.data_as(_u32),
                tri.size,
                ctypes.byref(out),
            ),
            "tc_scene_add_mesh",
        )
        return int(out.value)

    def add_tet_mesh(self, positions, tets, tet_medium=None) -> int:
        """Adds a ready tetrahedral mesh (``tets`` (k, 4); optional per-tet medium ids)."""
        pos = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1)
        tet = np.ascontiguousarray(tets, dtype=np.uint32).reshape(-1)
        ids = None if tet_medium is None else np.ascontiguousarray(tet_medium, dtype=np.uint32)
        out = c_uint32()
        self._check(
            self.lib.function("tc_scene_add_tet_mesh")(
                self._h(),
                pos.ctypes.data_as(_f),
                pos.size // 3,
                tet.ctypes.data_as(_u32),
                tet.size // 4,
                None if ids is None else ids.ctypes.data_as(_u32),
                ctypes.byref(out),
            ),
            "tc_scene_add_tet_mesh",
        )
        return int(out.value)

    def set_transform(self, obj: int, matrix) -> None:
        """Object → world matrix, given as a row-major 4×4 (NumPy / ``mathutils`` layout);
        sent column-major as the ABI expects."""
        m = np.asarray(matrix, dtype=np.float64).reshape(4, 4)
        col = np.ascontiguousarray(m.T, dtype=np.float32).reshape(-1)
        self._check(self._c.tc_object_set_transform(self._h(), obj, col.ctypes.data_as(_f)), "tc_object_set_transform")

    def set_scale(self, obj: int, mm_per_unit: float) -> None:
        """Millimetres per scene unit of the object (``tc_object_set_scale``)."""
        self._check(self._c.tc_object_set_scale(self._h(), obj, float(mm_per_unit)), "tc_object_set_scale")

    def set_name(self, obj: int, name: str) -> None:
        """Names the object in the library's messages (``tc_object_set_name``)."""
        self._check(self.lib.function("tc_object_set_name")(self._h(), obj, name.encode("utf-8")), "tc_object_set_name")

    def vertex_count(self, obj: int) -> int:
        """``tc_object_vertex_count``."""
        out = c_size_t()
        self._check(self._c.tc_object_vertex_count(self._h(), obj, ctypes.byref(out)), "tc_object_vertex_count")
        return int(out.value)

    # -- media -----------------------------------------------------------------------------

    def set_medium(self, obj: int, sigma_a, sigma_s_prime, eta: float, g: float = 0.0) -> None:
        """Homogeneous medium from coefficients in mm⁻¹ (``tc_object_set_medium``)."""
        m = TcMedium(_vec3(sigma_a, "sigma_a"), _vec3(sigma_s_prime, "sigma_s_prime"), float(eta), float(g))
        self._check(self._c.tc_object_set_medium(self._h(), obj, ctypes.byref(m)), "tc_object_set_medium")

    def set_medium_preset(self, obj: int, name: str) -> None:
        """A measured preset by name (``tc_object_set_medium_preset``)."""
        self._check(
            self._c.tc_object_set_medium_preset(self._h(), obj, name.encode("utf-8")), "tc_object_set_medium_preset"
        )

    def set_medium_artist(self, obj: int, albedo, radius, scale: float, ior: float, anisotropy: float = 0.0) -> None:
        """Artist parameters (``tc_object_set_medium_artist``; radius in scene units, converted
        with the object's mm_per_unit at the time of the call: call :meth:`set_scale` first)."""
        m = TcArtistMedium(_vec3(albedo, "albedo"), _vec3(radius, "radius"), float(scale), float(ior), float(anisotropy))
        self._check(
            self._c.tc_object_set_medium_artist(self._h(), obj, ctypes.byref(m)), "tc_object_set_medium_artist"
        )

    def set_media_table(self, obj: int, media) -> None:
        """One medium per material id of a tet mesh: ``media`` is a list of
        ``(sigma_a, sigma_s_prime, eta, g)`` (``tc_object_set_media_table``)."""
        table = (TcMedium * len(media))()
        for i, (sa, ss, eta, g) in enumerate(media):
            table[i] = TcMedium(_vec3(sa, "sigma_a"), _vec3(ss, "sigma_s_prime"), float(eta), float(g))
        self._check(
            self.lib.function("tc_object_set_media_table")(self._h(), obj, table, len(media)),
            "tc_object_set_media_table",
        )

    def set_media_per_tet(self, obj: int, sigma_a, sigma_s_prime, eta: float, g: float = 0.0) -> None:
        """Coefficients per tet of a tet mesh: ``sigma_a``, ``sigma_s_prime`` (tet_count, 3) mm⁻¹."""
        sa = np.ascontiguousarray(sigma_a, dtype=np.float32).reshape(-1, 3)
        ss = np.ascontiguousarray(sigma_s_prime, dtype=np.float32).reshape(-1, 3)
        if sa.shape != ss.shape:
            raise ValueError(f"sigma_a {sa.shape} and sigma_s_prime {ss.shape} differ in shape")
        self._check(
            self.lib.function("tc_object_set_media_per_tet")(
                self._h(), obj, sa.ctypes.data_as(_f), ss.ctypes.data_as(_f), sa.shape[0], float(eta), float(g)
            ),
            "tc_object_set_media_per_tet",
        )

    def set_medium_voxels(self, obj: int, origin, voxel_size, data, eta: float, g: float = 0.0) -> None:
        """A voxel grid in object space: ``data`` (nz, ny, nx, 6) = σa RGB then σ′s RGB (mm⁻¹),
        x fastest in memory; ``origin`` is the corner of voxel 0, ``voxel_size`` per axis."""
        grid = np.ascontiguousarray(data, dtype=np.float32)
        if grid.ndim != 4 or grid.shape[3] != 6:
            raise ValueError(f"voxel data must be (nz, ny, nx, 6), got {grid.shape}")
        dims = (c_uint32 * 3)(grid.shape[2], grid.shape[1], grid.shape[0])
        self._check(
            self.lib.function("tc_object_set_medium_voxels")(
                self._h(),
                obj,
                dims,
                _vec3(origin, "origin"),
                _vec3(voxel_size, "voxel_size"),
                grid.reshape(-1).ctypes.data_as(_f),
                grid.size,
                float(eta),
                float(g),
            ),
            "tc_object_set_medium_voxels",
        )

    def set_medium_voxel_file(self, obj: int, path: str, eta: float, g: float = 0.0) -> None:
        """A voxel grid read from a TCVOX1 file (``tc_object_set_medium_voxel_file``)."""
        self._check(
            self.lib.function("tc_object_set_medium_voxel_file")(self._h(), obj, os.fsencode(path), float(eta), float(g)),
            "tc_object_set_medium_voxel_file",
        )

    # -- lights ----------------------------------------------------------------------------

    def add_sun(self, direction, irradiance, angular_diameter_deg: float = 0.0) -> None:
        """A directional light travelling along ``direction`` with ``irradiance`` (RGB)."""
        self._check(
            self._c.tc_scene_add_sun(
                self._h(), _vec3(direction, "direction"), _vec3(irradiance, "irradiance"), float(angular_diameter_deg)
            ),
            "tc_scene_add_sun",
        )

    def add_point(self, position, intensity) -> None:
        """An isotropic point light of radiant intensity ``intensity`` (RGB, W/sr)."""
        self._check(
            self._c.tc_scene_add_point(self._h(), _vec3(position, "position"), _vec3(intensity, "intensity")),
            "tc_scene_add_point",
        )

    def add_spot(self, position, direction, intensity, cone_half_angle_deg: float, blend: float) -> None:
        """A spot light (intensity along the axis, cone half-angle in degrees, blend in [0, 1])."""
        self._check(
            self._c.tc_scene_add_spot(
                self._h(),
                _vec3(position, "position"),
                _vec3(direction, "direction"),
                _vec3(intensity, "intensity"),
                float(cone_half_angle_deg),
                float(blend),
            ),
            "tc_scene_add_spot",
        )

    def add_rect(self, center, half_u, half_v, radiance, two_sided: bool = False) -> None:
        """A parallelogram light emitting ``radiance`` along half_u × half_v (or both ways)."""
        self._check(
            self._c.tc_scene_add_rect(
                self._h(),
                _vec3(center, "center"),
                _vec3(half_u, "half_u"),
                _vec3(half_v, "half_v"),
                _vec3(radiance, "radiance"),
                1 if two_sided else 0,
            ),
            "tc_scene_add_rect",
        )

    def add_disc(self, center, normal, radius: float, radiance, two_sided: bool = False) -> None:
        """A disc light emitting ``radiance`` towards ``normal`` (or both ways)."""
        self._check(
            self._c.tc_scene_add_disc(
                self._h(),
                _vec3(center, "center"),
                _vec3(normal, "normal"),
                float(radius),
                _vec3(radiance, "radiance"),
                1 if two_sided else 0,
            ),
            "tc_scene_add_disc",
        )

    def add_environment(self, radiance) -> None:
        """A constant environment of ``radiance`` (RGB) from every direction."""
        self._check(self._c.tc_scene_add_environment(self._h(), _vec3(radiance, "radiance")), "tc_scene_add_environment")

    def add_environment_image(self, rgb, strength: float = 1.0) -> None:
        """An equirectangular environment: ``rgb`` (height, width, 3) linear, row 0 = top
        (+Z up, the library's convention, which Blender's world shares once rows are flipped)."""
        img = np.ascontiguousarray(rgb, dtype=np.float32)
        if img.ndim != 3 or img.shape[2] != 3:
            raise ValueError(f"environment image must be (height, width, 3), got {img.shape}")
        height, width = img.shape[0], img.shape[1]
        self._check(
            self._c.tc_scene_add_environment_image(
                self._h(), img.reshape(-1).ctypes.data_as(_f), width, height, float(strength)
            ),
            "tc_scene_add_environment_image",
        )

    def add_environment_file(self, path: str, strength: float = 1.0) -> None:
        """An equirectangular environment read from a .hdr / .exr file."""
        self._check(
            self.lib.function("tc_scene_add_environment_file")(self._h(), os.fsencode(path), float(strength)),
            "tc_scene_add_environment_file",
        )

    def clear_lights(self) -> None:
        """Removes every light (``tc_scene_clear_lights``)."""
        self._check(self.lib.function("tc_scene_clear_lights")(self._h()), "tc_scene_clear_lights")

    # -- bake ------------------------------------------------------------------------------

    def bake(self, progress: Optional[Callable[[str, float], bool]] = None, **options) -> None:
        """Bakes every object (``tc_scene_bake``).

        ``options`` are :class:`TcBakeOptions` field names (``tets``, ``tolerance``,
        ``max_iterations``, ``threads``, ``shadows``, ``area_samples``,
        ``environment_samples``, ``backend``); unset fields keep the library's defaults.
        ``backend`` is a ``TC_BACKEND_*`` value or one of the names in :data:`BACKENDS`
        (any case).
        ``progress(stage, fraction)`` may be called from several threads; returning True
        cancels (the call then raises :class:`TranscutError` with ``TC_CANCELLED``). An
        exception raised by ``progress`` cancels too and is re-raised here.
        """
        opts = self.lib.default_bake_options()
        names = {f[0] for f in TcBakeOptions._fields_} - {"size"}
        for key, value in options.items():
            if key not in names:
                raise TypeError(f"unknown bake option {key!r} (known: {', '.join(sorted(names))})")
            if key == "backend" and isinstance(value, str):
                if value.lower() not in BACKENDS:
                    raise ValueError(f"unknown backend {value!r} (known: {', '.join(BACKENDS)})")
                value = BACKENDS[value.lower()]
            current = getattr(opts, key)
            setattr(opts, key, float(value) if isinstance(current, float) else int(value))
        errors = []

        def trampoline(_user, stage, fraction):
            try:
                text = stage.decode("utf-8", "replace") if stage else ""
                return 1 if progress(text, float(fraction)) else 0
            except BaseException as exc:  # never let an exception unwind into the library
                errors.append(exc)
                return 1

        callback = TcProgressFn(trampoline) if progress is not None else TcProgressFn()
        status = self._c.tc_scene_bake(self._h(), ctypes.byref(opts), callback, None)
        if errors:
            raise errors[0]
        self._check(status, "tc_scene_bake")

    def radiance(self, obj: int) -> np.ndarray:
        """The baked radiance of an object: float32 (vertex_count, 3), linear RGB."""
        n = self.vertex_count(obj)
        out = np.empty((n, 3), dtype=np.float32)
        self._check(
            self._c.tc_object_radiance(self._h(), obj, out.ctypes.data_as(_f), out.size), "tc_object_radiance"
        )
        return out

    def stats(self, obj: int) -> dict:
        """``tc_object_stats`` as a dict."""
        st = TcBakeStats()
        st.size = ctypes.sizeof(TcBakeStats)
        self._check(self.lib.function("tc_object_stats")(self._h(), obj, ctypes.byref(st)), "tc_object_stats")
        out = {name: getattr(st, name) for name, _ in TcBakeStats._fields_ if name != "size"}
        out["iterations"] = list(st.iterations)
        return out

    def _object_text(self, name: str, obj: int) -> str:
        fn = self.lib.function(name)
        needed = c_size_t()
        self._check(fn(self._h(), obj, None, 0, ctypes.byref(needed)), name)
        buf = ctypes.create_string_buffer(needed.value)
        self._check(fn(self._h(), obj, buf, needed.value, None), name)
        return buf.value.decode("utf-8", "replace")

    def device(self, obj: int) -> str:
        """The GPU adapter that solved the object in the last bake ('' when the CPU did)."""
        return self._object_text("tc_object_device", obj)

    def backend_fallback(self, obj: int) -> str:
        """Why the ``auto`` backend solved the object on the CPU ('' when it did not)."""
        return self._object_text("tc_object_backend_fallback", obj)

    # -- editing (after a bake) ------------------------------------------------------------

    def _call(self, name: str, *args) -> None:
        self._check(self.lib.function(name)(self._h(), *args), name)

    def relight(self) -> None:
        """Re-solves every object for the scene's current lights (``tc_scene_relight``)."""
        self._call("tc_scene_relight", TcProgressFn(), None)

    def cut_plane(self, obj: int, point, normal, keep_both: bool = False) -> None:
        """Removes the side ``normal`` points into (``tc_object_cut_plane``); keep_both splits."""
        self._call("tc_object_cut_plane", obj, _vec3(point, "point"), _vec3(normal, "normal"), 1 if keep_both else 0)

    def cut_mesh(self, obj: int, positions, triangles, keep_both: bool = False) -> None:
        """Removes what lies inside a closed mesh, world space (``tc_object_cut_mesh``)."""
        pos = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1)
        tri = np.ascontiguousarray(triangles, dtype=np.uint32).reshape(-1)
        self._call(
            "tc_object_cut_mesh", obj, pos.ctypes.data_as(_f), pos.size // 3, tri.ctypes.data_as(_u32), tri.size,
            1 if keep_both else 0,
        )

    def paint(self, obj: int, points, radius: float, medium: TcMedium, strength: float = 1.0) -> None:
        """Paints ``medium`` along a 3D stroke (``tc_object_paint``)."""
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1)
        self._call(
            "tc_object_paint", obj, pts.ctypes.data_as(_d3), pts.size // 3, float(radius), ctypes.byref(medium),
            float(strength),
        )

    def piece_count(self, obj: int) -> int:
        """``tc_object_piece_count``."""
        out = c_uint32()
        self._call("tc_object_piece_count", obj, ctypes.byref(out))
        return out.value

    def set_piece_transform(self, obj: int, piece: int, matrix) -> None:
        """Places a piece rigidly (4 × 4, row-major like ``Matrix``; sent column-major)."""
        m = np.ascontiguousarray(np.asarray(matrix, dtype=np.float64).reshape(4, 4).T).reshape(-1)
        self._call("tc_object_set_piece_transform", obj, piece, m.ctypes.data_as(_d3))

    def piece_mesh(self, obj: int, piece: int) -> tuple:
        """A piece's surface: float32 positions (n, 3), uint32 triangles (m, 3), float32 radiance (n, 3)."""
        nv, nt = c_size_t(), c_size_t()
        self._call("tc_object_piece_sizes", obj, piece, ctypes.byref(nv), ctypes.byref(nt))
        pos = np.empty((nv.value, 3), np.float32)
        tri = np.empty((nt.value, 3), np.uint32)
        rgb = np.empty((nv.value, 3), np.float32)
        self._call(
            "tc_object_piece_mesh", obj, piece, pos.ctypes.data_as(_f), pos.size, tri.ctypes.data_as(_u32), tri.size,
            rgb.ctypes.data_as(_f), rgb.size,
        )
        return pos, tri, rgb

    def edit_stats(self, obj: int) -> dict:
        """``tc_object_edit_stats`` as a dict."""
        st = TcEditStats()
        st.size = ctypes.sizeof(TcEditStats)
        self._call("tc_object_edit_stats", obj, ctypes.byref(st))
        out = {name: getattr(st, name) for name, _ in TcEditStats._fields_ if name != "size"}
        out["iterations"] = list(st.iterations)
        return out
