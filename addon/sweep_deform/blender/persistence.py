# SPDX-License-Identifier: GPL-3.0-or-later
"""What a binding leaves in the .blend, and how it is checked when read back.

* The rig and the binding as the core's own versioned, checksummed blobs (``sd_rig_serialize``,
  ``sd_binding_serialize``), raw bytes in hidden ID properties of the mesh object
  (``_sweep_deform_rig``, ``_sweep_deform_binding``; names with "_" stay out of the Custom
  Properties panel). The binding blob holds the per-vertex parameters (t, θ, displacement,
  weights) exactly as bound, so a reloaded file deforms bit for bit as before saving, and a
  damaged blob is refused by the core instead of deforming wrongly.
* In ``Object.sweep_deform``: the rig's bone names (the pose is gathered by name), the mesh's
  element counts, a SHA-1 of its connectivity and of its rest positions.
* Native objects are never saved: the deformer cache re-creates a deformer lazily after load or
  undo (see deformer_cache.py). What it measures on the bound mesh, the joints' volume tables,
  is kept at save as the core's blob (``sd_deformer_serialize_joint_volumes``) with what it was
  measured on (``_sweep_deform_joint_volumes``, ``_sweep_deform_joint_volumes_for``: the bind id
  and the SHA-1 of the triangles), so a file opened again need not bend every limb joint.
* Key-ellipse corrections (Sect. 4.2) are properties of ``Object.sweep_deform`` (saved and
  undone like any property); when the file is saved, the rig blob gets a copy of them
  (format version 2 and on), so the blob alone describes the edited rig for other tools.
"""

import bpy
import numpy as np
from bpy.app.handlers import persistent

from ..core import arrays, native
from . import corrections, mesh_data

RIG_KEY = "_sweep_deform_rig"
BINDING_KEY = "_sweep_deform_binding"
#: The armature's rest matrices at binding (#B*16 float32, rig order): the deformer's rest
#: reference, and how a later change of the armature's rest pose is noticed.
REST_POSE_KEY = "_sweep_deform_rest_pose"
#: The fitting's JSON report (for inspection; not needed to deform).
REPORT_KEY = "_sweep_deform_fit_report"
#: The joints' volume tables (the core's blob) and "bind id:triangles' SHA-1" they were measured on.
JOINT_VOLUMES_KEY = "_sweep_deform_joint_volumes"
JOINT_VOLUMES_FOR_KEY = "_sweep_deform_joint_volumes_for"


# ---- storing ----------------------------------------------------------------------------


def _put_bytes(obj, key, data):
    """Stores raw bytes in an ID property. Blender 4.3 and 5.2 cut a bytes property at its
    first NUL when an existing one is assigned again, so the old one goes first; the length
    is checked after."""
    data = bytes(data)
    if key in obj:
        del obj[key]
    obj[key] = data
    if len(obj[key]) != len(data):
        raise RuntimeError(f"Blender stored {len(obj[key])} of {len(data)} bytes in '{key}'")


def store(obj, rig_blob, binding_blob, bone_names, rest_pose, sweep_count, report=""):
    """Saves a binding of `obj` (its current mesh is the rest mesh)."""
    mesh = obj.data
    s = obj.sweep_deform
    _put_bytes(obj, RIG_KEY, rig_blob)
    _put_bytes(obj, BINDING_KEY, binding_blob)
    _put_bytes(obj, REST_POSE_KEY, np.ascontiguousarray(rest_pose, np.float32).tobytes())
    obj[REPORT_KEY] = report
    s.bone_names = arrays.encode_names(bone_names)
    s.vertex_count, s.edge_count, s.loop_count, s.polygon_count = mesh_data.counts(mesh)
    s.topology = mesh_data.topology_fingerprint(mesh)
    s.rest_positions = arrays.positions_fingerprint(mesh_data.vertex_positions(mesh))
    s.sweep_count = sweep_count
    s.library_version = native.library_version()


def clear(obj):
    for key in (RIG_KEY, BINDING_KEY, REST_POSE_KEY, REPORT_KEY, JOINT_VOLUMES_KEY, JOINT_VOLUMES_FOR_KEY):
        if key in obj:
            del obj[key]
    s = obj.sweep_deform
    s.state = 'UNBOUND'
    s.bind_id = ""
    s.bone_names = ""
    s.topology = ""
    s.rest_positions = ""
    s.sweep_count = 0
    s.vertex_count = s.edge_count = s.loop_count = s.polygon_count = 0


def has_blobs(obj):
    return RIG_KEY in obj and BINDING_KEY in obj and REST_POSE_KEY in obj


def load_skeleton(obj):
    """(bone names, rest pose #B*16 float32) the object was bound with; KeyError when none."""
    rest = np.frombuffer(bytes(obj[REST_POSE_KEY]), dtype=np.float32).copy()
    return arrays.decode_names(obj.sweep_deform.bone_names), rest


def load(obj):
    """(Rig, Binding, bone names, rest pose #B*16) from the object; raises native.NativeError
    (SD_ERR_CORRUPT_DATA) for a damaged blob, KeyError when there is none."""
    rig = native.Rig.deserialize(bytes(obj[RIG_KEY]))
    binding = native.Binding.deserialize(bytes(obj[BINDING_KEY]))
    return (rig, binding) + load_skeleton(obj)


def joint_volumes_for(tables_key):
    """The text kept with the tables: what they were measured on (deformer_cache's key)."""
    return ":".join(tables_key)


def stored_joint_volumes(obj, tables_key):
    """The tables' blob kept for exactly this binding and triangles, or None."""
    if obj.get(JOINT_VOLUMES_FOR_KEY) != joint_volumes_for(tables_key) or JOINT_VOLUMES_KEY not in obj:
        return None
    return bytes(obj[JOINT_VOLUMES_KEY])


def store_joint_volumes(obj, deformer, tables_key):
    """Keeps the deformer's tables with the object unless the very same are kept already (a
    damaged blob is written anew). Returns True if written."""
    blob = deformer.serialize_joint_volumes()
    if stored_joint_volumes(obj, tables_key) == blob:
        return False
    _put_bytes(obj, JOINT_VOLUMES_KEY, blob)
    obj[JOINT_VOLUMES_FOR_KEY] = joint_volumes_for(tables_key)
    return True


# ---- checking ---------------------------------------------------------------------------


def counts_match(obj):
    s = obj.sweep_deform
    return mesh_data.counts(obj.data) == [s.vertex_count, s.edge_count, s.loop_count, s.polygon_count]


def topology_matches(obj):
    """Counts first (free), then the connectivity hash."""
    return counts_match(obj) and mesh_data.topology_fingerprint(obj.data) == obj.sweep_deform.topology


def rest_positions_match(obj):
    return arrays.positions_fingerprint(mesh_data.vertex_positions(obj.data)) == obj.sweep_deform.rest_positions


# ---- corrections into the rig blob (at save) ---------------------------------------------


def store_corrections(obj):
    """Writes the object's corrections into its rig blob if they differ from the blob's.
    Returns True if the blob was rewritten."""
    if RIG_KEY not in obj:
        return False
    old = bytes(obj[RIG_KEY])
    rig = native.Rig.deserialize(old)
    rig.set_corrections(*corrections.correction_arrays(obj.sweep_deform))
    new = rig.serialize()
    if new == old:
        return False
    _put_bytes(obj, RIG_KEY, new)
    return True


def _on_save_pre(*_args):
    for obj in bpy.data.objects:
        if obj.type != 'MESH' or obj.sweep_deform.state == 'UNBOUND' or RIG_KEY not in obj:
            continue
        try:
            store_corrections(obj)
        except (native.NativeError, native.NativeLibraryError, ValueError) as e:
            print(f"Sweep Deform: '{obj.name}': the corrections were not copied into the rig blob: {e}")


def register():
    global _save_handler
    unregister()
    _save_handler = persistent(_on_save_pre)
    bpy.app.handlers.save_pre.append(_save_handler)


def unregister():
    for h in [h for h in bpy.app.handlers.save_pre
              if getattr(h, "__qualname__", None) == _on_save_pre.__qualname__
              and getattr(h, "__module__", None) == __name__]:
        bpy.app.handlers.save_pre.remove(h)


_save_handler = None
