# SPDX-License-Identifier: GPL-3.0-or-later
"""Live evaluation: pose elbows and knees through the armature (plain posing, IK, playback)
and the evaluated mesh is exactly what the core computes."""

import math
import os
import subprocess

import bpy
import mathutils
import numpy as np
import pytest

import flexion
import helpers


def check_equals_core(obj, label=""):
    co, attrs = helpers.evaluated_positions(obj)
    expected, raw = helpers.core_expectation(obj)
    assert co.shape == expected.shape
    # Exactly the add-on's formula: base + offsets (float32, the node group's addition).
    np.testing.assert_array_equal(co, expected, err_msg=label)
    # And the core's own positions, back in mesh space (the rest shape round trip of the core
    # is below 1e-6 of the size).
    assert np.abs(co - raw).max() <= 2e-5 * helpers.diagonal(raw), label
    assert "sweep_deform_offset" not in attrs  # the node group removes it from its output
    return co


def test_bind_and_pose_elbows_and_knees(character):
    helpers.use_test_rig([character])
    obj = helpers.bind(character)
    md_names = [m.name for m in obj.modifiers]
    assert md_names.index("Sweep Deform") < md_names.index(obj.sweep_deform.armature_modifier)
    arm_md = obj.modifiers[obj.sweep_deform.armature_modifier]
    assert not arm_md.show_viewport and not arm_md.show_render
    assert arm_md.object == character.armature  # the artist's set-up is kept (issue 15)

    base = helpers.base_positions(obj)
    bpy.context.view_layer.update()
    rest_co, _ = helpers.evaluated_positions(obj)
    np.testing.assert_array_equal(rest_co, base)  # the rest pose is the rest mesh, exactly

    helpers.pose_limbs(character, elbow=1.2, knee=1.1)
    bpy.context.view_layer.update()
    co = check_equals_core(obj, character.key)
    moved = np.linalg.norm(co - base, axis=1)
    assert moved.max() > 0.05 * helpers.diagonal(base)

    # Close to Blender's own skinning of the same weights (same skeleton conventions).
    lbs = helpers.armature_modifier_positions(obj)
    err = np.linalg.norm(co - lbs, axis=1)
    diag = helpers.diagonal(base)
    print(f"{character.key}: {len(base)} vertices, max move {moved.max():.3f}, vs Armature modifier "
          f"mean {err.mean():.4f} max {err.max():.4f} (diagonal {diag:.3f})")
    assert err.mean() < 0.01 * diag and err.max() < 0.1 * diag

    # Another pose: rewritten; the same pose again: nothing to do (no feedback loop).
    helpers.pose_limbs(character, elbow=0.4, knee=0.3)
    bpy.context.view_layer.update()
    check_equals_core(obj, character.key + " pose 2")
    cache = helpers.sub("blender.deformer_cache")
    frames = cache.peek(obj).frames
    for _ in range(3):
        bpy.context.view_layer.update()
    obj.update_tag()
    bpy.context.view_layer.update()
    assert cache.peek(obj).frames == frames


def _bound_and_posed(char):
    """Binds the character with the product's fitting (the operator), bends its elbows, knees
    and shoulders and returns the evaluated mesh in world space."""
    obj = helpers.bind(char)
    helpers.pose_limbs(char, elbow=1.2, knee=1.1, shoulder=0.6)
    bpy.context.view_layer.update()
    co, _ = helpers.evaluated_positions(obj)
    m = np.array(obj.matrix_world, np.float64)
    return co @ m[:3, :3].T + m[:3, 3]


@pytest.mark.parametrize("convention", ["centimetres", "y_up_centimetres"])
def test_a_rig_in_another_unit_and_axes_deforms_as_in_metres_z_up(convention):
    """Many rigs come in centimetres under an object scale of 0.01, and FBX files from other
    tools with Y up under a 90 degree turn about X as well. The same body so, bound with the
    product's fitting and posed alike, deforms to the same world positions as in metres with Z
    up: nothing in the fitting, binding or deformation assumes metres or which way is up."""
    world = {}
    for converted in (False, True):
        char = helpers.load("fixture")
        obj, arm = char.mesh, char.armature
        before = np.array([obj.matrix_world @ v.co for v in obj.data.vertices])
        if converted:
            turn = mathutils.Euler((math.pi / 2, 0.0, 0.0)) if convention == "y_up_centimetres" else mathutils.Euler()
            placed = turn.to_matrix().to_4x4() @ mathutils.Matrix.Scale(0.01, 4)
            arm.data.transform(placed.inverted())
            obj.data.transform(placed.inverted())
            arm.rotation_euler, arm.scale = turn, (0.01, 0.01, 0.01)
            if obj.parent != arm:
                obj.rotation_euler, obj.scale = turn, (0.01, 0.01, 0.01)
            bpy.context.view_layer.update()
            after = np.array([obj.matrix_world @ v.co for v in obj.data.vertices])
            assert np.abs(after - before).max() < 1e-5 * helpers.diagonal(before)  # the same body
        world[converted] = _bound_and_posed(char)
    diag = helpers.diagonal(world[False])
    worst = np.linalg.norm(world[True] - world[False], axis=1).max()
    print(f"{convention} against metres, Z up: worst vertex {worst / diag:.2e} of the diagonal")
    assert worst < 1e-4 * diag


def test_bones_rolled_otherwise_deform_alike():
    """Rigs from other tools roll their bones their own way (Mixamo, DAZ, Rigify differ): a
    bone's roll turns its local axes about it, not the skin it moves. The same body with every
    bone rolled by 40 degrees, bound with the product's fitting and given the same deformation
    per bone, deforms to the same positions: nothing in the fitting or binding depends on the roll."""
    world, moves = {}, None
    for rolled in (False, True):
        char = helpers.load("fixture")
        obj, arm = char.mesh, char.armature
        if rolled:
            bpy.context.view_layer.objects.active = arm
            bpy.ops.object.mode_set(mode='EDIT')
            for eb in arm.data.edit_bones:
                eb.roll += math.radians(40.0)
            bpy.ops.object.mode_set(mode='OBJECT')
        helpers.bind(char)
        if moves is None:  # each bone's deformation (pose times inverse rest) in the unrolled rig
            helpers.pose_limbs(char, elbow=1.2, knee=1.1, shoulder=0.6)
            bpy.context.view_layer.update()
            moves = {pb.name: pb.matrix @ pb.bone.matrix_local.inverted() for pb in arm.pose.bones}
        else:  # the same deformations on the rolled rig's bones, parents first
            for pb in sorted(arm.pose.bones, key=lambda b: len(b.parent_recursive)):
                pb.matrix = moves[pb.name] @ pb.bone.matrix_local
                bpy.context.view_layer.update()
        world[rolled], _ = helpers.evaluated_positions(obj)
    diag = helpers.diagonal(world[False])
    worst = np.linalg.norm(world[True] - world[False], axis=1).max()
    print(f"bones rolled 40 degrees against as made: worst vertex {worst / diag:.2e} of the diagonal")
    assert worst < 1e-5 * diag


def test_limb_bones_cut_in_two_deform_as_uncut():
    """Rigify's deform bones (DEF-forearm.L and .001), DAZ's bend and twist bones and
    MakeHuman's default rig cut a limb bone in two. Cut so by Blender's Subdivide (the weights
    passed along the bone, scripts/blender_support/cut_limbs_body.py) and bound with the
    product's fitting, the built-in character deforms as the uncut one in the same pose."""
    import cut_limbs_body  # scripts/blender_support, on sys.path (run.py)
    world = {}
    for cut in (False, True):
        char = helpers.load("fixture")
        obj, arm = char.mesh, char.armature
        if cut:
            cut_limbs_body.cut_in_two(obj, arm, ["upper_arm.L", "forearm.L", "thigh.L", "shin.L",
                                                 "upper_arm.R", "forearm.R", "thigh.R", "shin.R"])
            assert "forearm.L.001" in arm.data.bones
        world[cut] = _bound_and_posed(char)
    diag = helpers.diagonal(world[False])
    worst = np.linalg.norm(world[True] - world[False], axis=1).max()
    print(f"limb bones cut in two against uncut: worst vertex {worst / diag:.2e} of the diagonal")
    assert worst < 1e-5 * diag


def test_a_rigify_rig_binds_and_deforms_as_its_source(tmp_path):
    """A rig Rigify generates (Blender's own rigging system; scripts/blender_support/
    rigify_body.py puts the shipped MakeHuman male on one) hangs its deform bones from mechanism
    bones (DEF-thigh.L from ORG-spine, DEF-upper_arm.L from ORG-shoulder.L): the product used to
    refuse it ("no humanoid found: no branching found below bone 0 'root'"). It binds, and with
    the left elbow bent and the left hand twisted (the deform bones posed, their constraints
    muted, as the shared instrument poses them) the body deforms as on its source rig."""
    path = os.path.join(helpers.FIXTURES, "mh_male_game_engine_subdiv1.blend")
    if not os.path.isfile(path):
        pytest.skip(f"{path} not found")
    # The rig is generated by another Blender: after Rigify had generated a rig in this process,
    # later tests' glTF imports crashed it now and then (a segmentation fault inside Blender 4.3's
    # importer, create_bones; also with Rigify disabled again, never in a process that did not
    # generate).
    rigified = str(tmp_path / "rigify_body.blend")
    script = os.path.join(helpers.REPO, "scripts", "blender_support", "rigify_body.py")
    made = subprocess.run([bpy.app.binary_path, "-b", "--factory-startup", "--python-exit-code", "1",
                           "--python", script, "--", path, rigified], capture_output=True, text=True)
    assert made.returncode == 0 and os.path.isfile(rigified), made.stdout[-2000:] + made.stderr[-2000:]
    _rigify_binds_and_deforms_as_its_source(path, rigified)


def _rigify_binds_and_deforms_as_its_source(source, rigified_path):
    world = {}
    for rigified in (False, True):
        bpy.ops.wm.open_mainfile(filepath=rigified_path if rigified else source)
        obj = next(o for o in bpy.data.objects if o.type == 'MESH' and o.find_armature())
        arm = obj.find_armature()
        forearm, hand = "lowerarm_l", "hand_l"
        if rigified:
            forearm, hand = "DEF-forearm.L", "DEF-hand.L"
            for pb in arm.pose.bones:
                for c in pb.constraints:
                    c.mute = True
        bpy.context.view_layer.objects.active = obj
        for o in bpy.context.selected_objects:
            o.select_set(False)
        obj.select_set(True)
        assert bpy.ops.object.sweep_deform_add() == {'FINISHED'}
        assert obj.sweep_deform.state == 'BOUND'
        elbow = arm.matrix_world @ arm.pose.bones[forearm].head
        wrist = arm.matrix_world @ arm.pose.bones[hand].head
        flexion.turn_about_head(arm, forearm, mathutils.Matrix.Rotation(1.2, 3, 'X'))
        flexion.turn_about_head(arm, hand, mathutils.Matrix.Rotation(2.0, 3, (wrist - elbow).normalized()))
        co, _ = helpers.evaluated_positions(obj)
        m = np.array(obj.matrix_world, np.float64)
        world[rigified] = co @ m[:3, :3].T + m[:3, 3]
    diag = helpers.diagonal(world[False])
    worst = np.linalg.norm(world[True] - world[False], axis=1).max()
    print(f"Rigify rig against its source: worst vertex {worst / diag:.2e} of the diagonal")
    assert worst < 1e-5 * diag

    # Posed as an animator poses it: the constraints on, the left hand's IK control moved up
    # 25 cm. The deform bones follow the rig's mechanism, and the mesh is the core's result for
    # their evaluated pose.
    for pb in arm.pose.bones:
        pb.matrix_basis = mathutils.Matrix.Identity(4)
        for c in pb.constraints:
            c.mute = False
    bpy.context.view_layer.update()
    before, _ = helpers.evaluated_positions(obj)
    arm.pose.bones["hand_ik.L"].location = (0.0, 0.25, 0.0)  # the control's own y: along the forearm
    bpy.context.view_layer.update()
    co = check_equals_core(obj, "Rigify, IK control moved")
    moved = np.linalg.norm(co - before, axis=1).max()
    print(f"Rigify IK control moved: the skin moved up to {moved:.3f} m")
    assert moved > 0.05


def test_volume_settings_and_limb_volumes(character):
    helpers.use_test_rig([character])
    obj = helpers.bind(character)
    helpers.pose_limbs(character, elbow=1.4, knee=1.3)
    bpy.context.view_layer.update()
    with_volume = check_equals_core(obj)
    e = helpers.sub("blender.deformer_cache").peek(obj)
    assert len(e.labels) == obj.sweep_deform.sweep_count == len(e.volumes()[0])
    # The controller alone (the joints' volume not held: its targets are the rest volumes)
    # moves every sweep's integral towards its rest value.
    e.deformer.hold_joint_volumes(np.empty((0, 3), np.int32))
    e.deformer.deform(e.last_pose)
    rest, before, after = e.deformer.volumes()
    assert np.all(np.abs(after - rest) <= np.abs(before - rest) + 1e-9 * np.abs(rest))
    e.deformer.hold_joint_volumes(helpers.sub("blender.mesh_data").triangles(obj.data))
    obj.sweep_deform.use_volume_preservation = False
    bpy.context.view_layer.update()
    without = check_equals_core(obj)
    assert not np.array_equal(with_volume, without)
    obj.sweep_deform.use_volume_preservation = True
    obj.sweep_deform.volume_strength = 0.5
    bpy.context.view_layer.update()
    check_equals_core(obj)


def test_the_body_keeps_its_volume_at_a_flexed_hip():
    """Issue 14: the add-on holds the mesh's volume at the limb joints (measured when the object's
    deformer is made; docs/math.md). MakeHuman's thigh flexed 80° forward: the body, one closed
    mesh, measured here with numpy over the evaluated mesh's triangles, against the core's result
    for the same pose without the joints' tables."""
    char = helpers.load("makehuman")
    obj = helpers.bind(char)
    e = helpers.sub("blender.deformer_cache").entry(obj)
    assert e.joints_held > 0 and not e.joint_volume_error
    tris = helpers.sub("blender.mesh_data").triangles(obj.data)

    def volume(co):
        co = np.asarray(co, np.float64)
        a, b, c = co[tris[:, 0]], co[tris[:, 1]], co[tris[:, 2]]
        return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6.0

    rest = volume(helpers.base_positions(obj))
    bones = char.armature.pose.bones
    hip, hip_r, head = (bones[n].head.copy() for n in ("thigh_l", "thigh_r", "head"))
    left, up = (hip - hip_r).normalized(), (head - hip).normalized()
    turn = (mathutils.Matrix.Translation(hip) @ mathutils.Matrix.Rotation(math.radians(80.0), 4, -left)
            @ mathutils.Matrix.Translation(-hip))
    assert ((turn @ bones["calf_l"].head) - bones["calf_l"].head).dot(left.cross(up)) > 0.1  # forwards
    bones["thigh_l"].matrix = turn @ bones["thigh_l"].matrix
    bpy.context.view_layer.update()
    held = volume(helpers.evaluated_positions(obj)[0])
    without = volume(helpers.core_result(obj, joint_volumes=False)[0])
    print(f"body {1e3 * rest:.2f} L; thigh flexed 80 deg: lost {1e3 * (rest - without):.3f} L without the "
          f"joints' tables, {1e3 * (rest - held):.3f} L with them")
    assert rest - without > 0.003 * rest
    assert abs(rest - held) < 0.3 * (rest - without)


def test_ik_posing(character):
    """An IK constraint moves the forearm: the evaluated pose is what counts."""
    helpers.use_test_rig([character])
    obj = helpers.bind(character)
    arm = character.armature
    target = bpy.data.objects.new("ik_target", None)
    bpy.context.scene.collection.objects.link(target)
    elbow = arm.pose.bones[character.elbows[0]]
    tip = arm.matrix_world @ elbow.tail
    target.location = tip
    c = elbow.constraints.new('IK')
    c.target = target
    c.chain_count = 2
    bpy.context.view_layer.update()
    target.location = tip + (arm.matrix_world.to_3x3() @ (elbow.tail - elbow.head)).normalized() * -0.15
    target.location.z += 0.1
    bpy.context.view_layer.update()
    co = check_equals_core(obj)
    target.location.x += 0.1
    bpy.context.view_layer.update()
    co2 = check_equals_core(obj)
    assert not np.array_equal(co, co2)


def test_playback_frame_by_frame(character):
    helpers.use_test_rig([character])
    obj = helpers.bind(character)
    arm = character.armature
    scene = bpy.context.scene
    for frame, angle in ((1, 0.0), (10, 1.2), (20, 0.3)):
        helpers.pose_limbs(character, elbow=angle, knee=angle)
        for n in character.elbows + character.knees:
            arm.pose.bones[n].keyframe_insert("rotation_euler", frame=frame)
    seen = []
    for f in (1, 5, 10, 15, 20, 10):
        scene.frame_set(f)
        seen.append(check_equals_core(obj, f"frame {f}"))
    assert not np.array_equal(seen[0], seen[2])
    np.testing.assert_array_equal(seen[2], seen[5])


def test_several_characters_in_one_scene():
    helpers.require("makehuman")
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    obj, arm = char.mesh, char.armature
    # A second character: copies of the armature and mesh, one metre to the side.
    arm2 = arm.copy()
    arm2.data = arm.data.copy()
    arm2.location.x += 1.0
    obj2 = obj.copy()
    obj2.data = obj.data.copy()
    obj2.parent = arm2
    obj2.modifiers[0].object = arm2
    for o in (arm2, obj2):
        bpy.context.scene.collection.objects.link(o)
    obj2.name, arm2.name = "Body.two", "Armature.two"
    helpers.bind(char)
    bpy.context.view_layer.objects.active = obj2
    assert bpy.ops.object.sweep_deform_add(armature=arm2.name) == {'FINISHED'}
    assert obj2.sweep_deform.armature == arm2
    helpers.pose_limbs(char, elbow=1.0, knee=0.2)
    arm2.pose.bones["lowerarm_l"].rotation_mode = 'XYZ'
    arm2.pose.bones["lowerarm_l"].rotation_euler = (0.0, 0.0, -0.8)
    bpy.context.view_layer.update()
    a = check_equals_core(obj)
    b = check_equals_core(obj2)
    assert not np.allclose(a, b)


def test_duplicated_character_follows_its_own_armature():
    """Shift+D on armature and mesh: the copy keeps its binding, points at the new armature
    and deforms on its own."""
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    new_obj, new_arm = helpers.duplicate_character(obj, char.armature)
    assert new_obj.sweep_deform.armature == new_arm
    new_arm.location.x += 1.0
    helpers.set_rotation(new_arm.pose.bones["lowerarm_l"], (1.2, 0.0, 0.0))
    helpers.pose_limbs(char, elbow=0.2)
    bpy.context.view_layer.update()
    a, b = check_equals_core(obj), check_equals_core(new_obj)
    assert not np.allclose(a, b)


def test_edit_mode_is_skipped_and_topology_change_needs_rebind():
    helpers.require("makehuman")
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    helpers.pose_limbs(char, elbow=1.0)
    bpy.context.view_layer.update()
    check_equals_core(obj)
    cache = helpers.sub("blender.deformer_cache")
    frames = cache.peek(obj).frames
    bpy.ops.object.mode_set(mode='EDIT')
    helpers.pose_limbs(char, elbow=0.2)
    bpy.context.view_layer.update()
    assert cache.peek(obj).frames == frames  # not evaluated in Edit Mode
    # Same element counts, other connectivity: turn one edge.
    import bmesh
    bm = bmesh.from_edit_mesh(obj.data)
    bm.edges.ensure_lookup_table()
    edge = next(e for e in bm.edges if len(e.link_faces) == 2)
    bmesh.ops.rotate_edges(bm, edges=[edge], use_ccw=True)
    bmesh.update_edit_mesh(obj.data)
    bpy.ops.object.mode_set(mode='OBJECT')
    bpy.context.view_layer.update()
    assert obj.sweep_deform.state == 'REBIND'
    assert "topology" in obj.sweep_deform.message
    co, attrs = helpers.evaluated_positions(obj)
    np.testing.assert_array_equal(co, helpers.base_positions(obj))  # shown undeformed
    assert "sweep_deform_offset" not in obj.data.attributes
    # Binding again makes it deform again.
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.object.sweep_deform_bind() == {'FINISHED'}
    bpy.context.view_layer.update()
    check_equals_core(obj)


def test_deleted_vertices_need_rebind():
    helpers.require("makehuman")
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    import bmesh
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bm.verts.ensure_lookup_table()
    bmesh.ops.delete(bm, geom=[bm.verts[0]], context='VERTS')
    bm.to_mesh(obj.data)
    bm.free()
    helpers.pose_limbs(char, elbow=1.0)
    bpy.context.view_layer.update()
    assert obj.sweep_deform.state == 'REBIND'
    co, _ = helpers.evaluated_positions(obj)
    np.testing.assert_array_equal(co, helpers.base_positions(obj))


def test_followed_by_subdivision_and_toggles():
    helpers.require("makehuman")
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    helpers.pose_limbs(char, elbow=1.0)
    bpy.context.view_layer.update()
    posed = check_equals_core(obj)
    sub = obj.modifiers.new("Subdivision", 'SUBSURF')
    sub.levels = 1
    bpy.context.view_layer.update()
    co, attrs = helpers.evaluated_positions(obj)
    assert len(co) > len(posed) and "sweep_deform_offset" not in attrs
    obj.modifiers.remove(sub)
    md = helpers.sub("blender.modifier").find(obj)
    md.show_viewport = False
    bpy.context.view_layer.update()
    co, _ = helpers.evaluated_positions(obj)
    np.testing.assert_array_equal(co, helpers.base_positions(obj))
    md.show_viewport = True
    helpers.pose_limbs(char, elbow=0.5)
    bpy.context.view_layer.update()
    check_equals_core(obj)


def test_apply_bakes_once():
    helpers.require("makehuman")
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    helpers.pose_limbs(char, elbow=1.2, knee=0.8)
    bpy.context.view_layer.update()
    posed = check_equals_core(obj)
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.object.modifier_apply(modifier="Sweep Deform") == {'FINISHED'}
    np.testing.assert_array_equal(helpers.base_positions(obj), posed)
    assert "sweep_deform_offset" not in obj.data.attributes
    helpers.pose_limbs(char, elbow=0.3, knee=0.1)
    bpy.context.view_layer.update()
    assert obj.sweep_deform.state == 'UNBOUND'
    co, _ = helpers.evaluated_positions(obj)
    np.testing.assert_array_equal(co, posed)  # not deformed a second time
    arm_md = next(m for m in obj.modifiers if m.type == 'ARMATURE')
    assert not arm_md.show_viewport  # would deform the baked mesh again
    assert arm_md.use_vertex_groups  # but its inputs are the artist's again


def test_remove_and_unbind_restore_the_armature_modifier():
    helpers.require("makehuman")
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    arm_md = obj.modifiers[obj.sweep_deform.armature_modifier]
    helpers.pose_limbs(char, elbow=0.7)
    bpy.context.view_layer.update()  # (the viewport's mesh carrier made)
    modifier = helpers.sub("blender.modifier")
    prefixes = tuple(modifier.CARRIER_PREFIX.values()) + (modifier.MESH_CARRIER_PREFIX,)
    assert len([o for o in bpy.data.objects if o.name.startswith(prefixes)]) == 3
    assert bpy.ops.object.sweep_deform_unbind() == {'FINISHED'}
    # Unbinding deletes the carriers and their meshes (the mesh carrier's is a copy of the mesh).
    assert not [o for o in bpy.data.objects if o.name.startswith(prefixes)]
    assert not [m for m in bpy.data.meshes if m.name.startswith(prefixes)]
    assert arm_md.show_viewport and arm_md.show_render and arm_md.object == char.armature
    assert obj.sweep_deform.state == 'UNBOUND' and helpers.sub("blender.modifier").find(obj) is not None
    assert bpy.ops.object.sweep_deform_bind() == {'FINISHED'}
    assert not arm_md.show_viewport
    assert not arm_md.use_vertex_groups  # while it is off (test_switched_off_armature_modifier_...)
    obj.modifiers.remove(helpers.sub("blender.modifier").find(obj))
    bpy.context.view_layer.update()
    assert obj.sweep_deform.state == 'UNBOUND'
    assert arm_md.show_viewport and arm_md.show_render and arm_md.object == char.armature
    assert arm_md.use_vertex_groups


def test_operator_errors_are_reported():
    helpers.require("makehuman")
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    bpy.context.view_layer.objects.active = char.mesh
    with pytest.raises(RuntimeError, match="No armature object named"):
        bpy.ops.object.sweep_deform_add(armature="nope")
    bpy.context.view_layer.objects.active = char.armature
    assert not bpy.ops.object.sweep_deform_add.poll()


def test_shared_mesh_can_be_bound():
    """A mesh used by two objects (Alt+D) binds: the binding lives in the object, the offsets in
    the object's own carrier; the other object keeps its own stack (no Sweep Deform)."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    other = char.mesh.copy()  # a linked duplicate: same mesh data
    bpy.context.scene.collection.objects.link(other)
    obj = helpers.bind(char)
    helpers.pose_limbs(char, elbow=1.0)
    bpy.context.view_layer.update()
    check_equals_core(obj)
    assert other.sweep_deform.state == 'UNBOUND' and helpers.sub("blender.modifier").find(other) is None


def test_disable_and_enable_the_extension():
    """Handlers go with the add-on and come back with it; the library stays loaded once."""
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    assert bpy.ops.preferences.addon_disable(module=helpers.MODULE) == {'FINISHED'}
    try:
        assert not any("sweep_deform" in getattr(h, "__module__", "") for h in bpy.app.handlers.depsgraph_update_post)
        helpers.pose_limbs(char, elbow=1.0)
        bpy.context.view_layer.update()  # nothing listens: the old offsets stay
    finally:
        assert bpy.ops.preferences.addon_enable(module=helpers.MODULE) == {'FINISHED'}
    bpy.ops.wm.save_as_mainfile(filepath=helpers.tmp_dir() + "/reenable.blend")
    bpy.ops.wm.open_mainfile(filepath=helpers.tmp_dir() + "/reenable.blend")
    obj = bpy.data.objects["Body"]
    helpers.pose_limbs(char, elbow=1.3)
    bpy.context.view_layer.update()
    check_equals_core(obj)
    maps = [l.split()[-1] for l in open("/proc/self/maps") if "libsweepdeform.so" in l]
    assert len(set(maps)) == 1, sorted(set(maps))


def test_in_menus_for_f3_search():
    ops = helpers.sub("ui.menu")
    assert ops._object_menu in bpy.types.VIEW3D_MT_object._dyn_ui_initialize()
    deform = getattr(bpy.types, "OBJECT_MT_modifier_add_deform", None)
    assert deform is not None and ops._modifier_menu in deform._dyn_ui_initialize()


def _mesh_evaluated_before_the_handler(obj, arm, elbow):
    """Poses the elbows and reports whether the depsgraph evaluated the mesh's geometry in
    the update's first pass, the one whose depsgraph_update_post runs the add-on's handler
    (before the handler writes the carrier; the second pass re-evaluates it with the offsets)."""
    seen = []

    def look(scene, depsgraph):
        seen.append(any(u.id.original == obj.data or (u.id.original == obj and u.is_updated_geometry)
                        for u in depsgraph.updates))

    for name in ("forearm.L", "forearm.R"):
        helpers.set_rotation(arm.pose.bones[name], (elbow, 0.0, 0.0))
    bpy.app.handlers.depsgraph_update_post.insert(0, look)  # before the add-on's
    try:
        bpy.context.view_layer.update()
    finally:
        bpy.app.handlers.depsgraph_update_post.remove(look)
    assert len(seen) == 1, seen
    return seen[0]


def test_switched_off_armature_modifier_costs_no_evaluation():
    """The replaced Armature modifier, off and keeping its object (issue 15), makes Blender
    evaluate the mesh on every pose change if it still reads the bones (Vertex Groups or Bone
    Envelopes ticked): once for nothing before the handler writes the offsets, once after. So
    while it is off both are unticked, and they are the artist's again whenever it is on (the
    artist comparing, a save, unbinding)."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj, arm = char.mesh, char.armature
    md_arm = next(m for m in obj.modifiers if m.type == 'ARMATURE')
    md_arm.use_bone_envelopes = True  # the artist's set-up: both ticked
    assert md_arm.use_vertex_groups
    # Unbound, the Armature modifier deforms: a pose change evaluates the mesh in the first pass
    # (the check below can tell).
    assert _mesh_evaluated_before_the_handler(obj, arm, 0.7)
    obj = helpers.bind(char)
    s = obj.sweep_deform
    assert md_arm.object == arm and not md_arm.show_viewport and not md_arm.show_render
    assert not md_arm.use_vertex_groups and not md_arm.use_bone_envelopes
    assert not _mesh_evaluated_before_the_handler(obj, arm, 1.1)
    check_equals_core(obj, "one evaluation")
    # Ticked again while off (what the add-on did before): the first pass evaluates the mesh.
    md_arm.use_vertex_groups = True
    assert _mesh_evaluated_before_the_handler(obj, arm, 0.5)
    check_equals_core(obj, "two evaluations")
    md_arm.use_vertex_groups = False

    # The artist switches it on to compare: their inputs are back at the next update, and it
    # deforms; off again, unticked again.
    md_arm.show_viewport = True
    bpy.context.view_layer.update()
    assert md_arm.use_vertex_groups and md_arm.use_bone_envelopes
    md_arm.show_viewport = False
    bpy.context.view_layer.update()
    assert not md_arm.use_vertex_groups and not md_arm.use_bone_envelopes and s.armature_modifier_inputs_kept

    # A save: the file has the artist's modifier (on, both ticked); this session goes on as before.
    path = os.path.join(helpers.tmp_dir(), "replaced_inputs.blend")
    seen = {}

    def on_save(*_):
        seen["saved"] = (md_arm.show_viewport, md_arm.use_vertex_groups, md_arm.use_bone_envelopes)

    bpy.app.handlers.save_pre.append(on_save)  # after the add-on's
    try:
        bpy.ops.wm.save_as_mainfile(filepath=path)
    finally:
        bpy.app.handlers.save_pre.remove(on_save)
    assert seen["saved"] == (True, True, True), seen
    assert not md_arm.show_viewport and not md_arm.use_vertex_groups and not md_arm.use_bone_envelopes
    bpy.ops.wm.open_mainfile(filepath=path)
    obj, arm = bpy.data.objects[char.mesh_name], bpy.data.objects[char.armature_name]
    md_arm = obj.modifiers[obj.sweep_deform.armature_modifier]
    assert not md_arm.show_viewport and not md_arm.use_vertex_groups and not md_arm.use_bone_envelopes
    assert not _mesh_evaluated_before_the_handler(obj, arm, 0.9)
    check_equals_core(obj, "reopened")

    # Unbinding gives everything back.
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.object.sweep_deform_unbind() == {'FINISHED'}
    assert md_arm.show_viewport and md_arm.use_vertex_groups and md_arm.use_bone_envelopes and md_arm.object == arm
    assert not obj.sweep_deform.armature_modifier_inputs_kept
