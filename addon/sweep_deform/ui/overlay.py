# SPDX-License-Identifier: GPL-3.0-or-later
"""The "Edit Key Ellipses" overlay: a ``gpu`` draw handler (no ``bgl``) in every 3D viewport.

For each bound mesh with *Edit Key Ellipses* on, in the pose being shown, it draws

* the sweep surfaces as a wireframe of sampled ellipses and lines along them (blue),
* every key ellipse as a closed line loop (cyan, :data:`KEY_COLOR`),
* the selected key highlighted (yellow), with the key as Sect. 4.1 alone would place it
  (grey) when a correction moves it.

Everything is drawn on top of the mesh (no depth test): the key ellipses lie on the skin
or inside it. The geometry comes from the core (key_ellipses.overlay_data: the corrected keys
and the sampled sweeps, before volume control, the values an artist edits) and is turned
into GPU batches only when the pose, the corrections, the selection or the armature's
transform change.
"""

import bpy
import gpu
import numpy as np
from gpu_extras.batch import batch_for_shader

from ..blender import deformer_cache, key_ellipses
from ..core import key_edit

#: Colours (RGBA). The key colour is pure cyan so that a test can find it on screen.
KEY_COLOR = (0.0, 1.0, 1.0, 1.0)
SELECTED_COLOR = (1.0, 0.85, 0.0, 1.0)
PLACED_COLOR = (0.65, 0.65, 0.65, 0.9)
SWEEP_COLOR = (0.25, 0.55, 1.0, 0.45)
KEY_WIDTH, SELECTED_WIDTH, SWEEP_WIDTH = 2.0, 3.5, 1.0
#: Points per drawn ellipse.
ELLIPSE_POINTS = 64

_handle = None
_cache = {}       # object name -> (key, {name: (batch, colour, width)})
_reported = set()


def edited_objects(context):
    """Bound meshes of the view layer with Edit Key Ellipses on and visible."""
    out = []
    view_layer = getattr(context, "view_layer", None)
    if view_layer is None:
        return out
    for obj in view_layer.objects:
        if obj.type != 'MESH':
            continue
        s = obj.sweep_deform
        if not s.edit_keys or s.state != 'BOUND' or s.armature is None:
            continue
        try:
            if not obj.visible_get():
                continue
        except RuntimeError:
            continue
        out.append(obj)
    return out


def world_matrix(obj):
    """Armature space → world (numpy 4×4)."""
    return np.array(obj.sweep_deform.armature.matrix_world, np.float64)


def _to_world(m, points):
    p = np.asarray(points, np.float64)
    return p @ m[:3, :3].T + m[:3, 3]


def key_loops(obj, data=None):
    """[(sweep, key, world points (n,3))] of every key ellipse of `obj` as shown."""
    data = key_ellipses.overlay_data(obj) if data is None else data
    if not data:
        return []
    m = world_matrix(obj)
    out = []
    for s, sw in enumerate(data):
        loops = key_edit.ellipses_points(sw["centers"], sw["rotations"], sw["half_axes"], ELLIPSE_POINTS)
        for k in range(len(loops)):
            out.append((s, k, _to_world(m, loops[k])))
    return out


def geometry(obj):
    """World-space line segments of the overlay: {"sweeps", "keys", "selected", "placed"}."""
    data = key_ellipses.overlay_data(obj)
    if not data:
        return {}
    s_sel, k_sel = obj.sweep_deform.active_sweep, obj.sweep_deform.active_key
    m = world_matrix(obj)
    sweeps, keys, selected, placed = [], [], [], []
    for s, sw in enumerate(data):
        if obj.sweep_deform.show_sweeps:
            sweeps.append(key_edit.sweep_wire(sw["wire_centers"], sw["wire_rotations"], sw["wire_half_axes"],
                                              theta_count=32, lines=8))
        loops = key_edit.ellipses_points(sw["centers"], sw["rotations"], sw["half_axes"], ELLIPSE_POINTS)
        if s != s_sel:
            keys.append(key_edit.loops_segments(loops))
            continue
        for k in range(len(sw["centers"])):
            seg = key_edit.loop_segments(loops[k])
            if k == k_sel:
                selected.append(seg)
                if not (np.allclose(sw["centers"][k], sw["placed_centers"][k], atol=1e-6)
                        and np.allclose(sw["rotations"][k], sw["placed_rotations"][k], atol=1e-6)
                        and np.allclose(sw["half_axes"][k], sw["placed_half_axes"][k], atol=1e-6)):
                    placed.append(key_edit.loop_segments(key_edit.ellipse_points(
                        sw["placed_centers"][k], sw["placed_rotations"][k], *sw["placed_half_axes"][k],
                        ELLIPSE_POINTS)))
            else:
                keys.append(seg)
    out = {}
    for name, parts in (("sweeps", sweeps), ("keys", keys), ("placed", placed), ("selected", selected)):
        if parts:
            out[name] = _to_world(m, np.concatenate(parts)).astype(np.float32)
    return out


_STYLE = {"sweeps": (SWEEP_COLOR, SWEEP_WIDTH), "keys": (KEY_COLOR, KEY_WIDTH),
          "placed": (PLACED_COLOR, KEY_WIDTH), "selected": (SELECTED_COLOR, SELECTED_WIDTH)}
_ORDER = ("sweeps", "placed", "keys", "selected")


def _shader():
    return gpu.shader.from_builtin('POLYLINE_UNIFORM_COLOR')


def _batches(obj):
    e = deformer_cache.peek(obj)
    s = obj.sweep_deform
    data = key_ellipses.overlay_data(obj)
    key = (id(data), e.overlay_key if e is not None else None, tuple(map(tuple, world_matrix(obj))),
           s.active_sweep, s.active_key, s.show_sweeps)
    cached = _cache.get(obj.name)
    if cached is not None and cached[0] == key:
        return cached[1]
    shader = _shader()
    batches = {}
    for name, coords in geometry(obj).items():
        batches[name] = batch_for_shader(shader, 'LINES', {"pos": coords})
    _cache[obj.name] = (key, batches)
    return batches


def draw():
    context = bpy.context
    try:
        objects = edited_objects(context)
    except Exception:  # e.g. while a file loads
        return
    if not objects:
        return
    shader = _shader()
    viewport = gpu.state.viewport_get()
    gpu.state.blend_set('ALPHA')
    gpu.state.depth_test_set('NONE')
    gpu.state.depth_mask_set(False)
    try:
        for obj in objects:
            try:
                batches = _batches(obj)
            except Exception as err:  # never break the viewport's drawing
                message = f"Sweep Deform overlay: '{obj.name}': {type(err).__name__}: {err}"
                if message not in _reported:
                    _reported.add(message)
                    print(message)
                continue
            shader.bind()
            shader.uniform_float("viewportSize", (float(viewport[2]), float(viewport[3])))
            for name in _ORDER:
                if name in batches:
                    color, width = _STYLE[name]
                    shader.uniform_float("color", color)
                    shader.uniform_float("lineWidth", width)
                    batches[name].draw(shader)
    finally:
        gpu.state.blend_set('NONE')
        gpu.state.depth_mask_set(True)


def clear():
    _cache.clear()


def register():
    global _handle
    unregister()
    _handle = bpy.types.SpaceView3D.draw_handler_add(draw, (), 'WINDOW', 'POST_VIEW')


def unregister():
    global _handle
    if _handle is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_handle, 'WINDOW')
        _handle = None
    _cache.clear()
