# SPDX-License-Identifier: GPL-3.0-or-later
"""Every application handler of the add-on, in one place.

When offsets are written (measured in Blender 4.3 and 5.2, see docs/addon.md):

* ``depsgraph_update_post(scene, depsgraph)`` — interactive posing (incl. IK, constraints,
  drivers), property changes, undo. It does not fire during renders.
* ``frame_change_post(scene, depsgraph)`` — playback, ``frame_set``, F12 and ``blender -b -a``.
  In a render its ``depsgraph`` is the render depsgraph, so the pose is the one being rendered;
  the write goes into the object's *render* carrier and is picked up by that very frame's
  render, while the viewport keeps its own carrier (see modifier.py).

No feedback loop: a write tags the mesh, and Blender evaluates it again in a second pass of
the same update *without* calling the handlers again; and :func:`frame.evaluate` writes
only when the evaluated pose (or a setting) differs from what it last wrote. The node group
does not depend on the armature, so a pose change evaluates the mesh once, after the write.

``load_post`` / ``undo_post`` / ``redo_post`` drop the native objects (re-created lazily from
the blobs in the file) and check the meshes' topology against the binding's fingerprint.

A file opened without the extension (a render-farm node, a colleague's machine) deforms by
the Armature modifier: ``save_pre`` switches every bound character's replaced Armature
modifier back on (it keeps its object) and its Sweep Deform modifier off, so the file on disk
is an ordinary Armature set-up; ``save_post`` (and ``save_post_fail``) and ``load_post``
restore both. See docs/addon.md, "Render farms".
"""

import traceback

import bpy
from bpy.app.handlers import persistent

from . import bind_state, binding, bound_objects, deformer_cache, frame, modifier, redraw

#: Object name → mode seen last (a full topology check runs when an object leaves Edit Mode).
_modes = {}
#: Errors already printed (a broken character must not flood the console on every update).
_reported = set()


def shows(obj, depsgraph, render):
    """Whether this evaluation needs the object; one that it does not need costs nothing, and
    showing it again is an update, which evaluates it for the current pose.

    * Not in the depsgraph at all (disabled in viewports or excluded and used by nothing; in a
      render, ``hide_render`` and used by nothing; not in the view layer): not needed.
    * Visible in the depsgraph's view layer: needed.
    * In the depsgraph though not visible: Blender put it there because something uses it (a
      Surface Deform or Shrinkwrap target, a constraint target), so it is needed; except when
      the object itself is hidden (H, the eye), which Blender keeps in the depsgraph whether used
      or not: not needed (disable it in viewports instead to hide a character others use)."""
    if depsgraph is None:
        return True
    try:
        if obj.evaluated_get(depsgraph) == obj:
            return False  # the original: this depsgraph does not hold it
        if render or obj.visible_get(view_layer=depsgraph.view_layer):
            return True
        return not obj.hide_get(view_layer=depsgraph.view_layer)
    except (RuntimeError, TypeError, ReferenceError):
        return True


def evaluate_scene(scene, depsgraph, render=False):
    """Updates every bound character of the scene. Returns how many were rewritten. A
    character that does not show costs its armature's Edit Mode bookkeeping and shows()."""
    written = 0
    for obj in bound_objects.in_scene(scene):
        try:
            s = obj.sweep_deform
            arm = s.armature
            if arm is not None:  # (also while the mesh is hidden: its rest pose may be edited then)
                key = ("armature", arm.name)
                mode = arm.mode
                if mode != _modes.get(key):
                    if _modes.get(key) == 'EDIT':
                        deformer_cache.forget_armature(arm)
                    _modes[key] = mode
            if not shows(obj, depsgraph, render) and _modes.get(obj.name) != 'EDIT':
                continue  # costs nothing; evaluated when it shows again (that is an update too)
            if s.saved_for_blender_without_extension:
                binding.restore_after_save(obj)  # appended, or made local: no load_post came
            else:
                binding.sync_replaced_modifier(obj)  # the artist switched it on or off
            mode = obj.mode
            if _modes.get(obj.name) == 'EDIT' and mode != 'EDIT':
                bind_state.check_topology(obj)
            if _modes.get(obj.name, 'OBJECT') != mode:  # a paint mode may have changed the mesh
                deformer_cache.mesh_changed(obj.data)
            _modes[obj.name] = mode
            written += frame.evaluate(obj, depsgraph, render)
        except ReferenceError:
            continue
        except Exception as e:  # never let one character stop the others, or the frame
            message = f"Sweep Deform: '{obj.name}': {type(e).__name__}: {e}"
            if message not in _reported:
                _reported.add(message)
                traceback.print_exc()
                print(message)
    return written


def _meshes_changed(depsgraph):
    """Meshes edited in this update (their mesh carriers copy them again, their shape keys are
    read again): a mesh whose geometry was updated, unless its shape keys were too (an animated
    or dragged key value re-evaluates the mesh on every frame, and the keys are not in the copy:
    only the keys are read again)."""
    meshes, keys = [], set()
    for update in depsgraph.updates:
        if not update.is_updated_geometry:
            continue
        if isinstance(update.id, bpy.types.Mesh):
            meshes.append(update.id.original)
        elif isinstance(update.id, bpy.types.Key):
            keys.add(update.id.original.as_pointer())
    for mesh in meshes:
        by_keys = mesh.shape_keys is not None and mesh.shape_keys.as_pointer() in keys
        deformer_cache.mesh_changed(mesh, keys_only=by_keys)


@persistent
def on_depsgraph_update_post(scene, depsgraph=None):
    if depsgraph is None:
        return
    _meshes_changed(depsgraph)
    if evaluate_scene(scene, depsgraph, render=depsgraph.mode == 'RENDER') and not bpy.app.background:
        redraw.redraw_properties()


@persistent
def on_frame_change_post(scene, depsgraph=None):
    if depsgraph is None:
        depsgraph = bpy.context.evaluated_depsgraph_get()
    render = depsgraph.mode == 'RENDER'
    evaluate_scene(scene, depsgraph, render=render)


def _bound_meshes():
    return [o for o in bpy.data.objects if o.type == 'MESH' and o.sweep_deform.state != 'UNBOUND']


def _each_bound_mesh(action, failure):
    """`action(obj)` on every bound mesh; an error is printed with `failure`, never raised
    (a save must not fail for it)."""
    for obj in _bound_meshes():
        try:
            action(obj)
        except (ReferenceError, AttributeError, RuntimeError) as e:
            print(f"Sweep Deform: '{obj.name}': {failure}: {e}")


@persistent
def on_save_pre(*_args):
    """The file on disk deforms by the Armature modifier where the extension is missing, and
    keeps the offsets, not the mesh carriers' copies of the meshes, and the joints' measured
    volume tables."""
    _each_bound_mesh(frame.fall_back_to_offsets, "its mesh carrier was not emptied")
    _each_bound_mesh(deformer_cache.keep_joint_volumes, "the joints' volume tables were not kept")
    _each_bound_mesh(binding.prepare_for_save, "not prepared for Blender without the extension")


@persistent
def on_save_post(*_args):
    _each_bound_mesh(binding.restore_after_save, "the modifiers were not restored after saving")


@persistent
def on_load_post(*_args):
    deformer_cache.clear(keep_tables=False)  # (another file, most often: nothing to take again)
    modifier.forget_identifiers()
    _modes.clear()
    if any(modifier.is_sweep_group(ng) for ng in bpy.data.node_groups):
        modifier.node_group()  # bring an older layout up to date
    for obj in _bound_meshes():
        binding.restore_after_save(obj)  # saved for Blender without the extension
    for scene in bpy.data.scenes:
        for obj in bound_objects.in_scene(scene):
            # Files bound by layout version 1 kept the offsets in the mesh: they go (once, at
            # load); the object gets its carrier at its first evaluation.
            modifier.remove_offset_attribute(obj.data)
            if obj.sweep_deform.state == 'BOUND':
                bind_state.check_topology(obj)


@persistent
def on_undo_redo_post(*_args):
    deformer_cache.clear()
    modifier.forget_identifiers()


_HANDLERS = (
    (bpy.app.handlers.depsgraph_update_post, on_depsgraph_update_post),
    (bpy.app.handlers.frame_change_post, on_frame_change_post),
    (bpy.app.handlers.load_post, on_load_post),
    (bpy.app.handlers.save_pre, on_save_pre),
    (bpy.app.handlers.save_post, on_save_post),
    (bpy.app.handlers.undo_post, on_undo_redo_post),
    (bpy.app.handlers.redo_post, on_undo_redo_post),
)


def _all_handlers():
    found = list(_HANDLERS)
    if hasattr(bpy.app.handlers, "save_post_fail"):  # Blender 4.2+: a failed save restores too
        found.append((bpy.app.handlers.save_post_fail, on_save_post))
    return found


def register():
    unregister()
    for handlers, fn in _all_handlers():
        handlers.append(fn)


def unregister():
    for handlers, fn in _all_handlers():
        # Match by name too: a reloaded module brings new function objects.
        for h in [h for h in handlers if h is fn or getattr(h, "__qualname__", None) == fn.__qualname__
                  and getattr(h, "__module__", None) == fn.__module__]:
            handlers.remove(h)
    deformer_cache.clear(keep_tables=False)
