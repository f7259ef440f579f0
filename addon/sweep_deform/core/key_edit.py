# SPDX-License-Identifier: GPL-3.0-or-later
"""Editing key ellipses (Sect. 4.2) without Blender: numpy and math only, no ``bpy``.

A key ellipse's *correction* is 8 numbers (the core's layout, see the header's
"key-ellipse editing" block)::

    offset (3)    the center's shift along the key's own axes (major, minor, normal)
    rotation (3)  a rotation vector (axis × radians) in the key's frame
    scale (2)     factors of the half-axes a and b

The core keeps, per key, a list of corrections keyed by the key's joint angle and
interpolates them. An *edit* made at some angle changes the correction at that angle (one
within :data:`DEFAULT_MERGE_ANGLE` of it, else a new one starting from the interpolated value,
so nothing jumps). Edits near the rest angle are edits *at* rest.

What the gizmos do, in numbers: a drag along an axis (:func:`axis_drag`), a turn about an
axis (:func:`dial_drag`), a factor on a half-axis (:func:`scale_drag`); and picking the key
ellipse under the mouse (:func:`nearest_loop`).
"""

import math

import numpy as np

#: The correction that changes nothing.
IDENTITY = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0)
#: An edit within this angle of a key's correction edits that correction (radians, 5°).
DEFAULT_MERGE_ANGLE = math.radians(5.0)
#: The core's limits (sweepdeform.h): |rotation| <= pi/2, factors in [0.1, 10],
#: |offset| <= 10 x the key's larger rest half-axis.
MAX_ROTATION = 0.5 * math.pi
MIN_SCALE, MAX_SCALE = 0.1, 10.0
MAX_OFFSET_FACTOR = 10.0

#: The edits a gizmo (or the tweak operator) makes.
MODES = ("MOVE", "MOVE_X", "MOVE_Y", "MOVE_Z", "ROTATE_X", "ROTATE_Y", "ROTATE_Z", "SCALE_A", "SCALE_B")


# ---- rotations --------------------------------------------------------------------------


def quat_to_matrix(q):
    """3×3 rotation of a unit quaternion (w, x, y, z); columns = the frame's axes."""
    w, x, y, z = (float(c) for c in q)
    n = math.sqrt(w * w + x * x + y * y + z * z) or 1.0
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def rotvec_to_matrix(v):
    """Rotation matrix of a rotation vector (Rodrigues)."""
    v = np.asarray(v, np.float64)
    angle = float(np.linalg.norm(v))
    if angle == 0.0:
        return np.eye(3)
    k = v / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def matrix_to_rotvec(R):
    """Rotation vector of a rotation matrix (angle in [0, pi])."""
    R = np.asarray(R, np.float64)
    c = max(-1.0, min(1.0, (np.trace(R) - 1.0) / 2.0))
    angle = math.acos(c)
    if angle < 1e-12:
        return np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2.0
    if math.pi - angle < 1e-6:  # near pi: the axis from the symmetric part
        M = (R + np.eye(3)) / 2.0
        i = int(np.argmax(np.diag(M)))
        axis = M[:, i] / math.sqrt(max(M[i, i], 1e-300))
        return axis / np.linalg.norm(axis) * angle
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / (2.0 * math.sin(angle))
    return axis * angle


def axis_rotation(axis_index, angle):
    v = np.zeros(3)
    v[axis_index] = angle
    return rotvec_to_matrix(v)


# ---- corrections ------------------------------------------------------------------------


def as_values(offset=(0.0, 0.0, 0.0), rotation=(0.0, 0.0, 0.0), scale_a=1.0, scale_b=1.0):
    return np.array(list(offset) + list(rotation) + [scale_a, scale_b], np.float64)


def clamp_values(values, max_offset):
    """Keeps a correction within the core's limits (offset norm, rotation angle, factors)."""
    v = np.array(values, np.float64)
    n = np.linalg.norm(v[:3])
    if n > max_offset:
        v[:3] *= max_offset / n
    r = np.linalg.norm(v[3:6])
    if r > MAX_ROTATION:
        v[3:6] *= MAX_ROTATION / r
    v[6:8] = np.clip(v[6:8], MIN_SCALE, MAX_SCALE)
    return v


def max_offset(half_axes):
    """The largest center offset the core accepts for a key of these rest half-axes."""
    return MAX_OFFSET_FACTOR * float(max(half_axes)) * (1.0 - 1e-6)


def find_correction(angles, angle, merge=DEFAULT_MERGE_ANGLE):
    """Index of the correction nearest to `angle` if within `merge`, else None."""
    best, best_d = None, None
    for i, a in enumerate(angles):
        d = abs(float(a) - angle)
        if d <= merge and (best_d is None or d < best_d):
            best, best_d = i, d
    return best


def edit_angle(angle, rest_angle, merge=DEFAULT_MERGE_ANGLE):
    """The angle a new correction is stored at: the rest angle when the joint is within
    `merge` of it (an edit at rest shifts every pose), else the current angle."""
    return rest_angle if abs(angle - rest_angle) <= merge else angle


def moved(values, delta_local):
    """The correction with its center offset moved by `delta_local` (key axes)."""
    v = np.array(values, np.float64)
    v[:3] += np.asarray(delta_local, np.float64)
    return v


def turned(values, axis_index, angle):
    """The correction turned by `angle` about axis `axis_index` (0 major, 1 minor, 2 normal)
    of the key as shown (the turn composes after the correction's own rotation)."""
    v = np.array(values, np.float64)
    v[3:6] = matrix_to_rotvec(rotvec_to_matrix(v[3:6]) @ axis_rotation(axis_index, angle))
    return v


def scaled(values, which, factor):
    """The correction with half-axis `which` (0 = a, 1 = b) multiplied by `factor`."""
    v = np.array(values, np.float64)
    v[6 + which] *= factor
    return v


def apply(mode, values, amount, uncorrected_rotation=None):
    """One edit of a correction. `amount`: MOVE — a vector in the armature's space; MOVE_X/Y/Z
    — a distance along that axis of the key as shown (its correction's rotation included);
    ROTATE_* — radians about that axis of the key as shown; SCALE_A/B — a factor. The offset
    lives in the axes of the key as Sect. 4.1 places it (`uncorrected_rotation`)."""
    R0 = np.eye(3) if uncorrected_rotation is None else np.asarray(uncorrected_rotation, np.float64)
    if mode == "MOVE":
        return moved(values, R0.T @ np.asarray(amount, np.float64))
    if mode in ("MOVE_X", "MOVE_Y", "MOVE_Z"):
        shown = rotvec_to_matrix(np.asarray(values, np.float64)[3:6])  # R0ᵀ R_shown
        return moved(values, shown[:, "XYZ".index(mode[-1])] * float(amount))
    if mode.startswith("ROTATE_"):
        return turned(values, "XYZ".index(mode[-1]), float(amount))
    if mode in ("SCALE_A", "SCALE_B"):
        return scaled(values, 0 if mode == "SCALE_A" else 1, float(amount))
    raise ValueError(f"unknown edit mode {mode!r}")


def key_frame(center, rotation):
    """4×4 matrix (row-major numpy) of a key: its axes as columns, its center as origin."""
    m = np.eye(4)
    m[:3, :3] = rotation
    m[:3, 3] = center
    return m


def corrected_key(center, rotation, half_axes, values):
    """The key as a correction shows it: center + R dc, R exp(dr), a sa, b sb."""
    v = np.asarray(values, np.float64)
    R = np.asarray(rotation, np.float64)
    return (np.asarray(center, np.float64) + R @ v[:3], R @ rotvec_to_matrix(v[3:6]),
            np.asarray(half_axes, np.float64) * v[6:8])


# ---- drags in the viewport (2D) -----------------------------------------------------------


def axis_drag(mouse0, mouse, origin2d, tip2d, length):
    """World distance along an axis for a mouse drag: the drag projected on the axis's screen
    direction (origin2d → tip2d, the image of `length` world units along the axis)."""
    d = np.asarray(tip2d, np.float64) - np.asarray(origin2d, np.float64)
    n2 = float(d @ d)
    if n2 < 1e-6:
        return 0.0
    m = np.asarray(mouse, np.float64) - np.asarray(mouse0, np.float64)
    return float(m @ d) / n2 * length


def dial_drag(center2d, mouse0, mouse, facing=1.0):
    """Signed angle the mouse turned about `center2d` (counter-clockwise positive on screen;
    `facing` = -1 when the axis points away from the viewer, so the turn follows the mouse)."""
    c = np.asarray(center2d, np.float64)
    u, v = np.asarray(mouse0, np.float64) - c, np.asarray(mouse, np.float64) - c
    if u @ u < 1e-6 or v @ v < 1e-6:
        return 0.0
    return facing * math.atan2(u[0] * v[1] - u[1] * v[0], u @ v)


def scale_drag(mouse0, mouse, center2d, handle2d):
    """Factor of a half-axis when its handle (at handle2d, seen from the key's center) is
    dragged: the ratio of the projected distances from the center, at least 0.05."""
    c = np.asarray(center2d, np.float64)
    d = np.asarray(handle2d, np.float64) - c
    n2 = float(d @ d)
    if n2 < 1e-6:
        return 1.0
    m = np.asarray(mouse, np.float64) - np.asarray(mouse0, np.float64)
    return max(0.05, 1.0 + float(m @ d) / n2)


# ---- drawing and picking ----------------------------------------------------------------


def ellipse_points(center, rotation, a, b, count=48):
    """(count, 3) points of an ellipse (closed: the last one is not repeated)."""
    t = np.linspace(0.0, 2.0 * math.pi, count, endpoint=False)
    R = np.asarray(rotation, np.float64)
    local = np.stack([a * np.cos(t), b * np.sin(t), np.zeros_like(t)], axis=1)
    return local @ R.T + np.asarray(center, np.float64)


def loop_segments(points):
    """A closed loop's points as line segments (2n, 3), for a LINES batch."""
    p = np.asarray(points)
    return np.stack([p, np.roll(p, -1, axis=0)], axis=1).reshape(-1, p.shape[1])


def polyline_segments(points):
    """An open polyline's points as line segments (2(n-1), 3)."""
    p = np.asarray(points)
    return np.stack([p[:-1], p[1:]], axis=1).reshape(-1, p.shape[1])


def ellipses_points(centers, rotations, half_axes, count=48):
    """(n, count, 3) points of n ellipses at once; rotations (n,3,3) with the axes as columns."""
    t = np.linspace(0.0, 2.0 * math.pi, count, endpoint=False)
    ab = np.asarray(half_axes, np.float64)
    local = np.stack([ab[:, 0:1] * np.cos(t), ab[:, 1:2] * np.sin(t), np.zeros((len(ab), count))], axis=2)
    return np.einsum("nij,nkj->nki", np.asarray(rotations, np.float64), local) + \
        np.asarray(centers, np.float64)[:, None, :]


def loops_segments(loops):
    """(n, count, 3) closed loops as line segments (n*2*count, 3)."""
    p = np.asarray(loops)
    return np.stack([p, np.roll(p, -1, axis=1)], axis=2).reshape(-1, p.shape[2])


def sweep_wire(centers, rotations, half_axes, rings=None, theta_count=24, lines=8):
    """Wireframe of a sampled sweep: the ellipses at the sample rows `rings` (all if None) and
    `lines` curves along it at fixed angles. centers (n,3), rotations (n,9) column-major,
    half_axes (n,2). Returns (m, 3) line-segment endpoints."""
    centers = np.asarray(centers, np.float64)
    R = np.asarray(rotations, np.float64).reshape(-1, 3, 3).transpose(0, 2, 1)  # column-major → rows
    ab = np.asarray(half_axes, np.float64)
    rows = np.arange(len(centers)) if rings is None else np.asarray(list(rings), int)
    out = [loops_segments(ellipses_points(centers[rows], R[rows], ab[rows], theta_count))] if len(rows) else []
    if lines and len(centers) > 1:
        along = ellipses_points(centers, R, ab, lines)  # (n, lines, 3)
        p = along.transpose(1, 0, 2)                     # (lines, n, 3)
        out.append(np.stack([p[:, :-1], p[:, 1:]], axis=2).reshape(-1, 3))
    return np.concatenate(out) if out else np.zeros((0, 3))


def segment_distances(point, segments2d):
    """Distance from a 2D point to each segment of (m, 2, 2) endpoints."""
    s = np.asarray(segments2d, np.float64)
    p0, p1 = s[:, 0], s[:, 1]
    d = p1 - p0
    n2 = np.einsum("ij,ij->i", d, d)
    t = np.where(n2 > 0, np.einsum("ij,ij->i", np.asarray(point, np.float64) - p0, d) / np.where(n2 > 0, n2, 1), 0)
    t = np.clip(t, 0.0, 1.0)
    q = p0 + t[:, None] * d
    return np.linalg.norm(q - np.asarray(point, np.float64), axis=1)


def nearest_loop(mouse, loops2d, max_distance=None):
    """(index, distance) of the closed 2D loop nearest to the mouse; loops may be None (not
    visible). (None, inf) when none is within `max_distance` (pixels)."""
    best, best_d = None, math.inf
    for i, loop in enumerate(loops2d):
        if loop is None or len(loop) < 2:
            continue
        p = np.asarray(loop, np.float64)
        seg = np.stack([p, np.roll(p, -1, axis=0)], axis=1)
        d = float(segment_distances(mouse, seg).min())
        if d < best_d:
            best, best_d = i, d
    if max_distance is not None and best_d > max_distance:
        return None, math.inf
    return best, best_d


def project(points, perspective, width, height):
    """Region pixel coordinates of world points through a 4×4 perspective matrix (row-major,
    Blender's region_3d.perspective_matrix); None where a point is behind the viewer."""
    p = np.asarray(points, np.float64)
    h = np.concatenate([p, np.ones((len(p), 1))], axis=1) @ np.asarray(perspective, np.float64).T
    w = h[:, 3]
    if np.any(w <= 1e-9):
        return None
    ndc = h[:, :2] / w[:, None]
    return np.stack([(ndc[:, 0] + 1.0) * 0.5 * width, (ndc[:, 1] + 1.0) * 0.5 * height], axis=1)


# ---- labels ---------------------------------------------------------------------------------


def degrees(angle):
    return f"{math.degrees(angle):.1f}°"


def key_role(key, key_count, joint_key):
    if joint_key:
        return "start joint" if key == 0 else "end joint" if key == key_count - 1 else "joint"
    return "start" if key == 0 else "end" if key == key_count - 1 else "link"


def format_key_label(sweep_label, key, key_count, joint_key=False, joint_name=""):
    """E.g. "arm_l · key 3 (joint forearm.L)"."""
    role = key_role(key, key_count, joint_key)
    return f"{sweep_label} · key {key} ({role}{' ' + joint_name if joint_name else ''})"
