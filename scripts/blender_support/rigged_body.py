# SPDX-License-Identifier: GPL-3.0-or-later
"""The bodies scripts/quality makes from a shared file: opening the source and finding its one
rigged mesh and that mesh's armature, and passing skin weight from one bone to another."""

import bpy


def open_rigged_body(source, who):
    """Opens `source` and returns (its one mesh with an armature, that armature); exits with a
    message naming `who` when the file holds none or several."""
    bpy.ops.wm.open_mainfile(filepath=source)
    bodies = [o for o in bpy.data.objects if o.type == "MESH" and o.find_armature()]
    if len(bodies) != 1:
        raise SystemExit(f"{who}: {source} has {len(bodies)} rigged meshes, expected one")
    return bodies[0], bodies[0].find_armature()


def select_only(active, *also):
    """Makes `active` the active object and it (and `also`) the only selected objects, as the
    operators that follow (mode switches, apply, subdivide) need."""
    bpy.context.view_layer.objects.active = active
    for o in bpy.context.view_layer.objects:
        o.select_set(o == active or o in also)


def smoothstep(x):
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


def pass_weight(body, armature, bone, to_group, head, tail, share):
    """Moves share(x) of each vertex's weight on `bone` to the vertex group `to_group`, x being
    the vertex's place along the bone from `head` (0) to `tail` (1), in armature space."""
    to_armature = armature.matrix_world.inverted() @ body.matrix_world
    group = body.vertex_groups[bone]
    d = tail - head
    for v in body.data.vertices:
        for g in v.groups:
            if g.group != group.index or g.weight <= 0.0:
                continue
            moved = g.weight * share(((to_armature @ v.co) - head).dot(d) / d.length_squared)
            to_group.add([v.index], moved, 'REPLACE')
            group.add([v.index], g.weight - moved, 'REPLACE')
