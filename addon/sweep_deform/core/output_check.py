# SPDX-License-Identifier: GPL-3.0-or-later
"""Every frame's output against what a sweep can produce (issue 15): no ``bpy``; the check
itself runs in the core (``sd_output_check_*``, native/src/deform/output_check.cpp), Python
reads its verdict.

A sweep moves a vertex with its limb: its distance to the bones it is skinned to changes at a
joint (the skin folds, bulges, keeps its volume), but not by much. So each vertex's distance
to its posed bones (the nearer of its two heaviest skin bones, as segments head→tail) must
stay within :data:`RATIO_LIMIT` times its rest distance to them. Rest distances below
:data:`FLOOR_SHARE` of the body's size count as that floor, so a vertex on its bone at rest
may still move a little off it. A frame beyond the bound is not shown: frame.py shows the
linear blend skinning of the same pose instead (:meth:`OutputCheck.linear_blend`), and the panel
says so, naming the frame's worst bone.

Measured on the built-in character bound with the product's fitting, 1000 seeded frames
with every bone at up to ±170° about each axis (tests/blender/explore_extreme.py): the largest
ratio of a frame is at most 1.58 (1.68 with the anatomical effects on), so the bound of 3 is
nearly twice what the sweeps produce; the shards the issue reported (vertices a metre off a
body 1.8 m tall) are a ratio above 10.

Cost per frame (75K vertices): one parallel pass in the core, 0.1–0.3 ms on the shared
two-core machine; the numpy version it replaces took 2.5–8 ms (docs/addon.md, Time per frame).
"""

import math

import numpy as np

from . import native

#: A vertex's distance to its posed bones may be at most this multiple of its rest distance.
RATIO_LIMIT = 3.0
#: Rest distances below this share of the rest body's bounding-box diagonal count as this.
FLOOR_SHARE = 0.05


class OutputCheck:
    """The per-vertex bound of one binding.

    rest_positions (V,3) and rest_matrices (#B*16, column-major) in armature space, the
    rig's bone order; lengths (B,) the bones' rest lengths; skin_ids / skin_weights (V,S) the
    vertices' skin bones (-1: none) and weights."""

    def __init__(self, rest_positions, rest_matrices, lengths, skin_ids, skin_weights):
        self.core = native.OutputCheck(rest_positions, rest_matrices, lengths, skin_ids, skin_weights, FLOOR_SHARE)
        self.vertex_count = self.core.vertex_count

    def worst(self, deformed, pose):
        """(largest ratio, its vertex, its heaviest bone index) when a vertex is beyond
        RATIO_LIMIT (the ratio is then above it, inf for a non-finite vertex), or
        (0.0, -1, -1) when every vertex is within it. `deformed` (V,3) and `pose` #B*16
        float32, contiguous, armature space."""
        if math.isinf(RATIO_LIMIT):  # no bound (explore_extreme.py measures the raw core)
            return 0.0, -1, -1
        beyond, ratio, vertex, bone = self.core.run(deformed, pose, RATIO_LIMIT)
        if beyond == 0:
            return 0.0, -1, -1
        return float(ratio), vertex, bone

    def largest(self, deformed, pose):
        """(largest ratio, its vertex, its heaviest bone) of the frame, within the bound or
        not ((0.0, -1, -1) when no vertex has skin weights). For tests and reports."""
        _, ratio, vertex, bone = self.core.run(*self._arrays(deformed, pose), 1.0)
        return float(ratio), vertex, bone

    def ratios(self, deformed, pose):
        """Each vertex's distance to the nearer of its two heaviest posed bones over its rest
        distance (0 for a vertex without skin weights, inf for a non-finite one), float32 (V,).
        For tests and reports."""
        out = np.empty(self.vertex_count, np.float32)
        self.core.run(*self._arrays(deformed, pose), 1.0, out)
        return out

    @staticmethod
    def _arrays(deformed, pose):
        return np.ascontiguousarray(deformed, np.float32), np.ascontiguousarray(pose, np.float32).ravel()

    def linear_blend(self, pose, out=None):
        """The linear blend skinning of the rest positions by `pose` (V,3) float32: the
        fallback shown for a frame beyond the bound (a vertex without skin weights stays at
        rest)."""
        if out is None:
            out = np.empty((self.vertex_count, 3), np.float32)
        return self.core.linear_blend(np.ascontiguousarray(pose, np.float32).ravel(), out)
