"""The add-on's handle on the native library: loaded once, never fatal.

Loading happens at register time and again on demand (the "Reload Library" button, or a bake
after a failed load), so a missing or broken library never stops the add-on from enabling: the
preferences panel shows :data:`state` (the exact paths tried and each error) instead.
"""

from __future__ import annotations

from typing import Optional

from . import native


class State:
    """What the last load attempt found: the library, or every path tried and why it failed."""

    def __init__(self):
        self.lib: Optional[native.Library] = None
        self.tried: list[tuple[str, str]] = []
        self.error: str = ""

    def reset(self) -> None:
        self.lib = None
        self.tried = []
        self.error = ""


state = State()


def configured_path(context=None) -> str:
    """The library path set in the add-on preferences ('' when unset or not registered)."""
    from . import preferences

    prefs = preferences.get(context)
    return bpy_abspath(prefs.library_path) if prefs is not None and prefs.library_path else ""


def bpy_abspath(path: str) -> str:
    try:
        import bpy

        return bpy.path.abspath(path)
    except Exception:  # outside Blender
        return path


def load(context=None) -> Optional[native.Library]:
    """(Re)loads the library into :data:`state`; returns it, or None after recording the failure."""
    state.reset()
    path = configured_path(context) or None
    try:
        state.lib = native.load(path)
        state.tried = [(state.lib.path, "loaded")]
    except native.LibraryNotFound as exc:
        state.tried = exc.tried
        state.error = str(exc)
    return state.lib


def get(context=None) -> native.Library:
    """The loaded library, loading it first if needed.

    Raises :class:`native.LibraryNotFound` (naming each path tried) when it cannot be loaded.
    """
    if state.lib is None:
        load(context)
    if state.lib is None:
        raise native.LibraryNotFound(state.tried)
    return state.lib
