# SPDX-License-Identifier: GPL-3.0-or-later
"""Editing key ellipses (Sect. 4.2) in real Blender, through the operator the gizmos run
(object.sweep_deform_key_tweak): an edit at 150° changes the deformation only near the
edited key and only near that angle (the rest pose stays bit for bit); an edit at rest
shifts every pose; the mesh is what the core computes with the same corrections; mute,
delete, keyframes; save and reload keep the edits; and, in a GUI Blender under Xvfb, undo
and redo restore them exactly and the overlay and gizmos are drawn (screenshots)."""

import math
import os
import struct
import zlib

import bpy
import numpy as np
import pytest

import helpers


# ---- set-up ---------------------------------------------------------------------------------


def elbow_key(obj, bone="forearm.L"):
    """(sweep, key) of the joint key whose lower link is `bone`."""
    e = helpers.sub("blender.deformer_cache").entry(obj)
    for s in range(e.rig.sweep_count):
        keys = e.rig.keys(s)
        for k in range(len(keys["bones"])):
            if keys["joint_parents"][k] >= 0 and e.bone_names[keys["bones"][k]] == bone:
                return s, k
    raise AssertionError(f"no joint key on {bone}")


@pytest.fixture
def fixture_char():
    """The built-in character, bound by the product path (the core's fitting)."""
    char = helpers.load("fixture")
    helpers.bind(char)
    return char


def bend(char, degrees, bone="forearm.L"):
    helpers.rest_pose(char)
    if degrees:
        helpers.set_rotation(char.armature.pose.bones[bone], (math.radians(degrees), 0.0, 0.0))
    bpy.context.view_layer.update()
    return helpers.evaluated_positions(char.mesh)[0]


def tweak(mode, amount):
    """One edit as a gizmo makes it (the operator's EXEC path, which its modal drag shares)."""
    a = tuple(amount) if mode == 'MOVE' else (amount, 0.0, 0.0)
    assert bpy.ops.object.sweep_deform_key_tweak(mode=mode, amount=a) == {'FINISHED'}


def select(obj, sweep, key):
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.object.sweep_deform_select_key(sweep=sweep, key=key) == {'FINISHED'}


def edit_elbow_at(char, degrees):
    obj = char.mesh
    sweep, key = elbow_key(obj)
    select(obj, sweep, key)
    bend(char, degrees)
    tweak('SCALE_A', 1.35)
    tweak('ROTATE_X', 0.3)
    tweak('MOVE_Y', 0.02)
    return sweep, key


def core_with_corrections(obj):
    """The mesh as the core computes it from the stored rig and binding plus the object's
    correction properties, bypassing the add-on's deformer cache."""
    return helpers.core_result(obj, corrections=True)[0]


# ---- Blender-free math -------------------------------------------------------------------------


def test_key_edit_math_is_blender_free():
    key_edit = helpers.sub("core.key_edit")
    source = open(key_edit.__file__).read()
    assert "import bpy" not in source and "from bpy" not in source
    rng = np.random.default_rng(3)
    for _ in range(20):
        v = rng.normal(size=3)
        v *= rng.uniform(0.01, 3.0) / np.linalg.norm(v)
        np.testing.assert_allclose(key_edit.matrix_to_rotvec(key_edit.rotvec_to_matrix(v)), v, atol=1e-9)
    # A turn about the shown key's normal composes after the correction's own rotation.
    v = key_edit.turned(key_edit.as_values(rotation=(0.2, 0, 0)), 2, 0.4)
    np.testing.assert_allclose(key_edit.rotvec_to_matrix(v[3:6]),
                               key_edit.rotvec_to_matrix((0.2, 0, 0)) @ key_edit.axis_rotation(2, 0.4), atol=1e-12)
    # A world move becomes key axes through the uncorrected rotation.
    R0 = key_edit.rotvec_to_matrix((0, 0, math.pi / 2))
    np.testing.assert_allclose(key_edit.apply("MOVE", key_edit.IDENTITY, (0, 1, 0), R0)[:3], (1, 0, 0), atol=1e-12)
    clamped = key_edit.clamp_values(key_edit.as_values((3, 4, 0), (0, 0, 2.0), 20.0, 0.01), 1.0)
    assert abs(np.linalg.norm(clamped[:3]) - 1.0) < 1e-12 and abs(np.linalg.norm(clamped[3:6]) - math.pi / 2) < 1e-12
    assert tuple(clamped[6:8]) == (10.0, 0.1)
    # Drags: along an axis, about a center, a half-axis handle.
    assert key_edit.axis_drag((0, 0), (5, 0), (0, 0), (10, 0), 2.0) == 1.0
    assert abs(key_edit.dial_drag((0, 0), (10, 0), (0, 10)) - math.pi / 2) < 1e-12
    assert key_edit.scale_drag((20, 0), (30, 0), (0, 0), (20, 0)) == 1.5
    # Merge and rest snap.
    assert key_edit.find_correction([0.1, 2.6], 2.55, math.radians(5)) == 1
    assert key_edit.find_correction([0.1, 2.6], 2.0, math.radians(5)) is None
    assert key_edit.edit_angle(0.05, 0.03, math.radians(5)) == 0.03
    # Picking: the nearest projected loop within the radius.
    circle = lambda cx, cy, r: np.array([[cx + r * math.cos(t), cy + r * math.sin(t)]
                                         for t in np.linspace(0, 2 * math.pi, 32, endpoint=False)])
    loops = [circle(0, 0, 10), None, circle(100, 0, 10)]
    assert key_edit.nearest_loop((88, 0), loops, 30)[0] == 2
    assert key_edit.nearest_loop((50, 50), loops, 30)[0] is None


# ---- edits and the deformation --------------------------------------------------------------


def test_edit_at_150_changes_only_near_the_key_and_the_angle(fixture_char):
    char = fixture_char
    obj = char.mesh
    before = {deg: bend(char, deg) for deg in (0, 30, 90, 150)}
    sweep, key = edit_elbow_at(char, 150)
    s = obj.sweep_deform
    assert len(s.corrections) == 1  # the three edits went into one correction at this angle
    c = s.corrections[0]
    assert (c.sweep, c.key) == (sweep, key)
    assert abs(math.degrees(c.angle) - 150.0) < 0.5
    # 20 mm along the minor axis as shown (turned by 0.3 rad about the major axis).
    np.testing.assert_allclose(tuple(c.offset), (0.0, 0.02 * math.cos(0.3), 0.02 * math.sin(0.3)), atol=1e-6)
    assert abs(c.scale_a - 1.35) < 1e-6 and c.scale_b == 1.0
    after = {deg: bend(char, deg) for deg in (0, 30, 90, 150)}

    # The rest pose: bit for bit as before (the rest angle is pinned to no correction).
    np.testing.assert_array_equal(after[0], before[0])
    np.testing.assert_array_equal(after[0], helpers.base_positions(obj))
    # 150°: a clear change near the elbow, nothing far from it.
    moved = np.linalg.norm(after[150] - before[150], axis=1)
    elbow = np.array(char.armature.data.bones["forearm.L"].head_local)
    dist = np.linalg.norm(helpers.base_positions(obj) - elbow, axis=1)
    near = moved[dist < 0.15].max()
    print(f"150°: near the elbow {1000 * near:.1f} mm; farther than 0.3 m {1000 * moved[dist > 0.3].max():.4f} mm; "
          f"at 90° {1000 * np.linalg.norm(after[90] - before[90], axis=1).max():.1f} mm, "
          f"at 30° {1000 * np.linalg.norm(after[30] - before[30], axis=1).max():.1f} mm")
    assert near > 0.01
    assert moved[dist > 0.3].max() < 0.01 * near
    assert moved[dist > 0.4].max() == 0.0
    right = helpers.base_positions(obj)[:, 0] < -0.05  # the other side of the body
    assert moved[right].max() == 0.0
    # Near the edit's angle only: the interpolation from the rest angle (0) to 150°.
    at30 = np.linalg.norm(after[30] - before[30], axis=1).max()
    at90 = np.linalg.norm(after[90] - before[90], axis=1).max()
    assert at30 < 0.15 * near
    assert 0.2 * near < at90 < near
    # The add-on's mesh is the core's, with the same corrections.
    bend(char, 150)
    np.testing.assert_allclose(helpers.evaluated_positions(obj)[0], core_with_corrections(obj), atol=1e-6)


def test_edit_at_rest_shifts_every_pose(fixture_char):
    char = fixture_char
    obj = char.mesh
    before = {deg: bend(char, deg) for deg in (0, 150)}
    sweep, key = elbow_key(obj)
    select(obj, sweep, key)
    bend(char, 0)
    tweak('MOVE', (0.0, -0.02, 0.0))  # world space (= armature space here): forward
    c = obj.sweep_deform.corrections[0]
    _, _, rest_angle = helpers.sub("blender.deformer_cache").entry(obj).rig.key_joint(sweep, key)
    assert c.angle == pytest.approx(rest_angle, abs=1e-6)
    after = {deg: bend(char, deg) for deg in (0, 150)}
    for deg in (0, 150):
        d = np.linalg.norm(after[deg] - before[deg], axis=1).max()
        assert d > 0.01, (deg, d)
    # At rest the elbow's skin moved forward (−Y) with the key.
    elbow = np.array(char.armature.data.bones["forearm.L"].head_local)
    near = np.linalg.norm(helpers.base_positions(obj) - elbow, axis=1) < 0.05
    assert (after[0] - before[0])[near, 1].mean() < -0.005
    bend(char, 150)
    np.testing.assert_allclose(helpers.evaluated_positions(obj)[0], core_with_corrections(obj), atol=1e-6)


def test_mute_delete_and_the_panel(fixture_char):
    char = fixture_char
    obj = char.mesh
    plain = bend(char, 150)
    edit_elbow_at(char, 150)
    edited = bend(char, 150)
    assert not np.array_equal(edited, plain)
    s = obj.sweep_deform
    s.corrections[0].mute = True
    np.testing.assert_array_equal(bend(char, 150), plain)
    s.corrections[0].mute = False
    np.testing.assert_array_equal(bend(char, 150), edited)
    # A second key's correction, then delete the first: the second stays in effect.
    select(obj, *elbow_key(obj, "shin.L"))
    bend(char, 150)
    tweak('SCALE_B', 1.2)
    assert len(s.corrections) == 2
    assert bpy.ops.object.sweep_deform_correction_remove(index=0) == {'FINISHED'}
    assert len(s.corrections) == 1 and s.corrections[0].key == elbow_key(obj, "shin.L")[1]
    assert bpy.ops.object.sweep_deform_key_clear() == {'FINISHED'}
    assert len(s.corrections) == 0
    np.testing.assert_array_equal(bend(char, 150), plain)
    # The panels draw (headless: through their draw functions' data; no error is recorded).
    assert helpers.sub("blender.deformer_cache").peek(obj).correction_error == ""


def test_invalid_values_are_refused_and_reported(fixture_char):
    char = fixture_char
    obj = char.mesh
    edit_elbow_at(char, 150)
    edited = bend(char, 150)
    offset = tuple(obj.sweep_deform.corrections[0].offset)
    obj.sweep_deform.corrections[0].offset = (0.0, 5.0, 0.0)  # far beyond 10 × the half-axes
    np.testing.assert_array_equal(bend(char, 150), edited)  # the last valid corrections stay
    assert "offset" in helpers.sub("blender.deformer_cache").peek(obj).correction_error
    obj.sweep_deform.corrections[0].offset = offset
    np.testing.assert_array_equal(bend(char, 150), edited)
    assert helpers.sub("blender.deformer_cache").peek(obj).correction_error == ""


def test_keyframed_correction_animates(fixture_char):
    """The correction's values are ordinary properties: keyed at two frames, the deformation
    follows the animation (as F-curves evaluate it) during playback."""
    char = fixture_char
    obj = char.mesh
    scene = bpy.context.scene
    edit_elbow_at(char, 150)
    c = obj.sweep_deform.corrections[0]
    c.scale_a = 1.0
    c.keyframe_insert("scale_a", frame=10)
    c.scale_a = 1.6
    c.keyframe_insert("scale_a", frame=20)
    results = {}
    for f in (10, 20):
        scene.frame_set(f)
        helpers.set_rotation(char.armature.pose.bones["forearm.L"], (math.radians(150), 0, 0))
        bpy.context.view_layer.update()
        results[f] = helpers.evaluated_positions(obj)[0]
        assert abs(obj.sweep_deform.corrections[0].scale_a - (1.0 if f == 10 else 1.6)) < 1e-6
        np.testing.assert_allclose(results[f], core_with_corrections(obj), atol=1e-6)
    assert np.linalg.norm(results[20] - results[10], axis=1).max() > 0.005
    # With auto keying on, a gizmo edit keys the values it changed at the current frame.
    scene.tool_settings.use_keyframe_insert_auto = True
    scene.frame_set(30)
    helpers.set_rotation(char.armature.pose.bones["forearm.L"], (math.radians(150), 0, 0))
    bpy.context.view_layer.update()
    tweak('MOVE_X', 0.01)
    scene.tool_settings.use_keyframe_insert_auto = False
    keyed = {(fc.data_path, int(k.co[0])) for coll in helpers.sub("blender.fcurves").fcurve_collections(obj) for fc in coll
             for k in fc.keyframe_points}
    assert ("sweep_deform.corrections[0].offset", 30) in keyed, keyed
    # A driver works the same way.
    fc = c.driver_add("scale_b")
    fc.driver.expression = "1.5"
    scene.frame_set(20)
    bpy.context.view_layer.update()
    assert abs(obj.sweep_deform.corrections[0].scale_b - 1.5) < 1e-6
    np.testing.assert_allclose(helpers.evaluated_positions(obj)[0], core_with_corrections(obj), atol=1e-6)


def test_deleting_a_correction_keeps_the_others_keyframes(fixture_char):
    char = fixture_char
    obj = char.mesh
    edit_elbow_at(char, 150)
    select(obj, *elbow_key(obj, "shin.L"))
    tweak('SCALE_B', 1.2)
    s = obj.sweep_deform
    s.corrections[1].keyframe_insert("scale_b", frame=1)
    s.corrections[0].keyframe_insert("scale_a", frame=1)
    assert bpy.ops.object.sweep_deform_correction_remove(index=0) == {'FINISHED'}
    paths = sorted(fc.data_path for coll in helpers.sub("blender.fcurves").fcurve_collections(obj) for fc in coll)
    assert paths == ["sweep_deform.corrections[0].scale_b"], paths


def test_save_and_reload_keep_the_edits(fixture_char):
    char = fixture_char
    obj = char.mesh
    edit_elbow_at(char, 150)
    edited = bend(char, 150)
    values = [tuple(c.offset) + tuple(c.rotation) + (c.angle, c.scale_a, c.scale_b) for c in obj.sweep_deform.corrections]
    path = os.path.join(helpers.tmp_dir(), "key_edit_reload.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    # The saved rig blob carries the corrections too (format version 2 and on), for other tools.
    native, persistence = helpers.sub("core.native"), helpers.sub("blender.persistence")
    blob = bytes(obj[persistence.RIG_KEY])
    assert struct.unpack("<I", blob[4:8])[0] == 4
    assert native.Rig.deserialize(blob).corrections()["sweeps"].size == 1

    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects[char.mesh_name]
    assert helpers.sub("blender.deformer_cache").peek(obj) is None
    assert [tuple(c.offset) + tuple(c.rotation) + (c.angle, c.scale_a, c.scale_b)
            for c in obj.sweep_deform.corrections] == values
    char = helpers.Character("fixture", "Body", "Armature", [], [], [])
    np.testing.assert_array_equal(bend(char, 150), edited)
    np.testing.assert_array_equal(bend(char, 0), helpers.base_positions(obj))


def test_overlay_and_gizmo_geometry_follow_the_edit(fixture_char):
    """What the overlay draws and where the gizmos sit (headless: the geometry, not the pixels)."""
    char = fixture_char
    obj = char.mesh
    overlay, key_ellipses = helpers.sub("ui.overlay"), helpers.sub("blender.key_ellipses")
    assert bpy.ops.object.sweep_deform_edit_keys(action='ENABLE') == {'FINISHED'}
    s = obj.sweep_deform
    assert s.edit_keys and (s.active_sweep, s.active_key) != (-1, -1)  # an interior joint key is selected
    sweep, key = elbow_key(obj)
    select(obj, sweep, key)
    bend(char, 150)
    geometry = overlay.geometry(obj)
    assert set(geometry) == {"sweeps", "keys", "selected"}  # nothing moved: no grey placed key
    st = key_ellipses.key_state(obj, sweep, key)
    tweak('MOVE_Z', 0.03)
    geometry = overlay.geometry(obj)
    assert "placed" in geometry
    st2 = key_ellipses.key_state(obj, sweep, key)
    np.testing.assert_allclose(st2["shown_center"] - st["shown_center"], st["shown_rotation"][:, 2] * 0.03,
                               atol=1e-5)
    # Along the axis as shown, also when the key is turned.
    tweak('ROTATE_Y', 0.4)
    st3 = key_ellipses.key_state(obj, sweep, key)
    tweak('MOVE_Z', 0.02)
    st4 = key_ellipses.key_state(obj, sweep, key)
    np.testing.assert_allclose(st4["shown_center"] - st3["shown_center"], st3["shown_rotation"][:, 2] * 0.02,
                               atol=1e-5)
    # The selected key drawn where the core places it.
    loops = dict(((sw, k), pts) for sw, k, pts in overlay.key_loops(obj))
    np.testing.assert_allclose(loops[(sweep, key)].mean(axis=0), st4["shown_center"], atol=1e-5)


def test_deformer_is_updated_not_recreated(fixture_char):
    """Edits reach the live deformer through sd_deformer_set_rig_corrections: the deformer
    (and its rest shape) stays the same object while dragging."""
    char = fixture_char
    obj = char.mesh
    cache = helpers.sub("blender.deformer_cache")
    bend(char, 150)
    e = cache.peek(obj)
    deformer = e.deformer
    edit_elbow_at(char, 150)
    bend(char, 150)
    assert cache.peek(obj) is e and e.deformer is deformer


# ---- undo, the overlay on screen (GUI Blender under Xvfb) --------------------------------------


def read_png(path):
    """(height, width, 3) uint8 of an RGB PNG written by scripts/xgrab.py (filter 0 rows)."""
    data = open(path, "rb").read()
    i, idat, w, h = 8, b"", 0, 0
    while i < len(data):
        n = struct.unpack(">I", data[i:i + 4])[0]
        kind, chunk = data[i + 4:i + 8], data[i + 8:i + 8 + n]
        i += 12 + n
        if kind == b"IHDR":
            w, h = struct.unpack(">II", chunk[:8])
        elif kind == b"IDAT":
            idat += chunk
    rows = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, 1 + 3 * w)
    assert not rows[:, 0].any(), "unexpected PNG row filter"
    return rows[:, 1:].reshape(h, w, 3)


def overlay_hits(image, points, radius=3):
    """Share of the projected ellipse points with a pixel of the overlay's key colour (cyan)
    within `radius` pixels. Points are window pixels from the bottom-left."""
    h, w, _ = image.shape
    cyan = (image[:, :, 0] < 90) & (image[:, :, 1] > 170) & (image[:, :, 2] > 170)
    hits = 0
    for x, y in points:
        col, row = int(round(x)), int(round(h - 1 - y))
        r0, r1, c0, c1 = max(0, row - radius), min(h, row + radius + 1), max(0, col - radius), min(w, col + radius + 1)
        hits += bool(cyan[r0:r1, c0:c1].any())
    return hits / max(1, len(points)), float(cyan.mean())


def test_undo_and_the_overlay_in_the_interface():
    """A Blender with its interface (Xvfb, 1280×720): bind, Edit Key Ellipses on, the left
    elbow key selected; at rest and at the elbow_bend marker (150°) the screen shows the
    overlay (its cyan where the key ellipses project) and the gizmos; three gizmo edits at
    150° make three undo steps, undone exactly and redone exactly; a simulated mouse drag on a
    gizmo edits the key (one undo step); a click selects another key. The two screenshots go
    to the test's scratch folder; with SWEEPDEFORM_WRITE_DOC_IMAGES=1 (Blender 5.2) they
    replace docs/images/edit_*.png (the user guide's, docs/editing.md), so a test run never
    changes the source tree unasked."""
    helpers.require("fixture")
    if bpy.app.version[:2] >= (5, 2) and os.environ.get("SWEEPDEFORM_WRITE_DOC_IMAGES") == "1":
        out_dir = os.path.join(helpers.REPO, "docs", "images")
    else:
        out_dir = os.path.join(helpers.tmp_dir(), f"shots_{bpy.app.version[0]}{bpy.app.version[1]}")
    os.makedirs(out_dir, exist_ok=True)
    blend = os.path.join(helpers.FIXTURES, "character_light.blend")
    out, log = helpers.run_gui_blender(blend, os.path.join(helpers.HERE, "gui_key_edit.py"), [out_dir],
                                       screen=(1280, 720), options=("-p", "0", "0", "1280", "720"))
    assert out["bind"] == ["FINISHED"] and out["edit_keys"] == ["FINISHED"] and out["select"] == ["FINISHED"]
    assert out["tool"] == "sweep_deform.edit_key_ellipses"
    assert out["gizmos_poll"]
    assert out["rest_positions_equal_mesh"]
    assert out["tweaks"] == [["FINISHED"]] * 3
    n, sweep, key, angle, offset, rotation, scale_a, scale_b = out["correction"]
    assert n == 1 and abs(math.degrees(angle) - 150.0) < 0.5 and abs(scale_a - 1.35) < 1e-6
    assert out["edit_moved"] > 0.005
    assert out["undone"] == [0, True, 0.0]
    assert out["redone"] == [1, True, 0.0]
    # A real drag on a gizmo (simulated mouse: hover the key's center, press, drag 40 px,
    # release) ran the tweak operator modally: the correction and the mesh changed, one undo
    # step takes it back exactly.
    assert out["drag_offset_after"] != out["drag_offset_before"]
    assert out["drag_moved"] > 1e-3
    assert out["drag_undone"]
    # A click on a drawn key ellipse selects it (the tool's keymap).
    assert out["clicked"] == out["click_target"]
    for name in ("edit_rest.png", "edit_elbow.png"):
        g = out["grabs"][name]
        assert g["ok"], g["log"]
        assert g["window"] == [1280, 720]
        image = read_png(g["path"])
        share, cyan_share = overlay_hits(image, g["points"])
        print(f"{name}: {len(g['points'])} projected key points, {100 * share:.0f} % on the overlay's colour; "
              f"{100 * cyan_share:.1f} % of the screen is that colour")
        assert len(g["points"]) > 200
        assert share > 0.7, share
        assert cyan_share < 0.1
    assert "Traceback" not in log and "Sweep Deform overlay" not in log, log[-3000:]
