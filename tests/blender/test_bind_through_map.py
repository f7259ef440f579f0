# SPDX-License-Identifier: GPL-3.0-or-later
"""Binding through the continuous displacement map d(θ, t) (Sect. 3.4, issue 9), in Blender.

The built-in light character is bound (automatic fitting). A finer mesh of the same body — the
character with one level of *simple* subdivision, which keeps every original vertex and adds
points on the original faces — and a point cloud (the same points, no faces) are bound through
the character's map, without fitting. The reference is the bound character itself followed by
the same Simple subdivision in its modifier stack: the subdivision of the deformed mesh."""

import bpy
import numpy as np
import pytest

import helpers

POSES = ["walk", "arms_up", "knee_bend", "elbow_bend", "forearm_twist", "spine_bend"]


def frame(name):
    scene = bpy.context.scene
    scene.frame_set({m.name: m.frame for m in scene.timeline_markers}[name])
    bpy.context.view_layer.update()


def finer_copy(obj, name):
    """A new object: `obj`'s rest mesh with one level of simple subdivision, placed where
    `obj` is."""
    sub = obj.modifiers.new("simple", 'SUBSURF')
    sub.subdivision_type, sub.levels = 'SIMPLE', 1
    shown = {md.name: md.show_viewport for md in obj.modifiers}
    for md in obj.modifiers:
        md.show_viewport = md == sub  # the rest mesh, subdivided
    bpy.context.view_layer.update()
    mesh = bpy.data.meshes.new_from_object(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()))
    for md in obj.modifiers:
        md.show_viewport = shown[md.name]
    obj.modifiers.remove(sub)
    mesh.name = name
    target = bpy.data.objects.new(name, mesh)
    target.matrix_world = obj.matrix_world
    bpy.context.scene.collection.objects.link(target)
    return target


def bind_selected_through(source, targets):
    for o in bpy.context.selected_objects:
        o.select_set(False)
    for t in targets:
        t.select_set(True)
    source.select_set(True)
    bpy.context.view_layer.objects.active = source
    return bpy.ops.object.sweep_deform_bind_through_map()


def distances(a, b):
    d = np.linalg.norm(a.astype(np.float64) - b, axis=1)
    return d.mean(), np.percentile(d, 99), d.max()


def test_finer_mesh_and_point_cloud_follow_the_character():
    char = helpers.load("fixture")
    body = helpers.bind(char)  # the product's automatic fitting
    fine = finer_copy(body, "Body_fine")
    points = bpy.data.objects.new("Body_points", bpy.data.meshes.new("Body_points"))
    co = helpers.base_positions(fine)
    points.data.from_pydata(co.tolist(), [], [])
    points.matrix_world = body.matrix_world
    bpy.context.scene.collection.objects.link(points)
    assert len(fine.data.vertices) > 3 * len(body.data.vertices) and len(points.data.polygons) == 0

    assert bind_selected_through(body, [fine, points]) == {'FINISHED'}
    for t in (fine, points):
        assert t.sweep_deform.state == 'BOUND' and t.sweep_deform.armature == char.armature
        assert helpers.sub("blender.modifier").find(t) is not None

    # The character's Simple subdivision in its own stack is the reference.
    sub = body.modifiers.new("simple", 'SUBSURF')
    sub.subdivision_type, sub.levels = 'SIMPLE', 1
    frame("rest")
    reference, _ = helpers.evaluated_positions(body)
    np.testing.assert_array_equal(helpers.evaluated_positions(fine)[0], helpers.base_positions(fine))
    np.testing.assert_allclose(reference, helpers.base_positions(fine), atol=1e-5)
    diag = helpers.diagonal(reference)
    print(f"{len(body.data.vertices)} vertices bound by fitting; {len(fine.data.vertices)} "
          f"(simple subdivision) and a point cloud of as many bound through its map")
    worst_mean = worst_p99 = 0.0
    for pose in POSES:
        frame(pose)
        reference, _ = helpers.evaluated_positions(body)
        got, _ = helpers.evaluated_positions(fine)
        cloud, _ = helpers.evaluated_positions(points)
        # No connectivity is needed: the point cloud moves exactly like the mesh.
        np.testing.assert_array_equal(cloud, got)
        moved = float(np.linalg.norm(reference - helpers.base_positions(fine), axis=1).max())
        mean, p99, mx = distances(got, reference)
        print(f"{pose:14s} through the map vs the subdivided character: mean {1e3 * mean:.2f} mm, "
              f"99th percentile {1e3 * p99:.2f} mm, max {1e3 * mx:.2f} mm (largest motion {moved:.2f} m)")
        assert moved > 0.05
        worst_mean, worst_p99 = max(worst_mean, mean), max(worst_p99, p99)
    # The bound: 0.05 % of the body's diagonal on average (0.9 mm), 0.25 % for 99 % of the points.
    assert worst_mean < 0.5e-3 * diag and worst_p99 < 2.5e-3 * diag, (worst_mean, worst_p99, diag)


def test_a_copy_holds_the_joints_volume_as_its_source_and_says_so_without_it():
    """A mesh bound through a character's map takes the character's measured joint volumes (the
    same sweeps, also for a point cloud, which has no volume of its own); with the character gone
    from the file it still deforms, and the panel says the volume at the joints is not held."""
    char = helpers.load("fixture")
    body = helpers.bind(char)
    points = bpy.data.objects.new("Body_points", bpy.data.meshes.new("Body_points"))
    points.data.from_pydata(helpers.base_positions(body).tolist(), [], [])
    points.matrix_world = body.matrix_world
    bpy.context.scene.collection.objects.link(points)
    assert bind_selected_through(body, [points]) == {'FINISHED'}
    frame("knee_bend")
    cache = helpers.sub("blender.deformer_cache")
    source, copy = cache.entry(body), cache.entry(points)
    assert source.joints_held > 0 and copy.joints_held == source.joints_held and not copy.joint_volume_error
    held, _ = helpers.evaluated_positions(points)
    bpy.data.objects.remove(body)
    cache.clear()
    bpy.context.view_layer.update()
    frame("knee_bend")
    alone, _ = helpers.evaluated_positions(points)
    copy = cache.entry(points)
    assert copy.joints_held == 0 and "not held" in copy.joint_volume_error, copy.joint_volume_error
    assert np.isfinite(alone).all() and not np.array_equal(alone, held)


def test_both_opensubdivs_in_one_blender():
    """The map's OpenSubdiv (3.5, bundled) and Blender's own (3.6) live side by side: all of
    3.5's symbols are in the versioned namespace OpenSubdiv::v3_5_0, so neither binds to the
    other's code. Blender's Subdivision Surface (its OpenSubdiv) still runs after ours."""
    char = helpers.load("fixture")
    body = helpers.bind(char)
    dmap = helpers.sub("blender.bind_through_map").fit_map(body)
    samples, rms, mx = dmap.fit_errors()
    print(f"map of {dmap.sweep_count} sweeps: residual rms up to {1e3 * rms.max():.2f} mm, "
          f"max up to {1e3 * mx.max():.2f} mm over {int(samples.sum())} samples")
    assert dmap.sweep_count == body.sweep_deform.sweep_count and samples.min() > 0
    maps = [l.split()[-1] for l in open("/proc/self/maps") if "libosdCPU" in l]
    ours = {m for m in maps if m.endswith("libosdCPU.so.3.5.0")}
    assert ours and all("sweep_deform" in m for m in ours), sorted(set(maps))
    print("OpenSubdiv libraries mapped:", sorted(set(maps)))
    # Blender's subdivision with both loaded (Catmull-Clark: Blender's OpenSubdiv does it).
    cc = body.modifiers.new("cc", 'SUBSURF')
    cc.levels = 1
    bpy.context.view_layer.update()
    co, _ = helpers.evaluated_positions(body)
    assert len(co) > 3 * len(body.data.vertices) and np.isfinite(co).all()


def test_bad_sources_and_targets_change_nothing():
    char = helpers.load("fixture")
    body = char.mesh
    fine = finer_copy(body, "Body_fine")
    btm = helpers.sub("blender.bind_through_map")
    # The character is not bound: no map.
    with pytest.raises(helpers.sub("blender.binding").BindError, match="not bound"):
        btm.bind_through_map([fine], body)
    helpers.bind(char)
    # A target sharing its mesh with the bound character, and a good one: neither is bound.
    # (A mesh shared with other objects is fine since issue 16: the offsets live in carriers.)
    twin = bpy.data.objects.new("twin", body.data)
    bpy.context.scene.collection.objects.link(twin)
    other = finer_copy(body, "Body_fine2")
    with pytest.raises(helpers.sub("blender.binding").BindError, match="is the bound character itself"):
        btm.bind_through_map([other, twin], body)
    assert other.sweep_deform.state == 'UNBOUND' and twin.sweep_deform.state == 'UNBOUND'
    assert helpers.sub("blender.modifier").find(other) is None
    # The operator reports it, and the poll explains what to select.
    with pytest.raises(RuntimeError, match="is the bound character itself"):
        bind_selected_through(body, [twin])
    for o in bpy.context.selected_objects:
        o.select_set(False)
    bpy.context.view_layer.objects.active = body
    assert not bpy.ops.object.sweep_deform_bind_through_map.poll()


def test_missing_map_library_is_reported(monkeypatch):
    char = helpers.load("fixture")
    body = helpers.bind(char)
    fine = finer_copy(body, "Body_fine")
    native_dmap = helpers.sub("core.native_dmap")
    monkeypatch.setattr(native_dmap, "_lib", None)
    monkeypatch.setenv("SWEEPDEFORM_DMAP_LIBRARY", "/nonexistent/libsweepdeform_dmap.so.0.1.0")
    with pytest.raises(RuntimeError, match="displacement-map library is missing"):
        bind_selected_through(body, [fine])
    assert fine.sweep_deform.state == 'UNBOUND' and helpers.sub("blender.modifier").find(fine) is None
