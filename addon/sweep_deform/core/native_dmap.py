# SPDX-License-Identifier: GPL-3.0-or-later
"""ctypes binding of libsweepdeform_dmap: the continuous displacement map d(θ, t) (Sect. 3.4).

The map lives in its own library because it needs OpenSubdiv, which libsweepdeform does not.
This module imports no ``bpy`` and loads the library only when the map is first used, so a
Blender that never binds through a map never maps OpenSubdiv. Blender 4.3 and 5.2 bring their
own OpenSubdiv 3.6; the bundled Debian 12 build is 3.5, whose symbols all live in the
versioned C++ namespace ``OpenSubdiv::v3_5_0`` (Blender's in ``v3_6_0``), so the two copies
cannot bind to each other's code (``test_bind_through_map.py`` proves it in both Blenders).

Rigs and bindings cross between the two libraries as blobs: the map is fitted from the blobs
a bound object stores, and binding points through it returns a binding blob for
:meth:`native.Binding.deserialize`.
"""

import ctypes

import numpy as np

from .native import (F32, F32_OUT, I32, I32_OUT, P_INT64, SD_OK, STATUS_NAMES, U8, U8_OUT, NativeError,
                     NativeLibraryError, Status, bundled_path, c_float, c_int32, c_int64, open_library)

#: The file this add-on version ships and loads (versioned, like native.LIBRARY_FILE).
LIBRARY_FILE = "libsweepdeform_dmap.so.0.1.0"

#: sd_dmap_bind's snap values (see the header).
SNAP_EXACT = 0.0
SNAP_SURFACE = 1e30
SNAP_DEFAULT = 0.1


class _MapT(ctypes.Structure):
    pass


class _BindingT(ctypes.Structure):
    pass


MapP = ctypes.POINTER(_MapT)
BindingP = ctypes.POINTER(_BindingT)

#: name -> (restype, argtypes). Every sd_dmap_* function of the header (a test compares).
SIGNATURES = {
    "sd_dmap_last_error": (ctypes.c_char_p, []),
    "sd_dmap_fit": (Status, [U8, c_int64, U8, c_int64, c_int32, I32, c_int32, c_int32, c_float,
                             ctypes.POINTER(MapP)]),
    "sd_dmap_destroy": (None, [MapP]),
    "sd_dmap_sweep_count": (c_int32, [MapP]),
    "sd_dmap_fit_errors": (Status, [MapP, c_int32, I32_OUT, F32_OUT, F32_OUT]),
    "sd_dmap_evaluate": (Status, [MapP, c_int32, c_int32, F32, F32, F32_OUT, F32_OUT]),
    "sd_dmap_bind": (Status, [MapP, c_int32, F32, c_float, ctypes.POINTER(c_int32), ctypes.POINTER(BindingP)]),
    "sd_dmap_binding_serialize": (Status, [BindingP, U8_OUT, c_int64, P_INT64]),
    "sd_dmap_binding_destroy": (None, [BindingP]),
}

_lib = None


def library_path():
    """$SWEEPDEFORM_DMAP_LIBRARY, else <extension>/lib/LIBRARY_FILE."""
    return bundled_path(LIBRARY_FILE, "SWEEPDEFORM_DMAP_LIBRARY")


def library():
    """The loaded library (never closed); NativeLibraryError if missing or incomplete."""
    global _lib
    if _lib is not None:
        return _lib
    path = library_path()
    lib = open_library(path, "displacement-map library")
    missing = [n for n in SIGNATURES if not hasattr(lib, n)]
    if missing:
        raise NativeLibraryError(f"{path} lacks {', '.join(missing)}")
    for name, (restype, argtypes) in SIGNATURES.items():
        getattr(lib, name).restype = restype
        getattr(lib, name).argtypes = argtypes
    _lib = lib
    return lib


def _call(name, *args):
    status = getattr(library(), name)(*args)
    if status != SD_OK:
        message = library().sd_dmap_last_error().decode("utf-8", "replace")
        raise NativeError(name, status, message or STATUS_NAMES.get(status, str(status)))


class DisplacementMap:
    """d(θ, t) of every sweep of a bound mesh, fitted on a regular control grid and evaluated
    as a smooth OpenSubdiv surface.

    rig_blob, binding_blob: the bytes a bound object stores (persistence.RIG_KEY, BINDING_KEY).
    triangles: (T, 3) int32 vertex indices of that bound mesh.
    theta_cells, t_cells_per_span: control points around / intervals per span (0 = defaults
    24 and 3); smoothing: bending weight (negative = default)."""

    def __init__(self, rig_blob, binding_blob, triangles, theta_cells=0, t_cells_per_span=0, smoothing=-1.0):
        rig = np.frombuffer(bytes(rig_blob), np.uint8)
        binding = np.frombuffer(bytes(binding_blob), np.uint8)
        tris = np.ascontiguousarray(triangles, np.int32).reshape(-1, 3)
        handle = MapP()
        _call("sd_dmap_fit", rig, rig.size, binding, binding.size, tris.shape[0], tris,
              int(theta_cells), int(t_cells_per_span), float(smoothing), ctypes.byref(handle))
        self._handle = handle

    def close(self):
        if self._handle:
            library().sd_dmap_destroy(self._handle)
            self._handle = MapP()

    def __del__(self):
        try:
            self.close()
        except Exception:  # noqa: BLE001 (interpreter shutdown: the library may be gone)
            pass

    @property
    def sweep_count(self):
        return int(library().sd_dmap_sweep_count(self._handle))

    def fit_errors(self):
        """(samples, rms, max) per sweep: the fit's residuals at its own vertices, rig units."""
        n = self.sweep_count
        samples, rms, mx = np.empty(n, np.int32), np.empty(n, np.float32), np.empty(n, np.float32)
        _call("sd_dmap_fit_errors", self._handle, n, samples, rms, mx)
        return samples, rms, mx

    def bind(self, points, snap=SNAP_DEFAULT):
        """Binds rest points (N, 3) float32 in armature space, no connectivity needed.
        Returns (binding blob bytes for native.Binding.deserialize, influences snapped)."""
        pts = np.ascontiguousarray(points, np.float32).reshape(-1, 3)
        snapped, binding = c_int32(0), BindingP()
        _call("sd_dmap_bind", self._handle, pts.shape[0], pts, float(snap), ctypes.byref(snapped),
              ctypes.byref(binding))
        try:  # the blob: size query, then fill
            size = c_int64(0)
            _call("sd_dmap_binding_serialize", binding, None, 0, ctypes.byref(size))
            blob = np.empty(size.value, np.uint8)
            _call("sd_dmap_binding_serialize", binding, blob, size.value, ctypes.byref(size))
            return blob.tobytes(), int(snapped.value)
        finally:
            library().sd_dmap_binding_destroy(binding)
