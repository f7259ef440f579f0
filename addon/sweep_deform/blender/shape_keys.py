# SPDX-License-Identifier: GPL-3.0-or-later
"""Where the shape keys put each vertex, read from the keys themselves.

Sweep Deform carries what reaches it along with each vertex's local linear map J:
``deformed_rest + J (incoming − rest)``. When only shape keys move the vertices (no modifier
before Sweep Deform), ``incoming − rest`` is known before Blender evaluates the mesh: Blender
mixes relative keys as ``reference + Σ value × (key − its relative key)``. The core then turns
that displacement itself (``sd_mix_shape_keys`` mixes the keys, ``sd_deform_frame`` turns
the vertices they move) and the carrier holds plain offsets: no J
blocks written or sampled by the node group, which made a frame with a shape key about twice
one without (docs/addon.md, "Time per frame").

Anything this module does not reproduce exactly returns None, and the caller keeps the general
path (J in the carrier, applied by the node group to whatever arrives): absolute keys, a key
with a vertex group, a pinned shape (``show_only_shape_key``), Edit Mode, a Blender without
``ShapeKey.points``.
"""

import numpy as np

import bpy

from ..core import native


def _evaluated(key, depsgraph):
    """The key as this evaluation sees it (a render's animated and driven values)."""
    if depsgraph is None:
        return key
    try:
        return key.evaluated_get(depsgraph)
    except (RuntimeError, TypeError, ReferenceError):
        return key


def displacements(obj, depsgraph, rest, scratch):
    """(the vertices the shape keys move, int32 ascending; their displacements incoming − rest,
    (M,3) float32 mesh space), both empty when no key moves anything; or None if the keys are
    not mixed as the core mixes them (the caller then uses the general path). `rest` is the
    mesh's own rest positions (V,3); `scratch` a ShapeKeyBuffers."""
    keys = obj.data.shape_keys
    if keys is None or "points" not in bpy.types.ShapeKey.bl_rna.properties:
        return None
    if not keys.use_relative or obj.show_only_shape_key or obj.mode == 'EDIT':
        return None
    reference = keys.reference_key
    evaluated = _evaluated(keys, depsgraph).key_blocks
    blocks = [reference]  # the blocks to read, the reference first
    where = {reference.name: 0}
    terms, values = [], []

    def block_of(block):
        if block.name not in where:
            where[block.name] = len(blocks)
            blocks.append(block)
        return where[block.name]

    for index, block in enumerate(keys.key_blocks):
        if block == reference or block.mute:
            continue
        value = evaluated[index].value
        if value == 0.0:
            continue
        if block.vertex_group:
            return None  # weighted per vertex: the general path
        terms.append((block_of(block), block_of(block.relative_key)))
        values.append(value)
    mix = ([b.name for b in blocks], terms, values)
    if mix != scratch.mixed:  # else the same keys and values as last time, and no key edited since
        positions = scratch.blocks(len(blocks))
        for i, block in enumerate(blocks):
            block.points.foreach_get('co', positions[i].reshape(-1))
        scratch.count = native.mix_shape_keys(rest, positions, np.array(terms, np.int32).reshape(-1, 2),
                                              np.array(values, np.float32), scratch.moved, scratch.moves)
        scratch.mixed = mix
        scratch.mixes += 1
    return scratch.moved[:scratch.count], scratch.moves[:scratch.count]


class ShapeKeyBuffers:
    """Per bound object: the keys' positions as read (grown as needed), the mix's output, and
    what it mixed: (the blocks read, the terms, the values). A frame with the same keys at the
    same values takes the output as it is (reading and mixing the keys took 0.5 ms a frame at
    75K vertices); an edit of the keys or the mesh forgets it (forget(), from handlers.py)."""

    def __init__(self, vertex_count):
        self._blocks = np.empty((0, vertex_count, 3), np.float32)
        self.moved = np.empty(vertex_count, np.int32)
        self.moves = np.empty((vertex_count, 3), np.float32)
        self.count = 0
        self.mixed = None
        self.mixes = 0  # how many mixes were made into moved and moves (a new one: new content)

    def forget(self):
        self.mixed = None

    def blocks(self, count):
        if len(self._blocks) < count:
            self._blocks = np.empty((count,) + self._blocks.shape[1:], np.float32)
        return self._blocks[:count]
