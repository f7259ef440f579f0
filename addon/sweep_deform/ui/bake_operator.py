# SPDX-License-Identifier: GPL-3.0-or-later
"""The "Bake Sweep Deform" operator: the bake of blender/bake.py over a frame range, to shape
keys, PC2, MDD or Alembic. From scripts and ``blender -b`` every frame at once (progress
printed); from the interface one frame per timer tick, with progress, and Esc cancels."""

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty

from ..blender.bake import EXTENSIONS, TARGETS, Bake, BakeError, export_alembic, frame_list, output_path
from .progress import ModalProgress


def _describe(error):
    """The message of an expected error; an unexpected one also names its type."""
    if isinstance(error, (BakeError, OSError, ValueError)):
        return str(error)
    return f"{type(error).__name__}: {error}"


# ---- the operator -------------------------------------------------------------------------


#: Blender 4.5+ warns about '//' paths unless the property says it takes them.
_PATH_OPTIONS = {'PATH_SUPPORTS_BLEND_RELATIVE'} if bpy.app.version >= (4, 5, 0) else set()


class OBJECT_OT_sweep_deform_bake(ModalProgress, bpy.types.Operator):
    """Bake the Sweep Deform result over a frame range to shape keys on a copy, a PC2 or MDD
    point cache, or Alembic, so the scene plays and renders without the extension"""
    bl_idname = "object.sweep_deform_bake"
    bl_label = "Bake Sweep Deform"
    bl_options = {'UNDO'}

    target: EnumProperty(name="Bake To", items=TARGETS, default='SHAPE_KEYS')
    filepath: StringProperty(name="File Path", subtype='FILE_PATH', default="", options=_PATH_OPTIONS,
                             description="The file to write (PC2, MDD, Alembic); '//' is the .blend's folder")
    frame_start: IntProperty(name="Start", description="First frame (default: the scene's start)")
    frame_end: IntProperty(name="End", description="Last frame (default: the scene's end)")
    frame_step: IntProperty(name="Step", min=1, default=1, description="Frames between baked frames "
                            "(default: the scene's frame step)")
    run_modal: BoolProperty(options={'HIDDEN', 'SKIP_SAVE'}, description="Bake one frame per timer tick, "
                            "with progress and Esc to cancel (set when run from the interface)")
    filter_glob: StringProperty(default="*.pc2;*.mdd;*.abc", options={'HIDDEN'})

    _bake = None

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.type != 'MESH' or obj.mode == 'EDIT':
            cls.poll_message_set("The active object must be a mesh in Object Mode")
            return False
        return True

    def _frames(self, scene):
        p = self.properties
        start = self.frame_start if p.is_property_set("frame_start") else scene.frame_start
        end = self.frame_end if p.is_property_set("frame_end") else scene.frame_end
        step = self.frame_step if p.is_property_set("frame_step") else scene.frame_step
        return frame_list(start, end, step)

    def invoke(self, context, event):
        scene = context.scene
        for name, value in (("frame_start", scene.frame_start), ("frame_end", scene.frame_end),
                            ("frame_step", scene.frame_step)):
            if not self.properties.is_property_set(name):
                setattr(self, name, value)
        self.run_modal = True
        if self.target in EXTENSIONS and not self.filepath:
            self.filepath = ("//" if bpy.data.filepath else "") + bpy.path.clean_name(context.active_object.name) \
                + EXTENSIONS[self.target]
            self.filter_glob = "*" + EXTENSIONS[self.target]
            context.window_manager.fileselect_add(self)
            return {'RUNNING_MODAL'}
        if self.target == 'SHAPE_KEYS':
            return context.window_manager.invoke_props_dialog(self)
        return self.execute(context)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "target")
        col = layout.column(align=True)
        col.prop(self, "frame_start")
        col.prop(self, "frame_end")
        col.prop(self, "frame_step")

    def execute(self, context):
        obj = context.active_object
        try:
            frames = self._frames(context.scene)
            path = output_path(self.filepath, self.target) if self.target in EXTENSIONS else ""
            if self.target == 'ALEMBIC':
                where = export_alembic(context, obj, path, frames)
                return self._report_done(obj, frames, where)
            bake = Bake(context, obj, self.target, frames, path)
        except (BakeError, OSError, ValueError) as e:
            self.report({'ERROR'}, f"Sweep Deform: {e}")
            return {'CANCELLED'}
        if self.run_modal and not bpy.app.background and context.window is not None:
            return self._start_modal(context, bake)
        return self._run_now(obj, bake)

    def _report_done(self, obj, frames, where):
        self.report({'INFO'}, f"Sweep Deform: baked {len(frames)} frames ({frames[0]}–{frames[-1]}) of "
                              f"'{obj.name}' to {where}")
        return {'FINISHED'}

    # -- scripts and blender -b: every frame now, progress printed ------------------------------

    def _run_now(self, obj, bake):
        n = len(bake.frames)
        every = max(1, n // 20)
        try:
            while not bake.done:
                frame = bake.frame
                bake.step()
                if bake.index % every == 0 or bake.done:
                    print(f"Sweep Deform bake: frame {frame} ({bake.index}/{n})", flush=True)
            where = bake.finish()
        except Exception as e:  # whatever failed, nothing half-made stays
            if not bake.done:
                bake.cancel()
            self.report({'ERROR'}, f"Sweep Deform: {_describe(e)}")
            return {'CANCELLED'}
        return self._report_done(obj, bake.frames, where)

    # -- the interface: one frame per timer tick, Esc cancels -----------------------------------

    def _start_modal(self, context, bake):
        self._bake = bake
        context.window_manager.progress_begin(0, len(bake.frames))
        self._status(context)
        self._timer = context.window_manager.event_timer_add(0.001, window=context.window)
        context.window_manager.modal_handler_add(self)
        return {'RUNNING_MODAL'}

    def _status(self, context):
        b = self._bake
        self._show_progress(context, b.index,
                            f"Sweep Deform: baking frame {b.frame} ({b.index}/{len(b.frames)}), Esc to cancel")

    def modal(self, context, event):
        bake = self._bake
        if event.type == 'ESC':
            bake.cancel()
            self._end(context)
            self.report({'WARNING'}, "Sweep Deform: bake cancelled, nothing written")
            return {'CANCELLED'}
        if event.type != 'TIMER':
            return {'RUNNING_MODAL'}  # no edits while the frame changes under the user's hands
        try:
            if not bake.step():
                self._status(context)
                return {'RUNNING_MODAL'}
            where = bake.finish()
        except Exception as e:  # whatever failed, nothing half-made stays
            if not bake.done:
                bake.cancel()
            self._end(context)
            self.report({'ERROR'}, f"Sweep Deform: {_describe(e)}")
            return {'CANCELLED'}
        self._end(context)
        return self._report_done(bpy.data.objects[bake.obj_name], bake.frames, where)

    def cancel(self, context):
        """Blender ends the operator (the window closes, a new file is loaded)."""
        if self._bake is not None and not self._bake.done:
            self._bake.cancel()
        self._end(context)


register, unregister = bpy.utils.register_classes_factory((OBJECT_OT_sweep_deform_bake,))
