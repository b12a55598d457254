"""Finding and loading the shared library.

The candidates (:func:`library_candidates`, first existing file wins):

1. the ``TRANSCUT_LIB`` environment variable (a full path to the shared library);
2. this package's folder (the wheel's ``transcut`` folder, or an add-on folder that bundles it);
3. the folder of an installed ``transcut`` package (the wheel the Blender extension carries);
4. a development checkout: ``target/release`` then ``target/debug`` of the repository that
   holds ``blender_addon/``.

An explicit path, or ``TRANSCUT_LIB``, is the only one tried.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from collections.abc import Sequence

from .scene import Library, TranscutError


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
    root = os.path.dirname(os.path.dirname(here))  # in a checkout: the repository
    paths.append(os.path.join(root, "target", "release", name))
    paths.append(os.path.join(root, "target", "debug", name))
    seen = set()
    return [p for p in paths if not (p in seen or seen.add(p))]


def load(path: str | None = None) -> Library:
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
