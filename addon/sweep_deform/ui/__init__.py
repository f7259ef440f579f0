# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's top floor: what the artist sees and does. Imports blender/ and core/.

    bind_operators   add, bind, unbind (modal, in stages, Esc cancels)
    map_operator     bind selected through the active character's displacement map
    bake_operator    bake to shape keys, PC2, MDD, Alembic
    key_operators    Edit Key Ellipses on/off, delete and clear corrections
    gizmos           the key-ellipse gizmo group, its tweak and select operators, the tool
    overlay          the key ellipses and sweeps drawn in the viewport
    panel            the modifier panel and the sidebar's key-ellipse panel
    menu             Object › Sweep Deform and Add Modifier › Deform
    progress         progress bar and status text of modal operators
"""
