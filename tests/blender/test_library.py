# SPDX-License-Identifier: GPL-3.0-or-later
"""A bound character from another .blend (issue 8): linked, linked through a library
override, instanced as a linked collection, and appended. Each test first writes the source
file into SWEEPDEFORM_TEST_TMP: the built-in character, bound with the test rig, in a
collection "Character", saved posed.

What is expected: Blender ignores an add-on's writes into linked data. A character linked
without an override was saved for Blender without the extension (issue 15: Armature modifier on,
Sweep Deform off), so it follows the pose by its Armature modifier, and its panel says so and how
to make a library override; a library override deforms as the core says (its mesh stays linked:
the offsets go into a local carrier, issue 16), and so does a local copy (appended, or made
local). Binding linked data again is refused with a message. Nothing raises in the
console, the source file is never written, and the file that links it saves and reopens."""

import hashlib
import os

import bpy
import numpy as np
import pytest

import bone_rig
import helpers
from test_bad_input import handler_failures
from test_deform import check_equals_core

COLLECTION = "Character"


def write_source(name):
    """Saves the bound, posed character in a collection; returns (path, SHA-1 of the file,
    the evaluated mesh positions as saved)."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    coll = bpy.data.collections.new(COLLECTION)
    bpy.context.scene.collection.children.link(coll)
    for o in (obj, char.armature):
        for c in list(o.users_collection):
            c.objects.unlink(o)
        coll.objects.link(o)
    helpers.pose_limbs(char, elbow=0.9, knee=0.6)
    bpy.context.view_layer.update()
    saved = check_equals_core(obj, "source")
    path = os.path.join(helpers.tmp_dir(), name)
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.read_homefile(use_empty=True)
    return path, sha1(path), saved


def sha1(path):
    with open(path, "rb") as f:
        return hashlib.sha1(f.read()).hexdigest()


def load_collection(path, link):
    with bpy.data.libraries.load(path, link=link) as (_, data_to):
        data_to.collections = [COLLECTION]
    return data_to.collections[0]


def members(coll):
    body = next(o for o in coll.all_objects if o.type == 'MESH')
    arm = next(o for o in coll.all_objects if o.type == 'ARMATURE')
    return body, arm


def pose(arm, elbow, knee):
    for name in ("forearm.L", "forearm.R"):
        helpers.set_rotation(arm.pose.bones[name], (elbow, 0.0, 0.0))
    for name in ("shin.L", "shin.R"):
        helpers.set_rotation(arm.pose.bones[name], (knee, 0.0, 0.0))


def assert_bind_refused(obj, words):
    """Binding is refused with a message; unbinding and key editing are not offered."""
    bpy.context.view_layer.objects.active = obj
    for op in (bpy.ops.object.sweep_deform_bind, bpy.ops.object.sweep_deform_add):
        with pytest.raises(RuntimeError, match=words):
            op()
    assert not bpy.ops.object.sweep_deform_unbind.poll()
    assert not bpy.ops.object.sweep_deform_edit_keys.poll()


def save_and_reopen(name):
    path = os.path.join(helpers.tmp_dir(), name)
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=path)


def assert_deforms_by_armature_modifier(body, saved):
    """The linked mesh is not written: its Armature modifier (on in the library, which was
    saved for Blender without the extension) deforms it, so it follows the pose, unlike the
    saved shape; the panel says why and what to do; the binding's state is untouched."""
    bpy.context.view_layer.update()
    md_sweep = helpers.sub("blender.modifier").find(body)
    md_arm = body.modifiers[body.sweep_deform.armature_modifier]
    assert not md_sweep.show_viewport and md_arm.show_viewport and md_arm.object == body.sweep_deform.armature
    co = helpers.evaluated_positions(body)[0]
    assert np.isfinite(co).all() and np.abs(co - saved).max() > 1e-3  # posed otherwise than saved
    e = helpers.sub("blender.deformer_cache").peek(body)
    assert e is not None and "is linked from" in e.error and "library override" in e.error, e and e.error
    assert "its Armature modifier deforms it here" in e.error, e.error
    assert body.sweep_deform.state == 'BOUND' and body.sweep_deform.message == ""


def test_linked_character():
    src, digest, saved = write_source("linked_src.blend")
    before = handler_failures()
    coll = load_collection(src, link=True)
    bpy.context.scene.collection.children.link(coll)
    body, arm = members(coll)
    assert body.library is not None and body.data.library is not None
    pose(arm, 1.3, 0.2)  # pose channels of linked data can be set (they are not saved)
    assert_deforms_by_armature_modifier(body, saved)
    assert_bind_refused(body, "linked from")
    save_and_reopen("links_character.blend")
    body, arm = members(bpy.data.collections[COLLECTION])
    pose(arm, 0.8, 1.1)
    assert_deforms_by_armature_modifier(body, saved)
    assert sha1(src) == digest  # the library file is never written
    assert handler_failures() == before


def test_library_override_deforms():
    """The usual way to animate a linked character is a library override of its collection;
    its mesh stays linked, and it deforms: the override's modifier gets a local carrier. Saved
    and reopened it still deforms; made local it deforms too; the library is never written."""
    src, digest, saved = write_source("override_src.blend")
    before = handler_failures()
    linked = load_collection(src, link=True)
    coll = linked.override_hierarchy_create(bpy.context.scene, bpy.context.view_layer)
    body, arm = members(coll)
    assert body.override_library is not None and body.library is None and body.data.library is not None
    assert body.sweep_deform.armature == arm  # the pointer follows the override
    pose(arm, 1.2, 0.4)
    bpy.context.view_layer.update()
    posed = check_equals_core(body, "override")
    assert not np.array_equal(posed, saved)
    e = helpers.sub("blender.deformer_cache").peek(body)
    assert body.sweep_deform.state == 'BOUND' and not e.error, e.error
    assert_bind_refused(body, "linked from")  # the binding itself is the library's

    names, coll_name = (body.name, arm.name), coll.name
    save_and_reopen("overrides_character.blend")
    body, arm = (bpy.data.objects[n] for n in names)
    assert body.override_library is not None and body.data.library is not None
    # The binding's armature pointer is the override's after reopening too, not the linked
    # armature (which is in no scene): it used to come back from the library on reload.
    assert body.sweep_deform.armature == arm and arm.override_library is not None
    pose(arm, 0.3, 1.3)
    bpy.context.view_layer.update()
    check_equals_core(body, "override, reopened")
    e = helpers.sub("blender.deformer_cache").peek(body)
    assert body.sweep_deform.state == 'BOUND' and not e.error, e.error
    bpy.context.view_layer.update()  # a second update changes nothing
    check_equals_core(body, "override, reopened, updated again")

    # Made local (what older versions asked for) it deforms as well.
    for o in bpy.context.selected_objects:
        o.select_set(False)
    body.select_set(True)
    bpy.context.view_layer.objects.active = body
    assert bpy.ops.object.make_local(type='SELECT_OBDATA') == {'FINISHED'}
    body, arm = members(bpy.data.collections[coll_name])
    assert body.data.library is None
    pose(arm, 0.9, 0.2)
    bpy.context.view_layer.update()
    check_equals_core(body, "made local")
    assert body.sweep_deform.state == 'BOUND' and not helpers.sub("blender.deformer_cache").peek(body).error
    assert sha1(src) == digest
    assert handler_failures() == before


def test_linked_collection_instance():
    """Add > Collection Instance of a linked character: its objects are not in the scene's
    object list, only instanced, and their mesh is linked: it deforms by its Armature
    modifier, as saved for Blender without the extension."""
    src, digest, saved = write_source("instanced_src.blend")
    before = handler_failures()
    coll = load_collection(src, link=True)
    for x in (0.0, 1.0):
        empty = bpy.data.objects.new(f"Instance {x}", None)
        empty.instance_type = 'COLLECTION'
        empty.instance_collection = coll
        empty.location.x = x
        bpy.context.scene.collection.objects.link(empty)
    body, arm = members(coll)
    assert body.name not in bpy.context.scene.objects
    pose(arm, 0.2, 1.0)
    bpy.context.view_layer.update()
    first = helpers.evaluated_positions(body)[0]
    assert np.abs(first - saved).max() > 1e-3  # follows the pose (Armature modifier)
    assert not helpers.sub("blender.modifier").find(body).show_viewport
    save_and_reopen("instances_character.blend")
    body, arm = members(bpy.data.collections[COLLECTION])
    pose(arm, 0.2, 1.0)  # a linked pose is not saved: the same pose again
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(helpers.evaluated_positions(body)[0], first)
    assert sha1(src) == digest
    assert handler_failures() == before


def test_appended_character():
    """Append: the character becomes local data and keeps its binding, exactly."""
    src, digest, saved = write_source("appended_src.blend")
    before = handler_failures()
    coll = load_collection(src, link=False)
    bpy.context.scene.collection.children.link(coll)
    body, arm = members(coll)
    assert body.library is None and body.sweep_deform.state == 'BOUND'
    bpy.context.view_layer.update()
    source_pose = check_equals_core(body, "appended, as saved")
    pose(arm, 1.4, 0.3)
    bpy.context.view_layer.update()
    posed = check_equals_core(body, "appended, posed")
    assert not np.allclose(posed, source_pose)
    names = body.name, arm.name
    save_and_reopen("appends_character.blend")
    body, arm = (bpy.data.objects[n] for n in names)
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(helpers.evaluated_positions(body)[0], posed)
    # Local now: it can be bound again.
    helpers.use_test_rig([helpers.Character("fixture", body.name, arm.name, [], [], bone_rig.FIXTURE_CHAINS)])
    bpy.context.view_layer.objects.active = body
    assert bpy.ops.object.sweep_deform_bind() == {'FINISHED'}
    bpy.context.view_layer.update()
    check_equals_core(body, "appended, bound again")
    assert sha1(src) == digest
    assert handler_failures() == before
