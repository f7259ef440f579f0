# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's ground floor: everything that needs no Blender. No module here imports
``bpy`` or anything above this folder (tests/addon_core checks both, without Blender).

    native, native_dmap   ctypes bindings of libsweepdeform and libsweepdeform_dmap
    arrays                numpy arrays between Blender's data and the core (poses, weights, offsets)
    checks                are the object transforms usable? (sentences for the panel)
    fit_report            the fitting's JSON report: limb labels, elbows and knees, warnings
    key_edit              key-ellipse editing maths (Sect. 4.2): corrections, gizmo drags, picking
    cache_files           PC2 and MDD point-cache writers (and readers, for the tests)
"""
