# SPDX-License-Identifier: GPL-3.0-or-later
"""pytest inside Blender: every test starts from an empty file, with the add-on's rig maker
restored (tests that bind install the test rig of bone_rig.py explicitly)."""

import bpy
import pytest

import helpers


def pytest_report_header(config):
    ok, version = helpers.sub("core.native").available()
    return [f"Blender {bpy.app.version_string}, libsweepdeform {version if ok else 'UNAVAILABLE: ' + version}"]


@pytest.fixture(autouse=True)
def fresh_file():
    bind = helpers.sub("blender.binding")
    fitter = bind.fitter
    bpy.ops.wm.read_homefile(use_empty=True)
    yield
    bind.fitter = fitter
    bpy.ops.wm.read_homefile(use_empty=True)


@pytest.fixture(params=helpers.CHARACTERS)
def character(request):
    """Each character in turn (skipped, saying why, when its file is missing)."""
    return helpers.load(request.param)
