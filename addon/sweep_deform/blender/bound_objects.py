# SPDX-License-Identifier: GPL-3.0-or-later
"""Which objects of a scene carry a binding, without scanning every object on every update."""

_bound = {}      # scene name -> (object count, generation, [object names])
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
    the scene's object count or the generation changes."""
    objects = scene.objects
    cached = _bound.get(scene.name)
    if cached is None or cached[0] != len(objects) or cached[1] != _generation:
        names = [o.name for o in objects if o.type == 'MESH' and o.sweep_deform.state != 'UNBOUND']
        cached = _bound[scene.name] = (len(objects), _generation, names)
    found = []
    for name in cached[2]:
        o = objects.get(name)
        if o is None or o.type != 'MESH' or o.sweep_deform.state == 'UNBOUND':
            _bound.pop(scene.name, None)  # renamed or unbound: scan again next time
            continue
        found.append(o)
    return found
