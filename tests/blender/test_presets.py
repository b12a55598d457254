"""The add-on's preset menu (``properties.PRESET_NAMES``) is exactly the library's preset list:
every entry is accepted by ``tc_medium_preset`` and gives a valid medium (finite, σa ≥ 0,
σ′s > 0, 1 < η < 3), and an unknown name's ``TC_NOT_FOUND`` message, which lists every
valid preset, names no preset the menu lacks. A preset added to or renamed in
``core/src/optics/presets.rs`` therefore fails here until the add-on follows.
"""

from __future__ import annotations

import math
import re

import pytest

from conftest import require_library


def test_preset_menu_equals_the_library_presets(addon):
    require_library()
    lib = addon.library.get()
    menu = addon.properties.PRESET_NAMES
    assert len(set(menu)) == len(menu), "duplicate preset in the add-on menu"
    for name in menu:
        m = lib.medium_preset(name)
        values = [*m.sigma_a, *m.sigma_s_prime]
        assert all(math.isfinite(v) and v >= 0.0 for v in values), name
        assert all(v > 0.0 for v in m.sigma_s_prime), name
        assert 1.0 < m.eta < 3.0, name
    with pytest.raises(addon.transcut.TranscutError) as err:
        lib.medium_preset("no-such-preset")
    assert err.value.status_name == "TC_NOT_FOUND"
    listed = re.search(r"valid presets are: (.*)$", err.value.message)
    assert listed, err.value.message
    library_names = {n.strip() for n in listed.group(1).split(",")}
    assert library_names == set(menu), f"library {sorted(library_names)} vs add-on {sorted(menu)}"
