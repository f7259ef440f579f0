# SPDX-License-Identifier: GPL-3.0-or-later
"""Baking the Sweep Deform result over a frame range, so a scene renders without the extension
and a character goes to other tools.

Targets:

* ``SHAPE_KEYS`` — a new object ``<name>_baked``: a copy of the character whose mesh has a
  Basis (the rest mesh) and one shape key per baked frame, each keyed to 1 on its frame and 0
  on its neighbours (linear), so playback and renders need no extension. The copy has neither
  the Sweep Deform modifier, nor the modifiers before it, nor Armature modifiers (their effect
  is in the keys), and no binding; the modifiers after Sweep Deform stay. The original is left
  as it was, so it can still be posed, edited and baked again; baking into the bound mesh
  itself would change its rest positions (re-bind needed) and deform twice.
* ``PC2`` / ``MDD`` — a point cache written by :mod:`cache_files` (Blender 4.2+ no longer
  bundles these exporters), read back by Blender's Mesh Cache modifier.
* ``ALEMBIC`` — Blender's own exporter (``wm.alembic_export``, the object only). Blenders
  built without Alembic (``bpy.app.alembic.supported`` False, e.g. Debian's) refuse it clearly.

What is baked (shape keys and point caches): the object-space vertex positions the Sweep Deform
modifier outputs at its place in the stack, i.e. the mesh's own vertices in the mesh's order.
While baking, Sweep Deform is switched on for the viewport and the modifiers after it off (a
Subdivision Surface would change the vertex count); both are put back afterwards, as is the
scene's current frame. Alembic stores topology per frame, so it takes the whole stack as
Blender's exporter evaluates it.

:class:`Bake` does one frame per :meth:`Bake.step`; the operator (ui/bake_operator.py) calls it
in a loop (scripts, ``blender -b``: printed progress) or once per timer tick (the interface:
progress, Esc cancels).
:meth:`Bake.cancel` removes everything it made: no half-written file, no half-made object.
"""

import os

import bpy
import numpy as np

from ..core import cache_files, native
from . import binding, deformer_cache, fcurves, modifier

TARGETS = [
    ('SHAPE_KEYS', "Shape Keys", "A new object '<name>_baked' with one shape key per frame, animated"),
    ('PC2', "Point Cache (.pc2)", "A PC2 point cache, read by the Mesh Cache modifier"),
    ('MDD', "Lightwave Point Cache (.mdd)", "An MDD point cache, read by the Mesh Cache modifier"),
    ('ALEMBIC', "Alembic (.abc)", "Blender's Alembic exporter, the object only (needs a Blender built with Alembic)"),
]
EXTENSIONS = {'PC2': ".pc2", 'MDD': ".mdd", 'ALEMBIC': ".abc"}


class BakeError(RuntimeError):
    pass


def check_bakeable(obj):
    """Raises BakeError saying why `obj` cannot be baked now; changes nothing."""
    if obj is None or obj.type != 'MESH':
        raise BakeError("The active object must be a mesh")
    if obj.mode == 'EDIT':
        raise BakeError("Leave Edit Mode first")
    ok, why = native.available()
    if not ok:
        raise BakeError(why)
    s = obj.sweep_deform
    if s.state == 'UNBOUND':
        raise BakeError(f"'{obj.name}' is not bound: add Sweep Deform or bind it first")
    if s.state == 'REBIND':
        raise BakeError(f"'{obj.name}' needs to be bound again: {s.message or 'the mesh changed'}")
    if modifier.find(obj) is None:
        raise BakeError(f"'{obj.name}' has no Sweep Deform modifier")
    if s.armature is None:
        raise BakeError(f"'{obj.name}' has no armature")
    if s.armature.mode == 'EDIT':
        raise BakeError(f"Leave the Edit Mode of '{s.armature.name}' first")
    e = deformer_cache.entry(obj)
    if e.deformer is None:
        raise BakeError(f"'{obj.name}': {e.error}")


def frame_list(start, end, step):
    """The frames start, start+step, ... up to end (inclusive)."""
    if step < 1:
        raise BakeError(f"The frame step must be 1 or more (got {step})")
    if end < start:
        raise BakeError(f"The last frame ({end}) is before the first ({start})")
    return list(range(start, end + 1, step))


def output_path(filepath, target):
    """The absolute file path of a file target, with its extension; BakeError if unusable."""
    if not filepath:
        raise BakeError("Give a file path")
    if filepath.startswith("//") and not bpy.data.filepath:
        raise BakeError(f"'{filepath}' is relative to the .blend file: save it first or give an absolute path")
    path = bpy.path.ensure_ext(bpy.path.abspath(filepath), EXTENSIONS[target])
    folder = os.path.dirname(path) or "."
    if not os.path.isdir(folder):
        raise BakeError(f"The folder '{folder}' does not exist")
    return path


def evaluated_positions(obj, depsgraph, out):
    """Evaluated vertex positions of `obj` (object space) into `out` ((V,3) float32).
    BakeError if the evaluated mesh has another vertex count."""
    ev = obj.evaluated_get(depsgraph)
    if not ev.is_evaluated:  # not in the depsgraph: to_mesh() would give the rest mesh
        raise BakeError(f"'{obj.name}' is not evaluated in the viewport: enable it in viewports "
                        "(and its collection) for the bake")
    me = ev.to_mesh()
    try:
        if len(me.vertices) != len(out):
            raise BakeError(f"The evaluated mesh has {len(me.vertices)} vertices, the mesh {len(out)}: "
                            "a modifier before Sweep Deform changes the vertex count")
        me.vertices.foreach_get("co", out.reshape(-1))
    finally:
        ev.to_mesh_clear()
    return out


class StackCut:
    """Switches Sweep Deform on and every modifier after it off (viewport), so the evaluated
    mesh is the Sweep Deform result with the mesh's vertices; :meth:`restore` undoes it."""

    def __init__(self, obj):
        self.obj_name = obj.name
        self.saved = []  # (modifier name, show_viewport before)
        sweep = modifier.find(obj)
        after = False
        for md in obj.modifiers:
            want = True if md == sweep else (False if after else md.show_viewport)
            after = after or md == sweep
            if md.show_viewport != want:
                self.saved.append((md.name, md.show_viewport))
                md.show_viewport = want

    def restore(self):
        obj = bpy.data.objects.get(self.obj_name)
        for name, shown in self.saved if obj is not None else ():
            md = obj.modifiers.get(name)
            if md is not None:
                md.show_viewport = shown
        self.saved = []


# ---- outputs ------------------------------------------------------------------------------


class ShapeKeyOutput:
    """The ``<name>_baked`` object: made at the start, one shape key per frame, animated at
    :meth:`finish`; :meth:`discard` deletes it (object and mesh)."""

    def __init__(self, obj, frames):
        self.frames = frames
        self.object_name = self.mesh_name = ""
        try:
            self._make(obj)
        except BaseException:
            self.discard()
            raise

    def _make(self, obj):
        mesh = obj.data.copy()
        copy = obj.copy()
        copy.data = mesh
        copy.name = f"{obj.name}_baked"
        mesh.name = f"{obj.data.name}_baked"
        self.object_name, self.mesh_name = copy.name, mesh.name
        for coll in obj.users_collection:
            coll.objects.link(copy)
        # No binding, no offsets, no armature deformation: the shape keys hold all of it.
        binding.unbind(copy, restore_armature_modifier=False)
        copy.sweep_deform.armature = None
        stack = list(copy.modifiers)
        cut = stack.index(modifier.find(copy))
        for md in stack[:cut + 1] + [md for md in stack[cut + 1:] if md.type == 'ARMATURE']:
            copy.modifiers.remove(md)
        if copy.parent_type == 'ARMATURE':  # parenting with automatic armature deformation
            copy.parent_type = 'OBJECT'
        copy.shape_key_clear()
        copy.shape_key_add(name="Basis", from_mix=False)

    @property
    def object(self):
        return bpy.data.objects[self.object_name]

    def add(self, frame, positions):
        kb = self.object.shape_key_add(name=f"frame_{frame:04d}", from_mix=False)
        kb.data.foreach_set("co", positions.reshape(-1))
        kb.value = 0.0

    def finish(self):
        """Keys each shape key to 1 on its frame and 0 on the baked frames either side
        (linear: between two baked frames the mesh moves straight from one to the other)."""
        key = self.object.data.shape_keys
        blocks = key.key_blocks[1:]
        n = len(blocks)
        for i, (kb, frame) in enumerate(zip(blocks, self.frames)):
            points = [(frame, 1.0)]
            if i > 0:
                points.insert(0, (self.frames[i - 1], 0.0))
            if i < n - 1:
                points.append((self.frames[i + 1], 0.0))
            for t, v in points:
                kb.value = v
                kb.keyframe_insert("value", frame=t)
        for collection in fcurves.fcurve_collections(key)[1:]:  # the action's, not the drivers
            for fc in collection:
                for kp in fc.keyframe_points:
                    kp.interpolation = 'LINEAR'
        return f"'{self.object_name}' ({n} shape keys)"

    def discard(self):
        obj, mesh = bpy.data.objects.get(self.object_name), bpy.data.meshes.get(self.mesh_name)
        if obj is not None:
            bpy.data.objects.remove(obj)
        if mesh is not None:
            bpy.data.meshes.remove(mesh)  # its shape keys go with it


class CacheFileOutput:
    """A PC2 or MDD file, written frame by frame (see cache_files)."""

    def __init__(self, target, path, points, frames, fps):
        if target == 'PC2':
            step = frames[1] - frames[0] if len(frames) > 1 else 1
            self.writer = cache_files.PC2Writer(path, points, len(frames), start=frames[0], sampling=step)
        else:
            self.writer = cache_files.MDDWriter(path, points, [(f - frames[0]) / fps for f in frames])

    def add(self, frame, positions):
        self.writer.write(positions)

    def finish(self):
        self.writer.close()
        return f"'{self.writer.path}'"

    def discard(self):
        self.writer.abort()


# ---- one bake -----------------------------------------------------------------------------


class Bake:
    """One bake of `obj` to `target` over `frames`: :meth:`step` bakes the next frame, then
    :meth:`finish` (or :meth:`cancel`) ends it. Both put back the scene's frame and the
    modifier toggles; cancel also removes the partial output. Raises BakeError."""

    def __init__(self, context, obj, target, frames, path=""):
        check_bakeable(obj)
        if target not in ('SHAPE_KEYS', 'PC2', 'MDD'):
            raise BakeError(f"{target} is not baked frame by frame")
        self.scene = context.scene
        self.obj_name, self.target, self.frames, self.index = obj.name, target, list(frames), 0
        self.saved_frame = (self.scene.frame_current, self.scene.frame_subframe)
        self.positions = np.empty((len(obj.data.vertices), 3), np.float32)
        if target == 'SHAPE_KEYS':
            self.output = ShapeKeyOutput(obj, self.frames)  # copies the stack as the user set it
        else:
            fps = self.scene.render.fps / self.scene.render.fps_base
            self.output = CacheFileOutput(target, path, len(self.positions), self.frames, fps)
        self.cut = StackCut(obj)

    @property
    def done(self):
        return self.index >= len(self.frames)

    @property
    def frame(self):
        """The frame the next step bakes."""
        return self.frames[min(self.index, len(self.frames) - 1)]

    def step(self):
        """Bakes the next frame. Returns True when every frame is baked."""
        frame = self.frames[self.index]
        obj = bpy.data.objects.get(self.obj_name)
        if obj is None:
            raise BakeError(f"'{self.obj_name}' went away while baking")
        self.scene.frame_set(frame)  # the frame handler deforms the mesh
        s = obj.sweep_deform
        e = deformer_cache.peek(obj)
        if s.state != 'BOUND':
            raise BakeError(f"Frame {frame}: '{obj.name}' {s.message or 'is no longer bound'}")
        if e is None or e.error:
            raise BakeError(f"Frame {frame}: '{obj.name}' was not deformed{': ' + e.error if e else ''}")
        depsgraph = bpy.context.evaluated_depsgraph_get()
        self.output.add(frame, evaluated_positions(obj, depsgraph, self.positions))
        self.index += 1
        return self.done

    def _restore(self):
        self.cut.restore()
        frame, subframe = self.saved_frame
        self.scene.frame_set(frame, subframe=subframe)

    def finish(self):
        """Completes the output (file named, keys animated). Returns where it went."""
        try:
            if not self.done:
                raise BakeError(f"{self.index} of {len(self.frames)} frames baked")
            self._restore()  # before animating: the keys are set at the scene's frame
            return self.output.finish()
        except BaseException:
            self.cancel()
            raise

    def cancel(self):
        """Removes the partial output and puts back what the bake changed."""
        try:
            self.output.discard()
        finally:
            self._restore()


def export_alembic(context, obj, path, frames):
    """Blender's Alembic exporter on `obj` alone, into a partial file renamed at the end.
    Restores the selection and the frame. Raises BakeError."""
    check_bakeable(obj)
    if not bpy.app.alembic.supported:
        raise BakeError("This Blender is built without Alembic (bpy.app.alembic.supported is False): "
                        "bake to PC2 or MDD instead")
    if len(frames) > 1 and frames[1] - frames[0] != 1:
        raise BakeError("Alembic bakes every frame: use frame step 1")
    scene, view_layer = context.scene, context.view_layer
    saved_frame = (scene.frame_current, scene.frame_subframe)
    selected = [o for o in view_layer.objects if o.select_get()]
    active = view_layer.objects.active
    partial = path + ".partial.abc"
    try:
        for o in selected:
            o.select_set(False)
        obj.select_set(True)
        view_layer.objects.active = obj
        try:
            result = bpy.ops.wm.alembic_export(filepath=partial, start=frames[0], end=frames[-1], selected=True,
                                               as_background_job=False, init_scene_frame_range=False)
        except RuntimeError as e:  # the exporter's own error report
            raise BakeError(f"Blender's Alembic exporter: {e}") from e
        if result != {'FINISHED'} or not os.path.isfile(partial):
            raise BakeError(f"Blender's Alembic exporter did not write the file ({', '.join(result)})")
        os.replace(partial, path)
    finally:
        if os.path.exists(partial):
            os.remove(partial)
        obj.select_set(False)
        for o in selected:
            o.select_set(True)
        view_layer.objects.active = active
        scene.frame_set(saved_frame[0], subframe=saved_frame[1])
    return f"'{path}'"
