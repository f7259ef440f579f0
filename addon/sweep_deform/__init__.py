# SPDX-License-Identifier: GPL-3.0-or-later
"""Sweep Deform: sweep-based deformation of rigged humans (Hyun et al. 2005) as a modifier.

Layers (dependencies point down):

    operators, panel, handlers, properties      Blender glue (bpy)
    bind, runtime, persistence, modifier        Blender glue: binding, one frame, the .blend
    rig_io                                      numpy only: arrays between Blender and the core
    native                                      ctypes binding of libsweepdeform (lib/)

See docs/addon.md in the repository for how the modifier works and what it costs per frame.
"""

from . import handlers, operators, panel, properties

_modules = (properties, operators, panel, handlers)


def register():
    for m in _modules:
        m.register()


def unregister():
    for m in reversed(_modules):
        m.unregister()
