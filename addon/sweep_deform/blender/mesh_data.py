# SPDX-License-Identifier: GPL-3.0-or-later
"""A mesh's own data as numpy arrays, one ``foreach_get`` per array: its vertex positions as
stored (the rest shape the modifiers start from), its loop triangles, and the counts and
connectivity fingerprint a binding is checked against."""

import numpy as np

from ..core import arrays


def counts(mesh):
    """[vertices, edges, loops, polygons]."""
    return arrays.topology_counts(len(mesh.vertices), len(mesh.edges), len(mesh.loops), len(mesh.polygons))


def vertex_positions(mesh):
    """(V,3) float32 vertex positions in the mesh's space, as stored in the mesh."""
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get('co', co)
    return co.reshape(-1, 3)


def triangles(mesh):
    """The mesh's loop triangles (T,3) int32, vertex indices in the mesh's (= the binding's) order."""
    mesh.calc_loop_triangles()
    tris = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get('vertices', tris)
    return tris.reshape(-1, 3)


def topology_fingerprint(mesh):
    """SHA-1 of the mesh's connectivity (arrays.topology_fingerprint)."""
    edges = np.empty(len(mesh.edges) * 2, np.int32)
    mesh.edges.foreach_get('vertices', edges)
    loops = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get('vertex_index', loops)
    totals = np.empty(len(mesh.polygons), np.int32)
    mesh.polygons.foreach_get('loop_total', totals)
    return arrays.topology_fingerprint(edges, loops, totals)
