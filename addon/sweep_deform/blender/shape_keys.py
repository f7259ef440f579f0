# SPDX-License-Identifier: GPL-3.0-or-later
"""Where the shape keys put each vertex, read from the keys themselves.

Sweep Deform carries what reaches it along with each vertex's local linear map J:
``deformed_rest + J (incoming − rest)``. When only shape keys move the vertices (no modifier
before Sweep Deform), ``incoming − rest`` is known before Blender evaluates the mesh: Blender
mixes relative keys as ``reference + Σ value × (key − its relative key)``. The core then turns
that displacement itself (``sd_deform_displaced``) and the carrier holds plain offsets: no J
blocks written or sampled by the node group, which made a frame with a shape key about twice
one without (docs/addon.md, "Time per frame").

Anything this module does not reproduce exactly returns None, and the caller keeps the general
path (J in the carrier, applied by the node group to whatever arrives): absolute keys, a key
with a vertex group, a pinned shape (``show_only_shape_key``), Edit Mode, a Blender without
``ShapeKey.points``.
"""

import numpy as np

import bpy


def _evaluated(key, depsgraph):
    """The key as this evaluation sees it (a render's animated and driven values)."""
    if depsgraph is None:
        return key
    try:
        return key.evaluated_get(depsgraph)
    except (RuntimeError, TypeError, ReferenceError):
        return key


def displacements(obj, depsgraph, rest, out, scratch):
    """(V,3) float32 `out` holding incoming − rest for the shape keys alone (mesh space), or
    None if the keys are not mixed as this function mixes them (the caller then uses the
    general path). `rest` is the mesh's own rest positions (V,3); `scratch` a (V,3) float32
    buffer. With no key active, `out` is all zeros."""
    keys = obj.data.shape_keys
    if keys is None or "points" not in bpy.types.ShapeKey.bl_rna.properties:
        return None
    if not keys.use_relative or obj.show_only_shape_key or obj.mode == 'EDIT':
        return None
    blocks = keys.key_blocks
    reference = keys.reference_key
    evaluated = _evaluated(keys, depsgraph).key_blocks
    flat = out.reshape(-1)
    reference.points.foreach_get('co', flat)
    np.subtract(out, rest, out=out)  # the basis itself may differ from the mesh's positions
    read = {}  # each block's positions read once

    def positions(block):
        if block.name not in read:
            data = np.empty_like(out)
            block.points.foreach_get('co', data.reshape(-1))
            read[block.name] = data
        return read[block.name]

    for index, block in enumerate(blocks):
        if block == reference or block.mute:
            continue
        value = evaluated[index].value
        if value == 0.0:
            continue
        if block.vertex_group:
            return None  # weighted per vertex: the general path
        relative = block.relative_key
        np.subtract(positions(block), positions(relative), out=scratch)
        scratch *= np.float32(value)
        out += scratch
    return out
