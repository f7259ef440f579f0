# SPDX-License-Identifier: GPL-3.0-or-later
"""Binding another mesh of the same body through a bound character's displacement map.

The paper's continuous displacement map d(θ, t) (Sect. 3.4) makes a binding independent of one
mesh's resolution: fitted once on a bound character, it binds a subdivided or retopologised
mesh of the same body, or a point cloud (a mesh object with vertices only, e.g. a scan), with
the character's own sweeps and key-ellipse edits and without fitting again. The new object
deforms with the same armature through its own Sweep Deform modifier.

The map comes from libsweepdeform_dmap (native_dmap.py); the rest is the ordinary binding's
store stage (bind.store), so the result saves, reloads, undoes and un-binds like any binding.
"""

import json

import numpy as np

from . import bind, native, native_dmap, persistence, rig_io, runtime


def check_source(source):
    """The bound character whose map is used: raises BindError saying what is wrong."""
    if source is None or source.type != 'MESH':
        raise bind.BindError("Make the bound character the active object")
    s = source.sweep_deform
    if s.state != 'BOUND' or not persistence.has_blobs(source) or s.armature is None:
        raise bind.BindError(f"'{source.name}' is not bound with Sweep Deform: bind it first")
    if not (persistence.topology_matches(source) and persistence.rest_positions_match(source)):
        raise bind.BindError(f"'{source.name}' changed since it was bound: re-bind it first")


def check_target(target, source):
    """A mesh object that may receive a binding through `source`'s map: raises BindError
    saying why not (as for any binding, plus: not the source itself, at least one vertex)."""
    bind.check_bindable(target, source.sweep_deform.armature)
    if target == source or target.data == source.data:
        raise bind.BindError(f"'{target.name}' is the bound character itself")
    if len(target.data.vertices) == 0:
        raise bind.BindError(f"'{target.name}' has no vertices")


def fit_map(source):
    """The displacement map of the bound `source` (its stored rig and binding, its mesh)."""
    return native_dmap.DisplacementMap(bytes(source[persistence.RIG_KEY]), bytes(source[persistence.BINDING_KEY]),
                                       runtime.mesh_triangles(source.data))


def bind_points(target, source, dmap, snap=native_dmap.SNAP_DEFAULT):
    """Binds `target`'s points through `dmap`, the map of the bound `source` (fit_map), without
    storing anything: returns (bind.BindInputs, bind.BindOutputs, influences snapped) for
    bind.store.

    target: a mesh object lying where the source's body lies (any resolution, faces optional).
    snap: sd_dmap_bind's snap (native_dmap.SNAP_*): how close to the map's smooth surface a
    point must be (× the local half-axis) to take the surface's point.
    Raises BindError, native.NativeError or native.NativeLibraryError."""
    check_source(source)
    check_target(target, source)
    arm = source.sweep_deform.armature
    _, _, names, rest = persistence.load(source)
    inp = bind.BindInputs()
    inp.object_name, inp.armature_name = target.name, arm.name
    inp.mesh_to_armature = [list(row) for row in arm.matrix_world.inverted() @ target.matrix_world]
    inp.positions = rig_io.transform_points(inp.mesh_to_armature, persistence.mesh_positions(target.data))
    inp.bone_names, inp.rest = names, rest
    binding_blob, snapped = dmap.bind(inp.positions, snap)
    rig_blob = bytes(source[persistence.RIG_KEY])
    rig, binding = native.Rig.deserialize(rig_blob), native.Binding.deserialize(binding_blob)
    # The source's fitting report (its chains give the anatomical effects' joints), marked.
    report = json.loads(source.get(persistence.REPORT_KEY, "") or "{}")
    report.update({"bound_through_map_of": source.name, "snapped_influences": snapped})
    return inp, bind.BindOutputs(rig, rig_blob, binding, json.dumps(report)), snapped


def bind_through_map(targets, source, snap=native_dmap.SNAP_DEFAULT):
    """Binds each of `targets` through the displacement map of the bound `source`, to the same
    armature. All are bound before any is stored, so an error leaves the file unchanged.
    Returns the influences snapped to the map's surface, per target."""
    check_source(source)
    dmap = fit_map(source)
    results = [bind_points(t, source, dmap, snap) for t in targets]
    arm = source.sweep_deform.armature
    for t, (inp, out, _) in zip(targets, results):
        bind.store(t, arm, inp, out)
    return [snapped for _, _, snapped in results]


def map_fit_errors(dmap):
    """(largest RMS, largest max) of the map's fit residuals over its sweeps, rig units."""
    _, rms, mx = dmap.fit_errors()
    return float(np.max(rms, initial=0.0)), float(np.max(mx, initial=0.0))
