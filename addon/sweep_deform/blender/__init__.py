# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's middle floor: Blender's data on one side, the core (../core) on the other.
No module here imports ui/.

    properties       Object.sweep_deform: settings, corrections, joints, bind state
    binding          binding in stages (read, fit, bind, store); unbind
    bind_through_map binding other meshes through a bound character's displacement map
    bind_state       BOUND / REBIND / unbound as the mesh, modifier and armature change
    persistence      the blobs and fingerprints in the .blend; corrections into the blob at save
    mesh_data        a mesh's positions, triangles, counts and fingerprint as arrays
    deformer_cache   per bound object: native deformer, buffers, the key of the last write
    bound_objects    which objects of a scene are bound (kept between updates)
    frame            one frame of one character: pose → core → offsets
    corrections      key-ellipse corrections: properties → core; removing one
    anatomy          elbows and knees; the native anatomical effects kept in step
    key_ellipses     the key ellipses of the shown pose (panel, overlay, gizmos); one key edit
    modifier         the "Sweep Deform" Geometry Nodes modifier and its offset attribute
    bake             bake outputs: shape keys, PC2/MDD, Alembic
    handlers         depsgraph, frame, load and undo handlers
    fcurves, redraw  F-curve collections of an ID; redraw requests
"""
