# SPDX-License-Identifier: GPL-3.0-or-later
"""Which objects of a scene carry a binding, without scanning every object on every update."""

_bound = {}      # scene name -> (object count, generation, [objects])
_generation = 0  # bumped by every bind, unbind, load and undo


def changed():
    """The set of bound objects may have changed (bind, unbind, load, undo)."""
    global _generation
    _generation += 1


def clear():
    _bound.clear()
    changed()


def in_scene(scene):
    """Mesh objects of the scene with a binding (any state but UNBOUND). Scanning every
    object on every depsgraph update would cost a large scene dearly: the list is kept until
    the scene's object count or the generation changes (an object removed changes the count,
    and load and undo the generation, before a kept reference could go stale); a renamed
    object is the same object."""
    objects = scene.objects
    cached = _bound.get(scene.name)
    if cached is not None and cached[0] == len(objects) and cached[1] == _generation:
        try:
            if all(o.sweep_deform.state != 'UNBOUND' for o in cached[2]):
                return cached[2]
        except ReferenceError:  # removed in a way the count did not show
            pass
    found = [o for o in objects if o.type == 'MESH' and o.sweep_deform.state != 'UNBOUND']
    _bound[scene.name] = (len(objects), _generation, found)
    return found
