# SPDX-License-Identifier: GPL-3.0-or-later
"""Time per frame in Blender, from a pose change to the evaluated mesh: Sweep Deform next to
Blender's Armature modifier (plain and "Preserve Volume") on the same mesh, same weights, same
poses, in the same Blender run. Prints a table; never fails on speed.

    BLENDER_USER_RESOURCES=$(mktemp -d) scripts/blender --use 5.2 -b --factory-startup \
        --python tests/blender/measure_frame.py -- [--zip ZIP] [--frames N] [--characters a,b]

Characters: ``fixture`` (blend_fixtures/character.blend, 75,394 vertices, bone-heat weights, up
to 6 per vertex), ``mh53k`` (../shared/data MakeHuman subdiv1, 53,514 vertices, at most 4).
``--shape-key 1``: a relative shape key at value 1 moving every vertex (all setups deform the
keyed mesh; Sweep Deform turns it in the core, sd_deform_displaced); ``--shape-key head`` the
same key on the top tenth of the body only, as a face's keys are. Rig: the core's automatic fitting (``--rig fit``, the product's path) or the bone rig of
bone_rig.py (``--rig bones``). Two ways to change the pose, each timed around the call that brings the evaluated mesh
up to date:

* ``posing``: rotations of 8 limb bones set from Python, then ``view_layer.update()`` (what
  interactive posing does: depsgraph_update_post);
* ``playback``: ``scene.frame_set(f)`` on a keyed action (frame_change_post).
"""

import contextlib
import os
import statistics
import sys
import time

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
# install.py, flexion.py, limb_volume.py: shared with the demo and scripts/render_*.py.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "scripts", "blender_support"))

import install  # noqa: E402


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    opts = {"zip": install.default_zip(), "frames": 60, "characters": "fixture,mh53k", "rig": "fit", "shape-key": "0"}
    for i in range(0, len(argv) - 1, 2):
        opts[argv[i].lstrip("-")] = argv[i + 1]
    opts["frames"] = int(opts["frames"])
    opts["shape-key"] = {"0": None, "no": None, "": None, "head": "head"}.get(opts["shape-key"], "all")
    return opts


def load(key):
    import bone_rig
    import helpers
    if key == "fixture":
        path = os.path.join(helpers.FIXTURES, "character.blend")
        chains = bone_rig.FIXTURE_CHAINS
        bones = ["upper_arm.L", "forearm.L", "upper_arm.R", "forearm.R", "thigh.L", "shin.L", "thigh.R", "shin.R"]
    else:
        path = os.path.join(helpers.SHARED, "mh_male_game_engine_subdiv1.blend")
        chains = bone_rig.MAKEHUMAN_CHAINS
        bones = ["upperarm_l", "lowerarm_l", "upperarm_r", "lowerarm_r", "thigh_l", "calf_l", "thigh_r", "calf_r"]
    if not os.path.isfile(path):
        return None
    bpy.ops.wm.open_mainfile(filepath=path)
    body, arm = bpy.data.objects["Body"], bpy.data.objects["Armature"]
    if arm.animation_data:
        arm.animation_data.action = None
    for pb in arm.pose.bones:
        pb.matrix_basis.identity()
    return body, arm, chains, bones


def poses(n, bones, seed=1):
    rng = np.random.default_rng(seed)
    return [{b: tuple(rng.uniform(-0.9, 0.9, 3)) for b in bones} for _ in range(n)]


def apply_pose(arm, pose):
    for b, e in pose.items():
        pb = arm.pose.bones[b]
        pb.rotation_mode = 'XYZ'
        pb.rotation_euler = e


def key_poses(arm, pose_list):
    for f, pose in enumerate(pose_list, start=1):
        apply_pose(arm, pose)
        for b in pose:
            arm.pose.bones[b].keyframe_insert("rotation_euler", frame=f)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, len(pose_list)


def time_posing(obj, arm, pose_list):
    vl = bpy.context.view_layer
    times = []
    for pose in pose_list:
        apply_pose(arm, pose)
        t0 = time.perf_counter()
        vl.update()
        times.append(time.perf_counter() - t0)
    return times


def time_playback(obj, frames):
    scene = bpy.context.scene
    times = []
    for f in frames:
        t0 = time.perf_counter()
        scene.frame_set(f)
        times.append(time.perf_counter() - t0)
    return times


def configure(obj, mode):
    """mode: 'sweep' (as bound: the replaced Armature modifier off, keeping its object, its
    Vertex Groups unticked while off), 'sweep_inputs' (the same with its Vertex Groups ticked,
    as before: the mesh depends on every bone in the depsgraph and is evaluated twice per pose
    change), 'armature', 'armature_dqs'."""
    from bl_ext.user_default.sweep_deform.blender import binding, modifier
    s = obj.sweep_deform
    md_sweep = modifier.find(obj)
    md_arm = obj.modifiers[s.armature_modifier]
    md_arm.object = s.armature
    md_sweep.show_viewport = mode.startswith('sweep')
    md_arm.show_viewport = not mode.startswith('sweep')
    md_arm.use_deform_preserve_volume = mode == 'armature_dqs'
    binding.sync_replaced_modifier(obj)  # what the handler does at the next update
    if mode == 'sweep_inputs':
        md_arm.use_vertex_groups = True  # (the artist's value stays remembered: nothing syncs it back)
    if not mode.startswith('sweep'):
        modifier.clear_offsets(obj)
    bpy.context.view_layer.update()


_reference = {}
BLOCK, WARM = 12, 2


def check_deformed(obj, mode):
    """The evaluated mesh really follows the pose in every mode: it moved away from the rest
    mesh, and Sweep Deform stays close to the Armature modifier (same weights) for the pose."""
    import helpers
    co, _ = helpers.evaluated_positions(obj)
    base = helpers.base_positions(obj)
    assert np.abs(co - base).max() > 0.01, f"{mode}: the mesh did not move"
    frame = bpy.context.scene.frame_current
    pose_key = tuple(round(v, 5) for pb in obj.sweep_deform.armature.pose.bones for v in pb.rotation_euler)
    ref = _reference.setdefault(pose_key, co)
    err = np.linalg.norm(co - ref, axis=1).mean()
    assert err < 0.01 * helpers.diagonal(base), f"{mode}: {err} from another mode at frame {frame}"


def ms(ts):
    ts = sorted(ts)
    return statistics.median(ts) * 1e3, statistics.mean(ts) * 1e3


def add_shape_key(body, region="all"):
    """A relative shape key at value 1 moving every vertex ("all"), or those of the top tenth
    of the body ("head"), 1 mm along X: Sweep Deform then carries it along with each vertex's
    local linear map, the Armature modifier deforms the keyed mesh."""
    body.shape_key_add(name="Basis", from_mix=False)
    kb = body.shape_key_add(name="Key", from_mix=False)
    co = np.empty(len(body.data.vertices) * 3, np.float32)
    body.data.vertices.foreach_get("co", co)
    if region == "head":
        z = co[2::3]
        co[0::3] += np.where(z >= np.quantile(z, 0.9), np.float32(0.001), np.float32(0.0))
    else:
        co[0::3] += 0.001
    kb.data.foreach_set("co", co)
    kb.value = 1.0


@contextlib.contextmanager
def handler_out():
    """The add-on's depsgraph handler removed for the block: updates evaluate Blender alone."""
    from bl_ext.user_default.sweep_deform.blender import handlers
    hooks = bpy.app.handlers.depsgraph_update_post
    hooks.remove(handlers.on_depsgraph_update_post)
    try:
        yield
    finally:
        hooks.append(handlers.on_depsgraph_update_post)


def carrier_of(body):
    """(the body's Sweep Deform modifier, the carrier that serves the viewport now: its mesh
    carrier if in use, else its offsets carrier, a copy of what was last written into it)."""
    from bl_ext.user_default.sweep_deform.blender import modifier
    md = modifier.find(body)
    c = modifier.mesh_carrier_in_use(body, md) or modifier.get_carrier(md)
    values = np.empty(3 * len(c.data.vertices), np.float32)
    c.data.attributes['position'].data.foreach_get('vector', values)
    return md, c, values.reshape(-1, 3)


def time_carrier_writes(carrier, offsets, n, warm=WARM):
    """`view_layer.update()` timed after each of n rewrites of the carrier (`offsets` nudged
    each time, in place), the first `warm` not recorded."""
    from bl_ext.user_default.sweep_deform.blender import modifier
    vl = bpy.context.view_layer
    times = []
    for i in range(n + warm):
        offsets[0, 0] += 1e-7  # a write Blender cannot skip as unchanged
        modifier.write_offsets(carrier, offsets)
        t0 = time.perf_counter()
        vl.update()
        if i >= warm:
            times.append(time.perf_counter() - t0)
    return times


def blender_share(body, arm, pose_list, n):
    """Blender's own part of a Sweep Deform frame, the add-on's handler out of the way: a pose
    change with no deform modifier on (the armature's evaluation), and an update after the
    carrier is rewritten with the same pose (the carrier's and the node group's evaluation: the
    mesh carrier handed on, or the offsets carrier's per-vertex Sample Index and Set Position
    over the whole mesh)."""
    configure(body, 'sweep')
    time_posing(body, arm, pose_list[:WARM])
    md, carrier, offsets = carrier_of(body)
    vl = bpy.context.view_layer
    try:
        with handler_out():
            md.show_viewport = False
            vl.update()
            pose_only = time_posing(body, arm, (pose_list * (1 + n // len(pose_list)))[:n])
            md.show_viewport = True
            vl.update()
            node_group = time_carrier_writes(carrier, offsets, n)
    finally:
        configure(body, 'sweep')
    return {'pose only': pose_only, 'node group': node_group}


def measure(key, n, rig="fit", shape_key=False):
    import helpers
    loaded = load(key)
    if loaded is None:
        print(f"{key}: file missing, skipped")
        return None
    body, arm, chains, bones = loaded
    char = helpers.Character(key, body.name, arm.name, [], [], chains)
    if rig == "bones":
        helpers.use_test_rig([char])
    bpy.context.view_layer.objects.active = body
    t0 = time.perf_counter()
    assert bpy.ops.object.sweep_deform_add() == {'FINISHED'}
    bind_s = time.perf_counter() - t0
    if shape_key:
        add_shape_key(body, shape_key)
    V = len(body.data.vertices)
    pose_list = poses(n + n // (BLOCK - WARM) * WARM + BLOCK, bones)

    # The add-on's own share: frame.evaluate (Python + core + attribute write) and the core.
    from bl_ext.user_default.sweep_deform.blender import deformer_cache, frame
    spent = []
    original = frame.evaluate

    def timed(*a, **k):
        t = time.perf_counter()
        r = original(*a, **k)
        if r:
            spent.append(time.perf_counter() - t)
        return r

    # The modes take turns in blocks of BLOCK poses (the first WARM of each block not recorded),
    # so a busy spell of the machine hits them alike while each runs warm, as in use.
    modes = ('sweep', 'sweep_inputs', 'armature', 'armature_dqs')
    results = {(m, sub): [] for m in modes for sub in ('posing', 'playback', 'addon')}
    blocks = [pose_list[i:i + BLOCK] for i in range(0, len(pose_list) - BLOCK + 1, BLOCK)]
    for b, block in enumerate(blocks):
        for mode in modes:
            configure(body, mode)
            time_posing(body, arm, block[:WARM])
            frame.evaluate = timed
            spent.clear()
            results[mode, 'posing'] += time_posing(body, arm, block[WARM:])
            results[mode, 'addon'] += list(spent)
            frame.evaluate = original
            check_deformed(body, mode)
    results.update(blender_share(body, arm, pose_list[:BLOCK * 4], n))
    e = deformer_cache.entry(body)
    pose = e.last_pose.copy()
    core = []
    for _ in range(n):
        t = time.perf_counter()
        e.deformer.deform(pose)
        core.append(time.perf_counter() - t)
    results['core'] = core

    for pb in arm.pose.bones:
        pb.matrix_basis.identity()
    key_poses(arm, pose_list)
    for b in range(len(blocks)):
        frames = range(1 + b * BLOCK, 1 + (b + 1) * BLOCK)
        for mode in modes:
            configure(body, mode)
            time_playback(body, frames[:WARM])
            results[mode, 'playback'] += time_playback(body, frames[WARM:])
            check_deformed(body, mode)

    print(f"\n{key}: {V:,} vertices, {len(arm.pose.bones)} bones, {body.sweep_deform.sweep_count} sweeps, "
          f"{'fitted' if rig == 'fit' else 'bone rig'}{f', a shape key at 1 ({shape_key})' if shape_key else ''}, fit+bind {bind_s * 1e3:.0f} ms; Blender {bpy.app.version_string}; {n} frames; median / mean ms")
    print(f"  {'':32s}{'posing':>16s}{'playback':>16s}")
    for mode, label in (('sweep', 'Sweep Deform'), ('sweep_inputs', 'Sweep, off modifier reads bones'),
                        ('armature', 'Armature modifier'), ('armature_dqs', 'Armature, Preserve Volume')):
        p, b = ms(results[mode, 'posing']), ms(results[mode, 'playback'])
        print(f"  {label:32s}{p[0]:8.2f} /{p[1]:6.2f}{b[0]:8.2f} /{b[1]:6.2f}")
    for sub in ('posing', 'playback'):
        r = ms(results['sweep', sub])[0] / ms(results['armature', sub])[0]
        rd = ms(results['sweep', sub])[0] / ms(results['armature_dqs', sub])[0]
        print(f"  ratio Sweep / Armature ({sub}, medians): {r:.2f} (plain), {rd:.2f} (Preserve Volume)")
    a, c = ms(results['sweep', 'addon']), ms(results['core'])
    print(f"  inside the add-on's handler: {a[0]:.2f} ms (core sd_deform alone {c[0]:.2f} ms)")
    p, g = ms(results['pose only'])[0], ms(results['node group'])[0]
    print(f"  Blender's own share, handler out: a pose change with no deform modifier {p:.2f} ms; "
          f"an update after a carrier write (the carrier and the node group) {g:.2f} ms")
    return results


def main():
    opts = args()
    install.install(opts["zip"])
    print(f"threads: {bpy.context.scene.render.threads}, cpus: {os.cpu_count()}")
    for key in opts["characters"].split(","):
        measure(key, opts["frames"], opts["rig"], opts["shape-key"])


if __name__ == "__main__":
    main()
