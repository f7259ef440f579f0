# SPDX-License-Identifier: GPL-3.0-or-later
"""Sweep Deform: sweep-based deformation of rigged humans (Hyun et al. 2005) as a modifier.

This file only registers. The add-on stands on three floors, and every import points down
(a test fails on an import circle, another on ``bpy`` in core/):

    ui/        what the artist sees and does: operators, panel, menus, overlay, gizmos
    blender/   Blender's data ↔ the core: properties, binding, one frame, the deformer
               cache, the .blend, the modifier, bake outputs, handlers
    core/      no bpy: ctypes bindings of libsweepdeform(_dmap), arrays, checks, the fitting
               report, key-editing maths, point-cache files

See docs/architecture.md (the add-on's floors and one frame's path) and docs/addon.md.
"""

from .blender import handlers, persistence, properties
from .ui import bake_operator, bind_operators, gizmos, key_operators, map_operator, menu, overlay, panel

_modules = (properties, bind_operators, key_operators, menu, map_operator, bake_operator, gizmos, panel, handlers,
            persistence, overlay)


def register():
    for m in _modules:
        m.register()


def unregister():
    for m in reversed(_modules):
        m.unregister()
