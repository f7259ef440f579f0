# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's import graph, read with ast (no Blender): no circle, floors point one way
(ui → blender → core), and every import stands at the top of its file."""

import addon_modules

FLOORS = {"core": 0, "blender": 1, "ui": 2}


def floor(name):
    parts = name.split(".")
    return FLOORS.get(parts[1]) if len(parts) > 1 else 3  # the package's __init__ registers: top


def test_no_import_circle():
    assert addon_modules.cycles(addon_modules.graph()) == []


def test_cycle_finder_finds_a_circle():
    """The finder the test above relies on: a three-module circle and a self-import."""
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": {"e"}}
    assert addon_modules.cycles(edges) == [["a", "b", "c"], ["e"]]
    assert addon_modules.cycles({"a": {"b"}, "b": set()}) == []


def test_every_module_is_read():
    names = set(addon_modules.graph())
    assert {"sweep_deform", "sweep_deform.core.native", "sweep_deform.blender.frame", "sweep_deform.ui.panel"} <= names


def test_floors_point_down():
    for name, targets in addon_modules.graph().items():
        for target in targets:
            assert floor(target) <= floor(name), \
                f"{name} (floor {floor(name)}) imports {target} (floor {floor(target)})"


def test_every_import_at_the_top_of_its_file():
    files = addon_modules.module_files()
    nested = [f"{files[n]}:{line} imports {target}" for n in files
              for target, line, inside in addon_modules.imports(n, files) if inside]
    assert nested == []
