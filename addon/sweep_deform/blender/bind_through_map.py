# SPDX-License-Identifier: GPL-3.0-or-later
"""Binding another mesh of the same body through a bound character's displacement map.

The paper's continuous displacement map d(θ, t) (Sect. 3.4) makes a binding independent of one
mesh's resolution: fitted once on a bound character, it binds a subdivided or retopologised
mesh of the same body, or a point cloud (a mesh object with vertices only, e.g. a scan), with
the character's own sweeps and key-ellipse edits and without fitting again. The new object
deforms with the same armature through its own Sweep Deform modifier.

The map comes from libsweepdeform_dmap (core/native_dmap.py); the rest is the ordinary binding's
store stage (binding.store), so the result saves, reloads, undoes and un-binds like any binding.
"""

import json

from ..core import arrays, native, native_dmap
from . import binding, mesh_data, persistence


def check_source(source):
    """The bound character whose map is used: raises BindError saying what is wrong."""
    if source is None or source.type != 'MESH':
        raise binding.BindError("Make the bound character the active object")
    s = source.sweep_deform
    if s.state != 'BOUND' or not persistence.has_blobs(source) or s.armature is None:
        raise binding.BindError(f"'{source.name}' is not bound with Sweep Deform: bind it first")
    if not (persistence.topology_matches(source) and persistence.rest_positions_match(source)):
        raise binding.BindError(f"'{source.name}' changed since it was bound: re-bind it first")


def check_target(target, source):
    """A mesh object that may receive a binding through `source`'s map: raises BindError
    saying why not (as for any binding, plus: not the source itself, at least one vertex)."""
    binding.check_bindable(target, source.sweep_deform.armature)
    if target == source or target.data == source.data:
        raise binding.BindError(f"'{target.name}' is the bound character itself")
    if len(target.data.vertices) == 0:
        raise binding.BindError(f"'{target.name}' has no vertices")


def fit_map(source):
    """The displacement map of the bound `source` (its stored rig and binding, its mesh)."""
    return native_dmap.DisplacementMap(bytes(source[persistence.RIG_KEY]), bytes(source[persistence.BINDING_KEY]),
                                       mesh_data.triangles(source.data))


def bind_through_map(targets, source, snap=native_dmap.SNAP_DEFAULT):
    """Binds each of `targets` through the displacement map of the bound `source`, to the same
    armature, with the source's rig (its sweeps and key-ellipse edits) and without fitting.

    targets: mesh objects lying where the source's body lies (any resolution, faces optional).
    snap: sd_dmap_bind's snap (native_dmap.SNAP_*): how close to the map's smooth surface a
    point must be (× the local half-axis) to take the surface's point.
    Every target is checked, then all are bound, before any is stored: an error (BindError,
    native.NativeError, native.NativeLibraryError) leaves the file unchanged. Returns the
    influences snapped to the map's surface, per target."""
    check_source(source)
    for t in targets:
        check_target(t, source)
    arm = source.sweep_deform.armature
    names, rest = persistence.load_skeleton(source)
    rig_blob = bytes(source[persistence.RIG_KEY])
    rig = native.Rig.deserialize(rig_blob)
    # The source's fitting report (its chains give the anatomical effects' joints), marked.
    report = json.loads(source.get(persistence.REPORT_KEY, "") or "{}")
    report["bound_through_map_of"] = source.name
    dmap = fit_map(source)
    bound = []
    for t in targets:
        inp = binding.BindInputs()
        inp.object_name, inp.armature_name = t.name, arm.name
        inp.mesh_to_armature = [list(row) for row in arm.matrix_world.inverted() @ t.matrix_world]
        inp.positions = arrays.transform_points(inp.mesh_to_armature, mesh_data.vertex_positions(t.data))
        inp.bone_names, inp.rest = names, rest
        binding_blob, snapped = dmap.bind(inp.positions, snap)
        out = binding.BindOutputs(rig, rig_blob, native.Binding.deserialize(binding_blob),
                                  json.dumps(dict(report, snapped_influences=snapped)))
        bound.append((t, inp, out, snapped))
    for t, inp, out, _ in bound:
        binding.store(t, arm, inp, out)
    return [snapped for _, _, _, snapped in bound]
