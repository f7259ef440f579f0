# SPDX-License-Identifier: GPL-3.0-or-later
"""Key-ellipse corrections (Sect. 4.2) between the object's properties and the core.

The corrections are ordinary properties of the object (``sweep_deform.corrections``), so they
can be keyframed, driven and undone; they are what the add-on uses. Every evaluation reads
them (one ``foreach_get`` per field; in a render from the render depsgraph's copy, so animated
values are the frame's) and, when they changed, hands them to the native rig and deformer
(``sd_deformer_set_rig_corrections``: microseconds, where creating the deformer again costs
milliseconds). The rig blob's own copy of the corrections is written when the file is saved
(persistence.py) and ignored when it is read.
"""

import re

import numpy as np

from ..core import native
from . import fcurves, redraw


def correction_arrays(settings):
    """(sweeps, keys, angles, values (N,8), muted) of a SweepDeformSettings' corrections, as
    the ABI takes them, read with one foreach_get per field."""
    coll = settings.corrections
    n = len(coll)
    sweeps, keys = np.empty(n, np.int32), np.empty(n, np.int32)
    angles, scale_a, scale_b = np.empty(n, np.float32), np.empty(n, np.float32), np.empty(n, np.float32)
    offset, rotation = np.empty(3 * n, np.float32), np.empty(3 * n, np.float32)
    muted = np.empty(n, bool)
    if n:
        coll.foreach_get("sweep", sweeps)
        coll.foreach_get("key", keys)
        coll.foreach_get("angle", angles)
        coll.foreach_get("offset", offset)
        coll.foreach_get("rotation", rotation)
        coll.foreach_get("scale_a", scale_a)
        coll.foreach_get("scale_b", scale_b)
        coll.foreach_get("mute", muted)
    values = np.concatenate([offset.reshape(n, 3), rotation.reshape(n, 3), scale_a[:, None], scale_b[:, None]],
                            axis=1).astype(np.float32)
    return sweeps, keys, angles, values, muted.astype(np.int32)


def sync_corrections(e, settings):
    """Hands the corrections of `settings` to the cache entry's rig and deformer if they
    changed. Returns the corrections' key (part of the evaluation key). Invalid corrections
    are refused by the core: the previous ones stay, and the panel shows why."""
    if not len(settings.corrections) and e.corrections_key == b"":
        return b""  # none, as before (most characters: no foreach_get per frame)
    arrays = correction_arrays(settings)
    key = b"".join(a.tobytes() for a in arrays)
    if key != e.corrections_key:
        e.corrections_key = key
        try:
            e.deformer.set_rig_corrections(*arrays)
            e.rig.set_corrections(*arrays)
            e.correction_error = ""
        except native.NativeError as err:
            e.correction_error = str(err).split(": ", 2)[-1]
    return key


def corrections_changed(obj):
    """A correction property changed (the next evaluation hands them on); redraw the overlay."""
    redraw.redraw_views()


_CORRECTION_PATH = re.compile(r"^sweep_deform\.corrections\[(\d+)\](.*)$")


def remove_correction(obj, index):
    """Removes correction `index`, keeping keyframes and drivers on the others (their paths
    hold the collection index)."""
    s = obj.sweep_deform
    for collection in fcurves.fcurve_collections(obj):
        for fc in list(collection):
            m = _CORRECTION_PATH.match(fc.data_path)
            if m is None:
                continue
            i = int(m.group(1))
            if i == index:
                collection.remove(fc)
            elif i > index:
                fc.data_path = f"sweep_deform.corrections[{i - 1}]{m.group(2)}"
    s.corrections.remove(index)
    s.active_correction = max(0, min(s.active_correction, len(s.corrections) - 1))
    obj.update_tag()  # removing an item is no property update: evaluate again
