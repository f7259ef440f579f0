# SPDX-License-Identifier: GPL-3.0-or-later
"""ctypes binding of libsweepdeform (``native/include/sweepdeform/sweepdeform.h``).

This module imports no ``bpy``. It

* finds the library in the extension's ``lib/`` folder and loads it by its exact, versioned
  file name (``libsweepdeform.so.<version>``). ``ctypes`` never unloads a library, and the
  dynamic loader hands out the cached handle for a path it has already opened, so a newer
  add-on must bring a file with another name: the version in the name guarantees it;
* declares ``argtypes`` and ``restype`` of every function of the ABI (:data:`SIGNATURES`; a
  test compares the table with the header), arrays as :func:`_array` parameters that refuse
  the wrong dtype or a non-contiguous buffer instead of letting C read garbage;
* refuses a library of another ABI version with a message that says what was found;
* wraps the opaque handles in small classes (:class:`Rig`, :class:`Binding`,
  :class:`Deformer`) that take and return numpy arrays (float32 / int32, the ABI's types),
  check every buffer size before C sees it, and raise :class:`NativeError` with the
  library's own message on failure.

The environment variable ``SWEEPDEFORM_LIBRARY`` may name another library file (development).
"""

import ctypes
import os

import numpy as np

#: The library file name this add-on version ships and loads (never the bare SONAME).
LIBRARY_FILE = "libsweepdeform.so.0.1.0"
#: The ``SD_ABI_VERSION`` this binding was written against.
ABI_VERSION = 7

SD_OK = 0
STATUS_NAMES = {
    0: "SD_OK",
    1: "SD_ERR_INVALID_ARGUMENT",
    2: "SD_ERR_CORRUPT_DATA",
    3: "SD_ERR_OUT_OF_MEMORY",
    4: "SD_ERR_MISMATCH",
    5: "SD_ERR_INTERNAL",
}


class NativeLibraryError(RuntimeError):
    """The library is missing, cannot be loaded, or is of another ABI version."""


class NativeError(RuntimeError):
    """A library call failed; ``status`` is the sd_status, the message is sd_last_error()."""

    def __init__(self, function, status, message):
        self.function = function
        self.status = status
        super().__init__(f"{function}: {STATUS_NAMES.get(status, status)}: {message}")


# ---- argument types ---------------------------------------------------------------------


class _Opaque(ctypes.Structure):
    pass


class _RigT(_Opaque):
    pass


class _BindingT(_Opaque):
    pass


class _DeformerT(_Opaque):
    pass


class _FitResultT(_Opaque):
    pass


RigP = ctypes.POINTER(_RigT)
BindingP = ctypes.POINTER(_BindingT)
DeformerP = ctypes.POINTER(_DeformerT)
FitResultP = ctypes.POINTER(_FitResultT)


class _AnatomyT(_Opaque):
    pass


AnatomyP = ctypes.POINTER(_AnatomyT)


class _OutputCheckT(_Opaque):
    pass


OutputCheckP = ctypes.POINTER(_OutputCheckT)

_array_types = {}


def _array(dtype, writable=False):
    """A ctypes parameter type for a C-contiguous numpy array of `dtype`, or None (NULL)."""
    dtype = np.dtype(dtype)
    key = (dtype.str, writable)
    if key in _array_types:
        return _array_types[key]

    class ArrayParam:
        @classmethod
        def from_param(cls, obj):
            if obj is None:
                return None
            if not isinstance(obj, np.ndarray):
                raise TypeError(f"expected a numpy array of {dtype}, got {type(obj).__name__}")
            if obj.dtype != dtype:
                raise TypeError(f"expected dtype {dtype}, got {obj.dtype}")
            if not obj.flags.c_contiguous:
                raise TypeError("array must be C-contiguous")
            if writable and not obj.flags.writeable:
                raise TypeError("output array is read-only")
            return ctypes.c_void_p(obj.ctypes.data)

    ArrayParam.__name__ = f"array_{dtype.name}{'_out' if writable else ''}"
    _array_types[key] = ArrayParam
    return ArrayParam


F32 = _array(np.float32)
F32_OUT = _array(np.float32, writable=True)
F64_OUT = _array(np.float64, writable=True)
I32 = _array(np.int32)
I32_OUT = _array(np.int32, writable=True)
U8 = _array(np.uint8)
U8_OUT = _array(np.uint8, writable=True)

c_int32, c_int64, c_float, c_char_p = ctypes.c_int32, ctypes.c_int64, ctypes.c_float, ctypes.c_char_p
P_INT32 = ctypes.POINTER(ctypes.c_int32)
P_INT64 = ctypes.POINTER(ctypes.c_int64)
P_DOUBLE = ctypes.POINTER(ctypes.c_double)
P_FLOAT = ctypes.POINTER(ctypes.c_float)
Status = ctypes.c_int  # sd_status is a C enum (int)

#: name -> (restype, argtypes). Every SD_API function of the header is here (a test compares).
SIGNATURES = {
    # library
    "sd_abi_version": (c_int32, []),
    "sd_library_version": (c_char_p, []),
    "sd_last_error": (c_char_p, []),
    # rig
    "sd_rig_create": (Status, [c_int32, I32, F32, F32, F32, ctypes.POINTER(RigP)]),
    "sd_rig_destroy": (None, [RigP]),
    "sd_rig_clone": (Status, [RigP, ctypes.POINTER(RigP)]),
    "sd_rig_add_sweep": (Status, [RigP, c_int32, F32, F32, F32, I32, I32, F32, P_INT32]),
    "sd_rig_bone_count": (c_int32, [RigP]),
    "sd_rig_sweep_count": (c_int32, [RigP]),
    "sd_rig_key_count": (c_int32, [RigP, c_int32]),
    "sd_rig_get_keys": (Status, [RigP, c_int32, F32_OUT, F32_OUT, F32_OUT, I32_OUT, I32_OUT, F32_OUT]),
    "sd_rig_sweep_rest_volume": (Status, [RigP, c_int32, P_DOUBLE]),
    "sd_rig_evaluate_sweep": (Status, [RigP, c_int32, c_int32, F32, F32_OUT, F32_OUT, F32_OUT, F32_OUT, F32_OUT]),
    "sd_rig_serialize": (Status, [RigP, U8_OUT, c_int64, P_INT64]),
    "sd_rig_deserialize": (Status, [U8, c_int64, ctypes.POINTER(RigP)]),
    # binding
    "sd_bind": (Status, [RigP, c_int32, F32, c_int32, I32, F32, c_int32, I32, F32, ctypes.POINTER(BindingP)]),
    "sd_binding_destroy": (None, [BindingP]),
    "sd_binding_vertex_count": (c_int32, [BindingP]),
    "sd_binding_get_parameters": (Status, [BindingP, c_int32, I32_OUT, F32_OUT, F32_OUT]),
    "sd_binding_serialize": (Status, [BindingP, U8_OUT, c_int64, P_INT64]),
    "sd_binding_deserialize": (Status, [U8, c_int64, ctypes.POINTER(BindingP)]),
    # deformation
    "sd_deformer_create": (Status, [RigP, BindingP, ctypes.POINTER(DeformerP)]),
    "sd_deformer_destroy": (None, [DeformerP]),
    "sd_deformer_set_volume_preservation": (Status, [DeformerP, c_int32, c_float]),
    "sd_deformer_set_volume_offsets": (Status, [DeformerP, c_int32, F32]),
    "sd_deformer_hold_joint_volumes": (Status, [DeformerP, c_int32, c_int32, I32, P_INT32]),
    "sd_deformer_hold_joint_volumes_of": (Status, [DeformerP, DeformerP, P_INT32]),
    "sd_deformer_set_skin_triangles": (Status, [DeformerP, c_int32, c_int32, I32]),
    "sd_deformer_fill_trunk_as": (Status, [DeformerP, DeformerP]),
    "sd_deformer_serialize_joint_volumes": (Status, [DeformerP, U8_OUT, c_int64, P_INT64]),
    "sd_deformer_load_joint_volumes": (Status, [DeformerP, U8, c_int64, P_INT32]),
    "sd_deform": (Status, [DeformerP, c_int32, F32, c_int32, F32_OUT]),
    "sd_deform_frames": (Status, [DeformerP, c_int32, F32, c_int32, F32_OUT, F32_OUT]),
    "sd_deform_displaced": (Status, [DeformerP, c_int32, F32, c_int32, c_int32, I32, F32, F32_OUT, F32_OUT]),
    "sd_mix_shape_keys": (Status, [c_int32, F32, c_int32, F32, c_int32, I32, F32, P_INT32, I32_OUT,
                                   F32_OUT]),
    "sd_compose_offsets": (Status, [c_int32, F32, F32, F32, c_int32, I32, F32, F32, F32_OUT]),
    "sd_deform_frame": (Status, [DeformerP, c_int32, F32, c_int32, c_int32, I32, F32, F32_OUT, F32_OUT,
                                 OutputCheckP, c_float, P_INT32, P_FLOAT, P_INT32, P_INT32, F32, F32, c_int32,
                                 F32_OUT]),
    "sd_deformer_get_volumes": (Status, [DeformerP, c_int32, F64_OUT, F64_OUT, F64_OUT]),
    "sd_deformer_get_volume_iterations": (Status, [DeformerP, c_int32, I32_OUT]),
    # the output check (issue 15)
    "sd_output_check_create": (Status, [c_int32, F32, c_int32, F32, F32, c_int32, I32, F32, c_float,
                                        ctypes.POINTER(OutputCheckP)]),
    "sd_output_check_destroy": (None, [OutputCheckP]),
    "sd_output_check_run": (Status, [OutputCheckP, c_int32, F32, c_int32, F32, c_float, P_INT32, P_FLOAT, P_INT32,
                                     P_INT32, F32_OUT]),
    "sd_output_check_linear_blend": (Status, [OutputCheckP, c_int32, F32, c_int32, F32_OUT]),
    # measurements (reports and tests)
    "sd_measure_volume": (Status, [c_int32, F32, c_int32, I32, P_DOUBLE]),
    "sd_measure_intersections": (Status, [c_int32, F32, c_int32, I32, c_int32, I32, P_INT64]),
    "sd_measure_cross_sections": (Status, [c_int32, F32, c_int32, I32, c_int32, F32, F32, ctypes.c_float, F64_OUT]),
    # anatomical effects (Sect. 4.3, 4.4)
    "sd_anatomy_create": (Status, [RigP, BindingP, c_int32, I32, ctypes.POINTER(AnatomyP)]),
    "sd_anatomy_destroy": (None, [AnatomyP]),
    "sd_anatomy_add_joint": (Status, [AnatomyP, c_int32, c_int32, F32, P_INT32]),
    "sd_anatomy_joint_count": (c_int32, [AnatomyP]),
    "sd_anatomy_set_joint_effects": (Status, [AnatomyP, c_int32, c_int32]),
    "sd_anatomy_get_joint_effects": (Status, [AnatomyP, c_int32, P_INT32]),
    "sd_anatomy_set_joint_parameter": (Status, [AnatomyP, c_int32, c_int32, ctypes.c_float]),
    "sd_anatomy_get_joint_parameter": (Status, [AnatomyP, c_int32, c_int32, ctypes.POINTER(ctypes.c_float)]),
    "sd_anatomy_set_joint_proxy": (Status, [AnatomyP, c_int32, c_int32, F32, c_int32, I32, ctypes.c_float]),
    "sd_anatomy_set_volume_feedback": (Status, [AnatomyP, c_int32, c_int32]),
    "sd_anatomy_set_folding_iterations": (Status, [AnatomyP, c_int32]),
    "sd_anatomy_apply": (Status, [AnatomyP, DeformerP, c_int32, F32, c_int32, F32_OUT]),
    "sd_deform_with_anatomy": (Status, [DeformerP, AnatomyP, c_int32, F32, c_int32, F32_OUT]),
    "sd_anatomy_get_stats": (Status, [AnatomyP, c_int32, F64_OUT]),
    "sd_anatomy_get_volume_offsets": (Status, [AnatomyP, c_int32, F64_OUT]),
    "sd_anatomy_count_intersections": (Status, [AnatomyP, c_int32, F32, P_INT32]),
    # automatic fitting
    "sd_fit_rig": (Status, [c_int32, F32, c_int32, I32, c_int32, I32, F32, F32, F32,
                            ctypes.POINTER(c_char_p), c_int32, I32, F32, c_int32, c_int32, I32, I32,
                            ctypes.POINTER(FitResultP)]),
    "sd_fit_result_destroy": (None, [FitResultP]),
    "sd_fit_result_rig": (Status, [FitResultP, ctypes.POINTER(RigP)]),
    "sd_fit_result_slot_counts": (Status, [FitResultP, P_INT32, P_INT32]),
    "sd_fit_result_weights": (Status, [FitResultP, c_int32, c_int32, I32_OUT, F32_OUT, c_int32, I32_OUT, F32_OUT]),
    "sd_fit_result_report": (Status, [FitResultP, U8_OUT, c_int64, P_INT64]),
    # key-ellipse editing (Sect. 4.2): pose-space corrections
    "sd_rig_key_joint": (Status, [RigP, c_int32, c_int32, P_INT32, P_INT32, P_FLOAT]),
    "sd_rig_key_joint_angle": (Status, [RigP, c_int32, c_int32, c_int32, F32, P_FLOAT]),
    "sd_rig_set_key_correction": (Status, [RigP, c_int32, c_int32, c_float, F32, c_int32, P_INT32]),
    "sd_rig_remove_key_correction": (Status, [RigP, c_int32, c_int32, c_int32]),
    "sd_rig_mute_key_correction": (Status, [RigP, c_int32, c_int32, c_int32, c_int32]),
    "sd_rig_key_correction_count": (c_int32, [RigP, c_int32, c_int32]),
    "sd_rig_get_key_corrections": (Status, [RigP, c_int32, c_int32, c_int32, F32_OUT, F32_OUT, I32_OUT]),
    "sd_rig_key_correction_at": (Status, [RigP, c_int32, c_int32, c_float, F32_OUT]),
    "sd_rig_correction_count": (c_int32, [RigP]),
    "sd_rig_get_corrections": (Status, [RigP, c_int32, I32_OUT, I32_OUT, F32_OUT, F32_OUT, I32_OUT]),
    "sd_rig_set_corrections": (Status, [RigP, c_int32, I32, I32, F32, F32, I32]),
    "sd_rig_pose_keys": (Status, [RigP, c_int32, c_int32, F32, c_int32, c_int32, F32_OUT, F32_OUT, F32_OUT, F32_OUT]),
    "sd_rig_evaluate_posed_sweep": (Status, [RigP, c_int32, c_int32, F32, c_int32, F32, F32_OUT, F32_OUT, F32_OUT]),
    "sd_deformer_set_rig_corrections": (Status, [DeformerP, c_int32, I32, I32, F32, F32, I32]),
}


# ---- loading ----------------------------------------------------------------------------

_lib = None
_load_error = None


#: The extension's root folder (this file is in its core/).
EXTENSION_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def bundled_path(file_name, override_variable):
    """$override_variable if set, else <extension>/lib/<file_name>."""
    return os.environ.get(override_variable) or os.path.join(EXTENSION_DIR, "lib", file_name)


def open_library(path, what):
    """ctypes.CDLL of `path` (never closed: ctypes keeps it for the life of the process);
    NativeLibraryError naming `what` and the file if it is missing or cannot be loaded."""
    if not os.path.isfile(path):
        raise NativeLibraryError(
            f"Sweep Deform's {what} is missing: {path} does not exist. "
            "Reinstall the extension from a complete sweep_deform-<version>.zip.")
    try:
        return ctypes.CDLL(path, mode=ctypes.RTLD_LOCAL)
    except OSError as e:
        raise NativeLibraryError(f"Sweep Deform could not load {path}: {e}") from e


def library_path():
    """Where the library is expected: $SWEEPDEFORM_LIBRARY, else <extension>/lib/LIBRARY_FILE."""
    return bundled_path(LIBRARY_FILE, "SWEEPDEFORM_LIBRARY")


def _load():
    path = library_path()
    lib = open_library(path, "native library")
    try:
        lib.sd_abi_version.restype = c_int32
        lib.sd_abi_version.argtypes = []
        found = lib.sd_abi_version()
    except AttributeError as e:
        raise NativeLibraryError(f"{path} is not a libsweepdeform (no sd_abi_version)") from e
    if found != ABI_VERSION:
        raise NativeLibraryError(
            f"{path} has ABI version {found}, this add-on needs {ABI_VERSION}: "
            "the add-on and its library are from different builds.")
    missing = []
    for name, (restype, argtypes) in SIGNATURES.items():
        try:
            fn = getattr(lib, name)
        except AttributeError:
            missing.append(name)
            continue
        fn.restype = restype
        fn.argtypes = argtypes
    if missing:
        raise NativeLibraryError(f"{path} lacks functions of ABI {ABI_VERSION}: {', '.join(missing)}")
    return lib


def library():
    """The loaded library; raises NativeLibraryError (the same one every time) if unusable."""
    global _lib, _load_error
    if _lib is not None:
        return _lib
    if _load_error is not None:
        raise _load_error
    try:
        _lib = _load()
    except NativeLibraryError as e:
        _load_error = e
        raise
    return _lib


def available():
    """(True, version text) or (False, the reason) without raising."""
    try:
        lib = library()
    except NativeLibraryError as e:
        return False, str(e)
    return True, lib.sd_library_version().decode()


def _check(name, status):
    if status != SD_OK:
        message = library().sd_last_error().decode("utf-8", "replace")
        raise NativeError(name, status, message)


def _call(name, *args):
    _check(name, getattr(library(), name)(*args))


def _f32(a):
    return np.ascontiguousarray(a, dtype=np.float32)


def _i32(a):
    return np.ascontiguousarray(a, dtype=np.int32)


def _expect_size(what, array, size):
    if array.size != size:
        raise ValueError(f"{what} has {array.size} values, {size} expected")


def abi_version():
    return int(library().sd_abi_version())


def library_version():
    return library().sd_library_version().decode()


# ---- handles ----------------------------------------------------------------------------


def mix_shape_keys(rest, blocks, terms, values, moved, moves):
    """sd_mix_shape_keys: relative keys mixed as Blender mixes them, as displacements from
    `rest` (V,3): `blocks` (B,V,3) the keys' positions, block 0 the reference key; `terms`
    (T,2) int32 each active key's block and its relative key's block; `values` (T,) float32.
    Writes the vertices that move (ascending) into `moved` (V,) int32 and their displacements
    into `moves` (V,3) float32; returns how many. All float32/int32 and contiguous."""
    V = len(rest)
    if blocks.ndim != 3 or blocks.shape[1:] != (V, 3) or len(blocks) < 1:
        raise ValueError(f"blocks must be (B, {V}, 3) with B >= 1")
    if terms.shape != (len(values), 2) or moved.size != V or moves.size != 3 * V:
        raise ValueError("terms must be (T, 2) for T values; moved and moves must hold V and 3V values")
    count = c_int32(0)
    _call("sd_mix_shape_keys", V, np.ascontiguousarray(rest), len(blocks), np.ascontiguousarray(blocks), len(values),
          np.ascontiguousarray(terms, dtype=np.int32), np.ascontiguousarray(values, dtype=np.float32),
          ctypes.byref(count), moved, moves)
    return count.value


def compose_offsets(positions, rest, base, moved, turned, displacements, out):
    """sd_compose_offsets: out = base + (positions − rest), then out[moved] += turned −
    displacements, in one pass and to the bit as those sums made one array at a time (numpy's
    order). positions, rest, out (V,3) float32; base (V,3) or None; moved (M,) int32 strictly
    ascending; turned (M,3); displacements (M,3) or None. Returns `out`."""
    V = len(rest)
    for name, a in (("positions", positions), ("base", base), ("out", out)):
        if a is not None and a.size != 3 * V:
            raise ValueError(f"{name} must hold {V} positions")
    M = 0 if moved is None else len(moved)
    for name, a in (("turned", turned), ("displacements", displacements)):
        if a is not None and a.size != 3 * M:
            raise ValueError(f"{name} must hold {M} vectors")
    _call("sd_compose_offsets", V, positions, rest, base, M, moved, turned, displacements, out)
    return out


class _Handle:
    _destroy = None

    def __init__(self, ptr):
        self._ptr = ptr

    @property
    def ptr(self):
        if not self._ptr:
            raise ValueError(f"{type(self).__name__} was closed")
        return self._ptr

    def close(self):
        if self._ptr:
            getattr(library(), self._destroy)(self._ptr)
            self._ptr = None

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass


class Rig(_Handle):
    """Skeleton + sweeps of key ellipses, in armature space (rest pose)."""

    _destroy = "sd_rig_destroy"

    @classmethod
    def create(cls, parents, rest, heads, tails):
        """parents #B int, rest #B*16 column-major, heads/tails #B*3."""
        parents, rest = _i32(parents).ravel(), _f32(rest).ravel()
        heads, tails = _f32(heads).ravel(), _f32(tails).ravel()
        B = parents.size
        _expect_size("rest", rest, 16 * B)
        _expect_size("heads", heads, 3 * B)
        _expect_size("tails", tails, 3 * B)
        out = RigP()
        _call("sd_rig_create", B, parents, rest, heads, tails, ctypes.byref(out))
        return cls(out)

    @classmethod
    def deserialize(cls, blob):
        return cls(_deserialize("sd_rig_deserialize", RigP, blob))

    def add_sweep(self, centers, orientations, half_axes, bones, joint_parents, fractions):
        """Keys: centers #K*3, orientations #K*4 (w,x,y,z), half_axes #K*2, bones #K,
        joint_parents #K, fractions #K*2. Returns the sweep index."""
        bones = _i32(bones).ravel()
        K = bones.size
        arrays = dict(centers=(_f32(centers).ravel(), 3), orientations=(_f32(orientations).ravel(), 4),
                      half_axes=(_f32(half_axes).ravel(), 2), fractions=(_f32(fractions).ravel(), 2))
        for name, (a, n) in arrays.items():
            _expect_size(name, a, n * K)
        joint_parents = _i32(joint_parents).ravel()
        _expect_size("joint_parents", joint_parents, K)
        index = ctypes.c_int32(-1)
        _call("sd_rig_add_sweep", self.ptr, K, arrays["centers"][0], arrays["orientations"][0],
              arrays["half_axes"][0], bones, joint_parents, arrays["fractions"][0], ctypes.byref(index))
        return index.value

    @property
    def bone_count(self):
        return int(library().sd_rig_bone_count(self.ptr))

    @property
    def sweep_count(self):
        return int(library().sd_rig_sweep_count(self.ptr))

    def key_count(self, sweep):
        n = library().sd_rig_key_count(self.ptr, sweep)
        if n < 0:
            _check("sd_rig_key_count", 1)
        return int(n)

    def keys(self, sweep):
        """The key ellipses of a sweep as a dict of arrays."""
        K = self.key_count(sweep)
        out = dict(centers=np.empty((K, 3), np.float32), orientations=np.empty((K, 4), np.float32),
                   half_axes=np.empty((K, 2), np.float32), bones=np.empty(K, np.int32),
                   joint_parents=np.empty(K, np.int32), fractions=np.empty((K, 2), np.float32))
        _call("sd_rig_get_keys", self.ptr, sweep, out["centers"], out["orientations"], out["half_axes"],
              out["bones"], out["joint_parents"], out["fractions"])
        return out

    def serialize(self):
        return _serialize("sd_rig_serialize", self.ptr)

    # -- key-ellipse editing (Sect. 4.2) -------------------------------------------------------
    # A correction's values are 8 floats: center offset (3, along the key's axes), rotation
    # vector (3, key frame, radians), factors of a and b. See the header for the joint angle.

    def key_joint(self, sweep, key):
        """(parent bone, child bone, rest angle) of the joint a key's corrections are keyed by."""
        parent, child, rest = ctypes.c_int32(), ctypes.c_int32(), ctypes.c_float()
        _call("sd_rig_key_joint", self.ptr, sweep, key, ctypes.byref(parent), ctypes.byref(child),
              ctypes.byref(rest))
        return parent.value, child.value, rest.value

    def _pose(self, pose):
        if pose is None:
            return None
        pose = _f32(pose).ravel()
        _expect_size("pose", pose, 16 * self.bone_count)
        return pose

    def key_correction_at(self, sweep, key, angle):
        """The interpolated correction (8 values) of a key at a joint angle."""
        out = np.empty(8, np.float32)
        _call("sd_rig_key_correction_at", self.ptr, sweep, key, float(angle), out)
        return out

    def corrections(self):
        """Every correction: dict of sweeps, keys, angles #N, values (N,8), muted #N."""
        n = int(library().sd_rig_correction_count(self.ptr))
        out = dict(sweeps=np.empty(n, np.int32), keys=np.empty(n, np.int32), angles=np.empty(n, np.float32),
                   values=np.empty((n, 8), np.float32), muted=np.empty(n, np.int32))
        _call("sd_rig_get_corrections", self.ptr, n, out["sweeps"], out["keys"], out["angles"], out["values"],
              out["muted"])
        return out

    def set_corrections(self, sweeps, keys, angles, values, muted=None):
        """Replaces every correction of the rig (empty arrays: none); all or nothing."""
        args = _correction_arrays(sweeps, keys, angles, values, muted)
        _call("sd_rig_set_corrections", self.ptr, *args)

    def pose_keys(self, sweep, pose=None, corrected=True):
        """The key ellipses of a sweep in `pose` (None = rest): dict of centers (K,3),
        orientations (K,4) w,x,y,z, half_axes (K,2) (before volume control), angles #K."""
        K = self.key_count(sweep)
        out = dict(centers=np.empty((K, 3), np.float32), orientations=np.empty((K, 4), np.float32),
                   half_axes=np.empty((K, 2), np.float32), angles=np.empty(K, np.float32))
        _call("sd_rig_pose_keys", self.ptr, sweep, self.bone_count, self._pose(pose), 1 if corrected else 0, K,
              out["centers"], out["orientations"], out["half_axes"], out["angles"])
        return out

    def evaluate_posed_sweep(self, sweep, u, pose=None):
        """The corrected sweep in `pose` at parameters u in [0,1]: centers (n,3), rotations
        (n,9) column-major, half_axes (n,2)."""
        u = _f32(u).ravel()
        n = u.size
        out = dict(centers=np.empty((n, 3), np.float32), rotations=np.empty((n, 9), np.float32),
                   half_axes=np.empty((n, 2), np.float32))
        _call("sd_rig_evaluate_posed_sweep", self.ptr, sweep, self.bone_count, self._pose(pose), n, u,
              out["centers"], out["rotations"], out["half_axes"])
        return out


def _correction_arrays(sweeps, keys, angles, values, muted):
    sweeps, keys, angles = _i32(sweeps).ravel(), _i32(keys).ravel(), _f32(angles).ravel()
    values = _f32(values).ravel()
    n = sweeps.size
    _expect_size("keys", keys, n)
    _expect_size("angles", angles, n)
    _expect_size("values", values, 8 * n)
    muted = None if muted is None else _i32(muted).ravel()
    if muted is not None:
        _expect_size("muted", muted, n)
    if n == 0:
        return 0, None, None, None, None, None
    return n, sweeps, keys, angles, values, muted


def _serialize(name, ptr):
    """The blob of a handle: asks the size first, then fills a buffer of that size."""
    size = ctypes.c_int64()
    _call(name, ptr, None, 0, ctypes.byref(size))
    buf = np.empty(size.value, np.uint8)
    _call(name, ptr, buf, size.value, ctypes.byref(size))
    return buf.tobytes()


def _deserialize(name, pointer_type, blob):
    """A new handle (of `pointer_type`) read from `blob` bytes by the ABI function `name`. An
    empty blob still passes a valid pointer, so the library reports it as corrupt data."""
    data = np.frombuffer(bytes(blob), dtype=np.uint8)
    out = pointer_type()
    _call(name, data if data.size else np.zeros(1, np.uint8), data.size, ctypes.byref(out))
    return out


class Binding(_Handle):
    """Per-vertex binding of one mesh to one rig."""

    _destroy = "sd_binding_destroy"

    @classmethod
    def bind(cls, rig, positions, sweep_ids, sweep_weights, bone_ids, bone_weights):
        """positions (V,3) armature space; sweep_ids/weights (V,S); bone_ids/weights (V,K)."""
        positions = _f32(positions).reshape(-1)
        V = positions.size // 3
        _expect_size("positions", positions, 3 * V)
        sweep_ids, sweep_weights = _i32(sweep_ids).reshape(V, -1), _f32(sweep_weights).reshape(V, -1)
        bone_ids, bone_weights = _i32(bone_ids).reshape(V, -1), _f32(bone_weights).reshape(V, -1)
        if sweep_ids.shape != sweep_weights.shape or bone_ids.shape != bone_weights.shape:
            raise ValueError("ids and weights must have the same shape")
        out = BindingP()
        _call("sd_bind", rig.ptr, V, positions, sweep_ids.shape[1], sweep_ids, sweep_weights,
              bone_ids.shape[1], bone_ids, bone_weights, ctypes.byref(out))
        return cls(out)

    @classmethod
    def deserialize(cls, blob):
        return cls(_deserialize("sd_binding_deserialize", BindingP, blob))

    @property
    def vertex_count(self):
        return int(library().sd_binding_vertex_count(self.ptr))

    def parameters(self):
        """(sweep #V int32, t #V, theta #V) of each vertex's heaviest sweep influence."""
        V = self.vertex_count
        sweep, t, theta = np.empty(V, np.int32), np.empty(V, np.float32), np.empty(V, np.float32)
        _call("sd_binding_get_parameters", self.ptr, V, sweep, t, theta)
        return sweep, t, theta

    def serialize(self):
        return _serialize("sd_binding_serialize", self.ptr)


class Deformer(_Handle):
    """A rig + binding + per-frame state. Owns its output buffer: no allocation per frame."""

    _destroy = "sd_deformer_destroy"

    def __init__(self, rig, binding):
        out = DeformerP()
        _call("sd_deformer_create", rig.ptr, binding.ptr, ctypes.byref(out))
        super().__init__(out)
        self.bone_count = rig.bone_count
        self.sweep_count = rig.sweep_count
        self.vertex_count = binding.vertex_count
        self.positions = np.empty((self.vertex_count, 3), np.float32)
        self._rest = np.empty(self.sweep_count, np.float64)
        self._before = np.empty(self.sweep_count, np.float64)
        self._after = np.empty(self.sweep_count, np.float64)
        self._verdict = None  # deform_frame's outputs, made at its first call

    def set_volume_preservation(self, enabled, strength=1.0):
        _call("sd_deformer_set_volume_preservation", self.ptr, 1 if enabled else 0, float(strength))

    def set_volume_offsets(self, offsets):
        offsets = _f32(offsets).ravel()
        _expect_size("volume offsets", offsets, self.sweep_count)
        _call("sd_deformer_set_volume_offsets", self.ptr, self.sweep_count, offsets)

    def hold_joint_volumes(self, triangles):
        """Measures the mesh's volume near each limb joint on `triangles` ((T,3) indices into the
        bound vertices; empty: stop) and holds it from then on. Returns the joints held."""
        tris = np.ascontiguousarray(triangles, np.int32).ravel()
        if tris.size % 3:
            raise ValueError("triangles must be (T,3) vertex indices")
        count = ctypes.c_int32(0)
        _call("sd_deformer_hold_joint_volumes", self.ptr, self.vertex_count, tris.size // 3, tris,
              ctypes.byref(count))
        return count.value

    def set_skin_triangles(self, triangles):
        """The bound mesh's triangles ((T,3) indices into the bound vertices; empty: none): with
        them a bent trunk fills its skin out from the spine to put its volume back."""
        tris = np.ascontiguousarray(triangles, np.int32).ravel()
        if tris.size % 3:
            raise ValueError("triangles must be (T,3) vertex indices")
        _call("sd_deformer_set_skin_triangles", self.ptr, self.vertex_count, tris.size // 3,
              tris if tris.size else np.zeros(3, np.int32))

    def fill_trunk_as(self, source):
        """Fills the trunk as `source` does (the same rig): for a mesh bound through its map."""
        _call("sd_deformer_fill_trunk_as", self.ptr, source.ptr)

    def hold_joint_volumes_of(self, source):
        """Holds the joints' volume with `source`'s measured tables (the same rig). Returns the
        joints held."""
        count = ctypes.c_int32(0)
        _call("sd_deformer_hold_joint_volumes_of", self.ptr, source.ptr, ctypes.byref(count))
        return count.value

    def serialize_joint_volumes(self):
        """The joints' tables as the core's versioned, checksummed blob (bytes)."""
        return _serialize("sd_deformer_serialize_joint_volumes", self.ptr)

    def load_joint_volumes(self, blob):
        """Holds the joints' volume by the tables of a blob from serialize_joint_volumes (the
        same rig; measured on this mesh: the caller's to know). Returns the joints held."""
        data = np.frombuffer(bytes(blob), np.uint8)
        count = ctypes.c_int32(0)
        _call("sd_deformer_load_joint_volumes", self.ptr, data if data.size else np.zeros(1, np.uint8), data.size,
              ctypes.byref(count))
        return count.value

    def deform(self, pose, out=None):
        """pose: #B*16 float32 column-major armature-space matrices. Returns (V,3) float32
        (`out` if given, else the deformer's own buffer, overwritten by the next call)."""
        if pose.dtype != np.float32 or pose.size != 16 * self.bone_count:
            raise ValueError(f"pose must be {16 * self.bone_count} float32 values")
        if out is None:
            out = self.positions
        elif out.size != 3 * self.vertex_count:
            raise ValueError(f"out must hold {3 * self.vertex_count} float32 values")
        _call("sd_deform", self.ptr, self.bone_count, np.ascontiguousarray(pose), self.vertex_count, out)
        return out

    def deform_frames(self, pose, out, frames):
        """sd_deform_frames: the positions into `out` (V,3) and each vertex's local linear map J
        into `frames` (3,V,3): frames[r, v] is row r of vertex v's J, armature space; both
        float32 and contiguous. Returns (out, frames)."""
        if pose.dtype != np.float32 or pose.size != 16 * self.bone_count:
            raise ValueError(f"pose must be {16 * self.bone_count} float32 values")
        if out.size != 3 * self.vertex_count or frames.size != 9 * self.vertex_count:
            raise ValueError(f"out and frames must hold {3 * self.vertex_count} and {9 * self.vertex_count} "
                             "float32 values")
        _call("sd_deform_frames", self.ptr, self.bone_count, np.ascontiguousarray(pose), self.vertex_count, out,
              frames)
        return out, frames

    def deform_displaced(self, pose, moved, displacements, out, turned):
        """sd_deform_displaced: the positions into `out` (V,3), and the displacements of the
        vertices `moved` (M int32, ascending; `displacements` (M,3), armature space, where a
        shape key put them) turned by their local linear maps J into `turned` (M,3); float32,
        contiguous. Returns (out, turned)."""
        if pose.dtype != np.float32 or pose.size != 16 * self.bone_count:
            raise ValueError(f"pose must be {16 * self.bone_count} float32 values")
        m = len(moved)
        if out.size != 3 * self.vertex_count:
            raise ValueError(f"out must hold {3 * self.vertex_count} float32 values")
        if displacements.size != 3 * m or turned.size != 3 * m or displacements.dtype != np.float32:
            raise ValueError(f"displacements and turned must hold {3 * m} float32 values")
        _call("sd_deform_displaced", self.ptr, self.bone_count, np.ascontiguousarray(pose), self.vertex_count, m,
              np.ascontiguousarray(moved, dtype=np.int32), np.ascontiguousarray(displacements), out, turned)
        return out, turned

    def deform_frame(self, pose, moved, displacements, out, turned, check, ratio_limit, rest, base, subtract,
                     composed):
        """sd_deform_frame: deform_displaced (moved None: deform) into `out` and `turned`, and
        in the same pass `check` (an OutputCheck, or None) against ratio_limit and the sums of
        compose_offsets into `composed` (base + (out − rest), then += turned, − displacements
        when `subtract`). Returns the check's (beyond, worst ratio, vertex, bone), (0, 0.0, -1,
        -1) without one."""
        if pose.dtype != np.float32 or pose.size != 16 * self.bone_count:
            raise ValueError(f"pose must be {16 * self.bone_count} float32 values")
        m = 0 if moved is None else len(moved)
        V = self.vertex_count
        for name, a in (("out", out), ("rest", rest), ("base", base), ("composed", composed)):
            if a is not None and a.size != 3 * V:
                raise ValueError(f"{name} must hold {3 * V} float32 values")
        if m and (displacements.size != 3 * m or turned.size != 3 * m or displacements.dtype != np.float32):
            raise ValueError(f"displacements and turned must hold {3 * m} float32 values")
        if check is not None and (check.vertex_count != V or check.bone_count != self.bone_count):
            raise ValueError("the output check was made for another mesh or rig")
        if self._verdict is None:
            self._verdict = (ctypes.c_int32(), ctypes.c_float(), ctypes.c_int32(), ctypes.c_int32())
            self._verdict_refs = tuple(ctypes.byref(x) for x in self._verdict)
        _call("sd_deform_frame", self.ptr, self.bone_count, np.ascontiguousarray(pose), V, m,
              None if not m else np.ascontiguousarray(moved, dtype=np.int32),
              None if not m else np.ascontiguousarray(displacements), out, turned if m else None,
              None if check is None else check.ptr, float(ratio_limit), *self._verdict_refs, rest, base,
              1 if subtract else 0, composed)
        return tuple(x.value for x in self._verdict)

    def volumes(self):
        """(rest, before, after) float64 #S of the last frame."""
        _call("sd_deformer_get_volumes", self.ptr, self.sweep_count, self._rest, self._before, self._after)
        return self._rest.copy(), self._before.copy(), self._after.copy()

    def set_rig_corrections(self, sweeps, keys, angles, values, muted=None):
        """Replaces the key-ellipse corrections of the deformer's rig (as Rig.set_corrections)."""
        args = _correction_arrays(sweeps, keys, angles, values, muted)
        _call("sd_deformer_set_rig_corrections", self.ptr, *args)


class OutputCheck(_Handle):
    """The core's bound on a frame's output (sd_output_check_*, issue 15): each vertex's
    distance to the nearer of its two heaviest skin bones against its rest distance, and the
    linear blend skinning shown instead for a frame beyond the bound. Read-only in the core,
    so any thread may use it; its result holders here serve one call at a time (the cache
    entry's lock)."""

    _destroy = "sd_output_check_destroy"

    def __init__(self, rest_positions, rest_pose, bone_lengths, skin_ids, skin_weights, floor_share):
        """rest_positions (V,3) and rest_pose #B*16 (column-major) in armature space;
        bone_lengths #B; skin_ids / skin_weights (V,S) (-1: unused slot); floor_share in [0, 1]."""
        rest_positions = _f32(rest_positions).reshape(-1)
        V = rest_positions.size // 3
        _expect_size("rest_positions", rest_positions, 3 * V)
        rest_pose, bone_lengths = _f32(rest_pose).ravel(), _f32(bone_lengths).ravel()
        B = bone_lengths.size
        _expect_size("rest_pose", rest_pose, 16 * B)
        ids, weights = _i32(skin_ids).reshape(V, -1), _f32(skin_weights).reshape(V, -1)
        if ids.shape != weights.shape:
            raise ValueError("skin ids and weights must have the same shape")
        S = ids.shape[1]
        out = OutputCheckP()
        _call("sd_output_check_create", V, rest_positions, B, rest_pose, bone_lengths, S, ids if S else None,
              weights if S else None, float(floor_share), ctypes.byref(out))
        super().__init__(out)
        self.vertex_count, self.bone_count = V, B
        self._beyond, self._vertex, self._bone = ctypes.c_int32(), ctypes.c_int32(), ctypes.c_int32()
        self._worst = ctypes.c_float()
        self._refs = (ctypes.byref(self._beyond), ctypes.byref(self._worst), ctypes.byref(self._vertex),
                      ctypes.byref(self._bone))

    def _frame(self, positions, pose):
        if pose.dtype != np.float32 or pose.size != 16 * self.bone_count or not pose.flags.c_contiguous:
            raise ValueError(f"pose must be {16 * self.bone_count} contiguous float32 values")
        if positions.dtype != np.float32 or positions.size != 3 * self.vertex_count \
                or not positions.flags.c_contiguous:
            raise ValueError(f"positions must be {3 * self.vertex_count} contiguous float32 values")

    def run(self, positions, pose, ratio_limit, ratios=None):
        """(vertices beyond ratio_limit, the frame's largest ratio, its vertex, its heaviest
        bone) for `positions` (V,3) float32 of `pose` (#B*16 float32); `ratios` (#V float32, or
        None) receives every vertex's ratio."""
        self._frame(positions, pose)
        if ratios is not None and ratios.size != self.vertex_count:
            raise ValueError(f"ratios must hold {self.vertex_count} values")
        _call("sd_output_check_run", self.ptr, self.bone_count, pose, self.vertex_count, positions,
              float(ratio_limit), *self._refs, ratios)
        return self._beyond.value, self._worst.value, self._vertex.value, self._bone.value

    def linear_blend(self, pose, out):
        """The linear blend skinning of the rest positions by `pose` into `out` (V,3) float32."""
        self._frame(out, pose)
        _call("sd_output_check_linear_blend", self.ptr, self.bone_count, pose, self.vertex_count, out)
        return out


# ---- anatomical effects (Sect. 4.3, 4.4) ---------------------------------------------

JOINT_GENERIC, JOINT_ELBOW, JOINT_KNEE = 0, 1, 2
EFFECT_FOLDING, EFFECT_PROTRUSION, EFFECT_BULGE = 1, 2, 4
EFFECT_ALL = EFFECT_FOLDING | EFFECT_PROTRUSION | EFFECT_BULGE
#: sd_joint_parameter
PARAM_PROTRUSION_STRENGTH, PARAM_PROTRUSION_FALLOFF, PARAM_BULGE_STRENGTH, PARAM_BULGE_FALLOFF = 0, 1, 2, 3
PARAM_FOLDING_FALLOFF, PARAM_FOLDING_MARGIN, PARAM_REGION_RADIUS = 4, 5, 6
#: sd_anatomy_stat names, in the ABI's order (SD_STAT_COUNT of them).
ANATOMY_STATS = (
    "ms_sweeps", "ms_bulge", "ms_protrusion", "ms_collision", "ms_folding", "ms_volume", "ms_total",
    "collision_triangles", "pairs_before", "pairs_after", "folding_iterations", "folding_regions",
    "bulge_vertices", "protrusion_vertices", "folded_vertices", "falloff_vertices", "relaxed_vertices",
    "max_bulge", "max_protrusion", "max_fold_depth", "volume_change", "effects_volume", "passes",
    "restored_volume")


class Anatomy(_Handle):
    """The anatomical effects of one bound mesh (skin folding, bone protrusion, muscle bulge,
    their volume fed back to the deformer), on top of a :class:`Deformer` of the same rig and
    binding."""

    _destroy = "sd_anatomy_destroy"

    def __init__(self, rig, binding, triangles):
        tris = _i32(triangles).reshape(-1)
        if tris.size == 0 or tris.size % 3:
            raise ValueError("triangles must be a non-empty (T,3) array")
        out = AnatomyP()
        _call("sd_anatomy_create", rig.ptr, binding.ptr, tris.size // 3, tris, ctypes.byref(out))
        super().__init__(out)
        self.bone_count = rig.bone_count
        self.vertex_count = binding.vertex_count
        self._stats = np.zeros(len(ANATOMY_STATS), np.float64)

    def add_joint(self, lower_bone, kind, flexion_direction=None):
        """Adds the joint whose lower link is `lower_bone`; returns its index."""
        direction = None if flexion_direction is None else _f32(flexion_direction).ravel()
        if direction is not None:
            _expect_size("flexion direction", direction, 3)
        index = ctypes.c_int32(-1)
        _call("sd_anatomy_add_joint", self.ptr, int(lower_bone), int(kind), direction, ctypes.byref(index))
        return index.value

    @property
    def joint_count(self):
        return int(library().sd_anatomy_joint_count(self.ptr))

    def set_joint_effects(self, joint, effects):
        _call("sd_anatomy_set_joint_effects", self.ptr, int(joint), int(effects))

    def set_joint_parameter(self, joint, parameter, value):
        _call("sd_anatomy_set_joint_parameter", self.ptr, int(joint), int(parameter), float(value))

    def set_volume_feedback(self, mode, restore=True):
        _call("sd_anatomy_set_volume_feedback", self.ptr, int(mode), 1 if restore else 0)

    def deform(self, deformer, pose, out=None):
        """sd_deform_with_anatomy: the deformer's frame, then the effects and the volume
        feedback. Returns (V,3) float32 (`out` if given, else the deformer's own buffer)."""
        if pose.dtype != np.float32 or pose.size != 16 * self.bone_count:
            raise ValueError(f"pose must be {16 * self.bone_count} float32 values")
        if out is None:
            out = deformer.positions
        elif out.size != 3 * self.vertex_count:
            raise ValueError(f"out must hold {3 * self.vertex_count} float32 values")
        _call("sd_deform_with_anatomy", deformer.ptr, self.ptr, self.bone_count, np.ascontiguousarray(pose),
              self.vertex_count, out)
        return out

    def stats(self):
        """The last frame's figures, a dict by :data:`ANATOMY_STATS` name."""
        _call("sd_anatomy_get_stats", self.ptr, self._stats.size, self._stats)
        return {name: float(v) for name, v in zip(ANATOMY_STATS, self._stats)}


# ---- automatic fitting ----------------------------------------------------------------


class FitResult(_Handle):
    """Result of :func:`fit_rig`: the rig, the weights for :meth:`Binding.bind`, a report."""

    _destroy = "sd_fit_result_destroy"

    def __init__(self, ptr, vertex_count):
        super().__init__(ptr)
        self.vertex_count = vertex_count

    def rig(self):
        out = RigP()
        _call("sd_fit_result_rig", self.ptr, ctypes.byref(out))
        return Rig(out)

    def slot_counts(self):
        s, k = ctypes.c_int32(), ctypes.c_int32()
        _call("sd_fit_result_slot_counts", self.ptr, ctypes.byref(s), ctypes.byref(k))
        return s.value, k.value

    def weights(self):
        """(sweep_ids, sweep_weights, bone_ids, bone_weights), (V, slots) arrays."""
        S, K = self.slot_counts()
        V = self.vertex_count
        sid, sw = np.empty((V, S), np.int32), np.empty((V, S), np.float32)
        bid, bw = np.empty((V, K), np.int32), np.empty((V, K), np.float32)
        _call("sd_fit_result_weights", self.ptr, V, S, sid, sw, K, bid, bw)
        return sid, sw, bid, bw

    def report(self):
        """The fitting report (JSON text)."""
        text = _serialize("sd_fit_result_report", self.ptr)  # NUL-terminated
        return text[:-1].decode("utf-8", "replace")


def fit_rig(positions, triangles, parents, rest, heads, tails, bone_names=None,
            skin_bones=None, skin_weights=None, keys_per_link=2, chains=None):
    """Fits a sweep rig to a rigged mesh (sd_fit_rig); everything in armature space.

    positions (V,3); triangles (T,3) int; parents #B; rest #B*16; heads, tails (B,3);
    bone_names #B str or None; skin_bones/skin_weights (V,S) or None; chains: None (found
    automatically) or a list of bone-index lists, from the body outwards."""
    positions = _f32(positions).reshape(-1)
    V = positions.size // 3
    triangles = _i32(triangles).reshape(-1)
    T = triangles.size // 3
    parents, rest, heads, tails = _i32(parents).ravel(), _f32(rest).ravel(), _f32(heads).ravel(), _f32(tails).ravel()
    B = parents.size
    _expect_size("rest", rest, 16 * B)
    _expect_size("heads", heads, 3 * B)
    _expect_size("tails", tails, 3 * B)
    names = None
    if bone_names is not None:
        if len(bone_names) != B:
            raise ValueError(f"{len(bone_names)} bone names for {B} bones")
        names = (c_char_p * B)(*[n.encode("utf-8") for n in bone_names])
    if skin_bones is None:
        S, skin_bones, skin_weights = 0, None, None
    else:
        skin_bones, skin_weights = _i32(skin_bones).reshape(V, -1), _f32(skin_weights).reshape(V, -1)
        if skin_bones.shape != skin_weights.shape:
            raise ValueError("skin_bones and skin_weights must have the same shape")
        S = skin_bones.shape[1]
    if chains:
        offsets = _i32(np.concatenate(([0], np.cumsum([len(c) for c in chains]))))
        chain_bones = _i32(np.concatenate([np.asarray(c, np.int32) for c in chains]))
        C = len(chains)
    else:
        C, offsets, chain_bones = 0, None, None
    out = FitResultP()
    _call("sd_fit_rig", V, positions, T, triangles, B, parents, rest, heads, tails, names, S,
          skin_bones, skin_weights, int(keys_per_link), C, offsets, chain_bones, ctypes.byref(out))
    return FitResult(out, V)


# ---- measurements -------------------------------------------------------------------------

def measure_volume(positions, triangles):
    """Volume enclosed by a closed triangle mesh: positions (V,3), triangles (T,3)."""
    p, t = _f32(positions).reshape(-1), _i32(triangles).reshape(-1)
    out = ctypes.c_double()
    _call("sd_measure_volume", p.size // 3, p, t.size // 3, t, ctypes.byref(out))
    return out.value


def measure_intersections(positions, triangles, subset=None):
    """Pairs of triangles (of `subset`, else all) that intersect and share no vertex."""
    p, t = _f32(positions).reshape(-1), _i32(triangles).reshape(-1)
    sub = None if subset is None else _i32(subset).ravel()
    out = ctypes.c_int64()
    _call("sd_measure_intersections", p.size // 3, p, t.size // 3, t,
          0 if sub is None else sub.size, sub, ctypes.byref(out))
    return out.value


def measure_cross_sections(positions, triangles, points, normals, reach=0.0):
    """Areas of the loops around points[i] cut by the planes (points[i], normals[i])."""
    p, t = _f32(positions).reshape(-1), _i32(triangles).reshape(-1)
    pts, nrm = _f32(points).reshape(-1), _f32(normals).reshape(-1)
    out = np.zeros(pts.size // 3, np.float64)
    _call("sd_measure_cross_sections", p.size // 3, p, t.size // 3, t, pts.size // 3, pts, nrm,
          float(reach), out)
    return out
