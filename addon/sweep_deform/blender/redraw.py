# SPDX-License-Identifier: GPL-3.0-or-later
"""Asking Blender to redraw the areas that show the add-on's state (after a setting, a
correction or a frame changed). Harmless without a window (background, scripts)."""

import bpy


def _tag_redraw(area_types):
    try:
        wm = bpy.context.window_manager
    except AttributeError:
        return
    if wm is None:
        return
    for window in wm.windows:
        for area in window.screen.areas:
            if area.type in area_types:
                area.tag_redraw()


def redraw_views():
    """The 3D viewports (the key-ellipse overlay) and the Properties editors (the panel)."""
    _tag_redraw(('VIEW_3D', 'PROPERTIES'))


def redraw_properties():
    """The Properties editors only (the panel's figures after a frame)."""
    _tag_redraw(('PROPERTIES',))
