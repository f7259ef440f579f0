# SPDX-License-Identifier: GPL-3.0-or-later
"""The installed extension: its files, its native library, the ABI table."""

import os
import re

import bpy

import helpers


def installed_dir():
    return os.path.join(bpy.utils.user_resource('EXTENSIONS'), "user_default", "sweep_deform")


def test_installed_from_the_zip_with_its_libraries():
    d = installed_dir()
    for f in ("blender_manifest.toml", "__init__.py", "core/native.py", "lib/libsweepdeform.so.0.1.0",
              "lib/libtbb.so.12"):
        assert os.path.isfile(os.path.join(d, f)), f
    assert helpers.addon().__name__ == helpers.MODULE
    assert hasattr(bpy.ops.object, "sweep_deform_add")


def test_library_loads_by_its_versioned_name_and_abi():
    native = helpers.sub("core.native")
    ok, version = native.available()
    assert ok, version
    assert version == "0.1.0"
    assert native.abi_version() == native.ABI_VERSION == 7
    assert native.library_path() == os.path.join(installed_dir(), "lib", "libsweepdeform.so.0.1.0")
    maps = open("/proc/self/maps").read()
    assert os.path.join(installed_dir(), "lib", "libsweepdeform.so.0.1.0") in maps


def test_tbb_is_blenders_one_copy():
    """The library needs libtbb.so.12; Blender has already loaded a newer one, which the
    loader reuses (same SONAME), so the copy bundled in lib/ stays unused and only one TBB
    runs in the process. The core runs on it (a deformation uses TBB)."""
    helpers.sub("core.native").library()
    maps = [l.split()[-1] for l in open("/proc/self/maps") if "libtbb.so" in l]
    tbb = sorted(set(maps))
    assert len(tbb) == 1, tbb
    assert not tbb[0].startswith(installed_dir()), tbb
    bundled = [l for l in open("/proc/self/maps") if "OpenMesh" in l]
    if bundled:  # OpenMesh (the fitting) is not in Blender: ours is used
        assert all(installed_dir() in l for l in bundled)


def test_every_abi_function_is_declared():
    """native.SIGNATURES and native_dmap.SIGNATURES against the header: same function names,
    same argument counts. sweepdeform_dmap.h (sd_dmap_*) belongs to libsweepdeform_dmap
    (native_dmap.py), sweepdeform.h to libsweepdeform (native.py)."""
    include = os.path.join(helpers.REPO, "native", "include", "sweepdeform")
    header = "".join(open(os.path.join(include, name)).read() for name in ("sweepdeform.h", "sweepdeform_dmap.h"))
    header = re.sub(r"/\*.*?\*/", "", header, flags=re.S)
    declared = {}
    for m in re.finditer(r"SD_API\s+[\w\s\*]+?\b(sd_\w+)\s*\(([^)]*)\)", header):
        args = m.group(2).strip()
        declared[m.group(1)] = 0 if args in ("", "void") else args.count(",") + 1
    for module, in_it in (("core.native", lambda n: not n.startswith("sd_dmap_")),
                          ("core.native_dmap", lambda n: n.startswith("sd_dmap_"))):
        binding = helpers.sub(module)
        mine = {n: c for n, c in declared.items() if in_it(n)}
        assert set(mine) == set(binding.SIGNATURES), module
        lib = binding.library()
        for name, count in mine.items():
            assert len(binding.SIGNATURES[name][1]) == count, name
            assert getattr(lib, name).argtypes is not None, name


def test_missing_library_is_reported_clearly(monkeypatch, tmp_path):
    native = helpers.sub("core.native")
    monkeypatch.setenv("SWEEPDEFORM_LIBRARY", str(tmp_path / "nothing.so"))
    try:
        native._load()
        assert False, "loaded a missing library"
    except native.NativeLibraryError as e:
        assert "missing" in str(e) and "nothing.so" in str(e)


def test_wrong_abi_version_is_refused(monkeypatch):
    native = helpers.sub("core.native")
    found = native.abi_version()
    monkeypatch.setattr(native, "ABI_VERSION", 99)
    try:
        native._load()
        assert False, "accepted another ABI"
    except native.NativeLibraryError as e:
        assert f"ABI version {found}" in str(e) and "needs 99" in str(e)


def test_arrays_of_the_wrong_dtype_never_reach_c():
    import numpy as np
    native = helpers.sub("core.native")
    rig = native.Rig.create([-1], np.eye(4).ravel(), [0, 0, 0], [0, 0, 1])
    try:
        native.library().sd_rig_create(1, np.array([-1], np.int64), None, None, None, None)
        assert False
    except Exception as e:
        assert "dtype" in str(e)
    assert rig.bone_count == 1


PREFS_SCRIPT = r'''
import bpy, sys
zip_path = sys.argv[sys.argv.index("--") + 1]
print("RESULT", bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True))
print("ENABLED", "bl_ext.user_default.sweep_deform" in bpy.context.preferences.addons)
from bl_ext.user_default.sweep_deform.core import native
print("NATIVE", native.available())
'''


def test_installs_from_preferences_too(tmp_path):
    """Preferences > Get Extensions > Install from Disk (the operator behind it), into a
    fresh user directory, in a child Blender."""
    import subprocess
    zip_path = os.environ["SWEEPDEFORM_ADDON_ZIP"]
    script = tmp_path / "prefs_install.py"
    script.write_text(PREFS_SCRIPT)
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "user"))
    proc = subprocess.run([bpy.app.binary_path, "-b", "--factory-startup", "--python", str(script), "--", zip_path],
                          capture_output=True, text=True, env=env, timeout=120)
    out = proc.stdout
    assert "RESULT {'FINISHED'}" in out and "ENABLED True" in out and "NATIVE (True, '0.1.0')" in out, out + proc.stderr
