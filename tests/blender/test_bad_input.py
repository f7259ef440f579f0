# SPDX-License-Identifier: GPL-3.0-or-later
"""Bad input on a bound character (issue 8): NaN and enormous bone and object transforms,
zero and negative scales, two characters on one armature. Each bad frame must give a clear
message, raise nothing in the console and leave the mesh and the file as they were (the
last good deformation stays); fixing the input deforms again, exactly as the core says.
Linked and appended characters are in test_library.py."""

import ast
import inspect

import bpy
import mathutils
import numpy as np
import pytest

import helpers
from test_deform import check_equals_core

NAN = float("nan")


def handler_failures():
    """Exceptions the add-on's handlers caught and printed (with a traceback) so far."""
    return set(helpers.sub("blender.handlers")._reported)


def bound_fixture():
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    helpers.pose_limbs(char, elbow=1.0, knee=0.8)
    bpy.context.view_layer.update()
    return char, obj, check_equals_core(obj)


def assert_refused(obj, last_good, *words):
    """The frame was refused: the last good deformation stays, the panel says why (with
    `words` in it), the binding is untouched and nothing raised in a handler."""
    e = helpers.sub("blender.deformer_cache").peek(obj)
    assert e is not None and e.error, "no message for the user"
    for w in words:
        assert w in e.error, e.error
    assert "last good deformation" in e.error
    assert obj.sweep_deform.state == 'BOUND' and obj.sweep_deform.message == ""
    co, _ = helpers.evaluated_positions(obj)
    np.testing.assert_array_equal(co, last_good)
    return e.error


def test_transform_checks_need_no_blender():
    transforms = helpers.sub("core.checks")
    tree = ast.parse(inspect.getsource(transforms))
    imported = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))
                for a in n.names}
    assert "bpy" not in imported and "mathutils" not in imported
    ok = np.eye(4)
    assert transforms.matrix_problem(ok, "x") is None
    assert transforms.matrix_problem(np.diag([-1.0, 1.0, 1.0, 1.0]), "x") is None  # mirrored is fine
    assert transforms.matrix_problem(np.diag([1e-5, 1e-5, 1e-5, 1.0]), "x") is None  # tiny but uniform
    assert "zero scale" in transforms.matrix_problem(np.diag([0.0, 1.0, 1.0, 1.0]), "x")
    assert "zero scale" in transforms.matrix_problem(np.zeros((4, 4)), "x")
    assert "NaN" in transforms.matrix_problem(np.diag([NAN, 1.0, 1.0, 1.0]), "x")
    assert "enormous" in transforms.matrix_problem(np.diag([1e30, 1.0, 1.0, 1.0]), "x")
    assert transforms.name_bones("sd_deform: SD_ERR_INVALID_ARGUMENT: sd_deform: pose matrix of bone 1 has a "
                                 "non-finite value", ["a", "b"]) == "pose matrix of bone 'b' has a non-finite value"


# Pose-bone channels set from Python, and whether Blender's evaluated pose is still usable
# (sin/cos keep a 1e30 Euler angle finite; every other value here reaches the pose matrices).
BONE_CASES = [
    ("quaternion NaN", "rotation_quaternion", (NAN, 0.0, 0.0, 0.0), False),
    ("euler NaN", "rotation_euler", (NAN, 0.0, 0.0), False),
    ("scale NaN", "scale", (NAN, 1.0, 1.0), False),
    ("scale 1e30", "scale", (1e30, 1.0, 1.0), False),
    ("scale 0 on one axis", "scale", (0.0, 1.0, 1.0), False),
    ("scale 0", "scale", (0.0, 0.0, 0.0), False),
    ("location NaN", "location", (NAN, 0.0, 0.0), False),
    ("location 1e30", "location", (1e30, 0.0, 0.0), False),
    ("euler 1e30", "rotation_euler", (1e30, 0.0, 0.0), True),
    ("mirrored bone", "scale", (-1.0, 1.0, 1.0), True),
]


@pytest.mark.parametrize("label,channel,value,usable", BONE_CASES, ids=[c[0] for c in BONE_CASES])
def test_bad_bone_transform(label, channel, value, usable):
    char, obj, good = bound_fixture()
    arm = char.armature
    before = handler_failures()
    base = helpers.base_positions(obj).copy()
    bone = "thigh.L"  # not connected to its parent: its location counts too
    assert not arm.data.bones[bone].use_connect
    pb = arm.pose.bones[bone]
    pb.rotation_mode = 'QUATERNION' if channel == "rotation_quaternion" else 'XYZ'
    setattr(pb, channel, value)
    bpy.context.view_layer.update()
    if usable:
        check_equals_core(obj, label)
        assert not helpers.sub("blender.deformer_cache").peek(obj).error
    else:
        message = assert_refused(obj, good, f"bone '{bone}'", "Unusable pose")
        print(f"{label}: {message}")
        if any(np.isnan(value)):  # issue 15: said as NaN, not only as "determinant 0"
            assert f"bone '{bone}': its {channel} is NaN" in message, message
        # The overlay and key edits stay on the pose the mesh shows.
        assert helpers.sub("blender.key_ellipses").overlay_data(obj) is not None
    np.testing.assert_array_equal(helpers.base_positions(obj), base)  # the rest mesh untouched
    # Fixed: deforms again, exactly as the core says.
    pb.matrix_basis.identity()
    helpers.set_rotation(pb, (0.4, 0.0, 0.0))
    bpy.context.view_layer.update()
    check_equals_core(obj, label + " fixed")
    assert not helpers.sub("blender.deformer_cache").peek(obj).error
    assert handler_failures() == before


# Object-level transforms: (label, which object, how, words of the message).
OBJECT_CASES = [
    ("armature location NaN", "armature", lambda o: setattr(o, "location", (NAN, 0.0, 0.0)), "NaN"),
    ("armature location 1e30", "armature", lambda o: setattr(o, "location", (1e30, 0.0, 0.0)), "enormous"),
    ("armature scale 1e30", "armature", lambda o: setattr(o, "scale", (1e30, 1e30, 1e30)), "enormous"),
    ("armature scale 0 on one axis", "armature", lambda o: setattr(o, "scale", (1.0, 0.0, 1.0)), "zero scale"),
    ("armature scale 0", "armature", lambda o: setattr(o, "scale", (0.0, 0.0, 0.0)), "zero scale"),
    ("armature matrix NaN", "armature", lambda o: setattr(o, "rotation_euler", (NAN, 0.0, 0.0)), "NaN"),
    ("mesh scale 0 on one axis", "mesh", lambda o: setattr(o, "scale", (0.0, 1.0, 1.0)), "zero scale"),
    ("mesh scale 0", "mesh", lambda o: setattr(o, "scale", (0.0, 0.0, 0.0)), "zero scale"),
    ("mesh location NaN", "mesh", lambda o: setattr(o, "location", (0.0, NAN, 0.0)), "NaN"),
    ("mesh scale 1e30", "mesh", lambda o: setattr(o, "scale", (1.0, 1e30, 1.0)), "enormous"),
]


@pytest.mark.parametrize("label,which,change,words", OBJECT_CASES, ids=[c[0] for c in OBJECT_CASES])
def test_bad_object_transform(label, which, change, words):
    char, obj, good = bound_fixture()
    target = char.armature if which == "armature" else obj
    saved = target.matrix_basis.copy()
    before = handler_failures()
    change(target)
    helpers.pose_limbs(char, elbow=0.3, knee=1.2)  # a new pose must not be applied either
    bpy.context.view_layer.update()
    name = char.armature_name if which == "armature" else char.mesh_name
    message = assert_refused(obj, good, f"'{name}'", words)
    print(f"{label}: {message}")
    assert handler_failures() == before
    target.matrix_basis = saved
    bpy.context.view_layer.update()
    check_equals_core(obj, label + " fixed")
    assert not helpers.sub("blender.deformer_cache").peek(obj).error


def test_binding_refuses_bad_object_transforms():
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = char.mesh
    bpy.context.view_layer.objects.active = obj
    for target, value, words in ((obj, (0.0, 1.0, 1.0), "zero scale"), (char.armature, (0.0, 0.0, 0.0), "zero scale"),
                                 (char.armature, (1e30, 1e30, 1e30), "enormous"), (obj, (NAN, 1.0, 1.0), "NaN")):
        target.scale = value
        for op in (bpy.ops.object.sweep_deform_add, bpy.ops.object.sweep_deform_bind):
            with pytest.raises(RuntimeError, match=words):
                op()
            with pytest.raises(RuntimeError, match=words):
                op('INVOKE_DEFAULT')  # the interface's (modal) path reads the inputs the same way
        target.scale = (1.0, 1.0, 1.0)
        assert obj.sweep_deform.state == 'UNBOUND' and helpers.sub("blender.modifier").find(obj) is None
        assert all(m.show_viewport for m in obj.modifiers)


def world_positions(obj):
    co, _ = helpers.evaluated_positions(obj)
    m = np.array(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).matrix_world, np.float64)
    return co.astype(np.float64) @ m[:3, :3].T + m[:3, 3]


def test_mirrored_armature_deforms_the_mirrored_character():
    """Armature scale −1 on X after binding (the mesh is its child): the character deforms as
    the core says, and in the world it is the mirror image of the unmirrored one."""
    char, obj, _ = bound_fixture()
    unmirrored = world_positions(obj)
    char.armature.scale.x = -1.0
    bpy.context.view_layer.update()
    check_equals_core(obj)
    mirrored = world_positions(obj)
    np.testing.assert_allclose(mirrored * [-1.0, 1.0, 1.0], unmirrored, atol=1e-5 * helpers.diagonal(unmirrored))
    assert not helpers.sub("blender.deformer_cache").peek(obj).error


def test_mirrored_mesh_object_binds_and_deforms_like_the_original():
    """A mesh whose object has scale −1 on X and whose data is mirrored back (so it sits where
    it did): binding and posing it gives the original's deformation in the world."""
    char, obj, _ = bound_fixture()
    reference = world_positions(obj)
    assert bpy.ops.object.sweep_deform_unbind() == {'FINISHED'}
    obj.data.transform(mathutils.Matrix.Scale(-1.0, 4, (1.0, 0.0, 0.0)))
    obj.data.flip_normals()
    obj.scale.x = -1.0
    bpy.context.view_layer.update()
    assert obj.matrix_world.determinant() < 0.0
    assert bpy.ops.object.sweep_deform_bind() == {'FINISHED'}
    bpy.context.view_layer.update()
    check_equals_core(obj)
    np.testing.assert_allclose(world_positions(obj), reference, atol=1e-5 * helpers.diagonal(reference))


def test_two_characters_on_one_armature():
    """A body and a shirt (the body pushed out along its normals), both bound to the same
    armature: each deforms exactly as the core says for it, and they stay together."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    body, arm = char.mesh, char.armature
    shirt = body.copy()
    shirt.data = body.data.copy()
    shirt.name = "Shirt"
    bpy.context.scene.collection.objects.link(shirt)
    normals = np.empty(len(shirt.data.vertices) * 3, np.float32)
    shirt.data.vertices.foreach_get("normal", normals)
    co = helpers.base_positions(shirt) + 0.005 * normals.reshape(-1, 3)
    shirt.data.vertices.foreach_set("co", co.ravel())
    shirt.data.update()
    helpers.bind(char)
    bpy.context.view_layer.objects.active = shirt
    assert bpy.ops.object.sweep_deform_add() == {'FINISHED'}
    assert shirt.sweep_deform.armature == arm == body.sweep_deform.armature
    for elbow, knee in ((1.2, 0.9), (0.3, 1.4)):
        helpers.pose_limbs(char, elbow=elbow, knee=knee)
        bpy.context.view_layer.update()
        b, s = check_equals_core(body, "body"), check_equals_core(shirt, "shirt")
        moved = np.linalg.norm(b - helpers.base_positions(body), axis=1).max()
        gap = np.linalg.norm(s - b, axis=1)
        print(f"elbow {elbow}, knee {knee}: body moved up to {moved:.3f} m, shirt-body gap "
              f"mean {gap.mean() * 1000:.2f} mm, max {gap.max() * 1000:.2f} mm")
        assert moved > 0.05 and gap.max() < 0.05
    # Unbinding one leaves the other deforming.
    assert bpy.ops.object.sweep_deform_unbind() == {'FINISHED'}
    helpers.pose_limbs(char, elbow=0.7, knee=0.2)
    bpy.context.view_layer.update()
    check_equals_core(body, "body alone")
