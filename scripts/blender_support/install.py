# SPDX-License-Identifier: GPL-3.0-or-later
"""Installs and enables the extension zip inside a running Blender (used by tests/blender/run.py,
the tests' measure_*.py and scripts/demo_scene.py):
``blender --command extension install-file -r user_default -e ZIP`` in a
child Blender, exactly as a user would, then enabling it here."""

import os
import subprocess
import sys

MODULE = "bl_ext.user_default.sweep_deform"
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def default_zip():
    return os.environ.get("SWEEPDEFORM_ADDON_ZIP") or os.path.join(REPO, "build", "sweep_deform-0.1.0.zip")


def install(zip_path):
    import addon_utils
    import bpy
    if not os.environ.get("BLENDER_USER_RESOURCES"):
        sys.exit("install.py: set BLENDER_USER_RESOURCES to a scratch directory (the user "
                 "configuration of the Blender root is shared)")
    zip_path = os.path.abspath(zip_path)
    if not os.path.isfile(zip_path):
        sys.exit(f"install.py: {zip_path} not found: cmake --build build --target addon_package")
    cmd = [bpy.app.binary_path, "--command", "extension", "install-file", "-r", "user_default", "-e", zip_path]
    out = subprocess.run(cmd, capture_output=True, text=True)
    print(out.stdout.strip().splitlines()[-1] if out.stdout.strip() else out.stderr, flush=True)
    # The command exits 0 even when it refuses a package: check the files.
    target = os.path.join(bpy.utils.user_resource('EXTENSIONS'), "user_default", "sweep_deform")
    if out.returncode != 0 or not os.path.isfile(os.path.join(target, "blender_manifest.toml")):
        sys.exit(f"install.py: installing {zip_path} failed:\n{out.stdout}\n{out.stderr}")
    addon_utils.modules_refresh()
    if bpy.ops.preferences.addon_enable(module=MODULE) != {'FINISHED'}:
        sys.exit(f"install.py: could not enable {MODULE}")
    os.environ["SWEEPDEFORM_ADDON_ZIP"] = zip_path
