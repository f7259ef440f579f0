# Sweep Deform: generate the built-in test character (blend_fixtures/).
#
#   scripts/blender --use 4.3 -b --factory-startup --python blend_fixtures/make_character.py -- --out blend_fixtures
#
# Options after "--":
#   --out DIR          where to write the .blend files (default: the folder of this script)
#   --variants LIST    comma-separated subset of "light,full" (default: both)
#   --no-compress      save uncompressed .blend files
#
# Writes character_light.blend (~4.7K vertices) and character.blend (~75K vertices): a human figure
# made with Blender's Skin modifier over a stick skeleton, subdivided and applied to a plain closed
# manifold mesh "Body", rigged to "Armature" with automatic (bone heat) weights, plus the action
# "demo_motion" with timeline markers at the key poses. Works in Blender 4.3 and 5.2; there is no
# randomness anywhere, so the same script gives the same vertex positions. See README.md.
import math
import os
import sys
import time

import bmesh
import bpy
import numpy as np
from mathutils import Euler, Matrix, Vector
from mathutils.kdtree import KDTree

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mesh_topology import topology_counts  # noqa: E402

HEIGHT = 1.75          # metres, top of the head; the soles touch z = 0
FPS = 24
LEVELS = {"light": 2, "full": 4}     # Catmull-Clark levels applied to the Skin modifier's cage
FILES = {"light": "character_light.blend", "full": "character.blend"}


# --------------------------------------------------------------------------------------------
# 1. Stick skeleton: joints (position in metres before normalisation, Skin radii) and edges.
#    Skin radius (r0, r1): for a vertical edge r0 is along X (width), r1 along Y (depth); for the
#    arms (edges in the XZ plane) r0 is along Y and r1 is perpendicular to the arm in the XZ plane;
#    for the feet (edges along Y) r0 is along X and r1 along Z.  Branch vertices (pelvis,
#    upper_chest, palm, ankle) take the hull of their neighbours' rings; their radius is unused.
# --------------------------------------------------------------------------------------------
JOINTS = {}
EDGES = []


def joint(name, pos, r):
    JOINTS[name] = (tuple(float(v) for v in pos), (float(r), float(r)) if isinstance(r, (int, float)) else tuple(r))


def chain(*names):
    EDGES.extend(zip(names, names[1:]))


joint("pelvis", (0, 0.0, 0.96), (0.17, 0.125))
joint("spine1", (0, 0.0, 1.07), (0.145, 0.10))
joint("spine2", (0, -0.005, 1.18), (0.155, 0.11))
joint("chest", (0, -0.01, 1.29), (0.17, 0.125))
joint("upper_chest", (0, 0.0, 1.39), (0.15, 0.10))
joint("neck", (0, 0.012, 1.49), 0.055)
joint("head_base", (0, 0.01, 1.555), (0.06, 0.065))
joint("head_low", (0, -0.012, 1.60), (0.07, 0.085))
joint("head", (0, -0.01, 1.665), (0.09, 0.105))
joint("head_top", (0, 0.0, 1.725), (0.055, 0.065))
chain("pelvis", "spine1", "spine2", "chest", "upper_chest", "neck", "head_base", "head_low", "head", "head_top")

ARM_DOWN = math.radians(45.0)        # A-pose: arms 45 degrees below horizontal
SHOULDER = (0.19, 0.0, 1.41)
ARM_DIR = (math.cos(ARM_DOWN), 0.0, -math.sin(ARM_DOWN))
UPPER_ARM, FOREARM, HAND = 0.29, 0.25, 0.18   # lengths along the arm


def _arm(sx, t, dy=0.0):
    return (sx * (SHOULDER[0] + t * ARM_DIR[0]), dy, SHOULDER[2] + t * ARM_DIR[2])


for side, sx in (("L", 1.0), ("R", -1.0)):
    def P(x, y, z):
        return (sx * x, y, z)

    def A(t, dy=0.0):
        return _arm(sx, t, dy)

    joint("clav." + side, P(0.11, 0.0, 1.415), (0.06, 0.065))
    joint("shoulder." + side, P(*SHOULDER), (0.06, 0.06))
    joint("uarm." + side, A(0.14), (0.053, 0.05))
    joint("elbow." + side, A(UPPER_ARM), (0.042, 0.038))
    joint("farm." + side, A(0.38), (0.047, 0.042))
    joint("wrist." + side, A(UPPER_ARM + FOREARM), (0.03, 0.022))
    joint("palm." + side, A(0.59), (0.045, 0.015))
    joint("knuckle." + side, A(0.64), (0.043, 0.014))
    joint("fingertip." + side, A(UPPER_ARM + FOREARM + HAND), (0.03, 0.012))
    joint("thumb1." + side, A(0.585, -0.04), 0.017)      # thumb points forward (-Y): palms face the body
    joint("thumb." + side, A(0.63, -0.065), 0.014)
    chain("upper_chest", "clav." + side, "shoulder." + side, "uarm." + side, "elbow." + side, "farm." + side,
          "wrist." + side, "palm." + side, "knuckle." + side, "fingertip." + side)
    chain("palm." + side, "thumb1." + side, "thumb." + side)

    joint("hip." + side, P(0.09, 0.0, 0.90), 0.095)
    joint("thigh." + side, P(0.095, -0.005, 0.72), 0.08)
    joint("knee." + side, P(0.10, -0.005, 0.50), 0.055)
    joint("calf." + side, P(0.10, 0.01, 0.38), (0.06, 0.065))
    joint("ankle." + side, P(0.10, 0.02, 0.09), 0.035)
    joint("heel." + side, P(0.10, 0.045, 0.035), 0.03)
    joint("ball." + side, P(0.105, -0.11, 0.025), (0.045, 0.025))
    joint("toe." + side, P(0.11, -0.18, 0.022), (0.035, 0.02))
    chain("pelvis", "hip." + side, "thigh." + side, "knee." + side, "calf." + side, "ankle." + side,
          "ball." + side, "toe." + side)
    chain("ankle." + side, "heel." + side)

# --------------------------------------------------------------------------------------------
# 2. Bones: (name, parent, connected, head, tail, roll target = direction of the local Z axis).
#    Convention: a positive rotation about a bone's local X axis is FLEXION, i.e. it swings the
#    bone's tail towards its local +Z:
#      pelvis, spine_01..03, neck, head: Z forward (-Y) -> bend forward
#      clavicle: Z up (+Z) -> shrug (elevate the shoulder)
#      upper_arm, forearm: Z forward (-Y) -> raise the arm forward / bend the elbow forward
#      hand: Z = palm normal (palms face the body) -> bend the wrist towards the palm
#      thigh: Z forward (-Y) -> raise the thigh forward (hip flexion)
#      shin: Z backward (+Y) -> bend the knee backward
#      foot, toe: Z up (+Z) -> lift the toes (dorsiflexion)
#    Local Y runs along the bone (head -> tail): twist.  Local Z rotation on the arms: + raises .L
#    sideways (abduction), - raises .R; mirrored poses negate Y and Z rotations on .R.
# --------------------------------------------------------------------------------------------
FWD, BACK, UP = (0.0, -1.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


def bone_table():
    J = {n: p for n, (p, _) in JOINTS.items()}
    mid = lambda a, b, t=0.5: tuple(a[i] + t * (b[i] - a[i]) for i in range(3))
    neck_base = mid(J["upper_chest"], J["neck"], 0.6)
    bones = [
        ("pelvis", None, False, J["pelvis"], J["spine1"], FWD),
        ("spine_01", "pelvis", True, J["spine1"], J["spine2"], FWD),
        ("spine_02", "spine_01", True, J["spine2"], J["chest"], FWD),
        ("spine_03", "spine_02", True, J["chest"], neck_base, FWD),
        ("neck", "spine_03", True, neck_base, J["head_base"], FWD),
        ("head", "neck", True, J["head_base"], (0.0, 0.0, J["head_top"][2]), FWD),
    ]
    for s, sx in (("L", 1.0), ("R", -1.0)):
        palm_normal = (-sx * math.sin(ARM_DOWN), 0.0, -math.cos(ARM_DOWN))
        bones += [
            ("clavicle." + s, "spine_03", False, (sx * 0.025, -0.01, 1.41), J["shoulder." + s], UP),
            ("upper_arm." + s, "clavicle." + s, True, J["shoulder." + s], J["elbow." + s], FWD),
            ("forearm." + s, "upper_arm." + s, True, J["elbow." + s], J["wrist." + s], FWD),
            ("hand." + s, "forearm." + s, True, J["wrist." + s], J["fingertip." + s], palm_normal),
            ("thigh." + s, "pelvis", False, J["hip." + s], J["knee." + s], FWD),
            ("shin." + s, "thigh." + s, True, J["knee." + s], J["ankle." + s], BACK),
            ("foot." + s, "shin." + s, True, J["ankle." + s], J["ball." + s], UP),
            ("toe." + s, "foot." + s, True, J["ball." + s], J["toe." + s], UP),
        ]
    return bones


# --------------------------------------------------------------------------------------------
# 3. Motion: key poses as local rotations in degrees, XYZ Euler (converted to quaternions).
#    Only .L / centre bones are written where a pose is symmetric; mirror() adds .R.
# --------------------------------------------------------------------------------------------
def mirror(pose):
    out = dict(pose)
    for name, rot in pose.items():
        if name.endswith(".L"):
            x, y, z = rot
            out[name[:-2] + ".R"] = (x, -y, -z)
    return out


POSES = {
    "rest": {},
    "arms_up": mirror({"clavicle.L": (12, 0, 0), "upper_arm.L": (0, 0, 110), "forearm.L": (10, 0, 0)}),
    # deep squat: hips flexed 95 deg with the knees apart, knees 135 deg, ankles 40 deg, trunk leaning
    # forward, arms forward for balance; the pelvis is lowered and moved back so the feet stay put.
    "knee_bend": dict(mirror({"thigh.L": (95, 0, 12), "shin.L": (135, 0, 0), "foot.L": (40, 0, 0),
                              "upper_arm.L": (55, 0, -20), "forearm.L": (20, 0, 0)}),
                      **{"spine_01": (10, 0, 0), "spine_02": (10, 0, 0), "spine_03": (8, 0, 0),
                         "neck": (-10, 0, 0), "head": (-8, 0, 0)}),
    "elbow_bend": mirror({"forearm.L": (150, 0, 0)}),
    # supination: the thumb turns up and back, the palm from facing the body to facing away
    "forearm_twist": mirror({"hand.L": (0, -180, 0)}),
    "spine_bend": {"spine_01": (20, 0, 0), "spine_02": (20, 0, 0), "spine_03": (15, 0, 0), "neck": (10, 0, 0)},
}


def walk_pose(phase):
    """In-place walk; phase 0 = left heel strike, 1 = left passing (left stance), 2 = right heel strike,
    3 = right passing.  Returned as a full pose dict."""
    def contact(f, b):   # f: forward leg side, b: back leg side
        sgn = 1 if f == "L" else -1
        return {
            "thigh." + f: (28, 0, 0), "shin." + f: (5, 0, 0), "foot." + f: (10, 0, 0),
            "thigh." + b: (-15, 0, 0), "shin." + b: (25, 0, 0), "foot." + b: (-20, 0, 0), "toe." + b: (25, 0, 0),
            "upper_arm." + f: (-20, 0, 0), "forearm." + f: (15, 0, 0),
            "upper_arm." + b: (25, 0, 0), "forearm." + b: (30, 0, 0),
            "pelvis": (0, 5 * sgn, 0), "spine_02": (0, -4 * sgn, 0), "spine_03": (0, -4 * sgn, 0),
        }

    def passing(st, sw):  # st: stance side, sw: swing side
        return {
            "thigh." + st: (0, 0, 0), "shin." + st: (5, 0, 0), "foot." + st: (0, 0, 0),
            "thigh." + sw: (20, 0, 0), "shin." + sw: (60, 0, 0), "foot." + sw: (10, 0, 0),
            "upper_arm." + st: (0, 0, 0), "forearm." + st: (20, 0, 0),
            "upper_arm." + sw: (5, 0, 0), "forearm." + sw: (20, 0, 0),
        }
    return [contact("L", "R"), passing("L", "R"), contact("R", "L"), passing("R", "L")][phase % 4]


# (frame, pose name or ("walk", phase), marker name or None).  24 fps, 240 frames = 10 s.
TIMELINE = [(1, "rest", "rest")]
for i, f in enumerate(range(9, 46, 6)):                  # 9, 15, ..., 45: two walk cycles of 24 frames
    TIMELINE.append((f, ("walk", i), "walk" if f == 21 else None))
TIMELINE += [
    (57, "rest", None), (60, "rest", None),
    (76, "arms_up", "arms_up"), (80, "arms_up", None), (96, "rest", None),
    (114, "knee_bend", "knee_bend"), (118, "knee_bend", None), (136, "rest", None),
    (150, "elbow_bend", "elbow_bend"), (154, "elbow_bend", None), (168, "rest", None),
    (184, "forearm_twist", "forearm_twist"), (188, "forearm_twist", None), (204, "rest", None),
    (220, "spine_bend", "spine_bend"), (224, "spine_bend", None), (240, "rest", None),
]
FRAME_END = 240


# --------------------------------------------------------------------------------------------
def log(*a):
    print("[make_character]", *a, flush=True)


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    out = os.path.dirname(os.path.abspath(__file__))
    variants, compress = ["light", "full"], True
    i = 0
    while i < len(argv):
        a = argv[i]
        if a == "--out":
            out = os.path.abspath(argv[i + 1]); i += 1
        elif a == "--variants":
            variants = [v for v in argv[i + 1].split(",") if v]; i += 1
        elif a == "--no-compress":
            compress = False
        else:
            raise SystemExit(f"make_character.py: unknown argument {a!r}")
        i += 1
    for v in variants:
        if v not in LEVELS:
            raise SystemExit(f"make_character.py: unknown variant {v!r}")
    return out, variants, compress


def build_meshes(levels):
    """Skin + Subdivision over the stick skeleton, evaluated (applied) at each level.
    Returns {level: bpy mesh} (not normalised)."""
    names = list(JOINTS)
    idx = {n: i for i, n in enumerate(names)}
    cage = bpy.data.meshes.new("StickSkeleton")
    cage.from_pydata([JOINTS[n][0] for n in names], [(idx[a], idx[b]) for a, b in EDGES], [])
    cage.update()
    ob = bpy.data.objects.new("StickSkeleton", cage)
    bpy.context.scene.collection.objects.link(ob)
    skin = ob.modifiers.new("Skin", 'SKIN')
    skin.branch_smoothing = 0.0
    skin.use_x_symmetry = True
    sv = cage.skin_vertices[0].data
    for n in names:
        sv[idx[n]].radius = JOINTS[n][1]
        sv[idx[n]].use_root = (n == "pelvis")
    sub = ob.modifiers.new("Subdivision", 'SUBSURF')
    sub.subdivision_type = 'CATMULL_CLARK'
    sub.quality = 3
    sub.use_limit_surface = True
    out = {}
    for lv in sorted(set(levels)):
        sub.levels = lv
        sub.render_levels = lv
        dg = bpy.context.evaluated_depsgraph_get()
        dg.update()
        me = bpy.data.meshes.new_from_object(ob.evaluated_get(dg))
        me.name = f"Body_L{lv}"
        # the Skin modifier's branch hulls can leave a few loose vertices behind: drop them
        bm = bmesh.new()
        bm.from_mesh(me)
        loose = [v for v in bm.verts if not v.link_edges]
        if loose:
            bmesh.ops.delete(bm, geom=loose, context='VERTS')
            bm.to_mesh(me)
        bm.free()
        me.update()
        out[lv] = me
    bpy.data.objects.remove(ob)
    bpy.data.meshes.remove(cage)
    return out


def mesh_coords(me):
    co = np.empty(len(me.vertices) * 3, np.float64)
    me.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def normalise(meshes, ref_level):
    """Scale about the origin so the reference mesh is HEIGHT tall, then lift it so min z = 0 and
    centre x.  Applies the same transform to all meshes and to the joint table.  Returns it."""
    co = mesh_coords(meshes[ref_level])
    lo, hi = co.min(0), co.max(0)
    s = HEIGHT / (hi[2] - lo[2])
    shift = Vector((0.0, 0.0, -lo[2] * s))
    M = Matrix.Translation(shift) @ Matrix.Scale(s, 4)
    for me in meshes.values():
        me.transform(M)
        me.update()
    for n, (p, r) in list(JOINTS.items()):
        JOINTS[n] = (tuple(M @ Vector(p)), r)
    return s, shift


def build_armature():
    arm_data = bpy.data.armatures.new("Armature")
    arm = bpy.data.objects.new("Armature", arm_data)
    bpy.context.scene.collection.objects.link(arm)
    arm_data.display_type = 'OCTAHEDRAL'
    arm.show_in_front = True
    bpy.context.view_layer.objects.active = arm
    arm.select_set(True)
    bpy.ops.object.mode_set(mode='EDIT')
    ebs = {}
    for name, parent, connected, head, tail, zdir in bone_table():
        eb = arm_data.edit_bones.new(name)
        eb.head = Vector(head)
        eb.tail = Vector(tail)
        eb.align_roll(Vector(zdir))
        if parent:
            eb.parent = ebs[parent]
            eb.use_connect = connected
        eb.use_deform = True
        ebs[name] = eb
    bpy.ops.object.mode_set(mode='OBJECT')
    for pb in arm.pose.bones:
        pb.rotation_mode = 'QUATERNION'
    return arm


def pose_quats(pose):
    out = {}
    for name, rot in pose.items():
        q = Euler([math.radians(a) for a in rot], 'XYZ').to_quaternion()
        if abs(q.w) < 1e-6:      # mathutils works in float32: cos(90 deg) comes out as -4.4e-8
            q.w = 0.0           # exactly 180 deg: keep the vector part's sign (it gives the turning direction)
        elif q.w < 0.0:
            q.negate()
        out[name] = q
    return out


def apply_pose(arm, pose, ground):
    """Set the pose bones to `pose` (dict name -> XYZ degrees) and move the pelvis so the feet keep
    contact.  Contact points per foot: heel, ankle, ball and toe tip (followed through the foot and
    toe bones).  ground == "lowest": lift/lower the body so that no contact point is below its rest
    height and at least one is on it; "feet": both ankles return (on average) to their rest Y and Z."""
    q = pose_quats(pose)
    for pb in arm.pose.bones:
        pb.rotation_quaternion = q.get(pb.name, (1.0, 0.0, 0.0, 0.0))
        pb.location = (0.0, 0.0, 0.0)
    bpy.context.view_layer.update()
    off = Vector((0.0, 0.0, 0.0))
    if ground == "lowest":
        lift = -1e9
        for s in "LR":
            pts = [("foot." + s, Vector(JOINTS["heel." + s][0])), ("foot." + s, Vector(JOINTS["ankle." + s][0])),
                   ("toe." + s, Vector(JOINTS["ball." + s][0])), ("toe." + s, Vector(JOINTS["toe." + s][0]))]
            for bname, p in pts:
                rest_m = arm.data.bones[bname].matrix_local
                posed = arm.pose.bones[bname].matrix @ (rest_m.inverted() @ p)
                lift = max(lift, p.z - posed.z)
        off.z = lift
    elif ground == "feet":
        rest = {s: arm.data.bones["foot." + s].head_local.copy() for s in "LR"}
        posed = {s: arm.pose.bones["foot." + s].head.copy() for s in "LR"}
        d = ((rest["L"] - posed["L"]) + (rest["R"] - posed["R"])) / 2
        off.y, off.z = d.y, d.z
    # a pose bone's location is in its rest frame (before its own rotation)
    arm.pose.bones["pelvis"].location = arm.data.bones["pelvis"].matrix_local.to_3x3().inverted() @ off
    bpy.context.view_layer.update()


def build_action(arm):
    scene = bpy.context.scene
    act = bpy.data.actions.new("demo_motion")
    arm.animation_data_create()
    arm.animation_data.action = act      # 5.x: the first keyframe_insert adds and assigns a slot
    prev = None
    for frame, what, marker in TIMELINE:
        if isinstance(what, tuple):
            pose, ground = walk_pose(what[1]), "lowest"
        else:
            pose, ground = POSES[what], ("feet" if what == "knee_bend" else "none")
        apply_pose(arm, pose, ground)
        # keep quaternion signs continuous between keys (q and -q are the same rotation)
        for pb in arm.pose.bones:
            if prev is not None and pb.rotation_quaternion.dot(prev[pb.name]) < -1e-6:
                pb.rotation_quaternion.negate()
        prev = {pb.name: pb.rotation_quaternion.copy() for pb in arm.pose.bones}
        for pb in arm.pose.bones:
            pb.keyframe_insert("rotation_quaternion", frame=frame, group=pb.name)
        arm.pose.bones["pelvis"].keyframe_insert("location", frame=frame, group="pelvis")
        if marker:
            scene.timeline_markers.new(marker, frame=frame)
    if arm.animation_data.action is not act:     # keyframe_insert must have used ours
        raise RuntimeError("keyframes went to another action")
    scene.render.fps = FPS
    scene.render.fps_base = 1.0
    scene.frame_start = 1
    scene.frame_end = FRAME_END
    scene.frame_set(1)
    return act


def vertex_weight_sums(ob):
    names = {vg.index: vg.name for vg in ob.vertex_groups}
    bones = set(b.name for b in bpy.data.objects["Armature"].data.bones)
    sums = np.zeros(len(ob.data.vertices))
    for v in ob.data.vertices:
        for g in v.groups:
            if names.get(g.group) in bones and g.weight > 0.0:
                sums[v.index] += g.weight
    return sums


def bind(body, arm):
    """Parent with automatic weights; fill vertices left unweighted from the nearest weighted one."""
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    body.select_set(True)
    arm.select_set(True)
    bpy.context.view_layer.objects.active = arm
    arm.data.pose_position = 'REST'
    bpy.context.view_layer.update()
    t = time.time()
    res = bpy.ops.object.parent_set(type='ARMATURE_AUTO')
    dt = time.time() - t
    arm.data.pose_position = 'POSE'
    if 'FINISHED' not in res or body.parent is not arm:
        raise RuntimeError(f"parent_set(ARMATURE_AUTO) failed: {res}")
    mods = [m for m in body.modifiers if m.type == 'ARMATURE']
    if len(mods) != 1 or mods[0].object is not arm:
        raise RuntimeError("no Armature modifier after parent_set")
    sums = vertex_weight_sums(body)
    missing = np.flatnonzero(sums <= 0.0)
    if len(missing):
        log(f"  {len(missing)} vertices without weights after bone heat: copying from nearest weighted vertex")
        co = mesh_coords(body.data)
        ok = np.flatnonzero(sums > 0.0)
        kd = KDTree(len(ok))
        for i in ok:
            kd.insert(co[i], int(i))
        kd.balance()
        src = {int(i): kd.find(co[i])[1] for i in missing}
        vgs = body.vertex_groups
        copy = {i: [(g.group, g.weight) for g in body.data.vertices[j].groups if g.weight > 0] for i, j in src.items()}
        for i, ws in copy.items():
            for gi, w in ws:
                vgs[gi].add([i], w, 'REPLACE')
    # bone heat drops tiny weights, so sums are 0.9..1: normalise to exactly 1 (the Armature
    # modifier divides by the sum anyway, so the deformation in Blender is unchanged)
    for v in body.data.vertices:
        tot = sum(g.weight for g in v.groups)
        if tot > 0.0:
            for g in v.groups:
                g.weight /= tot
    return dt, len(missing)


def save(path, compress):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    bpy.context.scene.frame_set(1)
    if os.path.exists(path):
        os.remove(path)
    bpy.ops.wm.save_as_mainfile(filepath=path, compress=compress, check_existing=False)


def main():
    t0 = time.time()
    out, variants, compress = parse_args()
    os.makedirs(out, exist_ok=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.name = "Scene"
    scene.unit_settings.system = 'METRIC'

    levels = {v: LEVELS[v] for v in variants}
    meshes = build_meshes(list(levels.values()) + [LEVELS["full"]])
    scale, shift = normalise(meshes, LEVELS["full"])
    log(f"Blender {bpy.app.version_string}; normalised: scale {scale:.5f}, lift {shift.z:.5f} m")
    for lv, me in sorted(meshes.items()):
        b, nm, c, _ = topology_counts(me)
        co = mesh_coords(me)
        log(f"  level {lv}: {len(me.vertices)} vertices, {len(me.polygons)} faces, boundary {b}, "
            f"non-manifold {nm}, components {c}, z {co[:, 2].min():.4f}..{co[:, 2].max():.4f}")
        if b or nm or c != 1:
            raise RuntimeError("generated mesh is not closed/manifold/connected")

    arm = build_armature()
    act = build_action(arm)
    log(f"  armature: {len(arm.data.bones)} bones; action {act.name!r}, frames 1..{FRAME_END}, "
        f"markers {[(m.name, m.frame) for m in sorted(scene.timeline_markers, key=lambda m: m.frame)]}")

    for v in variants:
        t = time.time()
        me = meshes[levels[v]]
        me.name = "Body"
        if hasattr(me, "shade_smooth"):
            me.shade_smooth()
        body = bpy.data.objects.new("Body", me)
        scene.collection.objects.link(body)
        scene.frame_set(1)
        dt, filled = bind(body, arm)
        path = os.path.join(out, FILES[v])
        save(path, compress)
        log(f"  {v}: {len(me.vertices)} vertices, automatic weights {dt:.1f} s, {filled} filled -> {path} "
            f"({os.path.getsize(path) / 1e6:.2f} MB, {time.time() - t:.1f} s)")
        bpy.data.objects.remove(body)
        bpy.data.meshes.remove(me)
    log(f"done in {time.time() - t0:.1f} s")
    if bpy.app.version >= (4, 4, 0):
        log(f"note: files saved by Blender {bpy.app.version_string} may not open in Blender 4.3; "
            "the committed fixtures are made with --use 4.3")


if __name__ == "__main__":
    main()
