# Sweep Deform: check a built-in character fixture (run inside Blender 4.3 or 5.2).
#
#   scripts/blender --use 4.3 -b --factory-startup --python blend_fixtures/check_character.py -- blend_fixtures/character_light.blend
#   scripts/blender --use 5.2 -b --factory-startup --python blend_fixtures/check_character.py -- blend_fixtures/character.blend
#
# Without a path it checks the file already open.  Prints every measurement and exits with status 1
# when any check fails (0 when all pass).
import hashlib
import math
import os
import sys

import bpy
import numpy as np
from mathutils import Quaternion

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mesh_topology import topology_counts  # noqa: E402

MARKERS = ["rest", "walk", "arms_up", "knee_bend", "elbow_bend", "forearm_twist", "spine_bend"]
BONES = ["pelvis", "spine_01", "spine_02", "spine_03", "neck", "head"] + [
    f"{b}.{s}" for s in "LR" for b in ("clavicle", "upper_arm", "forearm", "hand", "thigh", "shin", "foot", "toe")]

failures = []


def check(ok, what, detail=""):
    print(f"  [{'ok' if ok else 'FAIL'}] {what}" + (f": {detail}" if detail else ""), flush=True)
    if not ok:
        failures.append(what)
    return ok


def coords(me):
    co = np.empty(len(me.vertices) * 3, np.float64)
    me.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def evaluated_coords(ob):
    dg = bpy.context.evaluated_depsgraph_get()
    ev = ob.evaluated_get(dg)
    me = ev.to_mesh()
    co = coords(me)
    ev.to_mesh_clear()
    return co


def weights(ob, bone_names):
    """(n, n_bones) dense weight matrix over the deform bones."""
    col = {vg.index: bone_names.index(vg.name) for vg in ob.vertex_groups if vg.name in bone_names}
    W = np.zeros((len(ob.data.vertices), len(bone_names)))
    for v in ob.data.vertices:
        for g in v.groups:
            c = col.get(g.group)
            if c is not None:
                W[v.index, c] += g.weight
    return W


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if argv:
        path = os.path.abspath(argv[0])
        bpy.ops.wm.open_mainfile(filepath=path)
    path = bpy.data.filepath
    light = "light" in os.path.basename(path)
    print(f"check_character: {path} in Blender {bpy.app.version_string}", flush=True)
    scene = bpy.context.scene

    # ---- objects, rig -------------------------------------------------------------------
    body, arm = bpy.data.objects.get("Body"), bpy.data.objects.get("Armature")
    if not check(body is not None and body.type == 'MESH', "object 'Body' is a mesh") or \
            not check(arm is not None and arm.type == 'ARMATURE', "object 'Armature' is an armature"):
        return
    check(body.parent is arm, "Body is parented to Armature")
    mods = [m for m in body.modifiers if m.type == 'ARMATURE']
    check(len(mods) == 1 and mods[0].object is arm and len(body.modifiers) == 1,
          "Body has exactly one modifier, an Armature modifier on Armature", str([m.type for m in body.modifiers]))
    names = [b.name for b in arm.data.bones]
    check(sorted(names) == sorted(BONES), "bone set", f"{len(names)} bones")
    bad_parent = [b.name for b in arm.data.bones if b.name != "pelvis" and b.parent is None]
    check(not bad_parent and arm.data.bones["pelvis"].parent is None, "pelvis is the only root", str(bad_parent))

    # ---- mesh -------------------------------------------------------------------------------
    me = body.data
    nv = len(me.vertices)
    lo, hi = (4000, 9000) if light else (60000, 90000)
    check(lo <= nv <= hi, "vertex count", f"{nv} vertices, {len(me.polygons)} faces (expected {lo}..{hi})")
    b, nm, comps, chi = topology_counts(me)
    check(b == 0 and nm == 0 and comps == 1 and chi == 2, "closed, manifold, one component, genus 0",
          f"boundary edges {b}, non-manifold edges {nm}, components {comps}, Euler characteristic {chi}")
    rest = coords(me)
    digest = hashlib.sha1(np.round(rest, 6).astype(np.float32).tobytes()).hexdigest()[:16]
    print(f"  rest vertex positions sha1 (rounded 1e-6): {digest}")
    h = rest[:, 2].max() - rest[:, 2].min()
    check(1.70 <= h <= 1.80 and abs(rest[:, 2].min()) < 0.005, "height, feet on z = 0",
          f"height {h:.4f} m, z {rest[:, 2].min():.4f}..{rest[:, 2].max():.4f}, "
          f"x {rest[:, 0].min():.3f}..{rest[:, 0].max():.3f}, y {rest[:, 1].min():.3f}..{rest[:, 1].max():.3f}")
    toes = [arm.data.bones[f"toe.{s}"].tail_local for s in "LR"]
    check(all(t.y < -0.1 for t in toes), "facing -Y (toes point to -Y)", f"toe tips y {toes[0].y:.3f}, {toes[1].y:.3f}")

    # ---- weights ---------------------------------------------------------------------------
    W = weights(body, BONES)
    tot = W.sum(1)
    infl = (W > 0).sum(1)
    check(np.all(tot > 0), "every vertex weighted", f"{int(np.sum(tot <= 0))} unweighted; weight sums "
          f"{tot.min():.3f}..{tot.max():.3f}; influences per vertex max {infl.max()}, mean {infl.mean():.2f}")
    check(np.abs(tot - 1.0).max() < 1e-4, "weights normalised (sum 1 per vertex)", f"max |sum - 1| {np.abs(tot - 1.0).max():.1e}")
    print(f"  weights sha1 (rounded 1e-5): {hashlib.sha1(np.round(W, 5).astype(np.float32).tobytes()).hexdigest()[:16]}")
    dom = W.argmax(1)

    def part(*bones):
        return np.isin(dom, [BONES.index(x) for x in bones])

    # ---- action, markers ---------------------------------------------------------------------
    act = arm.animation_data.action if arm.animation_data else None
    check(act is not None and act.name == "demo_motion", "Armature plays action 'demo_motion'",
          act.name if act else "no action")
    markers = {m.name: m.frame for m in scene.timeline_markers}
    check(all(n in markers for n in MARKERS), "markers", ", ".join(f"{n}={markers.get(n)}" for n in MARKERS))
    print(f"  frames {scene.frame_start}..{scene.frame_end} at {scene.render.fps / scene.render.fps_base:g} fps")
    if any(n not in markers for n in MARKERS):
        return

    def at(marker):
        scene.frame_set(markers[marker])
        return evaluated_coords(body)

    def bone_q(name):
        return arm.pose.bones[name].rotation_quaternion

    # rest frame = bind pose
    r = at("rest")
    check(np.abs(r - rest).max() < 1e-5, "rest marker reproduces the bind pose", f"max |d| {np.abs(r - rest).max():.2e} m")

    # axis convention, independent of the action: +X on forearm bends the elbow forward, on shin the knee back
    saved_action = arm.animation_data.action
    arm.animation_data.action = None
    for pb in arm.pose.bones:
        pb.rotation_quaternion = (1, 0, 0, 0)
        pb.location = (0, 0, 0)
    for s in "LR":
        arm.pose.bones[f"forearm.{s}"].rotation_quaternion = Quaternion((1, 0, 0), math.radians(90))
        arm.pose.bones[f"shin.{s}"].rotation_quaternion = Quaternion((1, 0, 0), math.radians(90))
    bpy.context.view_layer.update()
    p = evaluated_coords(body)
    for s in "LR":
        hd = p[part(f"hand.{s}")].mean(0) - rest[part(f"hand.{s}")].mean(0)
        fd = p[part(f"foot.{s}")].mean(0) - rest[part(f"foot.{s}")].mean(0)
        check(hd[1] < -0.1, f"convention: forearm.{s} +90 deg about local X moves the hand forward (-Y)",
              f"hand moved ({hd[0]:+.3f}, {hd[1]:+.3f}, {hd[2]:+.3f}) m")
        check(fd[1] > 0.1 and fd[2] > 0.1, f"convention: shin.{s} +90 deg about local X moves the foot back (+Y) and up",
              f"foot moved ({fd[0]:+.3f}, {fd[1]:+.3f}, {fd[2]:+.3f}) m")
    for pb in arm.pose.bones:
        pb.rotation_quaternion = (1, 0, 0, 0)
    arm.animation_data.action = saved_action
    bpy.context.view_layer.update()

    # elbow_bend: forearm flexed ~150 deg about +X, hand forward (-Y) and up
    e = at("elbow_bend")
    for s in "LR":
        q = bone_q(f"forearm.{s}")
        ang = math.degrees(q.angle)
        axis = q.axis
        d = e[part(f"hand.{s}")].mean(0) - rest[part(f"hand.{s}")].mean(0)
        check(140 <= ang <= 160 and axis.x > 0.99, f"elbow_bend: forearm.{s} rotation",
              f"{ang:.1f} deg about local ({axis.x:+.2f}, {axis.y:+.2f}, {axis.z:+.2f})")
        check(d[1] < -0.05 and d[2] > 0.05, f"elbow_bend: hand.{s} moves forward (-Y) and up",
              f"hand centroid moved ({d[0]:+.3f}, {d[1]:+.3f}, {d[2]:+.3f}) m")

    # knee_bend: knee ~135 deg, foot behind the knee (+Y), feet stay on the floor
    k = at("knee_bend")
    for s in "LR":
        q = bone_q(f"shin.{s}")
        ang, axis = math.degrees(q.angle), q.axis
        foot, knee = part(f"foot.{s}"), arm.pose.bones[f"shin.{s}"]
        knee_rest, knee_now = arm.data.bones[f"shin.{s}"].head_local, (arm.matrix_world @ knee.head)
        rel_rest = rest[foot].mean(0)[1] - knee_rest.y
        rel_now = k[foot].mean(0)[1] - knee_now.y
        check(125 <= ang <= 145 and axis.x > 0.99, f"knee_bend: shin.{s} rotation",
              f"{ang:.1f} deg about local ({axis.x:+.2f}, {axis.y:+.2f}, {axis.z:+.2f})")
        check(rel_now - rel_rest > 0.1, f"knee_bend: foot.{s} moves backward (+Y) relative to the knee",
              f"foot centroid y - knee y: rest {rel_rest:+.3f} m, posed {rel_now:+.3f} m")
        fd = k[foot].mean(0) - rest[foot].mean(0)
        print(f"         foot.{s} world displacement ({fd[0]:+.3f}, {fd[1]:+.3f}, {fd[2]:+.3f}) m")
    check(abs(k[:, 2].min()) < 0.03, "knee_bend: lowest vertex near the floor", f"min z {k[:, 2].min():+.3f} m")
    check(k[:, 2].max() < 1.3, "knee_bend: body lowered", f"top {k[:, 2].max():.3f} m")

    # forearm_twist: hand turned 180 deg about the forearm axis: the thumb tip goes to the other side
    t = at("forearm_twist")
    for s in "LR":
        q = bone_q(f"hand.{s}")
        ang, axis = math.degrees(q.angle), q.axis
        check(175 <= ang <= 185 and abs(axis.y) > 0.99, f"forearm_twist: hand.{s} rotation",
              f"{ang:.1f} deg about local ({axis.x:+.2f}, {axis.y:+.2f}, {axis.z:+.2f})")
        hb, pb = arm.data.bones[f"hand.{s}"], arm.pose.bones[f"hand.{s}"]
        hand = np.flatnonzero(part(f"hand.{s}"))
        tip = hand[np.argmin(rest[hand, 1])]              # thumb tip: the most forward hand vertex
        a0, a1 = np.array(hb.head_local), np.array(hb.tail_local)
        b0, b1 = np.array(arm.matrix_world @ pb.head), np.array(arm.matrix_world @ pb.tail)

        def off(x, p0, p1):
            u = (p1 - p0) / np.linalg.norm(p1 - p0)
            v = x - p0
            return v - (v @ u) * u
        o0, o1 = off(rest[tip], a0, a1), off(t[tip], b0, b1)
        cosang = o0 @ o1 / (np.linalg.norm(o0) * np.linalg.norm(o1))
        check(cosang < -0.9, f"forearm_twist: thumb tip of hand.{s} turned to the opposite side of the axis",
              f"angle {math.degrees(math.acos(max(-1, min(1, cosang)))):.1f} deg")

    # arms_up: both hands above the head
    a = at("arms_up")
    for s in "LR":
        z = a[part(f"hand.{s}")].mean(0)[2]
        check(z > rest[:, 2].max() + 0.1, f"arms_up: hand.{s} above the head", f"hand centroid z {z:.3f} m")

    # spine_bend: head forward and down
    sp = at("spine_bend")
    d = sp[part("head")].mean(0) - rest[part("head")].mean(0)
    check(d[1] < -0.3 and d[2] < -0.1, "spine_bend: head moves forward (-Y) and down",
          f"head centroid moved ({d[0]:+.3f}, {d[1]:+.3f}, {d[2]:+.3f}) m")

    # walk: one foot forward, the other back, the lower one on the floor
    w = at("walk")
    fy = {s: w[part(f"foot.{s}", f"toe.{s}")].mean(0)[1] for s in "LR"}
    check(abs(fy["L"] - fy["R"]) > 0.2, "walk: feet apart in Y", f"foot centroids y L {fy['L']:+.3f}, R {fy['R']:+.3f}")
    check(abs(w[:, 2].min()) < 0.05, "walk: lowest vertex near the floor", f"min z {w[:, 2].min():+.3f} m")

    scene.frame_set(markers["rest"])


if __name__ == "__main__":
    try:
        main()
    except Exception:
        import traceback
        traceback.print_exc()
        failures.append("exception")
    print(f"check_character: {'FAILED: ' + ', '.join(failures) if failures else 'all checks passed'}", flush=True)
    sys.exit(1 if failures else 0)
