# SPDX-License-Identifier: GPL-3.0-or-later
"""What the Sweep Deform node group costs Blender per frame, against the least a node group must
do to deform a mesh from a carrier: after a carrier write (the pose fixed, the handler out of
the way), `view_layer.update()` is timed with the character's modifier running

* the product's node group sampling the offsets carrier (with a modifier before Sweep Deform);
* the product's node group handing on the mesh carrier (the viewport's path otherwise);
* the least that deforms: Object Info → Sample Index of the carrier's position by Index → Set
  Position's offset (checked to give the product's positions);
* Set Position with one offset for every vertex (no per-vertex sample; wrong, for scale), and
  the least group with Sample Index's Index input unlinked (as fast: it samples index 0);
* a group that passes the geometry through (the carrier's own evaluation only).

Prints medians; never fails on speed.

    BLENDER_USER_RESOURCES=$(mktemp -d) scripts/blender --use 5.2 -b --factory-startup \\
        --python tests/blender/measure_node_group.py -- [--zip ZIP] [--frames N] [--characters fixture]
"""

import os
import statistics
import sys

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "scripts", "blender_support"))

import helpers  # noqa: E402
import install  # noqa: E402
import measure_frame  # noqa: E402


def variant(kind, modifier):
    """A node group with the product's inputs doing `kind` ('least', 'one offset', 'through')."""
    ng = bpy.data.node_groups.new(f"Sweep Deform, {kind}", 'GeometryNodeTree')
    for name, socket, io in (("Geometry", 'NodeSocketGeometry', 'INPUT'),
                             (modifier.CARRIER_INPUT, 'NodeSocketObject', 'INPUT'),
                             (modifier.RENDER_CARRIER_INPUT, 'NodeSocketObject', 'INPUT'),
                             ("Geometry", 'NodeSocketGeometry', 'OUTPUT')):
        ng.interface.new_socket(name=name, in_out=io, socket_type=socket)
    if hasattr(ng, "is_modifier"):
        ng.is_modifier = True
    nodes, links = ng.nodes, ng.links
    gin, gout = nodes.new('NodeGroupInput'), nodes.new('NodeGroupOutput')
    if kind == 'through':
        links.new(gin.outputs["Geometry"], gout.inputs["Geometry"])
        return ng
    info = nodes.new('GeometryNodeObjectInfo')
    info.transform_space = 'ORIGINAL'
    links.new(gin.outputs[modifier.CARRIER_INPUT], info.inputs['Object'])
    sample = nodes.new('GeometryNodeSampleIndex')
    sample.data_type = 'FLOAT_VECTOR'
    sample.domain = 'POINT'
    links.new(info.outputs['Geometry'], sample.inputs['Geometry'])
    links.new(nodes.new('GeometryNodeInputPosition').outputs[0], sample.inputs['Value'])
    if kind == 'least':
        links.new(nodes.new('GeometryNodeInputIndex').outputs[0], sample.inputs['Index'])
    elif kind == 'one offset':  # index 0's for every vertex
        sample.inputs['Index'].default_value = 0
    # ('unlinked index': the Index input left as it comes)
    move = nodes.new('GeometryNodeSetPosition')
    links.new(gin.outputs["Geometry"], move.inputs['Geometry'])
    links.new(sample.outputs[0], move.inputs['Offset'])
    links.new(move.outputs['Geometry'], gout.inputs['Geometry'])
    return ng


def main():
    opts = measure_frame.args()
    install.install(opts["zip"])
    from bl_ext.user_default.sweep_deform.blender import modifier
    for key in opts["characters"].split(","):
        loaded = measure_frame.load(key)
        if loaded is None:
            print(f"{key}: file missing, skipped")
            continue
        body, arm, _, bones = loaded
        bpy.context.view_layer.objects.active = body
        assert bpy.ops.object.sweep_deform_add() == {'FINISHED'}
        measure_frame.configure(body, 'sweep')
        measure_frame.time_posing(body, arm, measure_frame.poses(3, bones))
        # The frame's positions (the mesh carrier serves now) and offsets (the mesh carrier emptied:
        # the variants sample the offsets carrier).
        from bl_ext.user_default.sweep_deform.blender import frame
        _, _, positions = measure_frame.carrier_of(body)
        frame.fall_back_to_offsets(body)
        md, carrier, base = measure_frame.carrier_of(body)
        vl = bpy.context.view_layer
        product = md.node_group
        kinds = ('least', 'one offset', 'unlinked index', 'through')
        groups = [("the product's", product)] + [(k, variant(k, modifier)) for k in kinds]
        groups.append(("mesh carrier", product))  # the product's group handing on the mesh carrier
        times, shown = {label: [] for label, _ in groups}, {}
        try:
            with measure_frame.handler_out():
                for _ in range(3):  # rounds, the groups taking turns
                    for label, ng in groups:
                        md.node_group = ng
                        modifier.set_carrier(md, carrier)
                        if label == "mesh carrier":  # (filled again; emptied below for the others)
                            written, values = modifier.mesh_carrier(body, md, stale=True)[0], positions
                        else:
                            written, values = carrier, base
                        vl.update()
                        times[label] += measure_frame.time_carrier_writes(written, values.copy(),
                                                                          opts["frames"] // 3)
                        modifier.write_offsets(written, values)  # the same frame for every group
                        vl.update()
                        shown[label] = helpers.evaluated_positions(body)[0].copy()
                        modifier.empty_mesh_carrier(body, md)
        finally:
            md.node_group = product
            modifier.set_carrier(md, carrier)
        print(f"\n{key}: {len(body.data.vertices):,} vertices; Blender {bpy.app.version_string}; "
              f"an update after a carrier write, median ms; the largest difference from the product's positions")
        for label, _ in groups:
            off = float(np.abs(shown[label] - shown["the product's"]).max())
            print(f"  {label:16s} {statistics.median(times[label]) * 1e3:6.3f}   {off:.2e}")


if __name__ == "__main__":
    main()
