# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators: add the modifier (and bind), bind, unbind. All undoable, all in menus (and so
in F3 search).

Binding runs in stages (bind.py). Invoked from the interface it is modal: the native stages
run in a worker thread while a timer updates the progress (``window_manager.progress_*``,
the status bar) and Esc cancels; nothing in the file changes before the last stage, so a
cancelled bind leaves no trace. Run from a script (``EXEC_DEFAULT``) it runs the same stages
at once.
"""

import re
import threading

import bpy
from bpy.props import EnumProperty, IntProperty, StringProperty

from . import bind
from .core import native

_STAGES = {"read": (0, "reading the mesh and skeleton"), "fit": (15, "fitting key ellipses"),
           "bind": (85, "binding vertices"), "store": (95, "storing the binding")}


def _mesh_object(context):
    obj = context.active_object
    return obj if obj is not None and obj.type == 'MESH' else None


class ModalProgress:
    """The progress bar, status-bar text and timer of a modal operator that works in steps
    (binding, baking): `_show_progress` at each step, `_end` once, whatever the outcome."""

    _timer = None

    def _show_progress(self, context, value, text):
        context.window_manager.progress_update(value)
        if context.workspace is not None and not bpy.app.background:
            context.workspace.status_text_set(text)

    def _end(self, context):
        context.window_manager.progress_end()
        if context.workspace is not None and not bpy.app.background:
            context.workspace.status_text_set(None)
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None


class _Binder(ModalProgress):
    """Shared by the add and bind operators."""

    armature: StringProperty(
        name="Armature", default="",
        description="Name of the armature to bind to (default: the mesh's Armature modifier, "
                    "its Sweep Deform armature, or its parent)")

    _thread = None

    @classmethod
    def poll(cls, context):
        obj = _mesh_object(context)
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

    def _prepare(self, context):
        ok, why = native.available()
        if not ok:
            self.report({'ERROR'}, why)
            return None
        obj = _mesh_object(context)
        try:
            arm = bind.find_armature(obj, self.armature)
        except bind.BindError as e:
            self.report({'ERROR'}, str(e))
            return None
        if arm is None:
            self.report({'ERROR'}, f"'{obj.name}' has no Armature modifier or armature parent: "
                                   "give the armature's name")
            return None
        return obj, arm

    def _finish(self, context, obj, arm, inp, out):
        self._progress(context, "store")
        bind.store(obj, arm, inp, out)
        for line in bind.report_warnings(out.report):
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
            inp = bind.read_inputs(obj, arm)
            out = bind.fit_and_bind(inp, stage=lambda name: self._progress(context, name))
            return self._finish(context, obj, arm, inp, out)
        except (bind.BindError, native.NativeError, native.NativeLibraryError, ValueError) as e:
            self.report({'ERROR'}, f"Sweep Deform: {e}")
            return {'CANCELLED'}
        finally:
            self._end(context)

    # -- interface: modal, native stages in a worker thread --------------------------------

    def invoke(self, context, event):
        prepared = self._prepare(context)
        if prepared is None:
            return {'CANCELLED'}
        self._obj_name, self._arm_name = prepared[0].name, prepared[1].name
        context.window_manager.progress_begin(0, 100)
        self._progress(context, "read")
        try:
            self._inp = bind.read_inputs(*prepared)
        except bind.BindError as e:
            self._end(context)
            self.report({'ERROR'}, f"Sweep Deform: {e}")
            return {'CANCELLED'}
        self._result, self._error, self._stage = None, None, "fit"

        def work(inp=self._inp):
            try:
                self._result = bind.fit_and_bind(inp, stage=lambda name: setattr(self, "_stage", name))
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
        self._end(context)
        if self._error is not None:
            self.report({'ERROR'}, f"Sweep Deform: {self._error}")
            return {'CANCELLED'}
        obj, arm = bpy.data.objects.get(self._obj_name), bpy.data.objects.get(self._arm_name)
        if obj is None or arm is None:
            self.report({'ERROR'}, "Sweep Deform: the object or armature went away while binding")
            return {'CANCELLED'}
        try:
            return self._finish(context, obj, arm, self._inp, self._result)
        except bind.BindError as e:
            self.report({'ERROR'}, f"Sweep Deform: {e}")
            return {'CANCELLED'}


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
        obj = _mesh_object(context)
        if obj is None or obj.sweep_deform.state == 'UNBOUND':
            cls.poll_message_set("The active mesh has no sweep binding")
            return False
        if bind.linked_reason(obj):
            cls.poll_message_set(bind.linked_reason(obj))
            return False
        return True

    def execute(self, context):
        obj = _mesh_object(context)
        bind.unbind(obj)
        self.report({'INFO'}, f"Sweep Deform: '{obj.name}' unbound")
        return {'FINISHED'}


# ---- key-ellipse editing (Sect. 4.2) -----------------------------------------------------------


def _bound_mesh(context):
    obj = _mesh_object(context)
    ok = obj is not None and obj.sweep_deform.state == 'BOUND' and not bind.linked_reason(obj)
    return obj if ok else None


def first_joint_key(obj):
    """(sweep, key) to select when editing starts: the first interior joint key (an elbow or a
    knee), else key 0 of sweep 0."""
    from . import runtime
    e = runtime.entry(obj)
    if e.rig is None or e.rig.sweep_count == 0:
        return -1, -1
    for sweep in range(e.rig.sweep_count):
        parents = e.rig.keys(sweep)["joint_parents"]
        for k in range(1, len(parents) - 1):
            if parents[k] >= 0:
                return sweep, k
    return 0, 0


class OBJECT_OT_sweep_deform_edit_keys(bpy.types.Operator):
    """Edit Key Ellipses: draw the sweeps and key ellipses in the viewport, with gizmos on the
    selected key, and make the Edit Key Ellipses tool active (click a key to select it)"""
    bl_idname = "object.sweep_deform_edit_keys"
    bl_label = "Edit Key Ellipses"
    bl_options = {'REGISTER', 'UNDO'}

    action: EnumProperty(name="Action", items=[('TOGGLE', "Toggle", ""), ('ENABLE', "Enable", ""),
                                               ('DISABLE', "Disable", "")], default='TOGGLE')

    @classmethod
    def poll(cls, context):
        if _bound_mesh(context) is None:
            cls.poll_message_set("The active object must be a bound Sweep Deform mesh")
            return False
        return True

    def execute(self, context):
        from . import gizmos, runtime
        obj = _bound_mesh(context)
        s = obj.sweep_deform
        enable = {'TOGGLE': not s.edit_keys, 'ENABLE': True, 'DISABLE': False}[self.action]
        s.edit_keys = enable
        if enable and (s.active_sweep < 0 or s.active_key < 0):
            s.active_sweep, s.active_key = first_joint_key(obj)
        if obj.mode == 'OBJECT':
            try:
                gizmos.activate_tool(context, enable)
            except (RuntimeError, TypeError) as e:  # no 3D viewport (scripts, background)
                print(f"Sweep Deform: tool not switched: {e}")
        runtime.redraw_views()
        return {'FINISHED'}


def _fcurve_lists(obj):
    """The F-curve collections (drivers, and the action's for this object) of `obj`."""
    ad = obj.animation_data
    if ad is None:
        return []
    out = [ad.drivers]
    act = ad.action
    if act is None:
        return out
    if hasattr(act, "fcurves") and not hasattr(act, "layers"):
        out.append(act.fcurves)  # Blender 4.3: a legacy action
        return out
    try:
        layers = act.layers
    except AttributeError:
        layers = []
    if len(layers) == 0 and hasattr(act, "fcurves"):
        out.append(act.fcurves)
    for layer in layers:
        for strip in layer.strips:
            bag = strip.channelbag(ad.action_slot) if ad.action_slot is not None else None
            if bag is not None:
                out.append(bag.fcurves)
    return out


_CORRECTION_PATH = re.compile(r"^sweep_deform\.corrections\[(\d+)\](.*)$")


def remove_correction(obj, index):
    """Removes correction `index`, keeping keyframes and drivers on the others (their paths
    hold the collection index)."""
    s = obj.sweep_deform
    for fcurves in _fcurve_lists(obj):
        for fc in list(fcurves):
            m = _CORRECTION_PATH.match(fc.data_path)
            if m is None:
                continue
            i = int(m.group(1))
            if i == index:
                fcurves.remove(fc)
            elif i > index:
                fc.data_path = f"sweep_deform.corrections[{i - 1}]{m.group(2)}"
    s.corrections.remove(index)
    s.active_correction = max(0, min(s.active_correction, len(s.corrections) - 1))
    obj.update_tag()  # removing an item is no property update: evaluate again


class OBJECT_OT_sweep_deform_correction_remove(bpy.types.Operator):
    """Delete a key-ellipse correction (its keyframes go with it)"""
    bl_idname = "object.sweep_deform_correction_remove"
    bl_label = "Delete Correction"
    bl_options = {'REGISTER', 'UNDO'}

    index: IntProperty(name="Index", default=-1, min=-1, description="-1: the active correction")

    @classmethod
    def poll(cls, context):
        obj = _bound_mesh(context)
        return obj is not None and len(obj.sweep_deform.corrections) > 0

    def execute(self, context):
        obj = _bound_mesh(context)
        s = obj.sweep_deform
        index = s.active_correction if self.index < 0 else self.index
        if not 0 <= index < len(s.corrections):
            self.report({'ERROR'}, f"Sweep Deform: no correction {index}")
            return {'CANCELLED'}
        remove_correction(obj, index)
        return {'FINISHED'}


class OBJECT_OT_sweep_deform_key_clear(bpy.types.Operator):
    """Delete every correction of the selected key ellipse"""
    bl_idname = "object.sweep_deform_key_clear"
    bl_label = "Clear Key Corrections"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        obj = _bound_mesh(context)
        return obj is not None and obj.sweep_deform.active_key >= 0

    def execute(self, context):
        obj = _bound_mesh(context)
        s = obj.sweep_deform
        for i in reversed(range(len(s.corrections))):
            c = s.corrections[i]
            if c.sweep == s.active_sweep and c.key == s.active_key:
                remove_correction(obj, i)
        return {'FINISHED'}


class VIEW3D_MT_sweep_deform(bpy.types.Menu):
    bl_label = "Sweep Deform"
    bl_idname = "VIEW3D_MT_sweep_deform"

    def draw(self, context):
        layout = self.layout
        layout.operator(OBJECT_OT_sweep_deform_add.bl_idname, icon='MOD_ARMATURE')
        layout.operator(OBJECT_OT_sweep_deform_bind.bl_idname)
        layout.operator(OBJECT_OT_sweep_deform_unbind.bl_idname)
        layout.separator()
        layout.operator(OBJECT_OT_sweep_deform_edit_keys.bl_idname, icon='MESH_CIRCLE')
        layout.separator()
        layout.operator_menu_enum("object.sweep_deform_bake", "target", text="Bake", icon='FILE_CACHE')


def _object_menu(self, context):
    self.layout.separator()
    self.layout.menu(VIEW3D_MT_sweep_deform.bl_idname)


def _modifier_menu(self, context):
    self.layout.operator(OBJECT_OT_sweep_deform_add.bl_idname, text="Sweep Deform", icon='MOD_ARMATURE')


classes = (OBJECT_OT_sweep_deform_add, OBJECT_OT_sweep_deform_bind, OBJECT_OT_sweep_deform_unbind,
           OBJECT_OT_sweep_deform_edit_keys, OBJECT_OT_sweep_deform_correction_remove,
           OBJECT_OT_sweep_deform_key_clear, VIEW3D_MT_sweep_deform)

# The Add Modifier menu's Deform column (Blender 4.0+), else nothing there.
_MODIFIER_MENUS = ("OBJECT_MT_modifier_add_deform",)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.VIEW3D_MT_object.append(_object_menu)
    for name in _MODIFIER_MENUS:
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.append(_modifier_menu)


def unregister():
    for name in _MODIFIER_MENUS:
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.remove(_modifier_menu)
    bpy.types.VIEW3D_MT_object.remove(_object_menu)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
