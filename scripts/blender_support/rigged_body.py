# SPDX-License-Identifier: GPL-3.0-or-later
"""The bodies scripts/quality makes from a shared file: opening the source and finding its one
rigged mesh and that mesh's armature."""

import bpy


def open_rigged_body(source, who):
    """Opens `source` and returns (its one mesh with an armature, that armature); exits with a
    message naming `who` when the file holds none or several."""
    bpy.ops.wm.open_mainfile(filepath=source)
    bodies = [o for o in bpy.data.objects if o.type == "MESH" and o.find_armature()]
    if len(bodies) != 1:
        raise SystemExit(f"{who}: {source} has {len(bodies)} rigged meshes, expected one")
    return bodies[0], bodies[0].find_armature()
