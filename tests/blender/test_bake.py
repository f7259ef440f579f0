# SPDX-License-Identifier: GPL-3.0-or-later
"""Baking (bake.py, cache_files.py): the light fixture character bound and baked over a few
frames of demo_motion to shape keys, PC2, MDD (and Alembic where Blender has it); the result,
played back by objects *without* the Sweep Deform modifier (the baked copy's shape keys,
Blender's Mesh Cache modifier on a copy of the rest mesh, an Alembic import), equals the
modifier's output frame by frame. Cancel leaves nothing behind; bad input changes nothing."""

import os
import shutil
import subprocess

import bpy
import numpy as np
import pytest

import helpers

cache_files = helpers.sub("core.cache_files")
FRAMES = list(range(72, 77))       # demo_motion going into arms_up (marker at 76)
STEPPED = list(range(124, 133, 2))  # from knee_bend towards elbow_bend, every second frame


def bound_fixture(subdivision=False):
    """The light fixture character, bound with the test rig; optionally with a Subdivision
    Surface after Sweep Deform (it changes the vertex count, so the bake must cut before it)."""
    char = helpers.load("fixture")
    helpers.use_test_rig([char])
    obj = helpers.bind(char)
    if subdivision:
        md = obj.modifiers.new("Subdivision", 'SUBSURF')
        md.levels = 1
    return obj


def modifier_output(obj, frames):
    """The Sweep Deform modifier's evaluated output (object space) at each frame, with the
    modifiers after it switched off by the test itself."""
    sweep = helpers.sub("blender.modifier").find(obj)
    later = list(obj.modifiers)[list(obj.modifiers).index(sweep) + 1:]
    saved = [md.show_viewport for md in later]
    out = {}
    try:
        for md in later:
            md.show_viewport = False
        for f in frames:
            bpy.context.scene.frame_set(f)
            out[f] = helpers.evaluated_positions(obj)[0]
    finally:
        for md, shown in zip(later, saved):
            md.show_viewport = shown
    frames = sorted(frames)
    moves = [float(np.abs(out[a] - out[b]).max()) for a, b in zip(frames, frames[1:])]
    assert min(moves) > 1e-3 * helpers.diagonal(out[frames[0]]), f"the motion does not move the mesh: {moves}"
    return out


def stack_state(obj):
    return [(md.name, md.type, md.show_viewport, md.show_render) for md in obj.modifiers]


def mesh_cache_reader(obj, path, fmt, frames):
    """A new object on a copy of the rest mesh whose only modifier is Blender's Mesh Cache
    reading `path`: frame_start and frame_scale map scene frame f to sample (f - first) / step."""
    step = frames[1] - frames[0] if len(frames) > 1 else 1
    reader = bpy.data.objects.new(f"{fmt} reader", obj.data.copy())
    bpy.context.scene.collection.objects.link(reader)
    md = reader.modifiers.new("Mesh Cache", 'MESH_CACHE')
    md.cache_format, md.filepath = fmt, path
    md.frame_start, md.frame_scale = frames[0] / step, 1.0 / step
    return reader


def bake(target, frames, path="", **kw):
    return bpy.ops.object.sweep_deform_bake(target=target, filepath=path, frame_start=frames[0],
                                            frame_end=frames[-1], frame_step=max(1, frames[1] - frames[0]), **kw)


def out_path(name):
    path = os.path.join(helpers.tmp_dir(), name)
    for p in (path, path + cache_files.PARTIAL_SUFFIX):
        if os.path.exists(p):
            os.remove(p)
    return path


# ---- the file formats (numpy only) -------------------------------------------------------------


def test_pc2_and_mdd_layout_byte_by_byte():
    rng = np.random.default_rng(3)
    frames = rng.normal(size=(3, 4, 3)).astype(np.float32)
    pc2, mdd = out_path("layout.pc2"), out_path("layout.mdd")
    w = cache_files.PC2Writer(pc2, 4, 3, start=7, sampling=2)
    for f in frames:
        w.write(f)
    w.close()
    data = open(pc2, "rb").read()
    assert data[:12] == b"POINTCACHE2\0"
    assert np.frombuffer(data[12:20], "<i4").tolist() == [1, 4]
    assert np.frombuffer(data[20:28], "<f4").tolist() == [7.0, 2.0]
    assert np.frombuffer(data[28:32], "<i4").tolist() == [3]
    assert len(data) == 32 + 3 * 4 * 12
    np.testing.assert_array_equal(np.frombuffer(data[32:], "<f4").reshape(3, 4, 3), frames)
    assert cache_files.read_pc2(pc2)[:2] == (7.0, 2.0)

    w = cache_files.MDDWriter(mdd, 4, [0.0, 0.5, 1.0])
    for f in frames:
        w.write(f)
    w.close()
    data = open(mdd, "rb").read()
    assert np.frombuffer(data[:8], ">i4").tolist() == [3, 4]
    assert np.frombuffer(data[8:20], ">f4").tolist() == [0.0, 0.5, 1.0]
    assert len(data) == 20 + 3 * 4 * 12
    np.testing.assert_array_equal(np.frombuffer(data[20:], ">f4").reshape(3, 4, 3), frames)
    times, positions = cache_files.read_mdd(mdd)
    np.testing.assert_array_equal(positions, frames)


def test_cache_writer_abort_keeps_the_older_file_and_refuses_bad_frames():
    path = out_path("abort.pc2")
    with open(path, "wb") as f:
        f.write(b"older")
    w = cache_files.PC2Writer(path, 2, 2, start=1)
    w.write(np.zeros((2, 3)))
    with pytest.raises(ValueError):
        w.write(np.zeros((3, 3)))  # another vertex count
    with pytest.raises(ValueError):
        w.close()                  # one frame missing
    assert os.path.exists(path + cache_files.PARTIAL_SUFFIX)
    w.abort()
    assert not os.path.exists(path + cache_files.PARTIAL_SUFFIX)
    assert open(path, "rb").read() == b"older"


# ---- baking, then playing back without Sweep Deform ---------------------------------------------


def test_bake_pc2_read_by_mesh_cache_equals_the_modifier():
    obj = bound_fixture(subdivision=True)
    scene = bpy.context.scene
    scene.frame_set(3)
    before = stack_state(obj)
    expected = modifier_output(obj, FRAMES)
    scene.frame_set(3)
    path = out_path("fixture.pc2")
    assert bake('PC2', FRAMES, path) == {'FINISHED'}
    # Everything the bake switched is back: frame, toggles (Subdivision on again), binding.
    assert scene.frame_current == 3
    assert stack_state(obj) == before and obj.sweep_deform.state == 'BOUND'
    assert not os.path.exists(path + cache_files.PARTIAL_SUFFIX)
    start, sampling, positions = cache_files.read_pc2(path)
    assert (start, sampling, positions.shape) == (FRAMES[0], 1.0, (len(FRAMES), len(obj.data.vertices), 3))

    reader = mesh_cache_reader(obj, path, 'PC2', FRAMES)
    for f in FRAMES:
        scene.frame_set(f)
        # float32 exact: the file holds the modifier's floats, the Mesh Cache modifier copies them
        np.testing.assert_array_equal(helpers.evaluated_positions(reader)[0], expected[f], err_msg=f"frame {f}")


def test_bake_mdd_with_a_frame_step_read_by_mesh_cache_equals_the_modifier():
    obj = bound_fixture()
    scene = bpy.context.scene
    expected = modifier_output(obj, STEPPED + [STEPPED[0] + 1])
    path = out_path("fixture.mdd")
    assert bake('MDD', STEPPED, path) == {'FINISHED'}
    times, positions = cache_files.read_mdd(path)
    fps = scene.render.fps / scene.render.fps_base
    np.testing.assert_allclose(times, [(f - STEPPED[0]) / fps for f in STEPPED], rtol=1e-6)
    assert positions.shape == (len(STEPPED), len(obj.data.vertices), 3)

    reader = mesh_cache_reader(obj, path, 'MDD', STEPPED)
    for f in STEPPED:
        scene.frame_set(f)
        np.testing.assert_array_equal(helpers.evaluated_positions(reader)[0], expected[f], err_msg=f"frame {f}")
    # Between two baked frames the Mesh Cache modifier interpolates: near the skipped frame.
    scene.frame_set(STEPPED[0] + 1)
    between = helpers.evaluated_positions(reader)[0]
    np.testing.assert_allclose(between, (expected[STEPPED[0]] + expected[STEPPED[1]]) / 2, rtol=0, atol=1e-6)
    assert np.abs(between - expected[STEPPED[0] + 1]).max() < 0.01 * helpers.diagonal(between)


def test_bake_shape_keys_on_a_copy_equals_the_modifier():
    obj = bound_fixture(subdivision=True)
    scene = bpy.context.scene
    objects_before = set(bpy.data.objects.keys())
    before = stack_state(obj)
    expected = modifier_output(obj, FRAMES)
    full = {}
    for f in FRAMES:
        scene.frame_set(f)
        full[f] = helpers.evaluated_positions(obj)[0]  # Sweep Deform and Subdivision
    scene.frame_set(1)
    assert bake('SHAPE_KEYS', FRAMES) == {'FINISHED'}
    assert scene.frame_current == 1
    assert stack_state(obj) == before and obj.sweep_deform.state == 'BOUND'

    new = set(bpy.data.objects.keys()) - objects_before
    assert new == {"Body_baked"}
    baked = bpy.data.objects["Body_baked"]
    # No binding, no Sweep Deform, no Armature modifier: only what came after Sweep Deform.
    assert [md.type for md in baked.modifiers] == ['SUBSURF']
    assert baked.sweep_deform.state == 'UNBOUND' and baked.data is not obj.data
    assert helpers.sub("core.arrays").OFFSET_ATTRIBUTE not in baked.data.attributes
    assert [kb.name for kb in baked.data.shape_keys.key_blocks] == ["Basis"] + [f"frame_{f:04d}" for f in FRAMES]
    np.testing.assert_array_equal(helpers.base_positions(baked), helpers.base_positions(obj))

    for f in FRAMES:
        scene.frame_set(f)
        # The whole stack (keys, then Subdivision) renders as the original does ...
        np.testing.assert_array_equal(helpers.evaluated_positions(baked)[0], full[f], err_msg=f"frame {f}")
        # ... and the keys alone are the Sweep Deform output (float32 exact).
        baked.modifiers["Subdivision"].show_viewport = False
        bpy.context.view_layer.update()
        np.testing.assert_array_equal(helpers.evaluated_positions(baked)[0], expected[f], err_msg=f"frame {f}")
        baked.modifiers["Subdivision"].show_viewport = True
    baked.modifiers["Subdivision"].show_viewport = False
    # Between two baked frames the keys blend linearly (a Bezier ease would give 0.84 / 0.16).
    scene.frame_set(FRAMES[0], subframe=0.25)
    np.testing.assert_allclose(helpers.evaluated_positions(baked)[0],
                               0.75 * expected[FRAMES[0]] + 0.25 * expected[FRAMES[1]], rtol=0, atol=1e-6)
    # Before the first and after the last baked frame the copy holds the end poses.
    for f, ref in ((FRAMES[0] - 5, FRAMES[0]), (FRAMES[-1] + 5, FRAMES[-1])):
        scene.frame_set(f)
        np.testing.assert_array_equal(helpers.evaluated_positions(baked)[0], expected[ref])


def test_a_baked_scene_plays_back_in_blender_without_the_extension():
    """Shape keys and a PC2 cache saved in a .blend, opened by a Blender that does not load
    the extension: the same positions as the modifier's."""
    obj = bound_fixture()
    expected = modifier_output(obj, FRAMES)
    path = out_path("noext.pc2")
    assert bake('SHAPE_KEYS', FRAMES) == {'FINISHED'}
    assert bake('PC2', FRAMES, path) == {'FINISHED'}
    mesh_cache_reader(obj, path, 'PC2', FRAMES)
    blend = os.path.join(helpers.tmp_dir(), "baked_noext.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    dump = os.path.join(helpers.tmp_dir(), "baked_noext.npz")
    expr = ("import bpy, sys, numpy as np\n"
            "assert not any('sweep_deform' in m for m in sys.modules), 'the extension is loaded'\n"
            "out = {}\n"
            f"for f in {FRAMES!r}:\n"
            "    bpy.context.scene.frame_set(f)\n"
            "    dg = bpy.context.evaluated_depsgraph_get()\n"
            "    for name in ('Body_baked', 'PC2 reader'):\n"
            "        me = bpy.data.objects[name].evaluated_get(dg).to_mesh()\n"
            "        co = np.empty(len(me.vertices) * 3, np.float32); me.vertices.foreach_get('co', co)\n"
            "        out[f'{name}_{f}'] = co.reshape(-1, 3)\n"
            f"np.savez({dump!r}, **out)\n")
    proc = subprocess.run([bpy.app.binary_path, "-b", "--factory-startup", blend, "--python-exit-code", "1",
                           "--python-expr", expr], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    got = np.load(dump)
    for f in FRAMES:
        np.testing.assert_array_equal(got[f"Body_baked_{f}"], expected[f], err_msg=f"shape keys, frame {f}")
        np.testing.assert_array_equal(got[f"PC2 reader_{f}"], expected[f], err_msg=f"PC2, frame {f}")


def test_batch_bake_from_the_command_line():
    """The docs' example: `blender -b file.blend --python-expr ...` bakes a PC2 with the
    installed extension, progress printed."""
    obj = bound_fixture()
    expected = modifier_output(obj, FRAMES)
    blend = os.path.join(helpers.tmp_dir(), "batch_bake.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    path = out_path("batch.pc2")
    expr = ("import bpy; bpy.context.view_layer.objects.active = bpy.data.objects['Body']; "
            f"bpy.ops.object.sweep_deform_bake(target='PC2', filepath={path!r}, "
            f"frame_start={FRAMES[0]}, frame_end={FRAMES[-1]})")
    proc = subprocess.run([bpy.app.binary_path, "-b", blend, "--python-exit-code", "1", "--python-expr", expr],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert f"Sweep Deform bake: frame {FRAMES[-1]} ({len(FRAMES)}/{len(FRAMES)})" in proc.stdout
    start, _, positions = cache_files.read_pc2(path)
    assert start == FRAMES[0]
    for i, f in enumerate(FRAMES):
        np.testing.assert_array_equal(positions[i], expected[f], err_msg=f"frame {f}")


def test_alembic_round_trip():
    if not bpy.app.alembic.supported:
        pytest.skip(f"Blender {bpy.app.version_string} is built without Alembic (bpy.app.alembic.supported "
                    "is False; Debian's packages are)")
    obj = bound_fixture()
    expected = modifier_output(obj, FRAMES)
    path = out_path("fixture.abc")
    assert bake('ALEMBIC', FRAMES, path) == {'FINISHED'}
    names = set(bpy.data.objects.keys())
    assert bpy.ops.wm.alembic_import(filepath=path) == {'FINISHED'}
    imported = [bpy.data.objects[n] for n in set(bpy.data.objects.keys()) - names
                if bpy.data.objects[n].type == 'MESH']
    assert len(imported) == 1
    for f in FRAMES:
        bpy.context.scene.frame_set(f)
        got = helpers.evaluated_positions(imported[0])[0]
        # Alembic stores float32 positions; its importer's axis conversion and transforms are
        # float arithmetic, hence the tolerance.
        np.testing.assert_allclose(got, expected[f], rtol=0, atol=1e-6 * helpers.diagonal(got), err_msg=f"frame {f}")


def test_alembic_without_alembic_support_is_refused_clearly():
    if bpy.app.alembic.supported:
        pytest.skip("this Blender has Alembic")
    obj = bound_fixture()
    path = out_path("refused.abc")
    with pytest.raises(RuntimeError, match="built without Alembic"):
        bake('ALEMBIC', FRAMES, path)
    assert not os.path.exists(path) and not os.path.exists(path + ".partial.abc")
    assert obj.sweep_deform.state == 'BOUND'


# ---- cancel and errors --------------------------------------------------------------------------


@pytest.mark.parametrize("target", ["SHAPE_KEYS", "PC2", "MDD"])
def test_cancel_leaves_no_partial_output(target):
    """The modal operator's Esc calls Bake.cancel(): after some frames, nothing stays behind;
    an older file of that name is kept as it was."""
    obj = bound_fixture(subdivision=True)
    scene = bpy.context.scene
    scene.frame_set(5)
    before = stack_state(obj)
    objects, meshes = set(bpy.data.objects.keys()), set(bpy.data.meshes.keys())
    path = out_path("cancelled" + helpers.sub("blender.bake").EXTENSIONS.get(target, ""))
    if target != 'SHAPE_KEYS':
        with open(path, "wb") as f:
            f.write(b"older")
    b = helpers.sub("blender.bake").Bake(bpy.context, obj, target, FRAMES, path)
    assert not b.step() and not b.step()
    partial = bpy.data.objects.get("Body_baked") if target == 'SHAPE_KEYS' \
        else os.path.exists(path + cache_files.PARTIAL_SUFFIX)
    assert partial  # there was something to clean up
    b.cancel()
    assert set(bpy.data.objects.keys()) == objects and set(bpy.data.meshes.keys()) == meshes
    assert not os.path.exists(path + cache_files.PARTIAL_SUFFIX)
    if target != 'SHAPE_KEYS':
        assert open(path, "rb").read() == b"older"
    assert scene.frame_current == 5 and stack_state(obj) == before


def test_relative_path_in_an_unsaved_file_is_refused():
    bpy.ops.mesh.primitive_cube_add()
    with pytest.raises(RuntimeError, match="save it first"):
        bpy.ops.object.sweep_deform_bake(target='PC2', filepath="//relative.pc2")


def user_objects():
    """The objects of the file but the add-on's hidden carriers (unbinding deletes them)."""
    modifier = helpers.sub("blender.modifier")
    prefixes = tuple(modifier.CARRIER_PREFIX.values()) + (modifier.MESH_CARRIER_PREFIX,)
    return {k for k in bpy.data.objects.keys() if not k.startswith(prefixes)}


def test_errors_change_nothing():
    obj = bound_fixture()
    scene = bpy.context.scene
    scene.frame_set(4)
    objects = user_objects()
    path = out_path("error.pc2")

    def refused(match, **kw):
        with pytest.raises(RuntimeError, match=match):
            bpy.ops.object.sweep_deform_bake(**kw)
        assert user_objects() == objects and not os.path.exists(path)
        assert scene.frame_current == 4

    refused("last frame .* before the first", target='PC2', filepath=path, frame_start=10, frame_end=5)
    refused("does not exist", target='PC2', filepath=os.path.join(path, "no_folder", "x.pc2"))
    obj.hide_viewport = True  # not evaluated: its evaluated mesh would be the rest mesh
    refused("not evaluated in the viewport", target='PC2', filepath=path)
    refused("not evaluated in the viewport", target='SHAPE_KEYS')
    obj.hide_viewport = False
    bpy.ops.object.sweep_deform_unbind()
    refused("not bound", target='SHAPE_KEYS')
    refused("not bound", target='PC2', filepath=path)
    helpers.bind(helpers.Character("fixture", "Body", "Armature", [], [], []))
    obj.sweep_deform.state = 'REBIND'
    obj.sweep_deform.message = "The mesh's topology changed after binding: bind again"
    refused("needs to be bound again: The mesh's topology", target='SHAPE_KEYS')


# ---- the interface: modal, progress, Esc -------------------------------------------------------

def test_modal_bake_in_the_interface_and_esc():
    """A Blender with its interface under Xvfb (gui_bake.py): a bake invoked from the interface
    runs modal and writes its file; Esc during an MDD and during a shape-key bake leaves no
    partial file, no object, the frame and the stack as they were."""
    helpers.require("fixture")
    out_dir = os.path.join(helpers.tmp_dir(), "gui_bake")
    shutil.rmtree(out_dir, ignore_errors=True)
    os.makedirs(out_dir)
    out, log = helpers.run_gui_blender(helpers._fixture_path(), os.path.join(helpers.HERE, "gui_bake.py"), [out_dir])
    assert out["bind"] == ["FINISHED"]
    assert out["invoke_pc2"] == ["RUNNING_MODAL"]
    assert out["pc2_samples"] == 6 and out["frame_after"] == 3
    assert out["invoke_long"] == ["RUNNING_MODAL"] and out["partial_seen"]
    assert out["mdd_left"] == [] and out["frame_after_cancel"] == 3
    assert out["keys_modal"] == ["RUNNING_MODAL"]
    assert "Body_baked" not in out["objects"] and not any("_baked" in m for m in out["meshes"])
    assert out["stack"] == [["NODES", True], ["ARMATURE", False]] and out["frame_at_end"] == 3
    assert "Traceback" not in log, log[-3000:]
