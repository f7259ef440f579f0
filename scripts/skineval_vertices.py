"""The shared instrument as scripts/skineval_compat.py runs it, also keeping, for each test with
axis segments, what its skin-to-bone distance ratio (r_max) was made of: per region vertex its rest
and posed positions, its rest and posed distances to the nearest bone segment and which segment
that was, written beside the instrument's JSON as <out>.<test>.npz; and for each test with slices,
the loops each slice found at rest and posed, as <out>.<test>.sections.json. Every figure stays the
instrument's (its own function is called and its result returned); this only looks over its
shoulder, so a miss can be placed on the body (scripts/quality --vertices, then
scripts/quality_vertices.py to list the worst vertices of two methods side by side).

  blender -b --python scripts/skineval_vertices.py -- <measure.py's arguments>
"""
import json
import os
import runpy
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SKINEVAL = os.path.normpath(os.environ.get("SKINEVAL_DIR", os.path.join(HERE, "..", "..", "shared", "skineval")))
sys.path.insert(0, SKINEVAL)

import measure  # noqa: E402  (the instrument's own module)

OUT = sys.argv[sys.argv.index("--out") + 1] if "--out" in sys.argv else None
_ratio = measure.axis_distance_ratio


def axis_distance_ratio(test, ev, P0, P1, mask):
    result = _ratio(test, ev, P0, P1, mask)
    segs = test.get("axis_segments") or []
    if OUT and segs and np.any(mask):
        Q0, Q1 = P0[mask], P1[mask]
        rest = np.array([[ev.point(a, False), ev.point(b, False)] for a, b in segs])
        posed = np.array([[ev.point(a, True), ev.point(b, True)] for a, b in segs])
        d0 = np.stack([measure.seg_dist(Q0, a, b) for a, b in rest])
        d1 = np.stack([measure.seg_dist(Q1, a, b) for a, b in posed])
        np.savez(OUT + "." + str(test.get("name", "test")) + ".npz", vertex=np.nonzero(mask)[0], rest=Q0, posed=Q1,
                 d0=d0.min(axis=0), d1=d1.min(axis=0), seg0=d0.argmin(axis=0), seg1=d1.argmin(axis=0),
                 segments_rest=rest, segments_posed=posed)
    return result


_cross_sections = measure.cross_sections


def _loops(P, T, origin, normal):
    """Every loop the instrument's slice finds: closed or not, its area, whether it winds about
    the slice's axis point, its extent in the plane (the instrument's own plane basis)."""
    e1, e2 = measure.geom.plane_basis(np.asarray(normal, float))
    out = []
    for closed, pts in measure.geom.slice_loops(P, T, origin, normal):
        xy = np.stack([(pts - origin) @ e1, (pts - origin) @ e2], axis=1)
        out.append({"closed": bool(closed), "points": len(pts),
                    "area": abs(measure.geom.polygon_area_2d(xy)) if closed else None,
                    "winds_about_axis": bool(measure.geom.winding_number(xy, np.zeros(2))) if closed else None,
                    "x": [float(xy[:, 0].min()), float(xy[:, 0].max())],
                    "y": [float(xy[:, 1].min()), float(xy[:, 1].max())]})
    return out


def cross_sections(test, ev, topo, dom_w, bone_index, P0, P1):
    """The instrument's slices, with each slice's loops at rest and posed beside them (what a
    smallest section was made of) in <out>.<test>.sections.json."""
    calls = []
    own = measure.geom.cross_section

    def logged(P, T, origin, normal, max_dist=None):
        calls.append(_loops(P, T, origin, normal))
        return own(P, T, origin, normal, max_dist=max_dist)

    measure.geom.cross_section = logged
    try:
        result = _cross_sections(test, ev, topo, dom_w, bone_index, P0, P1)
    finally:
        measure.geom.cross_section = own
    if OUT and result.get("slices"):
        slices = [dict(s, rest_loops=calls[2 * i], posed_loops=calls[2 * i + 1])
                  for i, s in enumerate(result["slices"]) if 2 * i + 1 < len(calls)]
        with open(OUT + "." + str(test.get("name", "test")) + ".sections.json", "w") as f:
            json.dump(slices, f, indent=1)
    return result


measure.axis_distance_ratio = axis_distance_ratio
measure.cross_sections = cross_sections
runpy.run_path(os.path.join(HERE, "skineval_compat.py"), run_name="__main__")
