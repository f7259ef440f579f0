# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators: add the modifier (and bind), bind, unbinding. All undoable, all in menus (and so
in F3 search, see menu.py).

Binding runs in stages (blender/binding.py). Invoked from the interface it is modal: the native stages
run in a worker thread while a timer updates the progress (``window_manager.progress_*``,
the status bar) and Esc cancels; nothing in the file changes before the last stage, so a
cancelled bind leaves no trace. Run from a script (``EXEC_DEFAULT``) it runs the same stages
at once.
"""

import threading
import traceback

import bpy
from bpy.props import StringProperty

from ..blender import binding
from ..core import fit_report, native
from .progress import ModalProgress

_STAGES = {"read": (0, "reading the mesh and skeleton"), "fit": (15, "fitting key ellipses"),
           "bind": (85, "binding vertices"), "store": (95, "storing the binding")}


def active_mesh(context):
    obj = context.active_object
    return obj if obj is not None and obj.type == 'MESH' else None


class _Binder(ModalProgress):
    """Shared by the add and bind operators."""

    armature: StringProperty(
        name="Armature", default="",
        description="Name of the armature to bind to (default: the mesh's Armature modifier, "
                    "its Sweep Deform armature, or its parent)")

    _thread = None

    @classmethod
    def poll(cls, context):
        obj = active_mesh(context)
        if obj is None:
            cls.poll_message_set("The active object must be a mesh")
            return False
        if obj.mode == 'EDIT':
            cls.poll_message_set("Leave Edit Mode first")
            return False
        return True

    # -- progress -------------------------------------------------------------------------

    def _progress(self, context, stage):
        value, text = _STAGES[stage]
        self._show_progress(context, value, f"Sweep Deform: {text}… (Esc to cancel)")

    def _fail(self, context, e):
        """The one error path of both binds (scripted and interactive): every error becomes a
        report in the interface, nothing in the file has changed. An error nobody foresaw is
        reported too, with its traceback in the console for a bug report."""
        self._end(context)
        if not isinstance(e, binding.bind_errors()):
            traceback.print_exception(type(e), e, e.__traceback__)
            self.report({'ERROR'}, f"Sweep Deform: unexpected error while binding ({type(e).__name__}: {e}); "
                                   "nothing was changed, details in the system console")
        else:
            self.report({'ERROR'}, f"Sweep Deform: {binding.error_message(e)}")
        return {'CANCELLED'}

    def _prepare(self, context):
        ok, why = native.available()
        if not ok:
            self.report({'ERROR'}, why)
            return None
        obj = active_mesh(context)
        try:
            arm = binding.find_armature(obj, self.armature)
        except binding.BindError as e:
            self.report({'ERROR'}, f"Sweep Deform: {e}")
            return None
        if arm is None:
            self.report({'ERROR'}, f"'{obj.name}' has no Armature modifier or armature parent: "
                                   "give the armature's name")
            return None
        return obj, arm

    def _finish(self, context, obj, arm, inp, out):
        self._progress(context, "store")
        binding.store(obj, arm, inp, out)
        for line in fit_report.report_warnings(out.report):
            self.report({'WARNING'}, f"Sweep Deform: {line}")
        s = obj.sweep_deform
        self.report({'INFO'}, f"Sweep Deform: '{obj.name}' bound to '{arm.name}' "
                              f"({s.sweep_count} sweeps, {s.vertex_count} vertices)")
        return {'FINISHED'}

    # -- scripts: all stages now ------------------------------------------------------------

    def execute(self, context):
        prepared = self._prepare(context)
        if prepared is None:
            return {'CANCELLED'}
        obj, arm = prepared
        context.window_manager.progress_begin(0, 100)
        try:
            self._progress(context, "read")
            inp = binding.read_inputs(obj, arm)
            out = binding.fit_and_bind(inp, stage=lambda name: self._progress(context, name))
            result = self._finish(context, obj, arm, inp, out)
        except Exception as e:  # noqa: BLE001 -- one error path, see _fail
            return self._fail(context, e)
        self._end(context)
        return result

    # -- interface: modal, native stages in a worker thread --------------------------------

    def invoke(self, context, event):
        prepared = self._prepare(context)
        if prepared is None:
            return {'CANCELLED'}
        self._obj_name, self._arm_name = prepared[0].name, prepared[1].name
        context.window_manager.progress_begin(0, 100)
        self._progress(context, "read")
        try:
            self._inp = binding.read_inputs(*prepared)
        except Exception as e:  # noqa: BLE001 -- one error path, see _fail
            return self._fail(context, e)
        self._result, self._error, self._stage = None, None, "fit"

        def work(inp=self._inp):
            try:
                self._result = binding.fit_and_bind(inp, stage=lambda name: setattr(self, "_stage", name))
            except Exception as e:  # reported on the main thread
                self._error = e

        self._thread = threading.Thread(target=work, name="sweep_deform_bind", daemon=True)
        self._thread.start()
        self._timer = context.window_manager.event_timer_add(0.1, window=context.window)
        context.window_manager.modal_handler_add(self)
        return {'RUNNING_MODAL'}

    def modal(self, context, event):
        if event.type == 'ESC':
            self._end(context)
            self.report({'WARNING'}, "Sweep Deform: binding cancelled")
            return {'CANCELLED'}  # the worker's result is dropped
        if event.type != 'TIMER':
            return {'PASS_THROUGH'}
        if self._thread.is_alive():
            self._progress(context, self._stage)
            return {'RUNNING_MODAL'}
        if self._error is not None:
            return self._fail(context, self._error)
        obj, arm = bpy.data.objects.get(self._obj_name), bpy.data.objects.get(self._arm_name)
        if obj is None or arm is None:
            return self._fail(context, binding.BindError("the object or armature went away while binding"))
        try:
            result = self._finish(context, obj, arm, self._inp, self._result)
        except Exception as e:  # noqa: BLE001 -- one error path, see _fail
            return self._fail(context, e)
        self._end(context)
        return result


class OBJECT_OT_sweep_deform_add(_Binder, bpy.types.Operator):
    """Add a Sweep Deform modifier to the active mesh and bind it to its armature; the
    Armature modifier it replaces is switched off"""
    bl_idname = "object.sweep_deform_add"
    bl_label = "Add Sweep Deform"
    bl_options = {'REGISTER', 'UNDO'}


class OBJECT_OT_sweep_deform_bind(_Binder, bpy.types.Operator):
    """Bind (or bind again) the active mesh's Sweep Deform modifier to the armature"""
    bl_idname = "object.sweep_deform_bind"
    bl_label = "Bind Sweep Deform"
    bl_options = {'REGISTER', 'UNDO'}


class OBJECT_OT_sweep_deform_unbind(bpy.types.Operator):
    """Remove the active mesh's sweep binding (the modifier stays, doing nothing) and give
    the replaced Armature modifier its deformation back"""
    bl_idname = "object.sweep_deform_unbind"
    bl_label = "Unbind Sweep Deform"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        obj = active_mesh(context)
        if obj is None or obj.sweep_deform.state == 'UNBOUND':
            cls.poll_message_set("The active mesh has no sweep binding")
            return False
        if binding.linked_reason(obj):
            cls.poll_message_set(binding.linked_reason(obj))
            return False
        return True

    def execute(self, context):
        obj = active_mesh(context)
        binding.unbind(obj)
        self.report({'INFO'}, f"Sweep Deform: '{obj.name}' unbound")
        return {'FINISHED'}


classes = (OBJECT_OT_sweep_deform_add, OBJECT_OT_sweep_deform_bind, OBJECT_OT_sweep_deform_unbind)
register, unregister = bpy.utils.register_classes_factory(classes)
