# SPDX-License-Identifier: GPL-3.0-or-later
"""A body the shared data does not have: a game level of detail of a rigged character, made by
Blender's own Decimate modifier (collapse, which carries the vertex groups along), for
scripts/quality. The source file is only read; the result is written elsewhere.

    blender -b --factory-startup --python scripts/blender_support/decimated_body.py -- SOURCE RATIO OUT
"""

import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rigged_body import open_rigged_body, select_only  # noqa: E402  (a sibling module, on the path just above)


def main():
    source, ratio, out = sys.argv[sys.argv.index("--") + 1:][:3]
    body, _ = open_rigged_body(source, "decimated_body")
    select_only(body)
    before = len(body.data.vertices)
    mod = body.modifiers.new("LOD", "DECIMATE")
    mod.ratio = float(ratio)
    bpy.ops.object.modifier_move_to_index(modifier=mod.name, index=0)
    bpy.ops.object.modifier_apply(modifier=mod.name)
    print(f"decimated_body: {body.name} {before} -> {len(body.data.vertices)} vertices")
    bpy.ops.wm.save_as_mainfile(filepath=out)


main()
