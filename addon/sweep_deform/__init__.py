# SPDX-License-Identifier: GPL-3.0-or-later
"""Sweep Deform: sweep-based deformation of rigged humans (Hyun et al. 2005) as a modifier.

Layers (dependencies point down):

    operators, panel, handlers, properties      Blender glue (bpy)
    bake                                        bake to shape keys, PC2/MDD (cache_files), Alembic
    gizmos, overlay                             key-ellipse editing in the viewport (Sect. 4.2)
    key_edit                                    numpy only: corrections, gizmo math, picking
    bind, runtime, persistence, modifier        Blender glue: binding, one frame, the .blend
    bind_through_map                            binding through a bound character's displacement map
    bake                                        Blender glue: bake to shape keys, PC2/MDD, Alembic
    rig_io, cache_files                         numpy only: arrays between Blender and the core,
                                                point-cache files
    transforms                                  plain Python: are the transforms usable? (messages)
    native, native_dmap                         ctypes bindings of libsweepdeform(_dmap) (lib/)

See docs/addon.md in the repository for how the modifier works and what it costs per frame.
"""

from . import (bake, gizmos, handlers, operator_bind_through_map, operators, overlay, panel, persistence,
               properties)

_modules = (properties, operators, operator_bind_through_map, bake, gizmos, panel, handlers, persistence, overlay)


def register():
    for m in _modules:
        m.register()


def unregister():
    for m in reversed(_modules):
        m.unregister()
