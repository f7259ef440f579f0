# SPDX-License-Identifier: GPL-3.0-or-later
"""Whether the object transforms and poses handed to the core are usable, said in words an
artist understands: plain Python, no ``bpy``.

The core refuses a NaN, infinite, enormous or degenerate bone matrix itself (naming the bone
by index); what it never sees are the object matrices, which only map its offsets back to
the mesh (arrays.offsets_into), so they are checked here with the same limits. A refused
frame changes nothing: the mesh keeps the last good deformation and the panel says why
(see blender/frame.py and docs/robustness.md).
"""

import math
import re

#: Largest magnitude of a matrix entry, as the core's check_matrix (skeleton.cpp).
ENORMOUS = 1e12
#: An axis shorter than this fraction of the longest one counts as a zero scale.
FLAT = 1e-12


def matrix_problem(matrix, what):
    """None if the 4x4 world matrix (rows: a mathutils.Matrix, a numpy array, nested lists)
    can map offsets, else a sentence starting with `what` (e.g. "The armature 'Armature'").
    Plain Python on 16 numbers: about 3 µs, where numpy's det and norms take 25 µs."""
    rows = [[float(x) for x in row] for row in matrix]
    flat = [x for row in rows for x in row]
    if not all(map(math.isfinite, flat)):
        return f"{what} has a NaN or infinite transform"
    if max(map(abs, flat)) > ENORMOUS:
        return f"{what} has an enormous transform (a value beyond {ENORMOUS:g})"
    (a, b, c, _), (d, e, f, _), (g, h, i, _) = rows[:3]
    axes = [math.sqrt(a * a + d * d + g * g), math.sqrt(b * b + e * e + h * h), math.sqrt(c * c + f * f + i * i)]
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    if not max(axes) > 0.0 or min(axes) <= FLAT * max(axes) or det == 0.0:
        return f"{what} has a zero scale"
    return None


def transforms_problem(object_matrix, object_name, armature_matrix, armature_name):
    """The first problem of a mesh object's and its armature's world matrices, or None. The
    armature is looked at first: a mesh parented to it inherits its problem."""
    return (matrix_problem(armature_matrix, f"The armature '{armature_name}'")
            or matrix_problem(object_matrix, f"The object '{object_name}'"))


_BONE_INDEX = re.compile(r"\bbone (\d+)\b")
_PREFIXES = re.compile(r"^(?:sd_\w+: |SD_ERR_\w+: )+")


def name_bones(message, bone_names):
    """The core's message with "bone 8" turned into "bone 'forearm.L'" (rig order names)
    and its "sd_deform: SD_ERR_…: " prefixes dropped."""
    text = _PREFIXES.sub("", message)

    def named(match):
        i = int(match.group(1))
        return f"bone '{bone_names[i]}'" if 0 <= i < len(bone_names) else match.group(0)

    return _BONE_INDEX.sub(named, text)
