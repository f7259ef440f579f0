# SPDX-License-Identifier: GPL-3.0-or-later
"""addon/sweep_deform/core/ runs without Blender: every module of it imports in plain Python
with bpy (and Blender's other modules) made unimportable, and none of them names one."""

import importlib
import sys
import types

import pytest

import addon_modules

#: Modules only Blender's Python has.
BLENDER_MODULES = {"bpy", "bpy_extras", "bmesh", "mathutils", "gpu", "gpu_extras", "addon_utils", "bl_ui"}

CORE = sorted(n for n in addon_modules.module_files() if n.startswith(f"{addon_modules.PACKAGE}.core"))


class _NoBlender:
    """A meta-path finder that refuses Blender's modules (even if some bpy were installed)."""

    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLENDER_MODULES:
            raise ImportError(f"core/ imported {name}")
        return None


@pytest.fixture
def addon_package(monkeypatch):
    """The add-on's package without running its __init__.py (that one registers with Blender):
    an empty package module on the add-on's folder, then core/ imports as in Blender."""
    for name in [n for n in sys.modules if n == addon_modules.PACKAGE or n.startswith(addon_modules.PACKAGE + ".")]:
        monkeypatch.delitem(sys.modules, name)
    package = types.ModuleType(addon_modules.PACKAGE)
    package.__path__ = [addon_modules.ADDON]
    monkeypatch.setitem(sys.modules, addon_modules.PACKAGE, package)
    finder = _NoBlender()
    monkeypatch.setattr(sys, "meta_path", [finder] + sys.meta_path)
    yield
    for name in [n for n in sys.modules if n.startswith(addon_modules.PACKAGE + ".")]:
        monkeypatch.delitem(sys.modules, name, raising=False)


def test_core_has_the_modules_the_docs_name():
    names = {n.rsplit(".", 1)[-1] for n in CORE}
    assert {"native", "native_dmap", "arrays", "checks", "fit_report", "key_edit", "cache_files"} <= names, names


@pytest.mark.parametrize("name", CORE)
def test_core_module_imports_without_blender(name, addon_package):
    module = importlib.import_module(name)
    assert module.__file__.startswith(addon_modules.ADDON)
    loaded = {n.split(".")[0] for n in sys.modules}
    assert not loaded & BLENDER_MODULES, loaded & BLENDER_MODULES


@pytest.mark.parametrize("name", CORE)
def test_core_module_names_no_blender_module_nor_a_floor_above(name):
    files = addon_modules.module_files()
    for target, line, _ in addon_modules.imports(name, files):
        assert target.split(".")[0] not in BLENDER_MODULES, f"{files[name]}:{line} imports {target}"
        if target.startswith(addon_modules.PACKAGE + "."):
            assert target.startswith(f"{addon_modules.PACKAGE}.core"), f"{files[name]}:{line} imports {target}"


def test_the_no_blender_guard_refuses_bpy(addon_package):
    """The guard the import test relies on does refuse bpy."""
    with pytest.raises(ImportError, match="bpy"):
        importlib.import_module("bpy")


def test_core_does_its_work_without_blender(addon_package):
    """Not only importable: the numpy layer computes (offsets of a rotated mesh, a label)."""
    import numpy as np
    arrays = importlib.import_module(f"{addon_modules.PACKAGE}.core.arrays")
    key_edit = importlib.import_module(f"{addon_modules.PACKAGE}.core.key_edit")
    out, scratch = np.empty((2, 3), np.float32), np.empty((2, 3), np.float32)
    deformed = np.array([[1, 0, 0], [0, 2, 0]], np.float32)
    offsets = arrays.offsets_into(deformed, np.zeros((2, 3), np.float32), None, out, scratch)
    np.testing.assert_array_equal(offsets, deformed)
    assert key_edit.format_key_label("arm_l", 3, 5, True, "forearm.L") == "arm_l · key 3 (joint forearm.L)"
