# SPDX-License-Identifier: GPL-3.0-or-later
"""The modifier in full (issue 16): the per-frame offsets live in a hidden carrier object per
bound object, never in the character's mesh; linked duplicates each deform with their own
armature; characters that do not show cost nothing; a modifier before Sweep Deform that
changes the vertex count is reported and passed through; the core is safe to call from two
threads at once."""

import hashlib
import threading
import time

import bpy
import numpy as np
import pytest

import helpers
from test_bad_input import handler_failures
from test_deform import check_equals_core

_FIELDS = {'FLOAT': 'value', 'INT': 'value', 'BOOLEAN': 'value', 'INT8': 'value', 'FLOAT_VECTOR': 'vector',
           'FLOAT2': 'vector', 'FLOAT_COLOR': 'color', 'BYTE_COLOR': 'color', 'QUATERNION': 'value'}


def mesh_digest(mesh):
    """SHA-1 of the mesh datablock's vertex positions and every attribute (name, domain, type,
    values), and of its shape keys."""
    h = hashlib.sha1()
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    h.update(co.tobytes())
    for attr in sorted(mesh.attributes, key=lambda a: a.name):
        h.update(f"{attr.name}/{attr.domain}/{attr.data_type}".encode())
        field = _FIELDS.get(attr.data_type)
        if field is None or len(attr.data) == 0:
            continue
        width = {'vector': 3 if attr.data_type == 'FLOAT_VECTOR' else 2, 'color': 4}.get(field, 1)
        if attr.data_type == 'QUATERNION':
            width = 4
        dtype = np.float32 if attr.data_type not in ('INT', 'BOOLEAN', 'INT8') else np.int32
        values = np.empty(len(attr.data) * width, dtype if attr.data_type != 'BOOLEAN' else bool)
        attr.data.foreach_get(field, values)
        h.update(values.tobytes())
    if mesh.shape_keys is not None:
        for kb in mesh.shape_keys.key_blocks:
            data = np.empty(len(kb.data) * 3, np.float32)
            kb.data.foreach_get("co", data)
            h.update(kb.name.encode() + data.tobytes())
    return h.hexdigest()


def animate_elbows(char, frames_angles):
    """Keys elbows and knees (the file's own animation goes first)."""
    arm = char.armature
    arm.animation_data_clear()
    for frame, angle in frames_angles:
        helpers.pose_limbs(char, elbow=angle, knee=0.5 * angle)
        for n in char.elbows + char.knees:
            arm.pose.bones[n].keyframe_insert("rotation_euler", frame=frame)


def core_calls():
    return helpers.sub("blender.frame").core_calls


def test_playback_leaves_the_mesh_untouched():
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    scene = bpy.context.scene
    animate_elbows(char, ((1, 0.0), (50, 1.4), (100, 0.2)))
    scene.frame_set(1)
    mesh = obj.data
    before = mesh_digest(mesh)
    names = set(mesh.attributes.keys())
    calls = core_calls()
    seen = {}
    for f in range(1, 101):
        scene.frame_set(f)
        if f in (1, 37, 50, 100):
            seen[f] = check_equals_core(obj, f"frame {f}")
    assert core_calls() - calls >= 90  # the frames were deformed, through the core
    assert not np.allclose(seen[1], seen[50])
    assert mesh_digest(mesh) == before, "playing wrote into the character's mesh"
    assert set(mesh.attributes.keys()) == names and "sweep_deform_offset" not in names
    # The offsets are in the object's own carriers (viewport, render), in no collection.
    modifier = helpers.sub("blender.modifier")
    for render in (False, True):
        carrier = modifier.get_carrier(modifier.find(obj), render)
        assert carrier is not None and modifier.owns(obj, carrier, render) and not carrier.users_collection
        assert len(carrier.data.vertices) == len(mesh.vertices)


def carrier_positions(obj, render):
    """The positions of the object's offsets carrier of the viewport (of renders)."""
    modifier = helpers.sub("blender.modifier")
    return helpers.base_positions(modifier.get_carrier(modifier.find(obj), render))


def viewport_offsets(obj):
    """The offsets the viewport shows: its mesh carrier's positions less the mesh's when that
    serves (the mesh has no shape keys here), else its offsets carrier's."""
    modifier = helpers.sub("blender.modifier")
    c = modifier.mesh_carrier_in_use(obj, modifier.find(obj))
    if c is None:
        return carrier_positions(obj, False)
    return helpers.base_positions(c) - helpers.base_positions(obj)


def modifier_before(obj):
    """A Displace of strength 0 first in the stack: it moves nothing, yet sends the frame through
    the node group's general path (J in the offsets carrier)."""
    before = obj.modifiers.new("Nothing", 'DISPLACE')
    before.strength = 0.0
    obj.modifiers.move(list(obj.modifiers).index(before), 0)
    return before


def posed_for_a_render():
    """The light fixture bound and posed in a scene set up for tiny Workbench renders."""
    import test_render
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    test_render.setup_scene(char)
    helpers.pose_limbs(char, elbow=1.2, knee=0.4)
    bpy.context.view_layer.update()
    return char, obj


def test_render_and_viewport_keep_their_own_carriers():
    """A render writes the render carrier for the pose it renders; the viewport writes its own
    and never the render's, so a render in another thread (Lock Interface off) and the viewport
    playing other frames do not overwrite each other's offsets."""
    char, obj = posed_for_a_render()
    check_equals_core(obj, "viewport")
    rendered = viewport_offsets(obj)  # the viewport's offsets for this pose
    assert rendered.any() and not carrier_positions(obj, True).any()  # no render yet: zero offsets
    calls = core_calls()
    assert bpy.ops.render.render() == {'FINISHED'}
    assert core_calls() > calls
    # (float32 positions less the mesh's: equal to the offsets to their last bit or so)
    np.testing.assert_allclose(carrier_positions(obj, True), rendered, rtol=0, atol=1e-6)
    helpers.pose_limbs(char, elbow=0.2, knee=1.3)
    bpy.context.view_layer.update()
    check_equals_core(obj, "viewport, other pose")  # from the viewport carrier
    assert not np.allclose(viewport_offsets(obj), rendered, rtol=0, atol=1e-6)
    np.testing.assert_allclose(carrier_positions(obj, True), rendered, rtol=0, atol=1e-6)


def test_linked_duplicates_each_on_their_own_armature():
    """Alt+D of the character and its armature: one mesh, two objects, two armatures in
    different poses: both are what the core computes for their own pose."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    new_obj, new_arm = helpers.duplicate_character(obj, char.armature, linked=True)
    assert new_obj.data == obj.data  # a shared mesh
    assert new_obj.sweep_deform.armature == new_arm
    new_arm.location.x += 1.0
    for n in char.elbows:
        helpers.set_rotation(new_arm.pose.bones[n], (1.3, 0.0, 0.0))
    helpers.pose_limbs(char, elbow=0.3, knee=0.9)
    bpy.context.view_layer.update()
    a, b = check_equals_core(obj, "original"), check_equals_core(new_obj, "linked duplicate")
    assert not np.allclose(a, b)
    assert new_obj.sweep_deform.state == 'BOUND' and not new_obj.sweep_deform.message
    # And again after another pose of the first one only.
    helpers.pose_limbs(char, elbow=1.0, knee=0.1)
    bpy.context.view_layer.update()
    check_equals_core(obj, "original, pose 2")
    np.testing.assert_array_equal(check_equals_core(new_obj, "duplicate, unchanged"), b)
    modifier = helpers.sub("blender.modifier")
    for render in (False, True):
        ca, cb = (modifier.get_carrier(modifier.find(o), render) for o in (obj, new_obj))
        assert ca != cb and modifier.owns(obj, ca, render) and modifier.owns(new_obj, cb, render)
    # Saved and reopened, both still deform.
    path = helpers.tmp_dir() + "/linked_duplicates.blend"
    names = obj.name, new_obj.name, new_arm.name
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj, new_obj, new_arm = (bpy.data.objects[n] for n in names)
    helpers.set_rotation(new_arm.pose.bones[char.elbows[0]], (0.6, 0.0, 0.0))
    bpy.context.view_layer.update()
    check_equals_core(obj, "reopened")
    check_equals_core(new_obj, "duplicate reopened")


def _hide(characters, scene):
    """Nine characters (mesh and armature) that do not show, three ways each: hidden in the
    view layer, disabled in viewports, in an excluded collection."""
    excluded = bpy.data.collections.new("Excluded")
    scene.collection.children.link(excluded)
    bpy.context.view_layer.layer_collection.children[excluded.name].exclude = True
    for i, pair in enumerate(characters):
        for o in pair:
            if i % 3 == 0:
                o.hide_set(True)
            elif i % 3 == 1:
                o.hide_viewport = True
            else:
                for c in list(o.users_collection):
                    c.objects.unlink(o)
                excluded.objects.link(o)


def _time_frames(scene, frames):
    """(seconds a frame, of which in the add-on's handlers)."""
    handlers = helpers.sub("blender.handlers")
    inner, spent = handlers.evaluate_scene, [0.0]

    def timed(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return inner(*args, **kwargs)
        finally:
            spent[0] += time.perf_counter() - t0

    handlers.evaluate_scene = timed
    try:
        t = time.perf_counter()
        for f in frames:
            scene.frame_set(f)
        total = time.perf_counter() - t
    finally:
        handlers.evaluate_scene = inner
    return total / len(frames), spent[0] / len(frames)


def test_hidden_and_unchanged_characters_cost_nothing():
    """Ten bound characters (linked duplicates, each with its own animated armature), nine
    that do not show: a frame deforms one. Counted (core calls), and timed against a scene
    with the visible one alone, in the same run (printed, not asserted)."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    scene = bpy.context.scene
    animate_elbows(char, ((1, 0.0), (30, 1.4), (60, 0.2)))
    others = []
    for i in range(9):
        obj_i, arm_i = helpers.duplicate_character(obj, char.armature, linked=True)
        arm_i.location.x += 1.0 + i
        others.append((obj_i, arm_i))
    scene.frame_set(1)
    bpy.context.view_layer.update()
    for o, _ in others:
        check_equals_core(o, "before hiding")
    _hide(others, scene)
    scene.frame_set(2)
    frames = list(range(3, 30))

    calls = core_calls()
    per_frame_hidden = _time_frames(scene, frames)
    assert core_calls() - calls == len(frames)  # the visible one only
    check_equals_core(obj, "visible")

    # The pose does not change between frames 61 and 70 (after the last key): nothing to do.
    scene.frame_set(61)
    calls = core_calls()
    for f in range(62, 71):
        scene.frame_set(f)
    assert core_calls() == calls

    # Showing one again deforms it at once, for the current pose.
    shown, shown_arm = others[0]
    shown.hide_set(False)
    shown_arm.hide_set(False)
    helpers.set_rotation(shown_arm.pose.bones[char.elbows[0]], (0.9, 0.0, 0.0))
    bpy.context.view_layer.update()
    check_equals_core(shown, "shown again")
    shown.hide_set(True)
    shown_arm.hide_set(True)
    bpy.context.view_layer.update()

    # A mesh disabled in viewports that a visible object uses (a Shrinkwrap target) is
    # evaluated: Blender puts it in the depsgraph for its user. (Its armature must be evaluated
    # too, for its pose: here it is shown again.)
    used, used_arm = others[1]  # disabled in viewports
    used_arm.hide_viewport = False
    cube = bpy.data.objects.new("Shrinkwrapped", bpy.data.meshes.new("Shrinkwrapped"))
    scene.collection.objects.link(cube)
    cube.modifiers.new("Shrinkwrap", 'SHRINKWRAP').target = used
    scene.frame_set(2)
    calls = core_calls()
    scene.frame_set(3)
    assert core_calls() - calls == 2
    check_equals_core(used, "hidden but used")
    bpy.data.objects.remove(cube)
    used_arm.hide_viewport = True

    # The same frames with the visible character alone in the scene.
    for o, a in others:
        for c in list(o.users_collection) + list(a.users_collection):
            if o.name in c.objects:
                c.objects.unlink(o)
            if a.name in c.objects:
                c.objects.unlink(a)
    scene.frame_set(2)
    calls = core_calls()
    per_frame_alone = _time_frames(scene, frames)
    assert core_calls() - calls == len(frames)
    (hidden, hidden_addon), (alone, alone_addon) = per_frame_hidden, per_frame_alone
    print(f"\nten characters, nine hidden: {1e3 * hidden:.2f} ms a frame ({1e3 * hidden_addon:.2f} ms in the add-on); "
          f"the visible one alone: {1e3 * alone:.2f} ms ({1e3 * alone_addon:.2f} ms); ratio {hidden / alone:.2f} "
          f"(add-on {hidden_addon / alone_addon:.2f})")


def test_hide_render_costs_nothing_in_a_render():
    """A character hidden for renders is not deformed by a render (its render carrier is not
    written); shown again for renders, it is."""
    char, obj = posed_for_a_render()
    obj.hide_render = True
    calls = core_calls()
    assert bpy.ops.render.render() == {'FINISHED'}
    assert core_calls() == calls and not carrier_positions(obj, True).any()
    obj.hide_render = False
    assert bpy.ops.render.render() == {'FINISHED'}
    assert core_calls() == calls + 1
    np.testing.assert_allclose(carrier_positions(obj, True), viewport_offsets(obj), rtol=0, atol=1e-6)


def test_vertex_count_changed_before_the_modifier():
    """An Array before Sweep Deform: the geometry passes through unchanged and the panel says
    why and what to do; after Sweep Deform it is fine."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    helpers.pose_limbs(char, elbow=1.1, knee=0.7)
    bpy.context.view_layer.update()
    check_equals_core(obj)
    modifier = helpers.sub("blender.modifier")
    panel = helpers.sub("ui.panel")
    assert panel.vertex_count_problem(bpy.context, obj) is None
    array = obj.modifiers.new("Array", 'ARRAY')
    array.count = 2
    bpy.ops.object.modifier_move_to_index(modifier="Array", index=0)
    assert list(obj.modifiers).index(modifier.find(obj)) == 1
    bpy.context.view_layer.update()
    co, _ = helpers.evaluated_positions(obj)
    md = modifier.find(obj)
    md.show_viewport = False
    bpy.context.view_layer.update()
    passed, _ = helpers.evaluated_positions(obj)
    md.show_viewport = True
    bpy.context.view_layer.update()
    assert len(co) == 2 * len(obj.data.vertices)
    np.testing.assert_array_equal(co, passed)  # passed through unchanged
    message = panel.vertex_count_problem(bpy.context, obj)
    assert message and "'Array'" in message and "changes the vertex count" in message \
        and "passes the geometry through unchanged" in message, message
    if hasattr(md, "node_warnings"):  # Blender 5.x lists the modifier's warnings
        assert any("vertex count" in w.message for w in md.node_warnings), [w.message for w in md.node_warnings]
    # Moved after Sweep Deform: deformed, then arrayed.
    bpy.ops.object.modifier_move_to_index(modifier="Array", index=len(obj.modifiers) - 1)
    bpy.context.view_layer.update()
    assert panel.vertex_count_problem(bpy.context, obj) is None
    co, _ = helpers.evaluated_positions(obj)
    expected, _ = helpers.core_expectation(obj)
    np.testing.assert_array_equal(co[:len(expected)], expected)


def test_two_threads_on_one_deformer_match_the_serial_results():
    """ctypes releases the GIL: a render thread and the viewport can run the same character's
    deformer at once. Each call must give the serial result for its own pose."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    bpy.context.view_layer.update()
    e = helpers.sub("blender.deformer_cache").entry(obj)
    d = e.deformer
    poses = []
    for angle in (0.2, 0.7, 1.2, 1.6):
        helpers.pose_limbs(char, elbow=angle, knee=angle)
        bpy.context.view_layer.update()
        poses.append(e.armature_pose(char.armature.evaluated_get(bpy.context.evaluated_depsgraph_get())).copy())
    V = d.vertex_count
    serial = [d.deform(p, np.empty((V, 3), np.float32)).copy() for p in poses]
    assert not np.array_equal(serial[0], serial[3])
    bad = []

    def worker(first):
        out = np.empty((V, 3), np.float32)
        for r in range(60):
            i = (first + r) % len(poses)
            d.deform(poses[i], out)
            if not np.array_equal(out, serial[i]):
                bad.append(i)

    threads = [threading.Thread(target=worker, args=(k,)) for k in (0, 2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not bad, f"{len(bad)} of 120 concurrent results differ from the serial ones"
    assert handler_failures() == set()


def _layout_1(ng):
    """The node group as version 1 of the add-on built it (offsets in the mesh's attribute)."""
    ng.nodes.clear()
    ng.interface.clear()
    ng.interface.new_socket(name="Geometry", in_out='INPUT', socket_type='NodeSocketGeometry')
    ng.interface.new_socket(name="Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
    nodes, links = ng.nodes, ng.links
    gin, gout = nodes.new('NodeGroupInput'), nodes.new('NodeGroupOutput')
    named = nodes.new('GeometryNodeInputNamedAttribute')
    named.data_type = 'FLOAT_VECTOR'
    named.inputs['Name'].default_value = "sweep_deform_offset"
    setpos = nodes.new('GeometryNodeSetPosition')
    remove = nodes.new('GeometryNodeRemoveAttribute')
    remove.inputs['Name'].default_value = "sweep_deform_offset"
    links.new(gin.outputs['Geometry'], setpos.inputs['Geometry'])
    links.new(named.outputs['Exists'], setpos.inputs['Selection'])
    links.new(named.outputs['Attribute'], setpos.inputs['Offset'])
    links.new(setpos.outputs['Geometry'], remove.inputs['Geometry'])
    links.new(remove.outputs['Geometry'], gout.inputs['Geometry'])
    ng["sweep_deform_group"] = 1


def test_file_bound_by_the_previous_version_loads_and_deforms():
    """A file as version 1 saved it (node group layout 1, the offsets in the mesh's
    ``sweep_deform_offset`` attribute, no carriers): opened, the group is brought up to date,
    the attribute leaves the mesh, the carriers are made, and the character deforms."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    helpers.pose_limbs(char, elbow=1.0, knee=0.6)
    bpy.context.view_layer.update()
    offsets = check_equals_core(obj, "bound") - helpers.base_positions(obj)
    modifier = helpers.sub("blender.modifier")
    md = modifier.find(obj)
    for render in (False, True):
        c = modifier.get_carrier(md, render)
        modifier.set_carrier(md, None, render)
        bpy.data.objects.remove(c)
    _layout_1(md.node_group)
    attr = obj.data.attributes.new("sweep_deform_offset", 'FLOAT_VECTOR', 'POINT')
    attr.data.foreach_set("vector", offsets.reshape(-1))
    path = helpers.tmp_dir() + "/bound_by_version_1.blend"
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects["Body"]
    md = modifier.find(obj)
    assert md is not None and md.node_group.get(modifier.GROUP_TAG) == modifier.GROUP_VERSION
    assert "sweep_deform_offset" not in obj.data.attributes
    helpers.pose_limbs(char, elbow=0.4, knee=1.2)
    bpy.context.view_layer.update()
    check_equals_core(obj, "migrated")
    assert obj.sweep_deform.state == 'BOUND' and not helpers.sub("blender.deformer_cache").peek(obj).error
    for render in (False, True):
        assert modifier.owns(obj, modifier.get_carrier(md, render), render)


def _weighted(obj, group, least=0.999):
    """Indices of the vertices with at least `least` of their weight in vertex group `group`."""
    index = obj.vertex_groups[group].index
    return np.array([v.index for v in obj.data.vertices
                     if any(g.group == index and g.weight >= least for g in v.groups)], np.int64)


def test_shape_key_rides_along_with_the_head():
    """A relative shape key on the head (3 cm along +X, value 1), the neck turned 90°: the head
    is the rigid turn of basis + key (Blender's Armature modifier on the same mesh, where the
    head's vertices follow one bone), within 1e-4 of the diagonal. Without the local linear
    maps the key's move would stay along +X."""
    helpers.require("makehuman")
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    head = _weighted(obj, "head")
    assert len(head) > 1000
    base = helpers.base_positions(obj)
    obj.shape_key_add(name="Basis", from_mix=False)
    key = obj.shape_key_add(name="Shift", from_mix=False)
    shifted = base.copy()
    shifted[head, 0] += 0.03
    key.data.foreach_set("co", shifted.reshape(-1))
    key.value = 1.0
    neck = char.armature.pose.bones["neck_01"]
    helpers.set_rotation(neck, (0.0, np.pi / 2, 0.0))  # about the bone's own axis: the head turns
    bpy.context.view_layer.update()
    co, _ = helpers.evaluated_positions(obj)
    rigid = helpers.armature_modifier_positions(obj)
    diag = helpers.diagonal(base)
    err = np.linalg.norm(co[head] - rigid[head], axis=1)
    turned = np.linalg.norm(rigid[head] - shifted[head], axis=1)
    print(f"\nhead ({len(head)} vertices), shape key +3 cm X, neck 90°: vs the rigid turn median {np.median(err):.2e}, "
          f"max {err.max():.2e} (diagonal {diag:.3f}); the head moved {np.median(turned):.3f} (median)")
    assert np.median(turned) > 0.02  # the neck really turned the head
    assert err.max() <= 1e-4 * diag
    # The rest of the body: the mesh as before (no key there), equal to the core's result.
    key.value = 0.0
    bpy.context.view_layer.update()
    check_equals_core(obj, "key at 0")


def test_displace_before_the_modifier_turns_with_the_forearm():
    """A Displace modifier before Sweep Deform (1 cm along mesh X everywhere), elbows bent: on
    the forearms its move turns with them as under Blender's Armature modifier (the move the
    modifier adds, with and without the Displace, compared on the vertices that follow the
    forearm alone, on its outer half: nearer the elbow the sweep's cross-sections turn by part
    of the bend, by design, where the bone turns by all of it)."""
    helpers.require("makehuman")
    char = helpers.load("makehuman")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    forearm = _weighted(obj, char.elbows[0])
    bone = char.armature.data.bones[char.elbows[0]]
    to_mesh = obj.matrix_world.inverted() @ char.armature.matrix_world
    head, tail = (np.array(to_mesh @ p) for p in (bone.head_local, bone.tail_local))
    along = (helpers.base_positions(obj)[forearm] - head) @ (tail - head) / np.dot(tail - head, tail - head)
    forearm = forearm[along > 0.5]
    assert len(forearm) > 30
    helpers.pose_limbs(char, elbow=1.4)
    bpy.context.view_layer.update()
    plain, lbs_plain = helpers.evaluated_positions(obj)[0], helpers.armature_modifier_positions(obj)
    texture_free = obj.modifiers.new("Displace", 'DISPLACE')
    texture_free.direction, texture_free.strength, texture_free.mid_level = 'X', 0.01, 0.0
    bpy.ops.object.modifier_move_to_index(modifier="Displace", index=0)
    bpy.context.view_layer.update()
    moved, lbs_moved = helpers.evaluated_positions(obj)[0], helpers.armature_modifier_positions(obj)
    ours, theirs = (moved - plain)[forearm], (lbs_moved - lbs_plain)[forearm]
    err = np.linalg.norm(ours - theirs, axis=1)
    turn = np.degrees(np.arccos(np.clip(theirs[:, 0] / 0.01, -1, 1)))
    print(f"\nDisplace 1 cm X, elbow 1.4 rad: {len(forearm)} forearm vertices turned {np.median(turn):.0f}° (median); "
          f"against the Armature modifier median {np.median(err):.2e}, max {err.max():.2e}")
    assert np.median(turn) > 45  # the move did turn
    assert err.max() < 0.05 * 0.01


def test_corrective_key_driven_by_the_elbow_turns_with_the_forearm():
    """A corrective shape key driven by the elbow angle (a driver on its value: the rotation
    between upper arm and forearm, 0 straight, 1 at 120°) moving the forearm 1 cm along the
    bone's Z axis: with the forearm at 120° the key is fully on and its move points with the
    forearm, as under Blender's Armature modifier on the same mesh (compared on the vertices
    that follow the forearm alone, on its outer half, as the Displace above). Left along its
    rest direction the move would be 1.7 cm off. The built-in character with the product's
    own fitting."""
    char = helpers.load("fixture")
    obj, arm = char.mesh, char.armature
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.object.sweep_deform_add() == {'FINISHED'}
    upper, lower = char.shoulders[0], char.elbows[0]
    forearm = _weighted(obj, lower, least=0.99)
    bone = arm.data.bones[lower]
    to_mesh = obj.matrix_world.inverted() @ arm.matrix_world
    head, tail = (np.array(to_mesh @ p) for p in (bone.head_local, bone.tail_local))
    base = helpers.base_positions(obj)
    along = (base[forearm] - head) @ (tail - head) / np.dot(tail - head, tail - head)
    forearm = forearm[along > 0.5]
    assert len(forearm) > 30
    z = np.array(to_mesh.to_3x3() @ bone.matrix_local.to_3x3().col[2])
    z /= np.linalg.norm(z)
    obj.shape_key_add(name="Basis", from_mix=False)
    key = obj.shape_key_add(name="Elbow corrective", from_mix=False)
    moved = base.copy()
    moved[forearm] += 0.01 * z
    key.data.foreach_set("co", moved.reshape(-1))
    driver = key.driver_add("value").driver
    driver.type = 'SCRIPTED'
    angle = driver.variables.new()
    angle.name, angle.type = "a", 'ROTATION_DIFF'
    for target, name in zip(angle.targets, (upper, lower)):
        target.id, target.bone_target = arm, name
    driver.expression = f"min(max(a / {float(np.radians(120.0))!r}, 0.0), 1.0)"
    assert driver.is_valid and driver.is_simple_expression  # runs without Python auto-execution

    def key_move(evaluate):
        """What the key adds to `evaluate()`'s positions on the outer forearm, and its value."""
        bpy.context.view_layer.update()
        value, keyed = key.value, evaluate()
        key.mute = True
        bpy.context.view_layer.update()
        plain = evaluate()
        key.mute = False
        bpy.context.view_layer.update()
        return (keyed - plain)[forearm], value

    helpers.set_rotation(arm.pose.bones[lower], (0.0, 0.0, 0.0))
    at_rest, value = key_move(lambda: helpers.evaluated_positions(obj)[0])
    assert value == 0.0 and not at_rest.any()  # straight: the corrective is off
    helpers.set_rotation(arm.pose.bones[lower], (np.radians(120.0), 0.0, 0.0))
    ours, value = key_move(lambda: helpers.evaluated_positions(obj)[0])
    theirs, _ = key_move(lambda: helpers.armature_modifier_positions(obj))
    assert abs(value - 1.0) < 1e-5
    err = np.linalg.norm(ours - theirs, axis=1)
    turn = np.degrees(np.arccos(np.clip(theirs @ z / np.linalg.norm(theirs, axis=1), -1.0, 1.0)))
    unturned = np.linalg.norm(0.01 * z - theirs, axis=1)
    print(f"\ncorrective key 1 cm, driven by the elbow, forearm at 120°: {len(forearm)} outer forearm vertices, "
          f"the move turned {np.median(turn):.0f}° (median) under the Armature modifier; Sweep Deform against it "
          f"median {np.median(err):.2e}, max {err.max():.2e} (unturned it would be {np.median(unturned):.2e} off)")
    assert np.median(turn) > 100  # the move did turn with the forearm
    assert err.max() < 0.05 * 0.01


def test_shape_keys_turned_in_the_core_match_the_node_group():
    """Shape keys alone are turned by the core (sd_deform_displaced; the carrier holds plain
    offsets), anything else by the node group from J in the carrier. Both give the same mesh:
    two keys at 0.7 and 0.4 (one relative to the other) moving the arms and legs, elbows and
    knees bent, against the same keys once a vertex group of weight 1 on one of them sends the
    character down the general path; then a key value changed with the pose held is followed
    at once; then a key moving every vertex."""
    char = helpers.load("fixture")
    obj = char.mesh
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.object.sweep_deform_add() == {'FINISHED'}
    md = helpers.sub("blender.modifier").find(obj)
    base = helpers.base_positions(obj)
    limbs = np.concatenate([_weighted(obj, n) for n in char.elbows + char.knees])
    rng = np.random.default_rng(16)
    obj.shape_key_add(name="Basis", from_mix=False)
    first = obj.shape_key_add(name="Swell", from_mix=False)
    swell = base.copy()
    swell[limbs] += rng.normal(0.0, 0.004, (len(limbs), 3)).astype(np.float32)
    first.data.foreach_set("co", swell.reshape(-1))
    second = obj.shape_key_add(name="Swell more", from_mix=False)
    more = swell.copy()
    more[limbs] += 0.01 * base[limbs] / np.linalg.norm(base[limbs], axis=1)[:, None]
    second.data.foreach_set("co", more.reshape(-1))
    second.relative_key = first
    first.value, second.value = 0.7, 0.4
    helpers.pose_limbs(char, elbow=1.5, knee=1.2)
    calls = core_calls()

    def evaluate():
        bpy.context.view_layer.update()
        carrier = helpers.sub("blender.modifier").get_carrier(md)
        return helpers.evaluated_positions(obj)[0], len(carrier.data.vertices)

    in_core, points = evaluate()
    assert core_calls() > calls and points == len(base)  # plain offsets: the core turned the keys
    everywhere = obj.vertex_groups.new(name="Everywhere")
    everywhere.add(range(len(base)), 1.0, 'REPLACE')
    first.vertex_group = everywhere.name
    by_nodes, points = evaluate()
    assert points == 5 * len(base)  # J in the carrier: the node group turned them
    diag = helpers.diagonal(base)
    err = np.linalg.norm(in_core - by_nodes, axis=1)
    keyed = np.linalg.norm(more - base, axis=1) > 0
    print(f"\ntwo keys (0.7, 0.4) on {keyed.sum()} limb vertices, elbows 1.5 and knees 1.2 rad: core against node "
          f"group max {err.max():.2e} (diagonal {diag:.3f})")
    assert err.max() <= 1e-5 * diag
    first.vertex_group = ""
    second.value = 0.9  # the pose held: the new value shows at once
    in_core, _ = evaluate()
    first.vertex_group = everywhere.name
    by_nodes, _ = evaluate()
    err = np.linalg.norm(in_core - by_nodes, axis=1)
    assert err.max() <= 1e-5 * diag
    # A key on every vertex (the add-on then works on whole arrays, not on the moved rows).
    first.vertex_group = ""
    whole = base + rng.normal(0.0, 0.003, base.shape).astype(np.float32)
    first.data.foreach_set("co", whole.reshape(-1))
    in_core, _ = evaluate()
    first.vertex_group = everywhere.name
    by_nodes, _ = evaluate()
    err = np.linalg.norm(in_core - by_nodes, axis=1)
    print(f"a key on all {len(base)} vertices: core against node group max {err.max():.2e}")
    assert err.max() <= 1e-5 * diag


def _evaluated_data(obj):
    """The evaluated mesh's UV map "UVMap", its face attribute "tag", its material indices, its
    materials and its positions."""
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    me = ev.to_mesh()
    try:
        uv = np.empty(2 * len(me.loops), np.float32)
        me.uv_layers["UVMap"].data.foreach_get("uv", uv)
        tag = np.empty(len(me.polygons), np.float32)
        me.attributes["tag"].data.foreach_get("value", tag)
        mi = np.empty(len(me.polygons), np.int32)
        me.polygons.foreach_get("material_index", mi)
        co = np.empty(3 * len(me.vertices), np.float32)
        me.vertices.foreach_get("co", co)
        return uv, tag, mi, [m.name if m else None for m in me.materials], co.reshape(-1, 3)
    finally:
        ev.to_mesh_clear()


def test_the_viewport_hands_on_a_copy_of_the_mesh_kept_up_to_date():
    """In the viewport, with nothing before Sweep Deform, Blender hands on the mesh carrier (a
    copy of the mesh holding the deformed positions) instead of sampling offsets: the result is
    the same to the bit, carries the mesh's UVs, attributes, materials and vertex groups (a
    modifier after Sweep Deform uses one), and follows edits of them; the copy has no shape
    keys and is made again only when the mesh changes, not on every frame."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    mesh, modifier = obj.data, helpers.sub("blender.modifier")
    rng = np.random.default_rng(3)
    uv = mesh.uv_layers.new(name="UVMap")
    uv.data.foreach_set("uv", rng.random(2 * len(mesh.loops)).astype(np.float32))
    tag = mesh.attributes.new("tag", 'FLOAT', 'FACE')
    tag.data.foreach_set("value", rng.random(len(mesh.polygons)).astype(np.float32))
    for name in ("Skin", "Cloth"):
        mesh.materials.append(bpy.data.materials.new(name))
    mesh.polygons.foreach_set("material_index", rng.integers(0, 2, len(mesh.polygons)).astype(np.int32))
    mesh.update()
    helpers.pose_limbs(char, elbow=1.2, knee=0.8)
    bpy.context.view_layer.update()
    co = check_equals_core(obj, "mesh carrier")
    c = modifier.mesh_carrier_in_use(obj, modifier.find(obj))
    assert c is not None and not c.users_collection and c.data.shape_keys is None
    got_uv, got_tag, got_mi, got_materials, _ = _evaluated_data(obj)
    want_uv = np.empty(2 * len(mesh.loops), np.float32)
    uv.data.foreach_get("uv", want_uv)
    want_tag = np.empty(len(mesh.polygons), np.float32)
    tag.data.foreach_get("value", want_tag)
    want_mi = np.empty(len(mesh.polygons), np.int32)
    mesh.polygons.foreach_get("material_index", want_mi)
    np.testing.assert_array_equal(got_uv, want_uv)
    np.testing.assert_array_equal(got_tag, want_tag)
    np.testing.assert_array_equal(got_mi, want_mi)
    assert got_materials == ["Skin", "Cloth"]

    # The same frame through the offsets carrier (a modifier before Sweep Deform that moves
    # nothing sends it there): the same positions to the bit.
    before = modifier_before(obj)
    bpy.context.view_layer.update()
    assert modifier.mesh_carrier_in_use(obj, modifier.find(obj)) is None
    np.testing.assert_array_equal(_evaluated_data(obj)[4], co)
    obj.modifiers.remove(before)
    bpy.context.view_layer.update()
    assert modifier.mesh_carrier_in_use(obj, modifier.find(obj)) is not None
    np.testing.assert_array_equal(_evaluated_data(obj)[4], co)

    # A vertex group used by a modifier after Sweep Deform: a Displace over the upper half.
    top = obj.vertex_groups.new(name="Top")
    base = helpers.base_positions(obj)
    upper = np.nonzero(base[:, 2] > np.median(base[:, 2]))[0]
    top.add(upper.tolist(), 1.0, 'REPLACE')
    after = obj.modifiers.new("Lift", 'DISPLACE')
    after.direction, after.strength, after.vertex_group = 'Z', 0.01, top.name
    bpy.context.view_layer.update()
    lifted = _evaluated_data(obj)[4] - co
    np.testing.assert_allclose(lifted[upper, 2], 0.005, atol=1e-6)
    assert np.abs(np.delete(lifted, upper, axis=0)).max() == 0.0
    obj.modifiers.remove(after)
    bpy.context.view_layer.update()  # (the stack changed: the mesh is copied again, once)

    # Edits of the mesh show at once (the copy is made again), a pose change does not copy.
    mesh_data = c.data
    helpers.pose_limbs(char, elbow=0.6, knee=1.1)
    bpy.context.view_layer.update()
    assert c.data == mesh_data, "a pose change copied the mesh again"
    new_uv = rng.random(2 * len(mesh.loops)).astype(np.float32)
    uv.data.foreach_set("uv", new_uv)
    mesh.materials[0] = bpy.data.materials.new("Leather")
    mesh.update()
    bpy.context.view_layer.update()
    got_uv, _, _, got_materials, _ = _evaluated_data(obj)
    np.testing.assert_array_equal(got_uv, new_uv)
    assert got_materials == ["Leather", "Cloth"]
    co = check_equals_core(obj, "after the edit")
    # Deleted by hand (the Outliner's Blender File view): made again at the next update.
    bpy.data.objects.remove(c)
    obj.update_tag()
    bpy.context.view_layer.update()
    assert modifier.mesh_carrier_in_use(obj, modifier.find(obj)) is not None
    np.testing.assert_array_equal(check_equals_core(obj, "carrier made again"), co)


def test_animated_shape_keys_do_not_copy_the_mesh_on_every_frame():
    """A shape key value animated over the frames re-evaluates the mesh on every frame; the
    mesh carrier is copied again only for edits of the mesh itself (handlers._meshes_changed
    sees the key's update beside the mesh's)."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    obj.shape_key_add(name="Basis")
    key = obj.shape_key_add(name="Swell")
    base = helpers.base_positions(obj)
    key.data.foreach_set("co", (base * 1.01).reshape(-1))
    for frame, value in ((1, 0.0), (20, 1.0)):
        key.value = value
        key.keyframe_insert("value", frame=frame)
    animate_elbows(char, [(1, 0.2), (20, 1.4)])
    handlers, modifier = helpers.sub("blender.handlers"), helpers.sub("blender.modifier")
    copies = []

    def after_frame(scene, depsgraph):  # what depsgraph_update_post does during GUI playback
        handlers._meshes_changed(depsgraph)
        c = modifier.mesh_carrier_in_use(obj, modifier.find(obj))
        copies.append(c.data.as_pointer() if c is not None else None)

    bpy.context.scene.frame_set(1)
    bpy.app.handlers.frame_change_post.append(after_frame)
    shown = []
    try:
        for f in range(2, 12):
            bpy.context.scene.frame_set(f)
            shown.append(helpers.evaluated_positions(obj)[0])
    finally:
        bpy.app.handlers.frame_change_post.remove(after_frame)
    assert copies[-1] is not None and len(set(copies[1:])) == 1, copies
    assert not np.allclose(shown[0], shown[-1])  # (the keys' turning: test_shape_key_rides_along...)


@pytest.mark.parametrize("shape_key", [False, True], ids=["plain", "shape key"])
def test_a_saved_file_keeps_the_offsets_not_a_copy_of_the_mesh(shape_key):
    """Saving empties the mesh carrier (the file keeps the offsets carrier, brought up to
    date; with a shape key, less the key's displacement, which Blender adds again): the file
    does not grow by a copy of the mesh, the viewport shows the same shape before and after
    the save, and the reopened file shows it too before any evaluation."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    if shape_key:
        base = helpers.base_positions(obj)
        obj.shape_key_add(name="Basis", from_mix=False)
        key = obj.shape_key_add(name="Swell", from_mix=False)
        key.data.foreach_set("co", (base * np.float32(1.03)).reshape(-1))
        key.value = 0.7
    helpers.pose_limbs(char, elbow=1.0, knee=0.7)
    bpy.context.view_layer.update()
    co = helpers.evaluated_positions(obj)[0] if shape_key else check_equals_core(obj, "before saving")
    modifier = helpers.sub("blender.modifier")
    c = modifier.mesh_carrier_in_use(obj, modifier.find(obj))
    assert c is not None
    carrier_mesh = c.data.name
    path = helpers.tmp_dir() + "/mesh_carrier.blend"
    bpy.ops.wm.save_as_mainfile(filepath=path)
    np.testing.assert_array_equal(helpers.evaluated_positions(obj)[0], co)
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(helpers.evaluated_positions(obj)[0], co)
    assert modifier.mesh_carrier_in_use(obj, modifier.find(obj)) is not None  # serving again
    name = obj.name
    bpy.ops.wm.open_mainfile(filepath=path)
    assert len(bpy.data.meshes[carrier_mesh].vertices) == 0, "the file holds a copy of the mesh"
    reopened = helpers.evaluated_positions(bpy.data.objects[name])[0]
    if shape_key:  # (float32 offsets less the key's move, plus Blender's own mix of it)
        np.testing.assert_allclose(reopened, co, rtol=0, atol=1e-6)
    else:
        np.testing.assert_array_equal(reopened, co)


def test_edit_mode_shows_the_offsets_carrier_brought_up_to_date():
    """In Edit Mode the modifier adds the offsets to the edited mesh (the mesh carrier would
    hide the edits): entering it empties the mesh carrier after giving the viewport's offsets
    carrier the deformation shown; leaving it, the mesh carrier serves again."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    modifier = helpers.sub("blender.modifier")
    helpers.pose_limbs(char, elbow=0.4, knee=1.2)  # (the offsets carrier last held the rest)
    bpy.context.view_layer.update()
    co = check_equals_core(obj, "object mode")
    assert modifier.mesh_carrier_in_use(obj, modifier.find(obj)) is not None
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.context.view_layer.update()
    assert modifier.mesh_carrier_in_use(obj, modifier.find(obj)) is None
    np.testing.assert_allclose(carrier_positions(obj, False), co - helpers.base_positions(obj), rtol=0, atol=1e-6)
    bpy.ops.object.mode_set(mode='OBJECT')
    bpy.context.view_layer.update()
    assert modifier.mesh_carrier_in_use(obj, modifier.find(obj)) is not None
    np.testing.assert_array_equal(check_equals_core(obj, "object mode again"), co)


def test_a_held_shape_key_is_mixed_once_and_again_when_edited():
    """Frames whose shape keys and values are those of the last mix reuse it (reading and mixing
    the keys took 0.5 ms a frame at 75K vertices); a key's shape edited by a script (with an
    update) or its value changed is mixed again, and the mesh is what the node group's general
    path gives for the same frame."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    base = helpers.base_positions(obj)
    obj.shape_key_add(name="Basis", from_mix=False)
    key = obj.shape_key_add(name="Swell", from_mix=False)
    limbs = np.nonzero(np.abs(base[:, 0]) > 0.2)[0]
    swollen = base.copy()
    swollen[limbs] *= np.float32(1.02)
    key.data.foreach_set("co", swollen.reshape(-1))
    key.value = 0.6
    native = helpers.sub("core.native")
    mix, mixes = native.mix_shape_keys, []

    def counted(*args):
        mixes.append(1)
        return mix(*args)

    native.mix_shape_keys = counted
    try:
        for elbow in (0.3, 0.6, 0.9):
            helpers.pose_limbs(char, elbow=elbow, knee=0.5)
            bpy.context.view_layer.update()
        assert len(mixes) == 1, mixes  # one mix for three poses
        first = helpers.evaluated_positions(obj)[0]
        swollen[limbs] *= np.float32(1.02)  # a script edits the key's shape, then updates the mesh
        key.data.foreach_set("co", swollen.reshape(-1))
        obj.data.update()
        bpy.context.view_layer.update()
        assert len(mixes) == 2
        edited = helpers.evaluated_positions(obj)[0]
        assert not np.allclose(first, edited)
        key.value = 0.8
        bpy.context.view_layer.update()
        assert len(mixes) == 3
        valued = helpers.evaluated_positions(obj)[0]
    finally:
        native.mix_shape_keys = mix
    # The same frame through the node group's general path (a modifier before Sweep Deform).
    modifier_before(obj)
    bpy.context.view_layer.update()
    general = helpers.evaluated_positions(obj)[0]
    assert np.abs(valued - general).max() <= 1e-5 * helpers.diagonal(base)
    # (the mesh carrier's copies drop their own shape keys, never the mesh's)
    assert [kb.name for kb in obj.data.shape_keys.key_blocks] == ["Basis", "Swell"]
