# SPDX-License-Identifier: GPL-3.0-or-later
"""Sweep Deform: sweep-based deformation of rigged humans (Hyun et al. 2005) as a modifier.

Layers (dependencies point down):

    operators, panel, handlers, properties      Blender glue (bpy)
    gizmos, overlay                             key-ellipse editing in the viewport (Sect. 4.2)
    key_edit                                    numpy only: corrections, gizmo math, picking
    bind, runtime, persistence, modifier        Blender glue: binding, one frame, the .blend
    bind_through_map                            binding through a bound character's displacement map
    rig_io                                      numpy only: arrays between Blender and the core
    transforms                                  plain Python: are the transforms usable? (messages)
    native, native_dmap                         ctypes bindings of libsweepdeform(_dmap) (lib/)

See docs/addon.md in the repository for how the modifier works and what it costs per frame.
"""

from . import gizmos, handlers, operator_bind_through_map, operators, overlay, panel, persistence, properties

_modules = (properties, operators, operator_bind_through_map, gizmos, panel, handlers, persistence, overlay)


def register():
    for m in _modules:
        m.register()


def unregister():
    for m in reversed(_modules):
        m.unregister()
