"""Kept bakes in Blender: the store of ``kept_native`` freed when its objects, the file or the
add-on go away (a persistent ``depsgraph_update_post`` handler closes the scenes of deleted
objects; ``load_pre`` and unregister close them all)."""

from __future__ import annotations

import bpy
from bpy.app.handlers import persistent

from .kept_native import STORE


@persistent
def _on_depsgraph(_scene, _depsgraph) -> None:
    if len(STORE):
        STORE.drop_missing(lambda name: bpy.data.objects.get(name) is not None)


@persistent
def _on_load(*_args) -> None:
    STORE.clear()


def register():
    bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph)
    bpy.app.handlers.load_pre.append(_on_load)


def unregister():
    for handlers, fn in (
        (bpy.app.handlers.depsgraph_update_post, _on_depsgraph),
        (bpy.app.handlers.load_pre, _on_load),
    ):
        if fn in handlers:
            handlers.remove(fn)
    STORE.clear()
