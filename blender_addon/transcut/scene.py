"""The Pythonic binding: :class:`Library` (a loaded libtranscut) and :class:`Scene` (a ``TcScene``).

Every function prototype (``argtypes``/``restype``, :mod:`._abi`) is declared once, when the
library is loaded. Every call's status is checked; a failure raises :class:`TranscutError`
carrying the status code, its name and the library's thread-local message
(``tc_last_error_message``), read on the thread that made the call. Scenes are freed by
:meth:`Scene.close` (also on ``with`` exit and at garbage collection). Arrays go in and come out
as NumPy arrays; 3-vectors are any sequence of three numbers.
"""

from __future__ import annotations

import ctypes
import os
from collections.abc import Callable
from ctypes import c_double, c_size_t, c_uint32

import numpy as np

from ._abi import (
    ABI_MAJOR,
    ARTIST_MAPPINGS,
    BACKENDS,
    DIPOLE_CHOICES,
    DISCRETIZATIONS,
    MATERIAL_NAMES,
    OPTIONAL,
    POLYGRID_STENCILS,
    RADIOSITY_ITERATIONS,
    REQUIRED,
    SIDES,
    SOLVERS,
    STATUS_NAMES,
    TC_GRADING_AUTO,
    TC_METHOD_HIERARCHICAL_DIPOLE,
    TC_METHOD_POLYGRID,
    TC_METHOD_PRT,
    TC_METHOD_RADIOSITY,
    TC_METHOD_TRANSCUT,
    TC_NOT_FOUND,
    TC_OK,
    ScenePtr,
    TcArtistMedium,
    TcBakeOptions,
    TcBakeStats,
    TcDipoleOptions,
    TcDipoleStats,
    TcEditStats,
    TcMedium,
    TcPolygridOptions,
    TcPolygridStats,
    TcProgressFn,
    TcPrtOptions,
    TcPrtStats,
    TcRadiosityOptions,
    TcRadiosityStats,
    TcTransCutOptions,
    c_double_p,
    c_float_p,
    c_uint32_p,
)


class TranscutError(RuntimeError):
    """A libtranscut call failed: ``status`` (int), ``status_name`` and the library's message."""

    def __init__(self, status: int, call: str, message: str):
        self.status = status
        self.status_name = STATUS_NAMES.get(status, f"status {status}")
        self.call = call
        self.message = message
        text = message or self.status_name
        if not text.startswith(f"{call}: "):  # the library's messages name the function already
            text = f"{call}: {text}"
        super().__init__(f"{text} ({self.status_name})")


def _vec3(values, what: str):
    arr = (c_double * 3)()
    vals = [float(v) for v in values]
    if len(vals) != 3:
        raise ValueError(f"{what} needs 3 values, got {len(vals)}")
    for i, v in enumerate(vals):
        arr[i] = v
    return arr


def medium(sigma_a, sigma_s_prime, eta: float, g: float = 0.0) -> TcMedium:
    """A :class:`TcMedium`: σa and σ′s (3 values each, mm⁻¹), relative index η, anisotropy g."""
    return TcMedium(_vec3(sigma_a, "sigma_a"), _vec3(sigma_s_prime, "sigma_s_prime"), float(eta), float(g))


#: What :meth:`Library.methods` says for a library without ``tc_method_count``: TransCut alone.
TRANSCUT_ONLY = (
    (
        "transcut",
        "TransCut (Li et al. 2012): diffusion on a tetrahedral mesh; heterogeneous media, relight, paint, cut",
    ),
)
_METHOD_FUNCTIONS = ("tc_method_count", "tc_method_name", "tc_method_description")


def _solver(value, what: str) -> int:
    """A ``TC_SOLVER_*`` value from a name of :data:`SOLVERS` (any case) or the value itself."""
    if isinstance(value, str):
        if value.lower() not in SOLVERS:
            raise ValueError(f"unknown {what} {value!r} (known: {', '.join(SOLVERS)})")
        return SOLVERS[value.lower()]
    return int(value)


def _discretization(value) -> int:
    """A ``TC_DISCRETIZATION_*`` value from a name of :data:`DISCRETIZATIONS` (any case) or the
    value itself."""
    if isinstance(value, str):
        if value.lower() not in DISCRETIZATIONS:
            raise ValueError(f"unknown discretization {value!r} (known: {', '.join(DISCRETIZATIONS)})")
        return DISCRETIZATIONS[value.lower()]
    return _unsigned(value, "discretization")


def _choice(value, field: str) -> int:
    """A ``TcDipoleOptions`` enumeration value from a name of :data:`DIPOLE_CHOICES` ``[field]``
    (any case) or the value itself."""
    if isinstance(value, str):
        names = DIPOLE_CHOICES[field]
        if value.lower() not in names:
            raise ValueError(f"unknown {field} {value!r} (known: {', '.join(names)})")
        return names[value.lower()]
    return int(value)


#: The keyword arguments of :meth:`Scene.bake` that are ``TcDipoleOptions`` fields.
DIPOLE_OPTIONS = ("oracle", "theta", "eps1", "eps2", "rule", "receivers", "mode", "geometry", "budget", "radiance")


#: The keyword arguments of :meth:`Scene.bake` that are ``TcRadiosityOptions`` fields, and the
#: field each sets (``solver``, shared with TransCut, sets ``TcRadiosityOptions.solver`` too).
RADIOSITY_OPTIONS = {
    "patch_size": "patch_size_mm",
    "rays": "rays_per_patch",
    "iteration": "iteration",
    "radiosity_tolerance": "tolerance",
    "radiosity_max_iterations": "max_iterations",
    "bounces": "bounces",
    "seed": "seed",
    "covered_fraction": "covered_fraction",
}


#: The keyword arguments of :meth:`Scene.bake` that are ``TcPrtOptions`` fields, and the field
#: each sets (``prt_cache``: a folder, sent as ``cache_dir``).
PRT_OPTIONS = {
    "prt_samples": "samples_log2",
    "prt_terms": "terms_per_vertex",
    "prt_basis": "basis_terms",
    "prt_cache": "cache_dir",
}


#: The keyword arguments of :meth:`Scene.bake` that are ``TcPolygridOptions`` fields (the CLI's
#: flags), and the field each sets (``solver`` and ``edit_solver``, shared with TransCut, set
#: its ``solver`` and ``edit_solver`` too).
POLYGRID_OPTIONS = {
    "polygrid_nodes": "nodes",
    "polygrid_cube": "cube_mm",
    "polygrid_resolution": "resolution",
    "polygrid_stencil": "stencil",
}


def _stencil(value) -> int:
    """A ``TC_POLYGRID_STENCIL_*`` value from a name of :data:`POLYGRID_STENCILS` (any case, ``_``
    for ``-`` too) or the value itself."""
    if isinstance(value, str):
        name = value.strip().lower().replace("_", "-")
        if name not in POLYGRID_STENCILS:
            raise ValueError(f"unknown polygrid_stencil {value!r} (known: {', '.join(POLYGRID_STENCILS)})")
        return POLYGRID_STENCILS[name]
    return _unsigned(value, "polygrid_stencil")


def _unsigned(value, what: str, bits: int = 32) -> int:
    """A whole number in [0, 2^bits) for an unsigned field (ctypes would wrap a negative one
    silently into a huge value, which the library would then report under its own name)."""
    if isinstance(value, float) and not value.is_integer():
        raise ValueError(f"{what} must be a whole number, got {value!r}")
    number = int(value)
    if not 0 <= number < 1 << bits:
        raise ValueError(f"{what} must be in [0, 2^{bits}), got {number}")
    return number


def _grading(value) -> int:
    """``TcTransCutOptions.grading`` from ``"auto"`` (any case) or a whole number."""
    if isinstance(value, str):
        if value.lower() != "auto":
            raise ValueError(f"grading must be 'auto' or a whole number, got {value!r}")
        return TC_GRADING_AUTO
    return _unsigned(value, "grading")


def _iteration(value) -> int:
    """A ``TC_RADIOSITY_*`` value from a name of :data:`RADIOSITY_ITERATIONS` (any case, ``_``
    for ``-`` too) or the value itself."""
    if isinstance(value, str):
        name = value.strip().lower().replace("_", "-")
        if name not in RADIOSITY_ITERATIONS:
            raise ValueError(f"unknown iteration {value!r} (known: {', '.join(RADIOSITY_ITERATIONS)})")
        return RADIOSITY_ITERATIONS[name]
    return _unsigned(value, "iteration")


def _sides(value) -> int:
    """A ``TC_SIDES_*`` value from a name of :data:`SIDES` (any case) or the value itself;
    ValueError for anything else."""
    if isinstance(value, str):
        if value.strip().lower() not in SIDES:
            raise ValueError(f"unknown sides {value!r} (known: {', '.join(SIDES)})")
        return SIDES[value.strip().lower()]
    number = int(value)
    if number not in SIDES.values():
        raise ValueError(f"unknown sides {value!r} (known: {', '.join(SIDES)}, or TC_SIDES_* 0 to {len(SIDES) - 1})")
    return number


def _emission(values):
    """The emission as 3 doubles, checked as the library checks it (finite, >= 0)."""
    arr = _vec3(values, "emission")
    if not all(np.isfinite(x) and x >= 0.0 for x in arr):
        raise ValueError(f"emission must be finite and >= 0 in every channel, got {tuple(arr)}")
    return arr


def _mapping(value) -> int:
    """A ``TC_ARTIST_*`` value from a name of :data:`ARTIST_MAPPINGS` (any case) or the value
    itself; ValueError for anything else."""
    if isinstance(value, str):
        name = value.strip().lower()
        if name not in ARTIST_MAPPINGS:
            raise ValueError(f"unknown mapping {value!r} (known: {', '.join(ARTIST_MAPPINGS)})")
        return ARTIST_MAPPINGS[name]
    number = int(value)
    if number not in ARTIST_MAPPINGS.values():
        raise ValueError(f"unknown mapping {value!r} (known: {', '.join(ARTIST_MAPPINGS)})")
    return number


def _artist(albedo, radius, scale: float, ior: float, anisotropy: float, mapping="random-walk") -> TcArtistMedium:
    return TcArtistMedium(
        _vec3(albedo, "albedo"),
        _vec3(radius, "radius"),
        float(scale),
        float(ior),
        float(anisotropy),
        _mapping(mapping),
    )


class Library:
    """A loaded libtranscut: the ``CDLL`` with every prototype declared, and its version."""

    def __init__(self, path: str):
        self.path = os.path.abspath(path)
        self.cdll = ctypes.CDLL(self.path)
        self._methods = None
        missing = []
        self.optional_missing = []
        for table, absent in ((REQUIRED, missing), (OPTIONAL, self.optional_missing)):
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
                f"{self.path} is libtranscut {self.version_string}; this binding needs ABI major version {ABI_MAJOR}"
            )

    def has(self, name: str) -> bool:
        """Whether the library exports the C function ``name``."""
        return hasattr(self.cdll, name) and name not in self.optional_missing

    def live_scene_count(self) -> int:
        """``tc_live_scene_count()``: the scenes of this process not yet closed."""
        return int(self.function("tc_live_scene_count")())

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

    def call(self, name: str, *args) -> None:
        """Calls the C function ``name`` and checks its status."""
        self.check(self.function(name)(*args), name)

    def text(self, name: str, *args) -> str:
        """The text the C function ``name`` copies out (its last three parameters ``out``,
        ``out_len``, ``out_needed``, as ``tc_object_device``): asks for the size, then copies."""
        needed = c_size_t()
        self.call(name, *args, None, 0, ctypes.byref(needed))
        buf = ctypes.create_string_buffer(needed.value)
        self.call(name, *args, buf, needed.value, None)
        return buf.value.decode("utf-8", "replace")

    def methods(self) -> list[tuple[str, str]]:
        """The subsurface methods this library has, ``(name, description)`` in ``TC_METHOD_*``
        order (the index is the ``TcBakeOptions.method`` value); TransCut alone for a library
        without ``tc_method_count``."""
        if self._methods is None:
            if all(self.has(n) for n in _METHOD_FUNCTIONS):
                count = self.cdll.tc_method_count()
                self._methods = tuple(
                    (self.text("tc_method_name", i), self.text("tc_method_description", i)) for i in range(count)
                )
            else:
                self._methods = TRANSCUT_ONLY
        return list(self._methods)

    def method_number(self, name: str) -> int:
        """The ``TC_METHOD_*`` value of the method called ``name`` (any case;
        ``tc_method_from_name``). An unknown name raises :class:`TranscutError` (``TC_NOT_FOUND``)
        listing the valid ones."""
        if self.has("tc_method_from_name"):
            out = c_uint32()
            self.call("tc_method_from_name", name.encode("utf-8"), ctypes.byref(out))
            return int(out.value)
        names = [n for n, _ in self.methods()]
        wanted = name.strip().lower()
        if wanted not in names:
            message = f"unknown method '{name.strip()}' (the methods are: {', '.join(names)})"
            raise TranscutError(TC_NOT_FOUND, "tc_method_from_name", message)
        return names.index(wanted)

    def medium_preset(self, name: str) -> TcMedium:
        """The named measured medium (``tc_medium_preset``)."""
        out = TcMedium()
        self.call("tc_medium_preset", name.encode("utf-8"), ctypes.byref(out))
        return out

    def medium_from_artist(
        self,
        mm_per_unit: float,
        albedo,
        radius,
        scale: float,
        ior: float,
        anisotropy: float = 0.0,
        mapping="random-walk",
    ) -> TcMedium:
        """The coefficients of artist parameters (as :meth:`Scene.set_medium_artist` takes them)
        for an object of ``mm_per_unit`` millimetres per scene unit (``tc_medium_from_artist``)."""
        artist = _artist(albedo, radius, scale, ior, anisotropy, mapping)
        out = TcMedium()
        self.call("tc_medium_from_artist", ctypes.byref(artist), float(mm_per_unit), ctypes.byref(out))
        return out

    def default_bake_options(self) -> TcBakeOptions:
        """The library's defaults (``tc_bake_options_init`` with this binding's struct size; a
        library without it: ``tc_bake_options_default``, the first version's fields)."""
        options = TcBakeOptions()
        if self.has("tc_bake_options_init"):
            self.call("tc_bake_options_init", ctypes.byref(options), ctypes.sizeof(options))
        else:
            self.cdll.tc_bake_options_default(ctypes.byref(options))
        return options

    def default_transcut_options(self) -> TcTransCutOptions:
        """``tc_transcut_options_init``."""
        options = TcTransCutOptions()
        self.call("tc_transcut_options_init", ctypes.byref(options), ctypes.sizeof(options))
        return options

    def default_dipole_options(self) -> TcDipoleOptions:
        """``tc_dipole_options_init``: the hierarchical dipole's defaults."""
        options = TcDipoleOptions()
        self.call("tc_dipole_options_init", ctypes.byref(options), ctypes.sizeof(options))
        return options

    def default_radiosity_options(self) -> TcRadiosityOptions:
        """``tc_radiosity_options_init``: translucent radiosity's defaults."""
        options = TcRadiosityOptions()
        self.call("tc_radiosity_options_init", ctypes.byref(options), ctypes.sizeof(options))
        return options

    def default_prt_options(self) -> TcPrtOptions:
        """``tc_prt_options_init``: the PRT method's defaults."""
        options = TcPrtOptions()
        self.call("tc_prt_options_init", ctypes.byref(options), ctypes.sizeof(options))
        return options

    def default_polygrid_options(self) -> TcPolygridOptions:
        """``tc_polygrid_options_init``: the polygrid method's defaults."""
        options = TcPolygridOptions()
        self.call("tc_polygrid_options_init", ctypes.byref(options), ctypes.sizeof(options))
        return options

    def scene(self) -> Scene:
        """A new empty scene (``tc_scene_create``); use it in a ``with`` block or call ``close``."""
        return Scene(self)


def _stats_dict(st) -> dict:
    """A ``TcBakeStats`` / ``TcEditStats`` as a dict (``size`` left out, ``iterations`` a list)."""
    out = {name: getattr(st, name) for name, _ in st._fields_ if name != "size"}
    out["iterations"] = list(st.iterations)
    if "resolution" in out:
        out["resolution"] = list(st.resolution)
    return out


def _progress_fn(progress: Callable[[str, float], bool], errors: list[BaseException]) -> TcProgressFn:
    """A ``TcProgressFn`` calling ``progress(stage, fraction)``: True cancels; an exception it
    raises cancels too and is appended to ``errors`` (it never unwinds into the library)."""

    def trampoline(_user, stage, fraction):
        try:
            text = stage.decode("utf-8", "replace") if stage else ""
            return 1 if progress(text, float(fraction)) else 0
        except BaseException as exc:
            errors.append(exc)
            return 1

    return TcProgressFn(trampoline)


class Scene:
    """A ``TcScene`` handle. Object indices are the ``uint32_t`` the ``add_*`` calls return."""

    def __init__(self, lib: Library):
        self.lib = lib
        self._handle = ScenePtr()
        # The edit calls' progress callback (set_progress): kept alive while the library holds
        # it, and the exceptions it raised during the current call.
        self._edit_progress = None
        self._edit_errors: list[BaseException] = []
        lib.call("tc_scene_create", ctypes.byref(self._handle))

    def close(self) -> None:
        """Frees the scene (``tc_scene_destroy``); later calls are errors, a second close is a no-op."""
        if getattr(self, "_handle", None):
            self.lib.cdll.tc_scene_destroy(ctypes.byref(self._handle))
        self._handle = ScenePtr()
        self._edit_progress = None

    def __enter__(self) -> Scene:
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

    def _call(self, name: str, *args) -> None:
        """Calls the C function ``name`` on this scene (its first argument) and checks its status;
        an exception the edit progress callback raised during the call is re-raised instead."""
        self._edit_errors.clear()
        status = self.lib.function(name)(self._h(), *args)
        if self._edit_errors:
            raise self._edit_errors.pop(0)
        self.lib.check(status, name)

    def _call_with_progress(self, name: str, progress: Callable[[str, float], bool] | None, *args) -> None:
        """``_call`` for a function whose last two parameters are a ``TcProgressFn`` and its
        ``user`` pointer: ``progress(stage, fraction)`` returning True cancels; an exception it
        raises cancels too and is re-raised here (it never unwinds into the library)."""
        errors: list[BaseException] = []
        callback = _progress_fn(progress, errors) if progress is not None else TcProgressFn()
        status = self.lib.function(name)(self._h(), *args, callback, None)
        if errors:
            raise errors[0]
        self.lib.check(status, name)

    # -- objects ---------------------------------------------------------------------------

    def add_mesh(self, positions, triangles) -> int:
        """Adds a triangle mesh: ``positions`` (n, 3) and ``triangles`` (m, 3) vertex indices.

        The arrays are copied by the library; returns the new object's index.
        """
        pos = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1)
        tri = np.ascontiguousarray(triangles, dtype=np.uint32).reshape(-1)
        out = c_uint32()
        self._call(
            "tc_scene_add_mesh",
            pos.ctypes.data_as(c_float_p),
            pos.size // 3,
            tri.ctypes.data_as(c_uint32_p),
            tri.size,
            ctypes.byref(out),
        )
        return int(out.value)

    def add_mesh_file(self, path: str) -> int:
        """Adds an object from an OBJ or PLY file (``tc_scene_add_mesh_file``: read by the
        library as the CLI reads it; radiance per vertex of the file, in file order)."""
        out = c_uint32()
        self._call("tc_scene_add_mesh_file", os.fsencode(path), ctypes.byref(out))
        return int(out.value)

    def set_mesh(self, obj: int, positions, triangles) -> None:
        """Replaces object ``obj``'s triangle mesh (``tc_object_set_mesh``; arrays as
        :meth:`add_mesh`); the next bake meshes this object again and keeps the others' tets."""
        pos = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1)
        tri = np.ascontiguousarray(triangles, dtype=np.uint32).reshape(-1)
        pos_p, tri_p = pos.ctypes.data_as(c_float_p), tri.ctypes.data_as(c_uint32_p)
        self._call("tc_object_set_mesh", obj, pos_p, pos.size // 3, tri_p, tri.size)

    def add_tet_mesh(self, positions, tets, tet_medium=None) -> int:
        """Adds a ready tetrahedral mesh (``tets`` (k, 4); optional per-tet medium ids)."""
        pos = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1)
        tet = np.ascontiguousarray(tets, dtype=np.uint32).reshape(-1)
        ids = None if tet_medium is None else np.ascontiguousarray(tet_medium, dtype=np.uint32)
        out = c_uint32()
        self._call(
            "tc_scene_add_tet_mesh",
            pos.ctypes.data_as(c_float_p),
            pos.size // 3,
            tet.ctypes.data_as(c_uint32_p),
            tet.size // 4,
            None if ids is None else ids.ctypes.data_as(c_uint32_p),
            ctypes.byref(out),
        )
        return int(out.value)

    def add_diffuse_mesh(self, positions, indices, albedo, emission=None, sides=None) -> int:
        """Adds an opaque diffuse surface (``tc_scene_add_diffuse_mesh``; only
        ``method="radiosity"`` bakes it): ``positions`` (n, 3), ``indices`` (m, 3) or flat, as
        :meth:`add_mesh` takes them, but the surface may be open (a floor, a wall). ``albedo``
        (RGB, each in [0, 1)) is the fraction of the irradiance it reflects; ``emission`` (RGB,
        finite, >= 0; default none) the exitance M it emits, in the lights' irradiance units
        (alone, a surface emitting M has radiance M/π); ``sides`` which sides reflect and
        emit: ``"both"`` (the library's default), ``"front"``, ``"back"`` (the inside of a
        closed room) or a ``TC_SIDES_*`` value. Returns the new object's index.

        A bad ``emission`` or ``sides`` raises ValueError before anything is added; the library
        refuses an albedo out of [0, 1) or NaN (``TC_INVALID_ARGUMENT`` naming it) and a bad mesh
        (``TC_INVALID_MESH``), adding nothing.
        """
        pos = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1)
        idx = np.ascontiguousarray(indices, dtype=np.uint32).reshape(-1)
        rho = _vec3(albedo, "albedo")
        glow = None if emission is None else _emission(emission)
        side = None if sides is None else _sides(sides)
        out = c_uint32()
        self._call(
            "tc_scene_add_diffuse_mesh",
            pos.ctypes.data_as(c_float_p),
            pos.size // 3,
            idx.ctypes.data_as(c_uint32_p),
            idx.size,
            rho,
            ctypes.byref(out),
        )
        obj = int(out.value)
        if glow is not None:
            self._call("tc_object_set_emission", obj, glow)
        if side is not None:
            self._call("tc_object_set_sides", obj, side)
        return obj

    def set_albedo(self, obj: int, albedo) -> None:
        """A diffuse object's albedo (RGB, each in [0, 1); ``tc_object_set_albedo``). The library
        refuses a value out of range or a translucent object (``TC_INVALID_ARGUMENT`` naming it)."""
        self._call("tc_object_set_albedo", obj, _vec3(albedo, "albedo"))

    def set_emission(self, obj: int, emission) -> None:
        """A diffuse object's emitted exitance M (RGB, finite, >= 0; ``tc_object_set_emission``):
        alone it has radiance M/π. The library refuses a translucent object."""
        self._call("tc_object_set_emission", obj, _vec3(emission, "emission"))

    def set_sides(self, obj: int, sides) -> None:
        """Which sides of a diffuse object reflect and emit (``tc_object_set_sides``):
        ``"both"``, ``"front"``, ``"back"`` or a ``TC_SIDES_*`` value (another raises
        ValueError). The library refuses a translucent object."""
        self._call("tc_object_set_sides", obj, _sides(sides))

    def material(self, obj: int) -> str:
        """What the object is made of (``tc_object_material``): ``"translucent"`` (a medium; added
        by :meth:`add_mesh`, :meth:`add_tet_mesh`) or ``"diffuse"`` (:meth:`add_diffuse_mesh`)."""
        out = c_uint32()
        self._call("tc_object_material", obj, ctypes.byref(out))
        return MATERIAL_NAMES.get(int(out.value), f"material {int(out.value)}")

    def set_transform(self, obj: int, matrix) -> None:
        """Object → world matrix, given as a row-major 4×4 (NumPy / ``mathutils`` layout);
        sent column-major as the ABI expects."""
        m = np.asarray(matrix, dtype=np.float64).reshape(4, 4)
        col = np.ascontiguousarray(m.T, dtype=np.float32).reshape(-1)
        self._call("tc_object_set_transform", obj, col.ctypes.data_as(c_float_p))

    def set_scale(self, obj: int, mm_per_unit: float) -> None:
        """Millimetres per scene unit of the object (``tc_object_set_scale``)."""
        self._call("tc_object_set_scale", obj, float(mm_per_unit))

    def set_name(self, obj: int, name: str) -> None:
        """Names the object in the library's messages (``tc_object_set_name``)."""
        self._call("tc_object_set_name", obj, name.encode("utf-8"))

    def _count(self, name: str, *args) -> int:
        out = c_size_t()
        self._call(name, *args, ctypes.byref(out))
        return int(out.value)

    def vertex_count(self, obj: int) -> int:
        """``tc_object_vertex_count``."""
        return self._count("tc_object_vertex_count", obj)

    # -- media -----------------------------------------------------------------------------

    def set_medium(self, obj: int, sigma_a, sigma_s_prime, eta: float, g: float = 0.0) -> None:
        """Homogeneous medium from coefficients in mm⁻¹ (``tc_object_set_medium``)."""
        self._call("tc_object_set_medium", obj, ctypes.byref(medium(sigma_a, sigma_s_prime, eta, g)))

    def set_medium_preset(self, obj: int, name: str) -> None:
        """A measured preset by name (``tc_object_set_medium_preset``)."""
        self._call("tc_object_set_medium_preset", obj, name.encode("utf-8"))

    def set_medium_artist(
        self, obj: int, albedo, radius, scale: float, ior: float, anisotropy: float = 0.0, mapping="random-walk"
    ) -> None:
        """Artist parameters (``tc_object_set_medium_artist``; radius in scene units, converted
        with the object's mm_per_unit at the time of the call: call :meth:`set_scale` first).
        ``mapping``: how colour and radius are read, a name of :data:`ARTIST_MAPPINGS`
        (``random-walk``, Cycles' Random Walk, the default; ``random-walk-skin``; ``dipole``)
        or its ``TC_ARTIST_*`` value."""
        m = _artist(albedo, radius, scale, ior, anisotropy, mapping)
        self._call("tc_object_set_medium_artist", obj, ctypes.byref(m))

    def set_media_table(self, obj: int, media) -> None:
        """One medium per material id of a tet mesh: ``media`` is a list of
        ``(sigma_a, sigma_s_prime, eta, g)`` (``tc_object_set_media_table``)."""
        table = (TcMedium * len(media))(*(medium(*m) for m in media))
        self._call("tc_object_set_media_table", obj, table, len(media))

    def set_media_per_tet(self, obj: int, sigma_a, sigma_s_prime, eta: float, g: float = 0.0) -> None:
        """Coefficients per tet of a tet mesh: ``sigma_a``, ``sigma_s_prime`` (tet_count, 3) mm⁻¹."""
        sa = np.ascontiguousarray(sigma_a, dtype=np.float32).reshape(-1, 3)
        ss = np.ascontiguousarray(sigma_s_prime, dtype=np.float32).reshape(-1, 3)
        if sa.shape != ss.shape:
            raise ValueError(f"sigma_a {sa.shape} and sigma_s_prime {ss.shape} differ in shape")
        self._call(
            "tc_object_set_media_per_tet",
            obj,
            sa.ctypes.data_as(c_float_p),
            ss.ctypes.data_as(c_float_p),
            sa.shape[0],
            float(eta),
            float(g),
        )

    def set_medium_voxels(self, obj: int, origin, voxel_size, data, eta: float, g: float = 0.0) -> None:
        """A voxel grid in object space: ``data`` (nz, ny, nx, 6) = σa RGB then σ′s RGB (mm⁻¹),
        x fastest in memory; ``origin`` is the corner of voxel 0, ``voxel_size`` per axis."""
        grid = np.ascontiguousarray(data, dtype=np.float32)
        if grid.ndim != 4 or grid.shape[3] != 6:
            raise ValueError(f"voxel data must be (nz, ny, nx, 6), got {grid.shape}")
        dims = (c_uint32 * 3)(grid.shape[2], grid.shape[1], grid.shape[0])
        self._call(
            "tc_object_set_medium_voxels",
            obj,
            dims,
            _vec3(origin, "origin"),
            _vec3(voxel_size, "voxel_size"),
            grid.reshape(-1).ctypes.data_as(c_float_p),
            grid.size,
            float(eta),
            float(g),
        )

    def set_medium_voxel_file(self, obj: int, path: str, eta: float, g: float = 0.0) -> None:
        """A voxel grid read from a TCVOX1 file (``tc_object_set_medium_voxel_file``)."""
        self._call("tc_object_set_medium_voxel_file", obj, os.fsencode(path), float(eta), float(g))

    # -- lights ----------------------------------------------------------------------------

    def add_sun(self, direction, irradiance, angular_diameter_deg: float = 0.0) -> None:
        """A directional light travelling along ``direction`` with ``irradiance`` (RGB)."""
        self._call(
            "tc_scene_add_sun",
            _vec3(direction, "direction"),
            _vec3(irradiance, "irradiance"),
            float(angular_diameter_deg),
        )

    def add_point(self, position, intensity) -> None:
        """An isotropic point light of radiant intensity ``intensity`` (RGB, W/sr)."""
        self._call("tc_scene_add_point", _vec3(position, "position"), _vec3(intensity, "intensity"))

    def add_spot(self, position, direction, intensity, cone_half_angle_deg: float, blend: float) -> None:
        """A spot light (intensity along the axis, cone half-angle in degrees, blend in [0, 1])."""
        self._call(
            "tc_scene_add_spot",
            _vec3(position, "position"),
            _vec3(direction, "direction"),
            _vec3(intensity, "intensity"),
            float(cone_half_angle_deg),
            float(blend),
        )

    def add_rect(self, center, half_u, half_v, radiance, two_sided: bool = False) -> None:
        """A parallelogram light emitting ``radiance`` along half_u × half_v (or both ways)."""
        self._call(
            "tc_scene_add_rect",
            _vec3(center, "center"),
            _vec3(half_u, "half_u"),
            _vec3(half_v, "half_v"),
            _vec3(radiance, "radiance"),
            1 if two_sided else 0,
        )

    def add_disc(self, center, normal, radius: float, radiance, two_sided: bool = False) -> None:
        """A disc light emitting ``radiance`` towards ``normal`` (or both ways)."""
        self._call(
            "tc_scene_add_disc",
            _vec3(center, "center"),
            _vec3(normal, "normal"),
            float(radius),
            _vec3(radiance, "radiance"),
            1 if two_sided else 0,
        )

    def add_environment(self, radiance) -> None:
        """A constant environment of ``radiance`` (RGB) from every direction."""
        self._call("tc_scene_add_environment", _vec3(radiance, "radiance"))

    def add_environment_image(self, rgb, strength: float = 1.0) -> None:
        """An equirectangular environment: ``rgb`` (height, width, 3) linear, row 0 = top
        (+Z up, the library's convention, which Blender's world shares once rows are flipped)."""
        img = np.ascontiguousarray(rgb, dtype=np.float32)
        if img.ndim != 3 or img.shape[2] != 3:
            raise ValueError(f"environment image must be (height, width, 3), got {img.shape}")
        height, width = img.shape[0], img.shape[1]
        self._call(
            "tc_scene_add_environment_image", img.reshape(-1).ctypes.data_as(c_float_p), width, height, float(strength)
        )

    def add_environment_file(self, path: str, strength: float = 1.0) -> None:
        """An equirectangular environment read from a .hdr / .exr file."""
        self._call("tc_scene_add_environment_file", os.fsencode(path), float(strength))

    def clear_lights(self) -> None:
        """Removes every light (``tc_scene_clear_lights``)."""
        self._call("tc_scene_clear_lights")

    # -- bake ------------------------------------------------------------------------------

    def bake(
        self,
        progress: Callable[[str, float], bool] | None = None,
        *,
        method: str | int | None = None,
        solver: str | int | None = None,
        edit_solver: str | int | None = None,
        grading: int | None = None,
        discretization: str | int | None = None,
        oracle: str | int | None = None,
        theta: float | None = None,
        eps1: float | None = None,
        eps2: float | None = None,
        rule: str | int | None = None,
        receivers: str | int | None = None,
        mode: str | int | None = None,
        geometry: str | int | None = None,
        budget: int | None = None,
        radiance: str | int | None = None,
        patch_size: float | None = None,
        rays: int | None = None,
        iteration: str | int | None = None,
        radiosity_tolerance: float | None = None,
        radiosity_max_iterations: int | None = None,
        bounces: int | None = None,
        seed: int | None = None,
        covered_fraction: float | None = None,
        prt_samples: int | None = None,
        prt_terms: int | None = None,
        prt_basis: int | None = None,
        prt_cache: str | None = None,
        polygrid_nodes: int | None = None,
        polygrid_cube: float | None = None,
        polygrid_resolution: int | None = None,
        polygrid_stencil: str | int | None = None,
        **options,
    ) -> None:
        """Bakes every object (``tc_scene_bake``) with the subsurface ``method``.

        ``method`` is a name of :meth:`Library.methods` (any case; an unknown one raises
        :class:`TranscutError` with ``TC_NOT_FOUND`` listing the valid names) or a
        ``TC_METHOD_*`` value; unset: the library's default, TransCut. TransCut's own options:
        ``solver``, the bake's solver on the CPU, and ``edit_solver``, the solver of the edits
        after it (relight, paint, cut), each a name of :data:`SOLVERS` (any case) or a
        ``TC_SOLVER_*`` value, ``grading`` (``"auto"`` or ``TC_GRADING_AUTO``, the
        default: graded where the medium's boundary layer needs it, uniform elsewhere; 0: one tet
        size everywhere; N: graded tets, the finest near the surface, N cubes of each size
        before the next doubling) and
        ``discretization`` (a name of :data:`DISCRETIZATIONS`, any case, or a
        ``TC_DISCRETIZATION_*`` value; default ``"fitted-layer"``); unset: the method's defaults.
        The hierarchical dipole's options (``method="hierarchical-dipole"``), the
        :class:`TcDipoleOptions` fields: ``theta`` (the opening angle, in (0, 1]), ``oracle``
        (``"opening-angle"`` or ``"paper"``, whose thresholds are ``eps1`` and ``eps2``),
        ``rule`` (``"gl3"`` / ``"gauss-legendre"`` or ``"paper"``), ``receivers``
        (``"vertices"`` or ``"faces"``), ``mode`` (``"on-the-fly"``, ``"render"`` or
        ``"incremental"``), ``budget`` (incremental mode: the most links per update, 0 = no
        limit), ``geometry`` (``"distance"`` or ``"paper"``) and ``radiance`` (``"transcut"`` or
        ``"jensen"``); names in any case (:data:`DIPOLE_CHOICES`) or the ``TC_DIPOLE_*``
        values; unset: ``tc_dipole_options_init``'s defaults.
        Translucent radiosity's options (``method="radiosity"``), the
        :class:`TcRadiosityOptions` fields: ``patch_size`` (the longest patch edge on diffuse
        objects, in mm; 0: the scene's diagonal / 80), ``rays`` (rays per patch for the form
        factors), ``iteration`` (``"jacobi"``, ``"gauss-seidel"`` or ``"bicgstab"``, any case, or a
        ``TC_RADIOSITY_*`` value), ``bounces`` (exactly that many bounces, Jacobi only; 0: until
        the tolerance), ``radiosity_tolerance`` (the estimated relative error in power at
        which the iteration stops), ``radiosity_max_iterations`` (its sweeps at most), ``seed``
        (of the rays) and ``covered_fraction``, and ``solver``, ``grading`` and
        ``discretization`` (the translucent objects' diffusion solver, tets and assembly, as
        TransCut's; their ``tets``, ``tolerance``, ``max_iterations`` and ``backend``
        are the :class:`TcBakeOptions` fields, as for TransCut); unset:
        ``tc_radiosity_options_init``'s defaults. A negative or fractional count, or an unknown
        name, raises ValueError before the call; the library names a value out of range
        (``TC_INVALID_ARGUMENT``, ``options->method_options->`` and the field's name).
        PRT's options (``method="prt"``), the :class:`TcPrtOptions` fields: ``prt_samples``
        (log₂ of the irradiance samples, 4 to 18), ``prt_terms`` (Haar coefficients kept per
        vertex), ``prt_basis`` (12 or 16 functions) and ``prt_cache`` (a folder of saved
        precomputes: a bake of the same surface, scale and options reads its transfer from
        there, and writes it there otherwise); unset: ``tc_prt_options_init``'s defaults.
        The polygrid's options (``method="polygrid"``), the :class:`TcPolygridOptions` fields:
        ``polygrid_nodes`` (target grid nodes per object), ``polygrid_cube`` (the polycube's cube
        edge in mm; 0: from the nodes), ``polygrid_resolution`` (grid cells per cube edge) and
        ``polygrid_stencil`` (``"fem"``, ``"finite-volume"`` or ``"paper-lsq"``, any case, or a
        ``TC_POLYGRID_STENCIL_*`` value), and ``solver`` and ``edit_solver`` as TransCut's (its
        ``tolerance``, ``max_iterations`` and ``backend`` are the :class:`TcBakeOptions` fields;
        ``tets`` does not apply); unset: ``tc_polygrid_options_init``'s defaults.
        A method's options given with another method raise ValueError.
        ``options`` are the other :class:`TcBakeOptions` field names (``tets``, ``tolerance``,
        ``max_iterations``, ``threads``, ``shadows``, ``area_samples``,
        ``environment_samples``, ``backend``); unset fields keep the library's defaults.
        ``backend`` is a ``TC_BACKEND_*`` value or one of the names in :data:`BACKENDS`
        (any case).
        ``progress(stage, fraction)`` may be called from several threads; returning True
        cancels (the call then raises :class:`TranscutError` with ``TC_CANCELLED``). An
        exception raised by ``progress`` cancels too and is re-raised here.
        """
        opts = self.lib.default_bake_options()
        names = {f[0] for f in TcBakeOptions._fields_} - {"size", "method", "method_options"}
        for key, value in options.items():
            if key not in names:
                known = sorted(
                    names
                    | {"method", "solver", "edit_solver", *DIPOLE_OPTIONS, *RADIOSITY_OPTIONS, *PRT_OPTIONS}
                    | set(POLYGRID_OPTIONS)
                )
                raise TypeError(f"unknown bake option {key!r} (known: {', '.join(known)})")
            if key == "backend" and isinstance(value, str):
                if value.lower() not in BACKENDS:
                    raise ValueError(f"unknown backend {value!r} (known: {', '.join(BACKENDS)})")
                value = BACKENDS[value.lower()]
            current = getattr(opts, key)
            setattr(opts, key, float(value) if isinstance(current, float) else int(value))
        if method is not None:
            opts.method = self.lib.method_number(method) if isinstance(method, str) else int(method)
        # Kept alive by this frame until tc_scene_bake, which reads it, has returned.
        method_options = None
        radiosity = {
            k: v
            for k, v in zip(
                RADIOSITY_OPTIONS,
                (
                    patch_size,
                    rays,
                    iteration,
                    radiosity_tolerance,
                    radiosity_max_iterations,
                    bounces,
                    seed,
                    covered_fraction,
                ),
                strict=True,
            )
            if v is not None
        }
        if radiosity and opts.method != TC_METHOD_RADIOSITY:
            raise ValueError(
                f"{', '.join(radiosity)} {'is an option' if len(radiosity) == 1 else 'are options'} of "
                f"radiosity, not of method {method if method is not None else 'transcut'!r}"
            )
        polygrid = {
            k: v
            for k, v in zip(
                POLYGRID_OPTIONS, (polygrid_nodes, polygrid_cube, polygrid_resolution, polygrid_stencil), strict=True
            )
            if v is not None
        }
        if polygrid and opts.method != TC_METHOD_POLYGRID:
            raise ValueError(
                f"{', '.join(polygrid)} {'is an option' if len(polygrid) == 1 else 'are options'} of "
                f"polygrid, not of method {method if method is not None else 'transcut'!r}"
            )
        if (grading is not None or discretization is not None) and opts.method not in (
            TC_METHOD_TRANSCUT,
            TC_METHOD_RADIOSITY,
        ):
            raise ValueError(
                "grading and discretization are options of transcut and radiosity, "
                f"not of method {method if method is not None else 'transcut'!r}"
            )
        if opts.method == TC_METHOD_RADIOSITY and edit_solver is None:
            if radiosity or solver is not None or grading is not None or discretization is not None:
                method_options = self._radiosity_options(solver, grading, discretization, radiosity)
        elif opts.method == TC_METHOD_POLYGRID:
            if polygrid or solver is not None or edit_solver is not None:
                method_options = self._polygrid_options(solver, edit_solver, polygrid)
        elif solver is not None or edit_solver is not None or grading is not None or discretization is not None:
            if opts.method != TC_METHOD_TRANSCUT:
                raise ValueError(
                    "solver and edit_solver are options of transcut and polygrid (solver also of radiosity), "
                    f"not of method {method!r}"
                )
            method_options = self.lib.default_transcut_options()
            if grading is not None:
                method_options.grading = _grading(grading)
            if discretization is not None:
                method_options.discretization = _discretization(discretization)
            if solver is not None:
                method_options.solver = _solver(solver, "solver")
            if edit_solver is not None:
                method_options.edit_solver = _solver(edit_solver, "edit_solver")
        given = {
            k: v
            for k, v in zip(
                DIPOLE_OPTIONS, (oracle, theta, eps1, eps2, rule, receivers, mode, geometry, budget, radiance)
            )
            if v is not None
        }
        if given:
            if opts.method != TC_METHOD_HIERARCHICAL_DIPOLE:
                raise ValueError(
                    f"{', '.join(given)} {'is an option' if len(given) == 1 else 'are options'} of "
                    f"hierarchical-dipole, not of method {method if method is not None else 'transcut'!r}"
                )
            method_options = self.lib.default_dipole_options()
            for key, value in given.items():
                if key in DIPOLE_CHOICES:
                    value = _choice(value, key)
                elif key == "budget":
                    value = int(value)
                else:
                    value = float(value)
                setattr(method_options, key, value)
        prt = {
            k: v
            for k, v in zip(PRT_OPTIONS, (prt_samples, prt_terms, prt_basis, prt_cache), strict=True)
            if v is not None
        }
        # The cache folder's bytes, kept alive with the struct until tc_scene_bake has returned.
        cache_dir = None
        if prt:
            if opts.method != TC_METHOD_PRT:
                raise ValueError(
                    f"{', '.join(prt)} {'is an option' if len(prt) == 1 else 'are options'} of "
                    f"prt, not of method {method if method is not None else 'transcut'!r}"
                )
            method_options = self.lib.default_prt_options()
            for key, value in prt.items():
                if key == "prt_cache":
                    cache_dir = os.fsencode(value)
                    if not cache_dir:
                        raise ValueError("prt_cache is an empty path (None means no cache)")
                    method_options.cache_dir = cache_dir
                else:
                    setattr(method_options, PRT_OPTIONS[key], _unsigned(value, key))
        if method_options is not None:
            opts.method_options = ctypes.addressof(method_options)
        self._call_with_progress("tc_scene_bake", progress, ctypes.byref(opts))
        del cache_dir

    def _polygrid_options(self, solver, edit_solver, given: dict) -> TcPolygridOptions:
        """``tc_polygrid_options_init``'s defaults with the :meth:`bake` keywords ``given``
        (:data:`POLYGRID_OPTIONS`), ``solver`` and ``edit_solver`` set, counts and names checked."""
        options = self.lib.default_polygrid_options()
        if solver is not None:
            options.solver = _solver(solver, "solver")
        if edit_solver is not None:
            options.edit_solver = _solver(edit_solver, "edit_solver")
        for key, value in given.items():
            if key == "polygrid_stencil":
                value = _stencil(value)
            elif key == "polygrid_nodes":
                value = _unsigned(value, key, 64)
            elif key == "polygrid_resolution":
                value = _unsigned(value, key)
            else:
                value = float(value)
            setattr(options, POLYGRID_OPTIONS[key], value)
        return options

    def _radiosity_options(self, solver, grading, discretization, given: dict) -> TcRadiosityOptions:
        """``tc_radiosity_options_init``'s defaults with the :meth:`bake` keywords ``given``
        (:data:`RADIOSITY_OPTIONS`), ``solver``, ``grading`` and ``discretization`` (the
        translucent objects', as TransCut's) set, counts and names checked."""
        options = self.lib.default_radiosity_options()
        if solver is not None:
            options.solver = _solver(solver, "solver")
        if grading is not None:
            options.grading = _grading(grading)
        if discretization is not None:
            options.discretization = _discretization(discretization)
        for key, value in given.items():
            field = RADIOSITY_OPTIONS[key]
            if key == "iteration":
                value = _iteration(value)
            elif key == "seed":
                value = _unsigned(value, key, 64)
            elif field in ("rays_per_patch", "max_iterations", "bounces"):
                value = _unsigned(value, key)
            else:
                value = float(value)
            setattr(options, field, value)
        return options

    def prt_stats(self, obj: int) -> dict:
        """``tc_object_prt_stats`` as a dict (``size`` left out; ``key`` as 32 hexadecimal
        digits, the name of the precompute's file in a cache folder)."""
        st = TcPrtStats()
        st.size = ctypes.sizeof(TcPrtStats)
        self._call("tc_object_prt_stats", obj, ctypes.byref(st))
        out = {name: getattr(st, name) for name, _ in st._fields_ if name not in ("size", "residual", "key", "medium")}
        out["residual"] = list(st.residual)
        out["key"] = f"{st.key[0]:016x}{st.key[1]:016x}"
        out["medium"] = medium(list(st.medium.sigma_a), list(st.medium.sigma_s_prime), st.medium.eta, st.medium.g)
        return out

    def prt_save(self, obj: int, path: str) -> None:
        """Saves a PRT object's precomputed transfer as a ``.tcprt`` file
        (``tc_object_prt_save``)."""
        self._call("tc_object_prt_save", obj, os.fsencode(path))

    def prt_set_medium(self, obj: int, sigma_a, sigma_s_prime, eta: float, g: float = 0.0) -> None:
        """Gives a PRT object a new medium without a new bake (``tc_object_prt_set_medium``): the
        radiance is updated at once (a K-term sum per vertex) and the scene's description
        follows; η and g must be the object's. Nothing changes on failure."""
        self._call("tc_object_prt_set_medium", obj, ctypes.byref(medium(sigma_a, sigma_s_prime, eta, g)))

    def prt_set_medium_artist(
        self, obj: int, albedo, radius, scale: float, ior: float, anisotropy: float = 0.0, mapping="random-walk"
    ) -> None:
        """As :meth:`prt_set_medium`, from artist parameters (``tc_object_prt_set_medium_artist``;
        the radius in scene units at the object's scale; ``mapping`` as :meth:`set_medium_artist`)."""
        artist = _artist(albedo, radius, scale, ior, anisotropy, mapping)
        self._call("tc_object_prt_set_medium_artist", obj, ctypes.byref(artist))

    def prt_set_scale(self, obj: int, mm_per_unit: float) -> None:
        """A PRT object's millimetres per scene unit, without a new bake
        (``tc_object_prt_set_scale``)."""
        self._call("tc_object_prt_set_scale", obj, float(mm_per_unit))

    def radiance(self, obj: int) -> np.ndarray:
        """The baked radiance of an object: float32 (vertex_count, 3), linear RGB."""
        out = np.empty((self.vertex_count(obj), 3), dtype=np.float32)
        self._call("tc_object_radiance", obj, out.ctypes.data_as(c_float_p), out.size)
        return out

    def bake_texture(self, obj: int, triangles, uvs, width: int, height: int, margin: int = 0) -> np.ndarray:
        """The object's radiance as a texture (``tc_object_bake_texture``): ``triangles`` (m, 3)
        vertex indices of the object, ``uvs`` (m, 3, 2) or (3m, 2) the UV of each corner (UV
        (0, 0) bottom-left); returns float32 (height, width, 4), linear RGB and alpha (1 on the
        surface and its ``margin`` of padding), rows from the TOP of the image."""
        tris = np.ascontiguousarray(triangles, dtype=np.uint32).reshape(-1, 3)
        uv = np.ascontiguousarray(uvs, dtype=np.float32).reshape(-1, 2)
        out = np.empty((int(height), int(width), 4), dtype=np.float32)
        self._call(
            "tc_object_bake_texture",
            obj,
            tris.ctypes.data_as(c_uint32_p),
            tris.shape[0],
            uv.ctypes.data_as(c_float_p),
            uv.size,
            int(width),
            int(height),
            int(margin),
            out.ctypes.data_as(c_float_p),
            out.size,
        )
        return out

    def stats(self, obj: int) -> dict:
        """``tc_object_stats`` as a dict."""
        st = TcBakeStats()
        st.size = ctypes.sizeof(TcBakeStats)
        self._call("tc_object_stats", obj, ctypes.byref(st))
        return _stats_dict(st)

    def radiosity_stats(self) -> dict:
        """``tc_scene_radiosity_stats`` as a dict (``size`` left out): what translucent radiosity
        measured of the whole scene in the last bake (``patches``, ``translucent_patches``,
        ``covered_patches``, ``nonzeros``, ``form_factor_bytes``, ``patch_size_mm``, the stages'
        ``*_ms``, ``iterations`` (sweeps), ``scatterings``, ``estimated_error``,
        ``energy_defect``). ``TC_NOT_BAKED`` before a bake or after a change, ``TC_UNSUPPORTED``
        after another method's bake."""
        st = TcRadiosityStats()
        st.size = ctypes.sizeof(TcRadiosityStats)
        self._call("tc_scene_radiosity_stats", ctypes.byref(st))
        return {name: getattr(st, name) for name, _ in st._fields_ if name != "size"}

    def polygrid_stats(self, obj: int) -> dict:
        """``tc_object_polygrid_stats`` as a dict (``size`` left out): the polycube and grid the
        polygrid method built for the object in the last bake (``resolution``, ``cubes``,
        ``cube_mm``, ``nodes``, ``cells``, ``min_scaled_jacobian``, ``mean_scaled_jacobian``).
        ``TC_UNSUPPORTED`` for an object another method baked."""
        st = TcPolygridStats()
        st.size = ctypes.sizeof(TcPolygridStats)
        self._call("tc_object_polygrid_stats", obj, ctypes.byref(st))
        return {name: getattr(st, name) for name, _ in st._fields_ if name != "size"}

    def dipole_stats(self, obj: int) -> dict:
        """``tc_object_dipole_stats`` as a dict (``size`` left out): what the hierarchical
        dipole's last update of the object (the bake, a relight, :meth:`set_positions`) did.
        ``TC_UNSUPPORTED`` for an object another method baked."""
        st = TcDipoleStats()
        st.size = ctypes.sizeof(TcDipoleStats)
        self._call("tc_object_dipole_stats", obj, ctypes.byref(st))
        return {name: getattr(st, name) for name, _ in st._fields_ if name != "size"}

    def device(self, obj: int) -> str:
        """The GPU adapter that solved the object in the last bake ('' when the CPU did)."""
        return self.lib.text("tc_object_device", self._h(), obj)

    def backend_fallback(self, obj: int) -> str:
        """Why the ``auto`` backend solved the object on the CPU ('' when it did not)."""
        return self.lib.text("tc_object_backend_fallback", self._h(), obj)

    # -- editing (after a bake) ------------------------------------------------------------

    def set_progress(self, progress: Callable[[str, float], bool] | None) -> None:
        """Sets the progress callback of every edit call on this scene (``tc_scene_set_progress``:
        the cuts, splits, fracture, paint, medium edits, piece moves and recombine, and
        :meth:`relight` without its own): ``progress(stage, fraction)`` with the fraction of the
        one call; returning True cancels the call, which then raises :class:`TranscutError` with
        ``TC_CANCELLED`` and changes nothing. An exception ``progress`` raises cancels too and is
        re-raised by the edit call. None clears it."""
        if progress is None:
            self._call("tc_scene_set_progress", TcProgressFn(), None)
            self._edit_progress = None
            return
        callback = _progress_fn(progress, self._edit_errors)
        self._call("tc_scene_set_progress", callback, None)
        self._edit_progress = callback

    def relight(self, progress: Callable[[str, float], bool] | None = None) -> None:
        """Re-solves every object for the scene's current lights (``tc_scene_relight``), warm
        started from the last solution; ``progress`` as for :meth:`bake`. A radiosity bake is
        re-solved as a whole, every object shadowing and lighting every other."""
        self._call_with_progress("tc_scene_relight", progress)

    def edit_albedo(self, obj: int, albedo) -> None:
        """Sets a diffuse object's albedo after a radiosity bake and re-solves the whole scene
        from the last solution, without new form factors (``tc_object_edit_albedo``): the
        results are kept and equal a fresh bake with that albedo, which the scene then also
        has. Reports through the callback of :meth:`set_progress`, which may cancel. The library
        refuses a value out of range or a translucent object (``TC_INVALID_ARGUMENT``), a bake
        by another method (``TC_UNSUPPORTED``) and no bake (``TC_NOT_BAKED``); nothing changes
        on failure."""
        self._call("tc_object_edit_albedo", obj, _vec3(albedo, "albedo"))

    def edit_emission(self, obj: int, emission) -> None:
        """Sets a diffuse object's emitted exitance after a radiosity bake and re-solves the
        whole scene (``tc_object_edit_emission``), as :meth:`edit_albedo` does."""
        self._call("tc_object_edit_emission", obj, _vec3(emission, "emission"))

    def set_positions(self, obj: int, positions) -> None:
        """Moves the vertices of a baked object (``tc_object_set_positions``): ``positions``
        (vertex_count, 3) in object space, the vertices in the order the mesh was added, the
        triangles kept (a frame of an animated mesh), copied as float32. The radiance is then
        updated under the scene's current lights (incrementally in the hierarchical dipole's
        ``mode="incremental"``); the object's transform stays. Reports through the callback of
        :meth:`set_progress`, which may cancel (``TC_CANCELLED``). A shape other than (n, 3)
        raises ValueError; the library refuses another vertex count or non-finite values
        (``TC_INVALID_ARGUMENT``) and an object whose method cannot deform (TransCut:
        ``TC_UNSUPPORTED``). Nothing changes on failure."""
        pos = np.array(positions, dtype=np.float32, order="C", copy=True)
        if pos.ndim != 2 or pos.shape[1] != 3:
            raise ValueError(f"positions must be (vertex_count, 3), got shape {pos.shape}")
        self._call("tc_object_set_positions", obj, pos.ctypes.data_as(c_float_p), pos.shape[0])

    def cut_plane(self, obj: int, point, normal, keep_both: bool = False) -> None:
        """Removes the side ``normal`` points into (``tc_object_cut_plane``); keep_both splits."""
        self._call("tc_object_cut_plane", obj, _vec3(point, "point"), _vec3(normal, "normal"), 1 if keep_both else 0)

    def cut_mesh(self, obj: int, positions, triangles, keep_both: bool = False) -> None:
        """Removes what lies inside a closed mesh, world space (``tc_object_cut_mesh``)."""
        pos = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1)
        tri = np.ascontiguousarray(triangles, dtype=np.uint32).reshape(-1)
        self._call(
            "tc_object_cut_mesh",
            obj,
            pos.ctypes.data_as(c_float_p),
            pos.size // 3,
            tri.ctypes.data_as(c_uint32_p),
            tri.size,
            1 if keep_both else 0,
        )

    def fracture(self, obj: int) -> int:
        """Splits every piece of an edited object into its connected components
        (``tc_object_fracture``); returns the new piece count."""
        out = c_uint32()
        self._call("tc_object_fracture", obj, ctypes.byref(out))
        return int(out.value)

    def paint(self, obj: int, points, radius: float, medium: TcMedium, strength: float = 1.0) -> None:
        """Paints ``medium`` along a 3D stroke (``tc_object_paint``)."""
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1)
        self._call(
            "tc_object_paint",
            obj,
            pts.ctypes.data_as(c_double_p),
            pts.size // 3,
            float(radius),
            ctypes.byref(medium),
            float(strength),
        )

    def piece_count(self, obj: int) -> int:
        """``tc_object_piece_count``."""
        out = c_uint32()
        self._call("tc_object_piece_count", obj, ctypes.byref(out))
        return int(out.value)

    def set_piece_transform(self, obj: int, piece: int, matrix) -> None:
        """Places a piece rigidly (4 × 4, row-major like ``Matrix``; sent column-major)."""
        m = np.ascontiguousarray(np.asarray(matrix, dtype=np.float64).reshape(4, 4).T).reshape(-1)
        self._call("tc_object_set_piece_transform", obj, piece, m.ctypes.data_as(c_double_p))

    def piece_mesh(self, obj: int, piece: int) -> tuple:
        """A piece's surface: float32 positions (n, 3), uint32 triangles (m, 3), float32 radiance (n, 3)."""
        nv, nt = c_size_t(), c_size_t()
        self._call("tc_object_piece_sizes", obj, piece, ctypes.byref(nv), ctypes.byref(nt))
        pos = np.empty((nv.value, 3), np.float32)
        tri = np.empty((nt.value, 3), np.uint32)
        rgb = np.empty((nv.value, 3), np.float32)
        self._call(
            "tc_object_piece_mesh",
            obj,
            piece,
            pos.ctypes.data_as(c_float_p),
            pos.size,
            tri.ctypes.data_as(c_uint32_p),
            tri.size,
            rgb.ctypes.data_as(c_float_p),
            rgb.size,
        )
        return pos, tri, rgb

    def edit_stats(self, obj: int) -> dict:
        """``tc_object_edit_stats`` as a dict."""
        st = TcEditStats()
        st.size = ctypes.sizeof(TcEditStats)
        self._call("tc_object_edit_stats", obj, ctypes.byref(st))
        return _stats_dict(st)
