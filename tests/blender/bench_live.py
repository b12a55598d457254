"""Benchmark (not part of the test run; run it by path): Live Translucency and Keep Bakes on the
Stanford bunny (35k vertices, 60 mm, marble, one sun) at 200k tets, through the add-on as a user
drives it, headless (the depsgraph handler applies each change before it returns, so a change's
time is from the change to the attribute written; Blender's UI adds at most the worker timer's
interval, ``live.POLL_SECONDS``; a press of Bake is timed from the operator's call to its
return, the attribute written).

    TRANSCUT_LIB=target/debug/libtranscut.so .venv/bin/python -m pytest -s -p no:cacheprovider \\
        tests/blender/bench_live.py

prints one JSON object per test: Live Translucency's start, then the median and each of five 5°
sun moves, a medium change (re-assembly, no meshing) and an object move (that object meshed
again); Keep Bakes' first bake, the warm-up it leaves running (the editors' setup, while the user
looks), then five presses of Bake after a 5° sun move; in seconds.
"""

from __future__ import annotations

import json
import math
import statistics
import time
from pathlib import Path

import numpy as np

from conftest import REPO, bpy, require_library
from test_addon import add_light, select_only

BUNNY = REPO / "assets" / "meshes" / "stanford-bunny.obj"
MOVES = 5


def timed(change) -> float:
    start = time.perf_counter()
    change()
    bpy.context.view_layer.update()
    return time.perf_counter() - start


def bunny_scene(scene):
    """The bunny, 60 mm across, the marble preset, 200k tets, a sun at 30°: (bunny, sun)."""
    bpy.ops.wm.obj_import(filepath=str(BUNNY))
    bunny = bpy.context.selected_objects[0]
    extent = max(bunny.dimensions)
    scene.unit_settings.scale_length = 0.060 / extent  # 60 mm across
    bunny.transcut.medium_source = "PRESET"
    bunny.transcut.preset = "marble"
    scene.transcut.tets = 200_000
    sun = add_light("SUN", rotation=(math.radians(30.0), 0.0, 0.0), energy=3.0)
    select_only(bunny)
    return bunny, sun


def test_bench_live_bunny(scene, addon):
    require_library()
    bunny, sun = bunny_scene(scene)
    extent = max(bunny.dimensions)
    start = time.perf_counter()
    assert bpy.ops.transcut.live_start() == {"FINISHED"}
    first = time.perf_counter() - start
    session = addon.live._live.worker.session
    moves = []
    for i in range(MOVES):
        angle = math.radians(30.0 + 5.0 * (i + 1))
        moves.append(timed(lambda angle=angle: setattr(sun, "rotation_euler", (angle, 0.0, 0.0))))
        assert session.outcome == "relit"
    medium = timed(lambda: setattr(bunny.transcut, "preset", "skimmilk"))
    assert session.outcome == "rebaked" and session.store.meshed == ()
    moved = timed(lambda: setattr(bunny, "location", (bunny.location.x + 0.1 * extent, 0.0, 0.0)))
    assert session.outcome == "rebaked" and session.store.meshed == (bunny.name,)
    assert np.all(np.isfinite(np.asarray(bunny.data.color_attributes["SSS"].data[0].color)))
    tets = next(iter(session.store._bakes.values())).tets
    assert bpy.ops.transcut.live_stop() == {"FINISHED"}
    print(
        json.dumps(
            {
                "mesh": Path(BUNNY).name,
                "vertices": len(bunny.data.vertices),
                "tets": tets,
                "first_bake_s": round(first, 4),
                "light_move_s": {"median": round(statistics.median(moves), 4), "each": [round(t, 4) for t in moves]},
                "medium_change_s": round(medium, 4),
                "object_move_s": round(moved, 4),
            }
        )
    )


def test_bench_keep_bakes_bunny(scene, addon):
    require_library()
    bunny, sun = bunny_scene(scene)
    store = addon.kept_native.STORE
    start = time.perf_counter()
    assert bpy.ops.object.transcut_bake() == {"FINISHED"}
    first = time.perf_counter() - start
    start = time.perf_counter()
    store.settle()
    warm_up = time.perf_counter() - start + first  # an upper bound of the thread's own time
    presses = []
    for i in range(MOVES):
        sun.rotation_euler = (math.radians(30.0 + 5.0 * (i + 1)), 0.0, 0.0)
        bpy.context.view_layer.update()
        start = time.perf_counter()
        assert bpy.ops.object.transcut_bake() == {"FINISHED"}
        presses.append(time.perf_counter() - start)
        assert bunny.transcut.last_bake.outcome == "relit"
    median = statistics.median(presses)
    print(
        json.dumps(
            {
                "mesh": Path(BUNNY).name,
                "tets": int(bunny.transcut.last_bake.tets),
                "first_bake_s": round(first, 4),
                "warm_up_ends_after_s": round(warm_up, 4),
                "rebake_after_sun_move_s": {"median": round(median, 4), "each": [round(t, 4) for t in presses]},
                "speedup": round(first / median, 1),
            }
        )
    )
