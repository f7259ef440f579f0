# SPDX-License-Identifier: GPL-3.0-or-later
"""The "Sweep Deform" modifier: a Geometry Nodes modifier running one small node group.

Blender's Python API cannot register a modifier type, so the modifier is built from what
Blender offers. The node group does::

    Group Input ─► Set Position (Selection = attribute exists,
                                Offset = Named Attribute "sweep_deform_offset")
                ─► Remove Named Attribute "sweep_deform_offset" ─► Group Output

* The add-on writes offsets (deformed − rest, mesh space), not positions, into the mesh's
  ``sweep_deform_offset`` point attribute; a missing attribute is a no-op, so the rest mesh is
  never overwritten and an unbound modifier does nothing.
* The group removes the attribute from its output: modifiers after it never see it, and
  *Apply* bakes the deformed positions into a mesh that carries no offsets any more, so the
  deformation cannot happen twice.
* Being a real modifier, it can be reordered, toggled for viewport and render, applied, and
  followed by other modifiers (Subdivision Surface).
* The group does not reference the armature, so a pose change evaluates the armature only;
  the handler then writes the offsets and Blender evaluates the mesh once (see handlers.py).
"""

import bpy

from ..core.arrays import OFFSET_ATTRIBUTE

GROUP_NAME = "Sweep Deform"
MODIFIER_NAME = "Sweep Deform"
#: Tag on the node group (an ID property) and its layout version.
GROUP_TAG = "sweep_deform_group"
GROUP_VERSION = 1


def is_sweep_group(ng):
    return ng is not None and ng.get(GROUP_TAG, 0) >= 1


def _build(ng):
    ng.nodes.clear()
    ng.interface.clear()
    ng.interface.new_socket(name="Geometry", in_out='INPUT', socket_type='NodeSocketGeometry')
    ng.interface.new_socket(name="Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
    if hasattr(ng, "is_modifier"):
        ng.is_modifier = True
    nodes, links = ng.nodes, ng.links
    gin = nodes.new('NodeGroupInput')
    gout = nodes.new('NodeGroupOutput')
    named = nodes.new('GeometryNodeInputNamedAttribute')
    named.data_type = 'FLOAT_VECTOR'
    named.inputs['Name'].default_value = OFFSET_ATTRIBUTE
    setpos = nodes.new('GeometryNodeSetPosition')
    remove = nodes.new('GeometryNodeRemoveAttribute')
    remove.inputs['Name'].default_value = OFFSET_ATTRIBUTE
    links.new(gin.outputs['Geometry'], setpos.inputs['Geometry'])
    links.new(named.outputs['Exists'], setpos.inputs['Selection'])
    links.new(named.outputs['Attribute'], setpos.inputs['Offset'])
    links.new(setpos.outputs['Geometry'], remove.inputs['Geometry'])
    links.new(remove.outputs['Geometry'], gout.inputs['Geometry'])
    gin.location, named.location = (-400, 0), (-400, -160)
    setpos.location, remove.location, gout.location = (-150, 0), (80, 0), (300, 0)
    ng[GROUP_TAG] = GROUP_VERSION


def node_group():
    """The shared "Sweep Deform" node group, created or brought up to date."""
    for ng in bpy.data.node_groups:
        if is_sweep_group(ng) and ng.bl_idname == 'GeometryNodeTree':
            if ng.get(GROUP_TAG) != GROUP_VERSION:
                _build(ng)
            return ng
    ng = bpy.data.node_groups.new(GROUP_NAME, 'GeometryNodeTree')
    _build(ng)
    return ng


def find(obj):
    """The object's Sweep Deform modifier, or None."""
    for md in obj.modifiers:
        if md.type == 'NODES' and is_sweep_group(md.node_group):
            return md
    return None


def ensure(obj, before=None):
    """The object's Sweep Deform modifier, added (at the index of modifier `before` if given,
    else first in the stack, where deform modifiers belong) when missing."""
    md = find(obj)
    if md is not None:
        return md
    md = obj.modifiers.new(MODIFIER_NAME, 'NODES')
    md.node_group = node_group()
    md.show_on_cage = False
    target = 0
    if before is not None:
        target = list(obj.modifiers).index(before)
    src = len(obj.modifiers) - 1
    if src != target:
        obj.modifiers.move(src, target)
    return obj.modifiers[target]


def armature_modifiers(obj):
    return [md for md in obj.modifiers if md.type == 'ARMATURE']


def active(md, render):
    """Whether the modifier runs in this kind of evaluation."""
    return md.show_render if render else md.show_viewport


# ---- the offset attribute ---------------------------------------------------------------


def write_offsets(mesh, offsets):
    """Writes (V,3) float32 offsets into the mesh's offset attribute and tags the mesh."""
    attr = mesh.attributes.get(OFFSET_ATTRIBUTE)
    if attr is not None and (attr.data_type != 'FLOAT_VECTOR' or attr.domain != 'POINT'):
        mesh.attributes.remove(attr)
        attr = None
    if attr is None:
        attr = mesh.attributes.new(OFFSET_ATTRIBUTE, 'FLOAT_VECTOR', 'POINT')
    attr.data.foreach_set('vector', offsets.reshape(-1))
    mesh.update()


def clear_offsets(mesh):
    """Removes the offset attribute (the modifier then does nothing)."""
    attr = mesh.attributes.get(OFFSET_ATTRIBUTE)
    if attr is not None:
        mesh.attributes.remove(attr)
        mesh.update()
        return True
    return False
