# SPDX-License-Identifier: GPL-3.0-or-later
"""The "Sweep Deform" modifier: a Geometry Nodes modifier running one small node group, and
the hidden *carriers* that bring it each frame's deformation.

Blender's Python API cannot register a modifier type, so the modifier is built from what
Blender offers. The node group (layout version 4) does::

    Mesh Carrier ─► Object Info (Original) ─────────────────────────────────────────┐
    Carrier ─► Object Info (Original) ─► Sample Index (Position, by Index) ──┐       │
    Group Input ─► Set Position (Selection = counts match, Offset = ─────────┘)     │
                ─► Remove Named Attribute "sweep_deform_offset" ─► Switch (viewport and
                   the mesh carrier's count = the incoming count: the mesh carrier) ─► Output

* The per-frame data lives outside the artist's mesh, in objects that are in no collection
  (so never drawn, rendered or listed in the view layer), owned by the object: the add-on
  writes them, never the character's mesh. Hence linked duplicates (Alt+D, a shared mesh)
  each have their own, a character whose mesh is linked from a library deforms through a
  library override (the override's modifier points at local carriers), and playback leaves
  the character's mesh datablock untouched.
* The **mesh carrier** (viewport only) is a copy of the character's mesh (its faces,
  attributes, UVs, vertex groups, materials; no shape keys) whose positions are the frame's
  deformed positions: the group hands it on as it is. It serves whenever nothing before Sweep
  Deform moves the vertices (shape keys are turned by the core): sampling a carrier per
  vertex costs Blender 0.5-0.7 ms a frame at 75K vertices, handing a mesh on 0.1-0.3 ms (see
  docs/addon.md). It is copied again when the character's mesh changes (frame.py), emptied
  when it cannot serve (a modifier before that moves vertices, Edit Mode or a paint mode on
  the character, a file being saved: files keep only the offsets), and then the offsets
  carrier serves, brought up to date first (fall_back_to_offsets).
* The **offsets carrier** (one for the viewport, one for renders): vertex *i* holds vertex
  *i*'s offset (deformed − rest, mesh space), added to what reaches the modifier; the rest
  pose gives zero offsets, so the rest mesh is reproduced exactly; no carrier (unbound) is a
  no-op. With modifiers before Sweep Deform it also holds each vertex's local linear map.
* A vertex count reaching the modifier that differs from the carrier's (a Mirror, Array, ...
  before it) passes the geometry through unchanged, with a warning on the modifier (Warning
  node, Blender 4.3+) and a message in the Sweep Deform panel (see count_problem()).
* The group still removes the attribute of layout version 1 (offsets in the mesh) from its
  output, so files bound by an older version never show a stale attribute.
* Being a real modifier, it can be reordered, toggled for viewport and render, applied, and
  followed by other modifiers (Subdivision Surface).
* The group does not reference the armature, so a pose change evaluates the armature only;
  the handler then writes a carrier and Blender evaluates the mesh once (see handlers.py).
"""

import bpy

from ..core.arrays import OFFSET_ATTRIBUTE

GROUP_NAME = "Sweep Deform"
MODIFIER_NAME = "Sweep Deform"
#: Tag on the node group (an ID property) and its layout version.
GROUP_TAG = "sweep_deform_group"
GROUP_VERSION = 4
#: The node group's object inputs: the offsets carrier of the viewport and that of renders,
#: and the viewport's mesh carrier.
CARRIER_INPUT = "Carrier"
RENDER_CARRIER_INPUT = "Render Carrier"
MESH_CARRIER_INPUT = "Mesh Carrier"
INPUTS = {False: CARRIER_INPUT, True: RENDER_CARRIER_INPUT}
#: On a mesh carrier object: marks it as one (offsets carriers do not have it).
CARRIER_MESH = "sweep_deform_mesh"
MESH_CARRIER_PREFIX = ".Sweep Deform mesh carrier "
#: On a carrier object: whether it is the render carrier.
CARRIER_RENDER = "sweep_deform_render"
#: On a carrier object: the name of the object it belongs to. A copy of the object (Alt+D,
#: Shift+D) still points at the original's carrier and gets its own; a renamed object gets a new
#: one (the old one, used by nobody, is not saved). A name and not an ID pointer: a pointer back
#: would make a cycle that keeps a deleted character and its carrier in the file for ever.
CARRIER_OWNER = "sweep_deform_owner"
CARRIER_PREFIX = {False: ".Sweep Deform carrier ", True: ".Sweep Deform render carrier "}
#: A carrier for shape keys and modifiers before Sweep Deform holds this many blocks of V
#: points: the offsets, the three rows of J - I (J: each vertex's local linear map, mesh space)
#: and the rest positions. One buffer, written in one copy (named attributes were 10x slower).
FRAME_BLOCKS = 5
#: The Warning node's text (Blender 4.3+).
COUNT_WARNING = ("A modifier before Sweep Deform changes the vertex count: the geometry passes through "
                 "unchanged. Move that modifier after Sweep Deform")


def is_sweep_group(ng):
    return ng is not None and ng.get(GROUP_TAG, 0) >= 1


def _int_inputs(node):
    """The A and B inputs of a Compare node set to integers (Blender 4.x lists the sockets of
    every type, 5.x only those of its type)."""
    found = [i for i in node.inputs if i.type == 'INT' and getattr(i, "enabled", True)]
    return found[0], found[1]


def _object_geometry(nodes, links, socket):
    """Object Info (Original space) of the object given by `socket`."""
    info = nodes.new('GeometryNodeObjectInfo')
    info.transform_space = 'ORIGINAL'
    links.new(socket, info.inputs['Object'])
    return info


def _point_count(nodes, links, geometry):
    """Domain Size (mesh) of `geometry`."""
    size = nodes.new('GeometryNodeAttributeDomainSize')
    size.component = 'MESH'
    links.new(geometry, size.inputs['Geometry'])
    return size


def _equal(nodes, links, first, second):
    """Compare (integers, equal) of two sockets."""
    compare = nodes.new('FunctionNodeCompare')
    compare.data_type = 'INT'
    compare.operation = 'EQUAL'
    a, b = _int_inputs(compare)
    links.new(first, a)
    links.new(second, b)
    return compare


def _switch(nodes, links, kind, condition, if_false, if_true):
    """Switch of `kind` ('GEOMETRY', 'VECTOR') on `condition`."""
    switch = nodes.new('GeometryNodeSwitch')
    switch.input_type = kind
    links.new(condition, switch.inputs['Switch'])
    links.new(if_false, switch.inputs['False'])
    links.new(if_true, switch.inputs['True'])
    return switch


def _binary(nodes, links, node_type, operation, first, second):
    """A Boolean Math or Vector Math node (`node_type`) doing `operation` on two sockets."""
    node = nodes.new(node_type)
    node.operation = operation
    links.new(first, node.inputs[0])
    links.new(second, node.inputs[1])
    return node


def _build(ng):
    _identifiers.clear()  # its sockets are made again
    ng.nodes.clear()
    ng.interface.clear()
    ng.interface.new_socket(name="Geometry", in_out='INPUT', socket_type='NodeSocketGeometry')
    ng.interface.new_socket(name=CARRIER_INPUT, in_out='INPUT', socket_type='NodeSocketObject')
    ng.interface.new_socket(name=RENDER_CARRIER_INPUT, in_out='INPUT', socket_type='NodeSocketObject')
    ng.interface.new_socket(name=MESH_CARRIER_INPUT, in_out='INPUT', socket_type='NodeSocketObject')
    ng.interface.new_socket(name="Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
    if hasattr(ng, "is_modifier"):
        ng.is_modifier = True
    nodes, links = ng.nodes, ng.links
    gin = nodes.new('NodeGroupInput')
    gout = nodes.new('NodeGroupOutput')
    # The viewport's carrier or the render's (a render in another thread while the viewport
    # plays other frames: each evaluation reads the offsets written for it).
    info = _object_geometry(nodes, links, gin.outputs[CARRIER_INPUT])
    render_info = _object_geometry(nodes, links, gin.outputs[RENDER_CARRIER_INPUT])
    is_viewport = nodes.new('GeometryNodeIsViewport')
    pick = _switch(nodes, links, 'GEOMETRY', is_viewport.outputs[0], render_info.outputs['Geometry'],
                   info.outputs['Geometry'])
    position = nodes.new('GeometryNodeInputPosition')
    index = nodes.new('GeometryNodeInputIndex')
    sample = nodes.new('GeometryNodeSampleIndex')
    sample.data_type = 'FLOAT_VECTOR'
    sample.domain = 'POINT'
    links.new(pick.outputs[0], sample.inputs['Geometry'])
    links.new(position.outputs['Position'], sample.inputs['Value'])
    links.new(index.outputs['Index'], sample.inputs['Index'])
    # counts: the incoming mesh's and the carrier's points
    size_in = _point_count(nodes, links, gin.outputs['Geometry'])
    size_carrier = _point_count(nodes, links, pick.outputs[0])
    plain = _equal(nodes, links, size_in.outputs['Point Count'], size_carrier.outputs['Point Count'])
    packed_size = nodes.new('ShaderNodeMath')
    packed_size.operation = 'MULTIPLY'
    links.new(size_in.outputs['Point Count'], packed_size.inputs[0])
    packed_size.inputs[1].default_value = float(FRAME_BLOCKS)
    packed = _equal(nodes, links, packed_size.outputs[0], size_carrier.outputs['Point Count'])
    same = _binary(nodes, links, 'FunctionNodeBooleanMath', 'OR', plain.outputs['Result'], packed.outputs['Result'])
    has_carrier = nodes.new('FunctionNodeCompare')
    has_carrier.data_type = 'INT'
    has_carrier.operation = 'GREATER_THAN'
    a, b = _int_inputs(has_carrier)
    links.new(size_carrier.outputs['Point Count'], a)
    b.default_value = 0
    # has a carrier and not the same count
    differ = _binary(nodes, links, 'FunctionNodeBooleanMath', 'NIMPLY', has_carrier.outputs['Result'],
                     same.outputs[0])
    use = nodes.new('FunctionNodeBooleanMath')
    use.operation = 'NOT'
    try:  # Blender 4.3+: the warning shows on the modifier; its output gates the deformation
        warning = nodes.new('GeometryNodeWarning')
        warning.warning_type = 'WARNING'
        warning.inputs['Message'].default_value = COUNT_WARNING
        links.new(differ.outputs[0], warning.inputs['Show'])
        links.new(warning.outputs['Show'], use.inputs[0])
        warning.location = (-150, -420)
    except RuntimeError:
        links.new(differ.outputs[0], use.inputs[0])
    setpos = nodes.new('GeometryNodeSetPosition')
    remove = nodes.new('GeometryNodeRemoveAttribute')
    remove.inputs['Name'].default_value = OFFSET_ATTRIBUTE
    links.new(gin.outputs['Geometry'], setpos.inputs['Geometry'])
    links.new(use.outputs[0], setpos.inputs['Selection'])
    # Shape keys and modifiers before this one ride along: offset + (J - I)(incoming - rest).
    # A carrier of FRAME_BLOCKS x the vertices holds, after the offsets, the rows of J - I and
    # the rest positions, block after block; a plain one (offsets only) samples zeros there
    # (Sample Index out of range), which leaves the plain offset.
    sampled = []
    for k in range(1, FRAME_BLOCKS):
        at_index = nodes.new('ShaderNodeMath')
        at_index.operation = 'MULTIPLY_ADD'  # Index + k * vertex count (exact in float below 2^24)
        links.new(size_in.outputs['Point Count'], at_index.inputs[0])
        at_index.inputs[1].default_value = float(k)
        links.new(index.outputs['Index'], at_index.inputs[2])
        at = nodes.new('GeometryNodeSampleIndex')
        at.data_type = 'FLOAT_VECTOR'
        at.domain = 'POINT'
        links.new(pick.outputs[0], at.inputs['Geometry'])
        links.new(position.outputs['Position'], at.inputs['Value'])
        links.new(at_index.outputs[0], at.inputs['Index'])
        at_index.location, at.location = (-650, -950 - 160 * k), (-400, -950 - 160 * k)
        sampled.append(at.outputs[0])
    incoming = nodes.new('GeometryNodeInputPosition')
    moved = _binary(nodes, links, 'ShaderNodeVectorMath', 'SUBTRACT', incoming.outputs['Position'], sampled[3])
    combine = nodes.new('ShaderNodeCombineXYZ')
    for i in range(3):
        dot = _binary(nodes, links, 'ShaderNodeVectorMath', 'DOT_PRODUCT', sampled[i], moved.outputs['Vector'])
        links.new(dot.outputs['Value'], combine.inputs[i])
        dot.location = (-150, -950 - 160 * i)
    total = _binary(nodes, links, 'ShaderNodeVectorMath', 'ADD', sample.outputs[0], combine.outputs['Vector'])
    # Only a carrier of FRAME_BLOCKS x the vertices needs the J part: the switch's condition is a
    # single value, so Blender evaluates only the branch it picks (layout 3; in layout 2 the four
    # samples of the J part, over zeros, made each evaluation of the mesh ~3x as long).
    with_frames = _switch(nodes, links, 'VECTOR', packed.outputs['Result'], sample.outputs[0],
                          total.outputs['Vector'])
    links.new(with_frames.outputs[0], setpos.inputs['Offset'])
    with_frames.location = (100, -150)
    incoming.location, moved.location = (-400, -1600), (-150, -1600)
    combine.location, total.location = (50, -1100), (50, -200)
    links.new(setpos.outputs['Geometry'], remove.inputs['Geometry'])
    # The viewport's mesh carrier, handed on as it is when it has the incoming point count (an
    # emptied one has none). The condition is a single value: only the branch picked runs.
    whole_info = _object_geometry(nodes, links, gin.outputs[MESH_CARRIER_INPUT])
    size_whole = _point_count(nodes, links, whole_info.outputs['Geometry'])
    whole_count = _equal(nodes, links, size_in.outputs['Point Count'], size_whole.outputs['Point Count'])
    whole_here = _binary(nodes, links, 'FunctionNodeBooleanMath', 'AND', is_viewport.outputs[0],
                         whole_count.outputs['Result'])
    whole = _switch(nodes, links, 'GEOMETRY', whole_here.outputs[0], remove.outputs['Geometry'],
                    whole_info.outputs['Geometry'])
    links.new(whole.outputs[0], gout.inputs['Geometry'])
    whole_info.location, size_whole.location = (-1150, 350), (-900, 350)
    whole_count.location, whole_here.location, whole.location = (-650, 350), (-400, 350), (600, 100)
    gin.location, info.location, render_info.location = (-1400, 0), (-1150, -100), (-1150, -300)
    is_viewport.location, pick.location = (-1150, 100), (-900, -150)
    position.location, index.location = (-650, -350), (-650, -450)
    sample.location, size_in.location, size_carrier.location = (-400, -150), (-650, -600), (-650, -750)
    same.location, has_carrier.location = (-400, -600), (-400, -780)
    plain.location, packed_size.location, packed.location = (-550, -560), (-800, -820), (-550, -700)
    differ.location, use.location = (-250, -650), (0, -450)
    setpos.location, remove.location, gout.location = (150, 0), (380, 0), (850, 0)
    ng[GROUP_TAG] = GROUP_VERSION


def node_group():
    """The shared "Sweep Deform" node group of this file, created or brought up to date. A
    group linked from a library is never changed (Blender would not keep it): its characters
    keep the library's layout, which reads the same carriers."""
    for ng in bpy.data.node_groups:
        if is_sweep_group(ng) and ng.bl_idname == 'GeometryNodeTree' and ng.library is None:
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


# ---- the modifier's carrier input ---------------------------------------------------------


#: (node group pointer, its layout tag, render) -> the input's identifier: looked up once per
#: group, not on every frame (the group's interface only changes with its layout); forgotten
#: on load and undo, which reallocate the groups.
_identifiers = {}


def forget_identifiers():
    _identifiers.clear()


def _input_identifier(md, render=False, name=None):
    """The identifier of the group's input `name` (default: the offsets carrier of a render or
    of the viewport)."""
    ng = md.node_group
    if ng is None:
        return None
    name = name or INPUTS[render]
    key = (ng.as_pointer(), ng.get(GROUP_TAG), name)
    found = _identifiers.get(key)
    if found is None:
        for item in ng.interface.items_tree:
            if getattr(item, "in_out", None) == 'INPUT' and item.name == name:
                found = item.identifier
                break
        if found is not None:
            _identifiers[key] = found
    return found


def _input_slot(md, identifier):
    """Blender 5.x: the input's RNA wrapper (``md.properties.inputs.<id>.value``); None in 4.x,
    where the inputs are ID properties of the modifier (``md[id]``)."""
    props = getattr(md, "properties", None)
    inputs = getattr(props, "inputs", None)
    if inputs is None:
        return None
    slot = getattr(inputs, identifier, None)
    if slot is None:  # the modifier has not caught up with its group's interface yet
        md.node_group = md.node_group
        slot = getattr(inputs, identifier, None)
    return slot


def get_carrier(md, render=False, name=None):
    """The object the modifier's Carrier (Render Carrier; input `name`) points at, or None."""
    identifier = _input_identifier(md, render, name)
    if identifier is None:
        return None
    if getattr(getattr(md, "properties", None), "inputs", None) is not None:
        slot = _input_slot(md, identifier)
        return slot.value if slot is not None else None
    value = md.get(identifier)
    return value if isinstance(value, bpy.types.Object) else None


def set_carrier(md, carrier, render=False, name=None):
    identifier = _input_identifier(md, render, name)
    if identifier is None:
        raise RuntimeError(f"the node group of '{md.name}' has no {name or INPUTS[render]} input")
    slot = _input_slot(md, identifier)
    if slot is not None:
        slot.value = carrier
    else:
        md[identifier] = carrier
    # A new object input is a new depsgraph relation: assigning the group again is what makes
    # Blender rebuild the relations (an ID property write alone does not).
    md.node_group = md.node_group
    md.id_data.update_tag()


# ---- the carrier ------------------------------------------------------------------------------


def owns(obj, carrier, render=False):
    """Whether `carrier` is `obj`'s own offsets carrier of the viewport (of renders)."""
    return (carrier is not None and carrier.type == 'MESH' and carrier.get(CARRIER_OWNER) == obj.name
            and bool(carrier.get(CARRIER_RENDER, False)) == render and not carrier.get(CARRIER_MESH, False))


def owns_mesh_carrier(obj, carrier):
    """Whether `carrier` is `obj`'s own mesh carrier."""
    return (carrier is not None and carrier.type == 'MESH' and carrier.get(CARRIER_OWNER) == obj.name
            and bool(carrier.get(CARRIER_MESH, False)))


def _writable(carrier):
    """Local through and through: not linked, not a library override, its mesh local (writes
    into library data are ignored by Blender, and an override would not keep them)."""
    return carrier.library is None and carrier.override_library is None and carrier.data.library is None


def _new_carrier(obj, vertex_count, render):
    name = (CARRIER_PREFIX[render] + obj.name)[:63]
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(vertex_count)  # zero offsets: the rest mesh
    carrier = bpy.data.objects.new(name, mesh)
    carrier[CARRIER_OWNER] = obj.name
    carrier[CARRIER_RENDER] = render
    carrier.hide_select = True
    return carrier


def carrier(obj, md, vertex_count, create=True, render=False):
    """(carrier, fresh): the object's own viewport (render) carrier with `vertex_count` vertices
    (FRAME_BLOCKS x the mesh's with the local linear maps): the one the modifier points at if
    `obj` owns it, else (a copy of another object, an old file, a library override whose carrier
    is linked) a new local one when `create` (not during a render), else (None, False).
    `fresh`: made or resized now, so it holds no offsets."""
    if _input_identifier(md, render) is None and md.id_data.library is None:
        md.node_group = node_group()  # a group of an older layout: brought up to date
    c = get_carrier(md, render)
    if owns(obj, c, render) and _writable(c):
        if len(c.data.vertices) == vertex_count:
            return c, False
        c.data.clear_geometry()
        c.data.vertices.add(vertex_count)
        return c, True
    if not create or md.id_data.library is not None:
        return None, False
    c = _new_carrier(obj, vertex_count, render)
    set_carrier(md, c, render)
    return c, True


def carriers(obj, md, vertex_count):
    """Both carriers, made if missing (binding, the viewport): [(viewport, fresh), (render, fresh)]."""
    return [carrier(obj, md, vertex_count, True, render) for render in (False, True)]


def _mesh_copy(obj, name):
    """A copy of the object's mesh for its mesh carrier: faces, attributes, UVs, vertex groups
    and materials as they are; no shape keys (the carrier's positions are final)."""
    mesh = obj.data.copy()
    mesh.name = name
    if mesh.shape_keys is not None:
        holder = bpy.data.objects.new(name, mesh)  # shape keys go through an object
        holder.shape_key_clear()
        bpy.data.objects.remove(holder)
    attr = mesh.attributes.get(OFFSET_ATTRIBUTE)
    if attr is not None:
        mesh.attributes.remove(attr)
    return mesh


def mesh_carrier(obj, md, stale=False):
    """(mesh carrier, fresh): the object's own mesh carrier holding a copy of its mesh: the one
    the modifier points at if `obj` owns it, filled again (a new copy) when empty, of another
    vertex count, or `stale`; else a new one. (None, False) for a linked modifier, which cannot
    point anywhere else. `fresh`: copied now, so it holds the rest positions."""
    if md.id_data.library is not None:
        return None, False
    if _input_identifier(md, name=MESH_CARRIER_INPUT) is None:
        md.node_group = node_group()  # a group of an older layout: brought up to date
    c = get_carrier(md, name=MESH_CARRIER_INPUT)
    name = (MESH_CARRIER_PREFIX + obj.name)[:63]
    if owns_mesh_carrier(obj, c) and _writable(c):
        if not stale and len(c.data.vertices) == len(obj.data.vertices) > 0:
            return c, False
        old = c.data
        c.data = _mesh_copy(obj, name)
        if old.users == 0:
            bpy.data.meshes.remove(old)
            c.data.name = name  # (the copy took a ".001" while the old mesh held the name)
        return c, True
    c = bpy.data.objects.new(name, _mesh_copy(obj, name))
    c[CARRIER_OWNER] = obj.name
    c[CARRIER_MESH] = True
    c.hide_select = True
    set_carrier(md, c, name=MESH_CARRIER_INPUT)
    return c, True


def mesh_carrier_in_use(obj, md):
    """The object's own mesh carrier if it holds a mesh (the modifier then hands it on), else None."""
    if md is None or _input_identifier(md, name=MESH_CARRIER_INPUT) is None:
        return None
    c = get_carrier(md, name=MESH_CARRIER_INPUT)
    if owns_mesh_carrier(obj, c) and _writable(c) and len(c.data.vertices) > 0:
        return c
    return None


def empty_mesh_carrier(obj, md):
    """The mesh carrier emptied (its copy dropped): the offsets carrier serves. Returns True if
    it held a mesh."""
    c = mesh_carrier_in_use(obj, md)
    if c is None:
        return False
    c.data.clear_geometry()
    c.data.update()
    return True


def write_offsets(carrier_obj, offsets):
    """Writes (N,3) float32 (the offsets, or the packed blocks: see FRAME_BLOCKS) as the
    carrier's vertex positions and tags it (the character's mesh is not touched)."""
    mesh = carrier_obj.data
    # The position attribute takes the buffer in one copy; vertices' "co" goes element by
    # element (measured at 75K vertices: 0.5 ms against 7 ms in 4.3, 0.07 against 15 in 5.2).
    mesh.attributes['position'].data.foreach_set('vector', offsets.reshape(-1))
    mesh.update()


def moved_before(obj, md, render=False):
    """Whether an active modifier before Sweep Deform moves the vertices."""
    stack = list(obj.modifiers)
    return any(active(m, render) for m in stack[:stack.index(md)])


def has_shape_keys(obj):
    """Whether the mesh has shape keys besides the basis (they may move the vertices)."""
    keys = obj.data.shape_keys
    return keys is not None and len(keys.key_blocks) > 1


def clear_offsets(obj):
    """The object's carriers (those it owns) go empty: the modifier then does nothing. The
    mesh is left alone. Returns True if there was something to clear."""
    md = find(obj)
    cleared = empty_mesh_carrier(obj, md)
    for render in (False, True):
        c = get_carrier(md, render) if md is not None else None
        if not owns(obj, c, render) or not _writable(c) or len(c.data.vertices) == 0:
            continue
        c.data.clear_geometry()
        c.data.update()
        cleared = True
    return cleared


def remove_carrier(obj):
    """Unbinding: the object's own carriers are deleted and the inputs cleared (carriers shared
    with the object this one was copied from are left to their owner)."""
    md = find(obj)
    if md is None:
        return
    for render, name in ((False, None), (True, None), (False, MESH_CARRIER_INPUT)):
        if _input_identifier(md, render, name) is None:
            continue
        c = get_carrier(md, render, name)
        if c is not None and md.id_data.library is None:
            set_carrier(md, None, render, name)
        mine = owns_mesh_carrier(obj, c) if name else owns(obj, c, render)
        if mine and _writable(c) and c.users == 0:
            mesh = c.data
            bpy.data.objects.remove(c)
            if mesh.users == 0:
                bpy.data.meshes.remove(mesh)


def remove_offset_attribute(mesh):
    """Layout version 1 kept the offsets in the mesh: migration removes them (local meshes)."""
    attr = mesh.attributes.get(OFFSET_ATTRIBUTE)
    if attr is None or mesh.library is not None:
        return False
    mesh.attributes.remove(attr)
    return True


# ---- what reaches the modifier ------------------------------------------------------------------

#: Modifier types that move vertices and never add or remove any.
DEFORM_ONLY = {
    'ARMATURE', 'CAST', 'CLOTH', 'COLLISION', 'CORRECTIVE_SMOOTH', 'CURVE', 'DISPLACE', 'HOOK',
    'LAPLACIANDEFORM', 'LAPLACIANSMOOTH', 'LATTICE', 'MESH_CACHE', 'MESH_DEFORM', 'SHRINKWRAP',
    'SIMPLE_DEFORM', 'SMOOTH', 'SOFT_BODY', 'SURFACE_DEFORM', 'WARP', 'WAVE', 'DATA_TRANSFER',
    'NORMAL_EDIT', 'WEIGHTED_NORMAL', 'UV_PROJECT', 'UV_WARP', 'VERTEX_WEIGHT_EDIT',
    'VERTEX_WEIGHT_MIX', 'VERTEX_WEIGHT_PROXIMITY', 'SURFACE', 'DYNAMIC_PAINT',
}


def count_problem(obj, md, vertex_count, evaluated_count=None, render=False):
    """The panel's message when a modifier before Sweep Deform changes (or may change) the
    vertex count, else None. `evaluated_count`: the evaluated mesh's count, which tells for
    sure when nothing after Sweep Deform changes the count either."""
    stack = list(obj.modifiers)
    cut = stack.index(md)
    before = [m for m in stack[:cut] if active(m, render) and m.type not in DEFORM_ONLY]
    if not before:
        return None
    after_changes = any(active(m, render) and m.type not in DEFORM_ONLY for m in stack[cut + 1:])
    names = ", ".join(f"'{m.name}'" for m in before)
    if evaluated_count is not None and not after_changes:
        if evaluated_count == vertex_count:
            return None
        return (f"{names} before Sweep Deform changes the vertex count ({vertex_count:,} bound, "
                f"{evaluated_count:,} reach it): Sweep Deform passes the geometry through unchanged. Move "
                f"{'it' if len(before) == 1 else 'them'} after Sweep Deform")
    return (f"{names} before Sweep Deform may change the vertex count: if it does, Sweep Deform passes "
            "the geometry through unchanged (the modifier shows a warning). Deform modifiers belong before it, "
            "the others after it")
