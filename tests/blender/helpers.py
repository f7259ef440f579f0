# SPDX-License-Identifier: GPL-3.0-or-later
"""Characters, poses and measurements shared by the Blender tests."""

import json
import os
import shutil
import subprocess

import bpy
import numpy as np
import pytest

import bone_rig

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
SHARED = os.path.normpath(os.path.join(REPO, "..", "shared", "data", "humans"))
FIXTURES = os.path.join(REPO, "blend_fixtures")
MODULE = "bl_ext.user_default.sweep_deform"


def addon():
    import importlib
    return importlib.import_module(MODULE)


def sub(name):
    import importlib
    return importlib.import_module(f"{MODULE}.{name}")


def tmp_dir():
    d = os.environ.get("SWEEPDEFORM_TEST_TMP") or os.path.join(bpy.app.tempdir or "/tmp", "sweepdeform-tests")
    os.makedirs(d, exist_ok=True)
    return d


# ---- characters -----------------------------------------------------------------------------


class Character:
    """A loaded character: mesh object name, armature name, elbow/knee bones, test chains."""

    def __init__(self, key, mesh, armature, elbows, knees, chains, shoulders=()):
        self.key, self.mesh_name, self.armature_name = key, mesh, armature
        self.elbows, self.knees, self.chains, self.shoulders = elbows, knees, chains, shoulders

    @property
    def mesh(self):
        return bpy.data.objects[self.mesh_name]

    @property
    def armature(self):
        return bpy.data.objects[self.armature_name]


CESIUM_CHAINS = [
    ("", ["Skeleton_torso_joint_1", "Skeleton_torso_joint_2"], "torso_joint_3"),
    ("torso_joint_3", ["Skeleton_arm_joint_L__4_", "Skeleton_arm_joint_L__3_"], "Skeleton_arm_joint_L__2_"),
    ("torso_joint_3", ["Skeleton_arm_joint_R", "Skeleton_arm_joint_R__2_"], "Skeleton_arm_joint_R__3_"),
    ("Skeleton_torso_joint_1", ["leg_joint_L_1", "leg_joint_L_2"], "leg_joint_L_3"),
    ("Skeleton_torso_joint_1", ["leg_joint_R_1", "leg_joint_R_2"], "leg_joint_R_3"),
]


def _fixture_path(full=False):
    """The built-in character: the light mesh (4.7K vertices) unless `full` (75K vertices)."""
    for name in (("character.blend",) if full else ("character_light.blend", "character.blend")):
        p = os.path.join(FIXTURES, name)
        if os.path.isfile(p):
            return p
    return None


CHARACTERS = ["fixture", "makehuman", "cesium"]


def available(key):
    if key in ("fixture", "fixture_full"):
        return _fixture_path(key == "fixture_full") is not None
    if key == "makehuman":
        return os.path.isfile(os.path.join(SHARED, "mh_male_game_engine.blend"))
    if key == "cesium":
        return os.path.isfile(os.path.join(SHARED, "CesiumMan.glb"))
    raise KeyError(key)


def require(key):
    if not available(key):
        where = {"fixture": FIXTURES + "/character*.blend", "fixture_full": FIXTURES + "/character.blend"}.get(key, SHARED)
        pytest.skip(f"character '{key}' not available ({where} missing)")


def load(key):
    """Opens the character in a fresh file and returns a Character ("fixture": the built-in one,
    light; "fixture_full": the built-in one at 75K vertices)."""
    require(key)
    if key in ("fixture", "fixture_full"):
        bpy.ops.wm.open_mainfile(filepath=_fixture_path(key == "fixture_full"))
        return Character(key, "Body", "Armature", ["forearm.L", "forearm.R"], ["shin.L", "shin.R"],
                         bone_rig.FIXTURE_CHAINS, ["upper_arm.L", "upper_arm.R"])
    if key == "makehuman":
        bpy.ops.wm.open_mainfile(filepath=os.path.join(SHARED, "mh_male_game_engine.blend"))
        return Character(key, "Body", "Armature", ["lowerarm_l", "lowerarm_r"], ["calf_l", "calf_r"],
                         bone_rig.MAKEHUMAN_CHAINS, ["upperarm_l", "upperarm_r"])
    if key == "cesium":
        bpy.ops.wm.read_homefile(use_empty=True)
        bpy.ops.import_scene.gltf(filepath=os.path.join(SHARED, "CesiumMan.glb"), bone_heuristic='TEMPERANCE')
        arm = next(o for o in bpy.data.objects if o.type == 'ARMATURE')
        if arm.animation_data:
            arm.animation_data.action = None
        for pb in arm.pose.bones:
            pb.matrix_basis.identity()
        bpy.context.scene.frame_set(1)
        return Character(key, "Cesium_Man", arm.name, ["Skeleton_arm_joint_L__3_", "Skeleton_arm_joint_R__2_"],
                         ["leg_joint_L_2", "leg_joint_R_2"], CESIUM_CHAINS,
                         ["Skeleton_arm_joint_L__4_", "Skeleton_arm_joint_R"])
    raise KeyError(key)


def use_test_rig(chars):
    """Replaces the add-on's rig maker (the core's fitting) with the bone rig of tests/."""
    chains = []
    for c in chars:
        chains.extend(c.chains)
    by_bones = {}
    for start, links, end in chains:
        by_bones.setdefault(tuple(links), (start, links, end))

    def fitter(inp):
        names = set(inp.bone_names)
        mine = [c for c in by_bones.values() if set(c[1]) <= names]
        return bone_rig.make_bone_rig(inp, mine)

    sub("blender.binding").fitter = fitter


def bind(char, use_operator=True):
    """Binds the character with the test rig (through the operator by default)."""
    obj = char.mesh
    bpy.context.view_layer.objects.active = obj
    for o in bpy.context.selected_objects:
        o.select_set(False)
    obj.select_set(True)
    if use_operator:
        result = bpy.ops.object.sweep_deform_add()
        assert result == {'FINISHED'}, result
    else:
        sub("blender.binding").bind_object(obj, char.armature)
    assert obj.sweep_deform.state == 'BOUND'
    return obj


def duplicate_character(obj, arm, linked=False):
    """Shift+D (Alt+D with `linked`) of a mesh object and its armature, as in the viewport.
    Returns (the new mesh object, the new armature)."""
    for o in bpy.context.selected_objects:
        o.select_set(False)
    obj.select_set(True)
    arm.select_set(True)
    bpy.context.view_layer.objects.active = arm
    assert bpy.ops.object.duplicate(linked=linked) == {'FINISHED'}
    new_arm = bpy.context.view_layer.objects.active
    new_obj = next(o for o in bpy.context.selected_objects if o.type == 'MESH')
    assert new_arm != arm and new_obj != obj
    return new_obj, new_arm


# ---- poses ----------------------------------------------------------------------------------


def set_rotation(pb, euler):
    pb.rotation_mode = 'XYZ'
    pb.rotation_euler = euler


def pose_limbs(char, elbow=1.1, knee=1.0, shoulder=0.0):
    arm = char.armature
    for n in char.elbows:
        set_rotation(arm.pose.bones[n], (elbow, 0.0, 0.0))
    for n in char.knees:
        set_rotation(arm.pose.bones[n], (knee, 0.0, 0.0))
    for n in char.shoulders:
        set_rotation(arm.pose.bones[n], (shoulder, 0.0, 0.0))


def rest_pose(char):
    for pb in char.armature.pose.bones:
        pb.matrix_basis.identity()


# ---- measurements ---------------------------------------------------------------------------


def evaluated_positions(obj, depsgraph=None):
    dg = depsgraph or bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(dg)
    me = ev.to_mesh()
    try:
        co = np.empty(len(me.vertices) * 3, np.float32)
        me.vertices.foreach_get("co", co)
        names = set(me.attributes.keys())
    finally:
        ev.to_mesh_clear()
    return co.reshape(-1, 3), names


def base_positions(obj):
    co = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def core_result(obj, depsgraph=None, anatomy=False, corrections=False, joint_volumes=True):
    """What the core computes for the evaluated pose, through the add-on's native module but
    not through its deformer cache: a fresh deformer from the stored blobs; with `anatomy`
    sd_deform_with_anatomy with the object's effect settings; without `joint_volumes` the
    mesh's volume at the joints not held; with `corrections` the
    object's key-ellipse correction properties instead of those in the rig blob. Returns (expected mesh
    positions float32 as the add-on must produce them, the core's raw deformed positions
    mapped to mesh space in float64, the anatomy's stats or None)."""
    native, persistence = sub("core.native"), sub("blender.persistence")
    effects_module, corrections_module = sub("blender.anatomy"), sub("blender.corrections")
    s = obj.sweep_deform
    dg = depsgraph or bpy.context.evaluated_depsgraph_get()
    rig, binding, names, rest = persistence.load(obj)
    if corrections:
        rig.set_corrections([], [], [], [])
    arm_eval = s.armature.evaluated_get(dg)
    obj_eval = obj.evaluated_get(dg)
    pose = np.concatenate([np.array(arm_eval.pose.bones[n].matrix, np.float32).T.ravel() for n in names])
    d = native.Deformer(rig, binding)
    d.set_volume_preservation(False, 0.0)
    rest_shape = d.deform(rest, np.empty((d.vertex_count, 3), np.float32))
    # As the add-on's deformer: the mesh's volume at the joints held, measured on its triangles
    # (a mesh bound through another's map: on that source's).
    triangles = sub("blender.mesh_data").triangles
    source = json.loads(obj.get(persistence.REPORT_KEY, "") or "{}").get("bound_through_map_of")
    if joint_volumes and source:
        srig, sbinding, _, _ = persistence.load(bpy.data.objects[source])
        measured = native.Deformer(srig, sbinding)
        measured.hold_joint_volumes(triangles(bpy.data.objects[source].data))
        d.hold_joint_volumes_of(measured)
    elif joint_volumes:
        d.hold_joint_volumes(triangles(obj.data))
    if source:  # the trunk's fill: as the source's, or on its own triangles
        filled = native.Deformer(*persistence.load(bpy.data.objects[source])[:2])
        filled.set_skin_triangles(triangles(bpy.data.objects[source].data))
        d.fill_trunk_as(filled)
    elif len(obj.data.vertices) == d.vertex_count:
        d.set_skin_triangles(triangles(obj.data))
    if corrections:
        d.set_rig_corrections(*corrections_module.correction_arrays(s))
    d.set_volume_preservation(s.use_volume_preservation, s.volume_strength)
    deformed = np.empty((d.vertex_count, 3), np.float32)
    stats = None
    if anatomy:
        tris = sub("blender.mesh_data").triangles(obj.data)
        effects, problems = effects_module.make_anatomy(rig, binding, names, tris,
                                                        effects_module.anatomy_settings(s))
        assert not problems, problems
        effects.deform(d, pose, deformed)
        stats = effects.stats()
    else:
        d.deform(pose, deformed)
    m = np.array(arm_eval.matrix_world.inverted() @ obj_eval.matrix_world, np.float64)
    lin = m[:3, :3]
    offsets = deformed - rest_shape
    if not np.array_equal(lin, np.eye(3)):
        offsets = offsets @ np.linalg.inv(lin).T.astype(np.float32)
    expected = base_positions(obj) + offsets.astype(np.float32)
    raw = (deformed.astype(np.float64) - m[:3, 3]) @ np.linalg.inv(lin).T
    return expected, raw, stats


def core_expectation(obj, depsgraph=None):
    """core_result without the anatomical effects: (expected float32, raw float64)."""
    expected, raw, _ = core_result(obj, depsgraph)
    return expected, raw


def armature_modifier_positions(obj):
    """Evaluated positions with Blender's Armature modifier instead of Sweep Deform."""
    s = obj.sweep_deform
    md_sweep = sub("blender.modifier").find(obj)
    md_arm = obj.modifiers[s.armature_modifier]
    saved = (md_sweep.show_viewport, md_arm.show_viewport, md_arm.object)
    md_sweep.show_viewport, md_arm.show_viewport, md_arm.object = False, True, s.armature
    try:
        bpy.context.view_layer.update()
        co, _ = evaluated_positions(obj)
    finally:
        md_sweep.show_viewport, md_arm.show_viewport, md_arm.object = saved
        bpy.context.view_layer.update()
    return co


def diagonal(points):
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


# ---- a Blender with its interface ------------------------------------------------------------


def run_gui_blender(blend, script, args=(), screen=(1024, 768), options=(), timeout=240):
    """Runs a Blender with its interface under Xvfb (skips the test without xvfb-run): opens
    `blend`, runs `script` with `args` after "--"; the script prints ``RESULT {json}`` and
    exits (gui_support.py). Returns (the result, the log); fails the test when no result came
    or the script reported an "error"."""
    xvfb = shutil.which("xvfb-run")
    if xvfb is None:
        pytest.skip("xvfb-run not found")
    cmd = [xvfb, "-a", "-s", f"-screen 0 {screen[0]}x{screen[1]}x24", bpy.app.binary_path, "--factory-startup",
           *options, "--enable-event-simulate", blend, "--python", script, "--", *args]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    assert lines, proc.stdout[-3000:] + proc.stderr[-3000:]
    out = json.loads(lines[-1][len("RESULT "):])
    assert "error" not in out, out["error"]
    return out, proc.stdout + proc.stderr
