# Sweep Deform: topology counts of a Blender mesh, shared by make_character.py (which reports them
# while generating) and check_character.py (which checks them on the saved fixtures).
import numpy as np


def topology_counts(me):
    """(boundary edges, non-manifold edges, connected components, Euler characteristic V − E + F)
    of a bpy Mesh, from its edge/face incidence; a closed manifold body has 0, 0, 1, 2."""
    nv = len(me.vertices)
    ev = np.empty(len(me.edges) * 2, np.int64)
    me.edges.foreach_get("vertices", ev)
    ev = ev.reshape(-1, 2)
    loop_edges = np.empty(len(me.loops), np.int64)
    me.loops.foreach_get("edge_index", loop_edges)
    faces_per_edge = np.bincount(loop_edges, minlength=len(me.edges))
    parent = np.arange(nv)  # union-find over the edges

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a
    for a, b in ev:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    components = len({find(i) for i in range(nv)})
    euler = nv - len(me.edges) + len(me.polygons)
    return int(np.sum(faces_per_edge == 1)), int(np.sum(faces_per_edge != 2)), components, euler
