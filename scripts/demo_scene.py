# SPDX-License-Identifier: GPL-3.0-or-later
"""The demo, run inside Blender by scripts/demo:

    blender -b --factory-startup --python scripts/demo_scene.py -- --out DIR
            [--character FILE.blend|.glb|.gltf|.fbx] [--action NAME] [--zip ADDON.zip]
            [--poses NAME,...] [--motion-step N (0: no clip)] [--timing-frames N (0: no timing)]

It installs the extension, loads the character (default: the CC0 MakeHuman male in
blend_fixtures/; a character without an action gets the demo motion of
blender_support/demo_motion.py, one key pose per joint),
puts four copies side by side — Blender's Armature modifier (plain), the Armature modifier with
"Preserve Volume", Sweep Deform, and Sweep Deform with its anatomical effects (skin folding,
bone protrusion, muscle bulge at the elbows and knees) — plays the action, and writes to DIR:

  poses/<pose>.png        one picture per key pose, the methods left to right
  poses/<pose>_<joint>_l.png close-ups of the left shoulder, elbow, forearm (twist), knee, hip and
                          spine where the pose bends them, the methods left to right, each
                          framed so that the whole limb (or the upper body) is in the picture
  motion/frame_NNNN.png   the motion as a short clip of frames
  report.json, report.md  per pose and method: volume change of each limb and of the body,
                          intersecting skin triangle pairs at each joint (shoulders, elbows,
                          hips, knees, neck, spine), the smallest forearm
                          cross-section relative to rest, and ms per frame

The figures come from the core's measurement functions (sd_measure_*), the same for all
methods, on the evaluated meshes Blender produces.
"""

import argparse
import json
import os
import sys
import time

import bpy
import numpy as np
from mathutils import Matrix, Vector

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "scripts", "blender_support"))
import install  # noqa: E402  (the installer the tests use too: the same path a user takes)
import limb_volume  # noqa: E402  (closed volume of a skin region, numpy only)
import demo_motion  # noqa: E402  (a key pose per joint for a character without an action)

METHODS = [
    ("armature", "Armature modifier"),
    ("preserve_volume", "Armature, Preserve Volume"),
    ("sweep_deform", "Sweep Deform"),
    ("sweep_deform_fx", "Sweep Deform + effects"),
]
#: Methods that bind Sweep Deform, and whether with the anatomical effects.
SWEEP_METHODS = {"sweep_deform": False, "sweep_deform_fx": True}
DEFAULT_POSES = ["rest", "walk", "arms_up", "elbow_bend", "forearm_twist", "knee_bend", "hip_flex", "spine_bend"]
#: The default character: the CC0 MakeHuman male (blend_fixtures/README.md says what it is).
DEFAULT_CHARACTER = os.path.join(REPO, "blend_fixtures", "mh_male_game_engine_subdiv1.blend")


def parse_args():
    p = picture_parser("demo_scene.py")
    p.add_argument("--action", default="")
    p.add_argument("--motion-step", type=int, default=6, help="render every Nth frame of the clip")
    p.add_argument("--timing-frames", type=int, default=40, help="0: no timing")
    p.add_argument("--poses", default="", help="only these key poses (comma-separated; rest is always measured)")
    return p.parse_args(script_argv())


# ---- scene ------------------------------------------------------------------------------

def load_character(path, action_name):
    """Opens or imports the character; returns (armature, body)."""
    ext = os.path.splitext(path)[1].lower()
    if ext == ".blend":
        bpy.ops.wm.open_mainfile(filepath=path)
    else:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        if ext in (".glb", ".gltf"):
            bpy.ops.import_scene.gltf(filepath=path)
        elif ext == ".fbx":
            bpy.ops.import_scene.fbx(filepath=path)
        else:
            sys.exit(f"demo: unsupported character file {path} (use .blend, .glb, .gltf or .fbx)")
    arms = [o for o in bpy.context.scene.objects if o.type == 'ARMATURE']
    if not arms:
        sys.exit(f"demo: {path} has no armature")
    bodies = [o for o in bpy.context.scene.objects if o.type == 'MESH' and any(
        m.type == 'ARMATURE' and m.object in arms for m in o.modifiers)]
    if not bodies:
        sys.exit(f"demo: {path} has no mesh deformed by an armature")
    body = max(bodies, key=lambda o: len(o.data.vertices))
    arm = next(m.object for m in body.modifiers if m.type == 'ARMATURE' and m.object in arms)
    for o in list(bpy.context.scene.objects):
        if o not in (arm, body) and o.type in ('MESH', 'ARMATURE', 'CURVE', 'FONT', 'EMPTY'):
            o.hide_render = True
    if action_name:
        action = bpy.data.actions.get(action_name)
        if action is None:
            sys.exit(f"demo: no action named {action_name!r}; have {[a.name for a in bpy.data.actions]}")
        arm.animation_data_create().action = action
    if not (arm.animation_data and arm.animation_data.action):
        # No motion in the file (the MakeHuman male has none): key one pose per joint.
        if demo_motion.add_demo_motion(arm, bpy.context.scene) is None:
            sys.exit("demo: the armature has no action and no bones the demo motion knows; give one with --action")
        print(f"demo: no action in {os.path.basename(path)}; keyed the demo motion "
              f"({', '.join(m.name for m in bpy.context.scene.timeline_markers)})", flush=True)
    return arm, body


def key_poses(scene, action):
    """[(name, frame)]: the timeline markers, or evenly spread frames of the action."""
    marks = {m.name: m.frame for m in scene.timeline_markers}
    if marks:
        named = [(n, marks[n]) for n in DEFAULT_POSES if n in marks]
        rest = [(n, f) for n, f in sorted(marks.items(), key=lambda x: x[1]) if n not in DEFAULT_POSES]
        return named + rest
    start, end = (int(x) for x in action.frame_range)
    return [("rest", start)] + [(f"frame_{int(f)}", int(f)) for f in np.linspace(start, end, 6).astype(int)[1:]]


def copied_character(arm, body):
    """A copy of the character in the same collections: the armature object sharing the
    armature data (its animation data copied: action, slot), the body with its own mesh,
    parented to the copied armature if the body was to the armature."""
    a = arm.copy()
    b = body.copy()
    b.data = body.data.copy()
    for coll in arm.users_collection:
        coll.objects.link(a)
    for coll in body.users_collection:
        coll.objects.link(b)
    if body.parent == arm:
        b.parent = a
    return a, b


def method_modifier(arm, body, key):
    """Points the body's Armature modifier at `arm`, with Preserve Volume for that method."""
    mod = next(m for m in body.modifiers if m.type == 'ARMATURE')
    mod.object = arm
    mod.use_deform_preserve_volume = key == "preserve_volume"


def picture_parser(prog):
    """The arguments every picture script takes: --out PNG, --zip (the extension to install) and
    --character (the shipped MakeHuman male by default); the script adds its own."""
    p = argparse.ArgumentParser(prog=prog)
    p.add_argument("--out", required=True)
    p.add_argument("--character", default=DEFAULT_CHARACTER)
    p.add_argument("--zip", default=install.default_zip())
    return p


def script_argv():
    """Blender's command line after `--` (the script's own arguments)."""
    return sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


#: Blender's two deformers and ours, for pictures side by side.
DEFORMERS = (("armature", "Armature"), ("preserve_volume", "Preserve Volume"), ("sweep_deform", "Sweep Deform"))


def put_at_rest(arm):
    """No action, every pose bone at its rest."""
    if arm.animation_data:
        arm.animation_data.action = None
    for pb in arm.pose.bones:
        pb.matrix_basis = Matrix.Identity(4)


def bind(arm, body, script):
    """Binds `body` to `arm` with Sweep Deform's automatic fitting (as an artist adds it); exits
    naming `script` if that fails."""
    with bpy.context.temp_override(object=body, active_object=body, selected_objects=[body]):
        if bpy.ops.object.sweep_deform_add(armature=arm.name) != {'FINISHED'}:
            sys.exit(f"{script}: binding failed: {body.sweep_deform.message}")


def deformer_copies(arm, body, script):
    """The character at rest in one copy per DEFORMERS entry (the first is the character
    itself): [(armature, body, label)], the last bound by Sweep Deform's automatic fitting;
    exits naming `script` if the binding fails."""
    put_at_rest(arm)
    columns = []
    for i, (key, label) in enumerate(DEFORMERS):
        a, b = (arm, body) if i == 0 else copied_character(arm, body)
        method_modifier(a, b, key)
        columns.append((a, b, label))
    bpy.context.view_layer.update()
    a, b, _ = columns[-1]
    bind(a, b, script)
    return columns


def make_columns(arm, body, spacing):
    """One (armature, body) pair per method, side by side; the original is the first. The
    Sweep Deform columns are each bound (the same automatic fitting), the last with the
    anatomical effects on."""
    columns = []
    for i, (key, label) in enumerate(METHODS):
        a, b = (arm, body) if i == 0 else copied_character(arm, body)
        a.location.x += i * spacing
        method_modifier(a, b, key)
        columns.append({"key": key, "label": label, "arm": a, "body": b})
    bpy.context.view_layer.update()
    for sweep in columns:
        if sweep["key"] not in SWEEP_METHODS:
            continue
        with bpy.context.temp_override(object=sweep["body"], active_object=sweep["body"],
                                       selected_objects=[sweep["body"]]):
            result = bpy.ops.object.sweep_deform_add(armature=sweep["arm"].name)
        if result != {'FINISHED'}:
            sys.exit(f"demo: binding Sweep Deform failed: {sweep['body'].sweep_deform.message}")
        if SWEEP_METHODS[sweep["key"]]:
            s = sweep["body"].sweep_deform
            s.use_anatomy = True
            if not len(s.joints):
                sys.exit("demo: no elbows or knees for the anatomical effects in the fitting report")
            print(f"demo: anatomical effects on at {', '.join(j.name for j in s.joints)}", flush=True)
    bpy.context.view_layer.update()
    return columns


def world_bbox(objs):
    pts = np.array([o.matrix_world @ Vector(c) for o in objs for c in o.bound_box])
    return pts.min(axis=0), pts.max(axis=0)


def setup_render(scene, width, height):
    scene.render.engine = 'BLENDER_WORKBENCH'
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = 'PNG'
    scene.display.shading.light = 'STUDIO'
    scene.display.shading.color_type = 'SINGLE'
    scene.display.shading.single_color = SKIN[:3]
    scene.display.shading.show_cavity = True
    scene.display.render_aa = '8'
    if scene.world is None:
        scene.world = bpy.data.worlds.new("World")
    scene.world.color = (0.92, 0.92, 0.92)


def ortho_camera(scene, name, ortho_scale):
    """A new orthographic camera, the scene's camera from now on."""
    cam = bpy.data.objects.new(name, bpy.data.cameras.new(name))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.data.type = 'ORTHO'
    cam.data.ortho_scale = ortho_scale
    cam.data.clip_end = 100.0
    return cam


def front_camera(scene, lo, hi, margin=1.08):
    """Orthographic camera looking along +Y (characters face -Y) framing the box [lo, hi]."""
    cam = scene.camera
    if cam is None or cam.type != 'CAMERA':
        cam = bpy.data.objects.new("DemoCamera", bpy.data.cameras.new("DemoCamera"))
        scene.collection.objects.link(cam)
        scene.camera = cam
    cam.data.type = 'ORTHO'
    center = (lo + hi) / 2
    w, h = hi[0] - lo[0], hi[2] - lo[2]
    aspect = scene.render.resolution_x / scene.render.resolution_y
    cam.data.ortho_scale = margin * max(w, h * aspect)
    cam.location = (center[0], lo[1] - 10.0, center[2])
    cam.rotation_euler = (np.pi / 2, 0.0, 0.0)
    cam.data.clip_end = 100.0
    return cam


def add_label(text, location, size):
    curve = bpy.data.curves.new("label", 'FONT')
    curve.body = text
    curve.align_x = 'CENTER'
    curve.size = size
    obj = bpy.data.objects.new("label", curve)
    obj.location = location
    obj.rotation_euler = (np.pi / 2, 0.0, 0.0)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def render(scene, path):
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)


def render_strip(scene, path, views, per_row=None):
    """Renders one picture per view and writes them side by side, left to right, to `path`
    (PNG); with `per_row`, in rows of that many, the first row on top. `views`: functions that
    each place the scene's camera for one picture."""
    tiles = []
    for i, place_camera in enumerate(views):
        place_camera()
        tile = path[:-4] + f"_{i}.png"
        render(scene, tile)
        img = bpy.data.images.load(tile)
        tiles.append(np.array(img.pixels[:], np.float32).reshape(img.size[1], img.size[0], 4))
        bpy.data.images.remove(img)
        os.remove(tile)
    per_row = per_row or len(tiles)
    rows = [np.concatenate(tiles[i:i + per_row], axis=1) for i in range(0, len(tiles), per_row)]
    strip = np.concatenate(rows[::-1], axis=0)  # Blender's pixels start at the bottom
    img = bpy.data.images.new("strip", strip.shape[1], strip.shape[0], alpha=True)
    img.pixels.foreach_set(strip.ravel())
    img.filepath_raw = os.path.abspath(path)
    img.file_format = 'PNG'
    img.save()
    bpy.data.images.remove(img)


#: Poses that get a close-up, and of which joint of the character's left side.
CLOSE_UPS = {"arms_up": "shoulder", "elbow_bend": "elbow", "forearm_twist": "forearm",
             "knee_bend": "knee", "hip_flex": "hip", "spine_bend": "spine"}
#: Short labels for the close-ups (the tiles are narrow).
SHORT_LABELS = {"armature": "Armature", "preserve_volume": "Preserve Volume",
                "sweep_deform": "Sweep Deform", "sweep_deform_fx": "Sweep + effects"}
#: Per joint: the bone roles (demo_motion.ROLES) whose skin the picture must hold whole.
#: ("@r": the right side's bone.) A limb is shown whole from the joint down (hand with the
#: fingers, foot with the toes), so that no part of it is cut off at the frame's edge.
CLOSE_UP_BONES = {
    # both arms: the picture is of the left armpit, but a raised right arm would be cut in two
    "shoulder": ["spine_03", "head", "clavicle_{s}", "upperarm_{s}", "lowerarm_{s}", "hand_{s}",
                 "clavicle_{s}@r", "upperarm_{s}@r", "lowerarm_{s}@r", "hand_{s}@r"],
    "elbow": ["upperarm_{s}", "lowerarm_{s}", "hand_{s}"],
    "forearm": ["lowerarm_{s}", "hand_{s}"],
    "knee": ["thigh_{s}", "calf_{s}", "foot_{s}"],
    "hip": ["pelvis", "thigh_{s}", "calf_{s}", "foot_{s}"],
    "spine": ["pelvis", "spine_01", "spine_02", "spine_03", "neck", "head",
              "clavicle_{s}", "upperarm_{s}", "lowerarm_{s}", "hand_{s}"],
}
SKIN = (0.8, 0.62, 0.52, 1.0)
INK = (0.05, 0.05, 0.05, 1.0)


def close_up_vertices(col, dom_names, joint):
    """Vertices (mask) whose heaviest bone is one of the joint's bones or, for the hand, any
    bone below it (the fingers)."""
    arm = col["arm"]
    names = set()
    for role in CLOSE_UP_BONES[joint]:
        role, _, side = role.partition("@")
        pb = demo_motion.bone(arm, role, side or "l")
        if pb is None:
            continue
        names.add(pb.name)
        if role.startswith(("hand", "foot")):
            names.update(c.name for c in pb.bone.children_recursive)
    return np.isin(dom_names, sorted(names)) if names else None


def close_up_axes(col, joint):
    """(look, up): the camera's viewing direction and its up vector, in world space."""
    arm = col["arm"]
    m = arm.matrix_world.to_3x3()

    def posed_dir(role):
        pb = demo_motion.bone(arm, role, "l")
        return None if pb is None else (m @ (pb.tail - pb.head)).normalized()

    up = Vector((0, 0, 1))
    if joint == "elbow":
        du, dl = posed_dir("upperarm_{s}"), posed_dir("lowerarm_{s}")
        if du is not None and dl is not None and du.cross(dl).length > 0.2:
            look = du.cross(dl).normalized()
            if look.x > 0:  # look from the outside of the arm, inwards
                look = -look
            return look, (up - up.dot(look) * look).normalized()
        return Vector((-1, 0, 0)), up
    if joint == "forearm":
        d = posed_dir("lowerarm_{s}")
        look = Vector((0, 1, 0))
        if d is not None:
            look = (look - look.dot(d) * d).normalized()
            return look, look.cross(d).normalized() if look.cross(d).z >= 0 else -look.cross(d).normalized()
        return look, up
    if joint == "shoulder":
        return Vector((0, 1, 0)), up  # from the front
    return Vector((-1, 0, 0)), up     # knee, hip, spine: from the character's left


def render_close_up(scene, columns, dom_names, labels, joint, path, tile_px=560, label_px=34):
    """The joint of the character's left side, one picture per method tiled left to right,
    each framed so that the skin of the joint's bones is whole in it, with the method's name
    on top. Other columns (and the full view's labels) are hidden meanwhile."""
    saved = (scene.render.resolution_x, scene.render.resolution_y, scene.camera.location.copy(),
             scene.camera.rotation_euler.copy(), scene.camera.data.ortho_scale)
    for lab in labels:
        lab.hide_render = True
    dg = bpy.context.evaluated_depsgraph_get()
    views = []
    for col in columns:
        mask = close_up_vertices(col, dom_names, joint)
        if mask is None or not mask.any():
            continue
        look, up = close_up_axes(col, joint)
        right = look.cross(up)
        pos = evaluated_positions(col["body"], dg)[mask]
        mw = np.array(col["body"].matrix_world)
        pos = pos @ mw[:3, :3].T + mw[:3, 3]
        r, u = pos @ np.array(right), pos @ np.array(up)
        views.append((col, look, up, right, (r.min(), r.max()), (u.min(), u.max())))
    if not views:
        return
    # One size for every method (the widest and tallest of them), 10 % margin on each side
    # and a band on top for the label.
    w = 1.2 * max(v[4][1] - v[4][0] for v in views)
    h = max(1.2 * max(v[5][1] - v[5][0] for v in views), 0.6 * w)
    # The label: label_px high at the output resolution, on a light band above the skin.
    scale = tile_px / max(w, h / 0.8)
    size = label_px / scale
    band = 2.0 * size
    h += band
    scale = tile_px / max(w, h)
    scene.render.resolution_x, scene.render.resolution_y = int(round(w * scale)), int(round(h * scale))
    tiles = []
    for col, look, up, right, (r0, r1), (u0, u1) in views:
        for other in columns:
            other["body"].hide_render = other is not col
        center = right * float((r0 + r1) / 2) + up * float((u0 + u1) / 2 + band / 2)
        # The depth of the centre along `look`: the joint's own skin.
        pos_depth = float(np.mean([look.dot(Vector(p)) for p in
                                   [col["body"].matrix_world @ Vector(c) for c in col["body"].bound_box]]))
        center += look * (pos_depth - look.dot(center))
        cam = scene.camera
        cam.location = center - 10.0 * look
        cam.rotation_euler = Matrix((right, up, -look)).transposed().to_euler()
        cam.data.ortho_scale = max(w, h)
        label = add_label(SHORT_LABELS.get(col["key"], col["label"]),
                          center + up * (h / 2 - band * 0.72) - 5.0 * look, size)
        label.rotation_euler = cam.rotation_euler
        label.color = INK
        backing = label_band(center + up * (h / 2 - band / 2) - 4.0 * look, cam.rotation_euler, w, band)
        tile = path[:-4] + f"_{col['key']}.png"
        render(scene, tile)
        bpy.data.objects.remove(label)
        bpy.data.objects.remove(backing)
        img = bpy.data.images.load(tile)
        px = np.array(img.pixels[:], np.float32).reshape(img.size[1], img.size[0], 4)
        bpy.data.images.remove(img)
        os.remove(tile)
        # A thin grey line between the methods.
        px[:, -2:, :3] = 0.6
        tiles.append(px)
    for col in columns:
        col["body"].hide_render = False
    for lab in labels:
        lab.hide_render = False
    (scene.render.resolution_x, scene.render.resolution_y, scene.camera.location,
     scene.camera.rotation_euler, scene.camera.data.ortho_scale) = saved
    strip = np.concatenate(tiles, axis=1)
    img = bpy.data.images.new("closeup", strip.shape[1], strip.shape[0], alpha=True)
    img.pixels.foreach_set(strip.ravel())
    img.filepath_raw = path
    img.file_format = 'PNG'
    img.save()
    bpy.data.images.remove(img)


def label_band(center, rotation, width, height):
    """A flat light rectangle (facing the camera) that the label stands on."""
    mesh = bpy.data.meshes.new("label_band")
    mesh.from_pydata([(-width, -height / 2, 0), (width, -height / 2, 0), (width, height / 2, 0),
                      (-width, height / 2, 0)], [], [(0, 1, 2, 3)])
    obj = bpy.data.objects.new("label_band", mesh)
    obj.location, obj.rotation_euler, obj.color = center, rotation, (0.93, 0.93, 0.93, 1.0)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def dominant_bone_names(body):
    """Per vertex: the name of its heaviest vertex group ('' if none)."""
    names = {g.index: g.name for g in body.vertex_groups}
    dominant = np.full(len(body.data.vertices), -1, np.int64)
    best = np.zeros(len(body.data.vertices))
    for v in body.data.vertices:
        for g in v.groups:
            if g.weight > best[v.index]:
                best[v.index], dominant[v.index] = g.weight, g.group
    group_names = np.array([names.get(i, "") for i in range(max(names) + 1)] if names else [""])
    return np.where(dominant >= 0, group_names[np.clip(dominant, 0, None)], "")


# ---- measurements ------------------------------------------------------------------------

def evaluated_positions(obj, depsgraph):
    ev = obj.evaluated_get(depsgraph)
    me = ev.to_mesh()
    co = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", co)
    ev.to_mesh_clear()
    return co.reshape(-1, 3)


def chains_from_report(body):
    """The fitted chains (kind, bone names, end bone) from the binding's report."""
    try:
        report = json.loads(body.get("_sweep_deform_fit_report", "") or "{}")
    except ValueError:
        report = {}
    return [c for c in report.get("chains", []) if c.get("sweep", -1) >= 0]


def limb_regions(dom_names, chains):
    """Per chain: the vertices whose heaviest vertex group is one of the chain's bones."""
    return {c["name"]: np.isin(dom_names, c["bone_names"]) for c in chains}


def limb_volumes(regions, tris):
    """Per chain: its region's triangles (all three vertices in it) as a limb_volume.ClosedRegion,
    whose volume (the region closed by a cap over each of its rings) is the chain's volume."""
    return {name: limb_volume.ClosedRegion(tris, np.flatnonzero(mask[tris].all(axis=1)))
            for name, mask in regions.items()}


def joints(arm, body, chains):
    """{joint name: (position in body space, radius of its region)}: elbows, knees,
    shoulders, hips and the neck base, found from the fitted chains."""
    to_body = body.matrix_world.inverted() @ arm.matrix_world
    out = {}
    for c in chains:
        bones = [arm.pose.bones.get(n) for n in c["bone_names"]]
        if any(b is None for b in bones):
            continue
        side = c["name"].split("_")[-1] if "_" in c["name"] else ""
        length = sum(b.length for b in bones)
        if c["kind"] in ("arm", "leg") and len(bones) >= 2:
            mid = "elbow" if c["kind"] == "arm" else "knee"
            top = "shoulder" if c["kind"] == "arm" else "hip"
            out[f"{mid}_{side}"] = (np.array(to_body @ bones[-1].head), 0.22 * length)
            out[f"{top}_{side}"] = (np.array(to_body @ bones[-2].head), 0.22 * length)
        elif c["kind"] == "neck":
            out["neck"] = (np.array(to_body @ bones[0].head), 0.5 * length)
        elif c["kind"] == "torso" and len(bones) >= 2:
            # The waist: the middle of the torso chain, half its length around.
            mid = bones[len(bones) // 2]
            out["spine"] = (np.array(to_body @ mid.head), 0.5 * length)
    return out


def forearm_planes(arm, body, chains, fractions=(0.35, 0.5, 0.65, 0.8, 0.9)):
    """Planes orthogonal to each forearm at fractions of its length: (points, normals)."""
    to_body = body.matrix_world.inverted() @ arm.matrix_world
    pts, nrm = [], []
    for c in chains:
        if c["kind"] != "arm":
            continue
        fore = arm.pose.bones.get(c["bone_names"][-1])
        if fore is None:
            continue
        h, t = np.array(to_body @ fore.head), np.array(to_body @ fore.tail)
        for f in fractions:
            pts.append(h + f * (t - h))
            nrm.append((t - h) / np.linalg.norm(t - h))
    return np.array(pts, np.float32).reshape(-1, 3), np.array(nrm, np.float32).reshape(-1, 3)


def measure(columns, chains, tris, native, limbs, height):
    """Figures of every method at the current frame."""
    dg = bpy.context.evaluated_depsgraph_get()
    out = {}
    for col in columns:
        arm, body = col["arm"], col["body"]
        pos = evaluated_positions(body, dg)
        fig = {"body_volume": native.measure_volume(pos, tris)}
        fig["limb_volumes"] = {name: limb.volume(pos) for name, limb in limbs.items()}
        centroids = pos[tris].mean(axis=1)
        fig["intersections"] = {}
        for name, (p, r) in joints(arm, body, chains).items():
            subset = np.nonzero(np.linalg.norm(centroids - p, axis=1) < r)[0].astype(np.int32)
            fig["intersections"][name] = int(native.measure_intersections(pos, tris, subset)) if len(subset) else 0
        points, normals = forearm_planes(arm, body, chains)
        fig["forearm_sections"] = (native.measure_cross_sections(pos, tris, points, normals, 0.05 * height).tolist()
                                   if len(points) else [])
        out[col["key"]] = fig
    return out


def time_methods(scene, columns, frames, rounds=5):
    """ms per frame from pose change to evaluated mesh, per method: frame changes with only that
    method's body visible, and once with no body at all ("armature only": armature evaluation
    and scene overhead, which every method pays). Rounds alternate between the methods so that a
    busy machine slows them alike; each figure is the median over the rounds."""
    from bl_ext.user_default.sweep_deform.blender import modifier  # noqa: E402 (installed by now)
    sweep_mods = {col["key"]: modifier.find(col["body"]) for col in columns}

    def run(active):
        for col in columns:
            col["body"].hide_viewport = col is not active
            # The add-on's frame handler evaluates hidden bodies too: only the active column's
            # Sweep Deform may run, or its cost lands in another method's figure.
            if sweep_mods[col["key"]] is not None:
                sweep_mods[col["key"]].show_viewport = col is active
        bpy.context.view_layer.update()
        dg = bpy.context.evaluated_depsgraph_get()
        scene.frame_set(frames[-1])
        t0 = time.perf_counter()
        for f in frames:
            scene.frame_set(f)
            if active is not None:
                active["body"].evaluated_get(dg).data  # noqa: B018 (forces the evaluated mesh)
        return (time.perf_counter() - t0) * 1000.0 / len(frames)

    samples = {key: [] for key in ["armature_only"] + [col["key"] for col in columns]}
    for _ in range(rounds):
        samples["armature_only"].append(run(None))
        for col in columns:
            samples[col["key"]].append(run(col))
    for col in columns:
        col["body"].hide_viewport = False
        if sweep_mods[col["key"]] is not None:
            sweep_mods[col["key"]].show_viewport = True
    return {key: float(np.median(v)) for key, v in samples.items()}


# ---- report ------------------------------------------------------------------------------

def relative(figs, rest):
    """Per method: the figures relative to the rest pose (percent changes, ratios)."""
    rel = {}
    for key, f in figs.items():
        r = rest[key]
        limb = {n: 100.0 * (v / r["limb_volumes"][n] - 1.0) if r["limb_volumes"][n] else 0.0
                for n, v in f["limb_volumes"].items()}
        sections = [s / rs for s, rs in zip(f["forearm_sections"], r["forearm_sections"]) if rs > 0]
        rel[key] = {
            "body_volume_change_percent": 100.0 * (f["body_volume"] / r["body_volume"] - 1.0),
            "limb_volume_change_percent": limb,
            "intersecting_pairs": f["intersections"],
            "smallest_forearm_section_vs_rest": min(sections) if sections else None,
        }
    return rel


def write_report(out_dir, info, poses, timing, timing_frames):
    with open(os.path.join(out_dir, "report.json"), "w") as f:
        json.dump({"character": info, "ms_per_frame": timing, "poses": poses}, f, indent=2)
    lines = [f"# Sweep Deform demo report: {info['name']}", "",
             f"{info['vertices']} vertices, {info['triangles']} triangles, Blender {bpy.app.version_string}. "
             "Volumes and cross-sections are relative to the same method at the rest pose; "
             "intersecting pairs are pairs of skin triangles near the joint that cross each other "
             "(exact test). Limb volume: the skin of the limb's region (vertices whose heaviest weight is one of "
             "its bones) closed by a cap over each ring where it meets the rest of the body.", "",
             "## Time per frame (pose change to evaluated mesh)", "",
             f"Median of 5 alternating rounds over {timing_frames} frames of the clip, with only that "
             "method's body in the scene; \"armature only\" is the same with no body (armature "
             "evaluation and scene overhead, which every method includes).", "",
             "| method | ms per frame |", "|---|---|"]
    lines += [f"| {label} | {timing[key]:.2f} |" for key, label in [("armature_only", "armature only")] + METHODS]
    for pose in poses:
        lines += ["", f"## {pose['name']} (frame {pose['frame']})", "",
                  f"![{pose['name']}](poses/{pose['name']}.png)", ""]
        limbs = sorted(next(iter(pose["methods"].values()))["limb_volume_change_percent"])
        joints_ = sorted(next(iter(pose["methods"].values()))["intersecting_pairs"])
        lines += ["| method | body volume | " + " | ".join(f"{n} volume" for n in limbs) +
                  " | intersecting pairs (" + ", ".join(joints_) + ") | smallest forearm section |",
                  "|---" * (4 + len(limbs)) + "|"]
        for key, label in METHODS:
            m = pose["methods"][key]
            sec = m["smallest_forearm_section_vs_rest"]
            lines.append(f"| {label} | {m['body_volume_change_percent']:+.2f} % | " +
                         " | ".join(f"{m['limb_volume_change_percent'][n]:+.1f} %" for n in limbs) +
                         " | " + ", ".join(str(m["intersecting_pairs"][j]) for j in joints_) +
                         f" | {'-' if sec is None else f'{100 * sec:.0f} %'} |")
    with open(os.path.join(out_dir, "report.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


# ---- main --------------------------------------------------------------------------------

def main():
    args = parse_args()
    out_dir = os.path.abspath(args.out)
    os.makedirs(os.path.join(out_dir, "poses"), exist_ok=True)
    os.makedirs(os.path.join(out_dir, "motion"), exist_ok=True)
    arm, body = load_character(os.path.abspath(args.character), args.action)
    install.install(args.zip)
    from bl_ext.user_default.sweep_deform.core import native  # noqa: E402 (after install)
    from bl_ext.user_default.sweep_deform.blender import mesh_data  # noqa: E402 (after install)

    scene = bpy.context.scene
    action = arm.animation_data.action
    poses = key_poses(scene, action)
    if args.poses:
        keep = set(args.poses.split(",")) | {"rest"}
        poses = [(n, f) for n, f in poses if n in keep]
    rest_frame = dict(poses).get("rest", poses[0][1])
    scene.frame_set(rest_frame)
    lo, hi = world_bbox([body])
    height = float(hi[2] - lo[2])
    # The columns far enough apart for the widest key pose (arms out to the side).
    width = 0.0
    for _, frame in poses:
        scene.frame_set(frame)
        plo, phi = world_bbox([body.evaluated_get(bpy.context.evaluated_depsgraph_get())])
        width = max(width, float(phi[0] - plo[0]))
    scene.frame_set(rest_frame)
    columns = make_columns(arm, body, spacing=1.15 * max(width, 0.6 * height))
    chains = chains_from_report(next(c for c in columns if c["key"] in SWEEP_METHODS)["body"])
    if not chains:
        sys.exit("demo: the fitting found no chains; see the Sweep Deform panel's message")
    tris = mesh_data.triangles(body.data)
    dom_names = dominant_bone_names(body)
    limbs = limb_volumes(limb_regions(dom_names, chains), tris)
    print(f"demo: {len(body.data.vertices)} vertices, chains {[c['name'] for c in chains]}", flush=True)

    setup_render(scene, 500 * len(columns), 720)
    scene.display.shading.color_type = 'OBJECT'  # skin on the bodies, ink on the labels
    for col in columns:
        col["body"].color = SKIN
    # One frame for every pose: the box around all bodies in all key poses (raised arms too).
    boxes = []
    for _, frame in poses:
        scene.frame_set(frame)
        dg = bpy.context.evaluated_depsgraph_get()
        boxes += [world_bbox([c["body"].evaluated_get(dg)]) for c in columns]
    scene.frame_set(rest_frame)
    blo, bhi = np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)
    labels = []
    for col in columns:
        clo, chi = world_bbox([col["body"]])
        labels.append(add_label(col["label"], ((clo[0] + chi[0]) / 2, blo[1] - 0.3, blo[2] - 0.085 * height),
                                0.06 * height))
        labels[-1].color = INK
    full_lo, full_hi = blo - np.array([0, 0, 0.12 * height]), bhi + np.array([0, 0, 0.02 * height])

    rest_figs = None
    report_poses = []
    for name, frame in poses:
        scene.frame_set(frame)
        bpy.context.view_layer.update()
        figs = measure(columns, chains, tris, native, limbs, height)
        if rest_figs is None:
            scene.frame_set(rest_frame)
            rest_figs = measure(columns, chains, tris, native, limbs, height)
            scene.frame_set(frame)
        report_poses.append({"name": name, "frame": frame, "methods": relative(figs, rest_figs)})
        front_camera(scene, full_lo, full_hi)
        render(scene, os.path.join(out_dir, "poses", f"{name}.png"))
        if name in CLOSE_UPS:
            joint = CLOSE_UPS[name]
            render_close_up(scene, columns, dom_names, labels, joint,
                            os.path.join(out_dir, "poses", f"{name}_{joint}_l.png"))
        print(f"demo: pose {name} (frame {frame}) rendered and measured", flush=True)

    # The motion as a clip of frames.
    scene.render.resolution_x, scene.render.resolution_y = 350 * len(columns), 504  # labels ~20 px
    start, end = (int(x) for x in action.frame_range)
    for i, f in enumerate(range(start, end + 1, args.motion_step) if args.motion_step > 0 else []):
        scene.frame_set(f)
        render(scene, os.path.join(out_dir, "motion", f"frame_{i:04d}.png"))

    step = max(1, (end - start) // max(1, args.timing_frames))
    timing_frames = list(range(start, end + 1, step))
    timing = (time_methods(scene, columns, timing_frames) if args.timing_frames > 0 else
              {key: float("nan") for key in ["armature_only"] + [c["key"] for c in columns]})
    info = {"name": os.path.basename(args.character), "vertices": len(body.data.vertices),
            "triangles": int(len(tris)), "chains": [c["name"] for c in chains],
            "blender": bpy.app.version_string}
    write_report(out_dir, info, report_poses, timing, len(timing_frames))
    print(f"demo: wrote {out_dir}/report.md, report.json, poses/ and motion/", flush=True)


if __name__ == "__main__":
    main()
