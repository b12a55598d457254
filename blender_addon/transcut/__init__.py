"""libtranscut through its C ABI (``include/transcut.h``), with ctypes and NumPy.

The package needs only the standard library and NumPy, never ``bpy``: the Blender add-on uses
it, and ``scripts/package-addon.py`` ships it as the ``transcut`` wheel beside the shared
library, which works with a plain ``pip install`` outside Blender.

- :mod:`._abi`: the header's constants, structs and function prototypes;
- :mod:`._loader`: where the shared library is looked for, :func:`load`, :class:`LibraryNotFound`;
- :mod:`.scene`: :class:`Library` (also the subsurface methods it has, :meth:`Library.methods`) and
  :class:`Scene`, the checked calls, :class:`TranscutError`.

Example (a unit cube of marble lit by a white sky)::

    import numpy as np, transcut
    lib = transcut.load()
    with lib.scene() as scene:
        obj = scene.add_mesh(positions, triangles)     # float32 (n, 3), uint32 (m, 3)
        scene.set_scale(obj, 10.0)                      # 10 mm per unit
        scene.set_medium_preset(obj, "marble")
        scene.add_environment((1.0, 1.0, 1.0))
        scene.bake(tets=20000)                          # defaults: method="transcut", solver="ssor-pcg"
        rgb = scene.radiance(obj)                       # float32 (n, 3), linear RGB
"""

from ._abi import (
    ABI_MAJOR,
    BACKENDS,
    SOLVERS,
    STATUS_NAMES,
    TC_BACKEND_AUTO,
    TC_BACKEND_CPU,
    TC_BACKEND_DEFAULT,
    TC_BACKEND_GPU,
    TC_BUFFER_TOO_SHORT,
    TC_BUSY,
    TC_CANCELLED,
    TC_GPU_UNAVAILABLE,
    TC_INTERNAL_ERROR,
    TC_INVALID_ARGUMENT,
    TC_INVALID_HANDLE,
    TC_INVALID_MESH,
    TC_IO_ERROR,
    TC_MAX_ITERATIONS,
    TC_MAX_SAMPLES,
    TC_MAX_TETS,
    TC_MAX_THREADS,
    TC_MEDIUM_ADD,
    TC_MEDIUM_ASSIGN,
    TC_MEDIUM_SCALE,
    TC_MESHING_FAILED,
    TC_METHOD_TRANSCUT,
    TC_NOT_BAKED,
    TC_NOT_FOUND,
    TC_NOTHING_LEFT,
    TC_NULL_POINTER,
    TC_OK,
    TC_REGION_ALL,
    TC_REGION_DEPTH,
    TC_REGION_MASK,
    TC_REGION_SPHERE,
    TC_SOLVE_FAILED,
    TC_SOLVER_CASCADE,
    TC_SOLVER_DEFAULT,
    TC_SOLVER_MG_PCG,
    TC_SOLVER_PCG,
    TC_SOLVER_SA_PCG,
    TC_SOLVER_SSOR_PCG,
    TC_UNRESOLVED,
    TC_UNSUPPORTED,
    TcArtistMedium,
    TcBakeOptions,
    TcBakeStats,
    TcEditStats,
    TcMedium,
    TcMediumEdit,
    TcProgressFn,
    TcTransCutOptions,
)
from ._loader import LibraryNotFound, library_candidates, library_file_name, load
from .scene import Library, Scene, TranscutError, medium

__all__ = [
    "ABI_MAJOR",
    "BACKENDS",
    "SOLVERS",
    "STATUS_NAMES",
    "TC_BACKEND_AUTO",
    "TC_BACKEND_CPU",
    "TC_BACKEND_DEFAULT",
    "TC_BACKEND_GPU",
    "TC_BUFFER_TOO_SHORT",
    "TC_BUSY",
    "TC_CANCELLED",
    "TC_GPU_UNAVAILABLE",
    "TC_INTERNAL_ERROR",
    "TC_INVALID_ARGUMENT",
    "TC_INVALID_HANDLE",
    "TC_INVALID_MESH",
    "TC_IO_ERROR",
    "TC_MAX_ITERATIONS",
    "TC_MAX_SAMPLES",
    "TC_MAX_TETS",
    "TC_MAX_THREADS",
    "TC_MEDIUM_ADD",
    "TC_MEDIUM_ASSIGN",
    "TC_MEDIUM_SCALE",
    "TC_MESHING_FAILED",
    "TC_METHOD_TRANSCUT",
    "TC_NOTHING_LEFT",
    "TC_NOT_BAKED",
    "TC_NOT_FOUND",
    "TC_NULL_POINTER",
    "TC_OK",
    "TC_REGION_ALL",
    "TC_REGION_DEPTH",
    "TC_REGION_MASK",
    "TC_REGION_SPHERE",
    "TC_SOLVE_FAILED",
    "TC_SOLVER_CASCADE",
    "TC_SOLVER_DEFAULT",
    "TC_SOLVER_MG_PCG",
    "TC_SOLVER_PCG",
    "TC_SOLVER_SA_PCG",
    "TC_SOLVER_SSOR_PCG",
    "TC_UNRESOLVED",
    "TC_UNSUPPORTED",
    "Library",
    "LibraryNotFound",
    "Scene",
    "TcArtistMedium",
    "TcBakeOptions",
    "TcBakeStats",
    "TcEditStats",
    "TcMedium",
    "TcMediumEdit",
    "TcProgressFn",
    "TcTransCutOptions",
    "TranscutError",
    "library_candidates",
    "library_file_name",
    "load",
    "medium",
]
