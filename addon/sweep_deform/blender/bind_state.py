# SPDX-License-Identifier: GPL-3.0-or-later
"""The binding's state (``sweep_deform.state``) as the scene changes after binding: 'REBIND'
when the mesh, its users or the armature's rest pose changed; unbound when the Sweep Deform
modifier left the stack. Library data is never written: a linked character is only told why."""

from . import binding, deformer_cache, modifier, persistence


def set_rebind(obj, message):
    """Marks the object 'REBIND' with `message` and empties its carrier (the mesh shows undeformed)."""
    if binding.linked_reason(obj):
        # Library data is never written (Blender would not save it): the panel says why.
        deformer_cache.entry(obj).refuse(obj, message)
        return
    s = obj.sweep_deform
    if s.state != 'REBIND':
        s.state = 'REBIND'
    if s.message != message:
        s.message = message
    deformer_cache.forget(obj)
    modifier.clear_offsets(obj)


def modifier_gone(obj):
    """The Sweep Deform modifier left the stack: applied or removed. Either way the binding
    ends. If the rest positions are untouched it was removed, and the Armature modifier it
    replaced gets its deformation back; if they changed it was applied (the deformation is in
    the mesh now), and re-enabling the Armature modifier would deform twice."""
    linked = binding.linked_reason(obj)
    if linked:  # nothing can be restored here, only said
        deformer_cache.entry(obj).refuse(obj, f"The Sweep Deform modifier is gone, but the binding stays: {linked}")
        return
    removed = persistence.rest_positions_match(obj) if persistence.counts_match(obj) else False
    binding.unbind(obj, restore_armature_modifier=removed)


def check_topology(obj):
    """Full check (connectivity hash); marks the object 'REBIND' on a change. True if fine."""
    s = obj.sweep_deform
    if s.state != 'BOUND':
        return False
    if not persistence.topology_matches(obj):
        set_rebind(obj, "The mesh's topology changed after binding: bind again")
        return False
    return True
