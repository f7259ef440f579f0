# SPDX-License-Identifier: GPL-3.0-or-later
"""Limb volume of a skinned mesh (numpy only, no bpy).

The limb is a fixed set of skin triangles (chosen once, at rest); its volume in any pose is the
volume that set encloses once each hole in it (the shoulder or hip ring, the wrist or ankle ring)
is closed by a fan of triangles from the hole's centroid. The caps move with the rings, so a
ring that moves rigidly adds the same cap volume in every pose and the change is the limb's own.
This is the same measure the core's volume restoration holds (native/src/geometry/mesh_volume.h), computed
here independently from the evaluated meshes, for any deformation method.
"""

import numpy as np


def sweep_skin_triangles(triangles, vertex_sweep, sweep):
    """Ids of the triangles whose three vertices have `sweep` as their heaviest sweep influence
    (`vertex_sweep` #V: Binding.parameters()[0]): a limb's skin as the binding sees it."""
    return np.flatnonzero((vertex_sweep[triangles] == sweep).all(axis=1)).astype(np.int32)


class ClosedRegion:
    """A region of a triangle mesh with its boundary loops, found once.

    triangles: (T,3) int vertex ids of the whole mesh; region: ids of the region's triangles.
    """

    def __init__(self, triangles, region):
        self.tris = np.asarray(triangles)[np.asarray(region)]
        edges = np.concatenate([self.tris[:, [0, 1]], self.tris[:, [1, 2]], self.tris[:, [2, 0]]])
        # Boundary: directed edges whose reverse is not in the region.
        code = edges[:, 0].astype(np.int64) << 32 | edges[:, 1].astype(np.int64)
        reverse = edges[:, 1].astype(np.int64) << 32 | edges[:, 0].astype(np.int64)
        boundary = edges[~np.isin(reverse, code)]
        # Loops: the boundary edges' connected components (union-find over their vertices).
        parent = {}

        def find(v):
            while parent.setdefault(v, v) != v:
                parent[v] = parent[parent[v]]
                v = parent[v]
            return v

        for a, b in boundary:
            ra, rb = find(int(a)), find(int(b))
            if ra != rb:
                parent[ra] = rb
        roots = np.array([find(int(a)) for a in boundary[:, 0]], np.int64)
        self.loops = [boundary[roots == r] for r in np.unique(roots)]

    @property
    def loop_count(self):
        return len(self.loops)

    def volume(self, positions):
        """Enclosed volume (units³) at `positions` (#V,3): Σ signed tetrahedra of the region's
        triangles and of the caps (each boundary edge a→b closed by the triangle b, a, centroid)."""
        p = np.asarray(positions, np.float64)
        a, b, c = p[self.tris[:, 0]], p[self.tris[:, 1]], p[self.tris[:, 2]]
        v = np.einsum("ij,ij->i", a, np.cross(b, c)).sum()
        for loop in self.loops:
            centroid = p[np.unique(loop)].mean(axis=0)
            ea, eb = p[loop[:, 0]], p[loop[:, 1]]
            v += np.einsum("ij,ij->i", eb, np.cross(ea, np.broadcast_to(centroid, ea.shape))).sum()
        return float(v / 6.0)
