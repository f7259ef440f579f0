# SPDX-License-Identifier: GPL-3.0-or-later
"""Exploration, not a test (pytest does not collect this file): seeded extreme frames on the
built-in character bound with the product's fitting. Prints per frame the largest
skin-to-bone distance ratio (each vertex against its heaviest bone, floor a share of the body)
and the largest distance to the Armature modifier's result, then dumps the rig, binding,
rest pose, poses and skin weights for scripts/extreme_poses.py (the same search without
Blender, thousands of frames a minute).

    echo '{"mode": "euler", "seeds": [0, 1], "full": false, "anatomy": false,
           "floor": 0.05, "out": "/tmp/sd_explore"}' > /tmp/sd_explore_cfg.json
    tests/blender/run_tests.sh 4.3 -s tests/blender/explore_extreme.py

(scripts/blender passes no environment into Blender, hence the file in /tmp.)
"""

import os

import bpy
import mathutils
import numpy as np

import helpers

SEED, FRAMES, LIMIT = 15, 200, np.radians(170.0)


_CFG = {}
if os.path.exists("/tmp/sd_explore_cfg.json"):  # scripts/blender passes no environment
    import json
    _CFG = json.load(open("/tmp/sd_explore_cfg.json"))
MODE = _CFG.get("mode", "axis")
SEEDS = _CFG.get("seeds", [SEED])
FULL = _CFG.get("full", False)


def random_pose(arm, rng):
    if MODE == "euler":
        for pb in arm.pose.bones:
            pb.rotation_mode = 'XYZ'
            pb.rotation_euler = rng.uniform(-LIMIT, LIMIT, size=3)
        return
    for pb in arm.pose.bones:
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        pb.rotation_mode = 'QUATERNION'
        pb.rotation_quaternion = mathutils.Quaternion(axis, rng.uniform(-LIMIT, LIMIT))


def bone_distance(points, heads, tails):
    ab = tails - heads
    t = np.clip(np.einsum("ij,ij->i", points - heads, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-20), 0, 1)
    return np.linalg.norm(points - heads - t[:, None] * ab, axis=1)


def test_explore():
    helpers.sub("core.output_check").RATIO_LIMIT = float("inf")  # raw core output
    char = helpers.load("fixture_full" if FULL else "fixture")
    obj = char.mesh
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.object.sweep_deform_add() == {'FINISHED'}
    obj.sweep_deform.use_anatomy = _CFG.get("anatomy", False)
    arm = char.armature
    names = [b.name for b in arm.data.bones]
    # each vertex's heaviest bone
    V = len(obj.data.vertices)
    best = np.full(V, -1)
    bw = np.zeros(V)
    for v in obj.data.vertices:
        for g in v.groups:
            n = obj.vertex_groups[g.group].name
            if n in names and g.weight > bw[v.index]:
                bw[v.index], best[v.index] = g.weight, names.index(n)
    m = np.array(arm.matrix_world.inverted() @ obj.matrix_world)
    base = helpers.base_positions(obj) @ m[:3, :3].T + m[:3, 3]
    rh = np.array([b.head_local for b in arm.data.bones])
    rt = np.array([b.tail_local for b in arm.data.bones])
    rest_d = bone_distance(base, rh[best], rt[best])
    floor = _CFG.get("floor", 0.02) * helpers.diagonal(base)
    rows, poses = [], []
    for f in range(FRAMES * len(SEEDS)):
        if f % FRAMES == 0:
            rng = np.random.default_rng(SEEDS[f // FRAMES])
        random_pose(arm, rng)
        bpy.context.view_layer.update()
        co, _ = helpers.evaluated_positions(obj)
        co = co @ m[:3, :3].T + m[:3, 3]
        ph = np.array([arm.pose.bones[n].head for n in names])
        pt = np.array([arm.pose.bones[n].tail for n in names])
        d = bone_distance(co, ph[best], pt[best])
        ratio = d / np.maximum(rest_d, floor)
        lbs = helpers.armature_modifier_positions(obj) @ m[:3, :3].T + m[:3, 3]
        vs = np.linalg.norm(co - lbs, axis=1).max()
        e = helpers.sub("blender.deformer_cache").peek(obj)
        rows.append((f, float(ratio.max()), int(ratio.argmax()), float(vs), helpers.diagonal(co), e.error if e else ""))
        poses.append(np.concatenate([np.array(arm.pose.bones[n].matrix).T.ravel() for n in names]))
        print("FRAME", *rows[-1], flush=True)
    out = _CFG.get("out", "/tmp/sd_explore")
    os.makedirs(out, exist_ok=True)
    p = helpers.sub("blender.persistence")
    rig, binding, bnames, rest = p.load(obj)
    ids, w = helpers.sub("blender.binding").skin_weights(obj, arm, bnames)
    e = helpers.sub("blender.deformer_cache").peek(obj)
    arm_bones = arm.data.bones
    parents = [bnames.index(arm_bones[n].parent.name) if arm_bones[n].parent else -1 for n in bnames]
    np.savez(os.path.join(out, "skin.npz"), ids=ids, w=w, core_rest=e.rest, parents=np.array(parents),
             lengths=np.array([arm_bones[n].length for n in bnames]))
    np.savez(os.path.join(out, "data.npz"), rig=np.frombuffer(bytes(obj[p.RIG_KEY]), np.uint8),
             binding=np.frombuffer(bytes(obj[p.BINDING_KEY]), np.uint8), rest=rest, poses=np.array(poses, np.float32),
             names=np.array(bnames), base=base, best=best, rest_d=rest_d)
    with open(os.path.join(out, "report.json"), "w") as fh:
        fh.write(obj.get(p.REPORT_KEY, ""))
    worst = sorted(rows, key=lambda r: -r[1])[:10]
    print("WORST", worst)
