"""The add-on's handle on the native library: loaded once, never fatal, no ``bpy``.

Loading happens at register time and again on demand (the "Reload Library" button, a change of
the library path, or a bake after a failed load), so a missing or broken library never stops the
add-on from enabling: the preferences panel shows :data:`state` (the exact paths tried and each
error) instead. The caller passes the path (:func:`preferences.library_path`), so this module
knows nothing of Blender.
"""

from __future__ import annotations

from . import transcut


class State:
    """What the last load attempt found: the library, or every path tried and why it failed."""

    def __init__(self):
        self.lib: transcut.Library | None = None
        self.tried: list[tuple[str, str]] = []
        self.error: str = ""

    def reset(self) -> None:
        self.lib = None
        self.tried = []
        self.error = ""


state = State()


def load(path: str | None = None) -> transcut.Library | None:
    """(Re)loads the library from ``path`` (empty or None: the default candidates of
    :func:`transcut.load`) into :data:`state`; returns it, or None after recording the failure."""
    state.reset()
    try:
        state.lib = transcut.load(path or None)
        state.tried = [(state.lib.path, "loaded")]
    except transcut.LibraryNotFound as exc:
        state.tried = exc.tried
        state.error = str(exc)
    return state.lib


def get(path: str | None = None) -> transcut.Library:
    """The loaded library, loading it from ``path`` first if none is loaded.

    Raises :class:`transcut.LibraryNotFound` (naming each path tried) when it cannot be loaded.
    """
    if state.lib is None:
        load(path)
    if state.lib is None:
        raise transcut.LibraryNotFound(state.tried)
    return state.lib
