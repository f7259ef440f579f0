#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Searches random extreme poses for frames the sweeps cannot follow (issue 15), without
Blender: the rig and binding dumped by tests/blender/explore_extreme.py, forward kinematics as
Blender's (pose = parent pose . parent rest^-1 . rest . local), libsweepdeform through the
add-on's core/native.py, the add-on's core/output_check.py as the measure.

    SWEEPDEFORM_LIBRARY=build/native/libsweepdeform.so python3 scripts/extreme_poses.py \\
        DUMP_DIR {euler|axis|haar} FRAMES SEED [novol]

euler: every bone at up to +-170 deg about each axis (XYZ); axis: a random axis, up to +-170 deg;
haar: uniformly random rotations. Prints the frames beyond the bound and the five worst."""

import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "addon_core"))
import addon_modules  # noqa: E402

LIMIT = np.radians(170.0)


def rotation(axis, angle):
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    m = np.eye(4)
    m[:3, :3] = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    return m


def euler(e):
    m = rotation((0, 0, 1), e[2]) @ rotation((0, 1, 0), e[1]) @ rotation((1, 0, 0), e[0])  # Blender XYZ
    return m


def local_rotations(mode, rng, count):
    if mode == "euler":
        return np.array([euler(rng.uniform(-LIMIT, LIMIT, 3)) for _ in range(count)])
    out = []
    for _ in range(count):
        if mode == "haar":
            q = rng.normal(size=4)
            q /= np.linalg.norm(q)
            angle = 2.0 * np.arccos(np.clip(abs(q[0]), 0.0, 1.0))
            axis = q[1:] * np.sign(q[0] or 1.0)
            n = np.linalg.norm(axis)
            out.append(rotation(axis / n if n > 0 else (1, 0, 0), angle))
        else:
            axis = rng.normal(size=3)
            out.append(rotation(axis / np.linalg.norm(axis), rng.uniform(-LIMIT, LIMIT)))
    return np.array(out)


def main():
    dump, mode, frames, seed = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    volume = not (len(sys.argv) > 5 and sys.argv[5] == "novol")
    native, output_check = addon_modules.import_core("native"), addon_modules.import_core("output_check")
    d, k = np.load(os.path.join(dump, "data.npz")), np.load(os.path.join(dump, "skin.npz"))
    rig = native.Rig.deserialize(d["rig"].tobytes())
    deformer = native.Deformer(rig, native.Binding.deserialize(d["binding"].tobytes()))
    deformer.set_volume_preservation(volume, 1.0)
    rest = d["rest"].astype(np.float32)
    bones = rest.size // 16
    rest_rows = rest.reshape(bones, 4, 4).transpose(0, 2, 1).astype(np.float64)
    parents, names = k["parents"], list(d["names"])
    check = output_check.OutputCheck(k["core_rest"], rest, k["lengths"], k["ids"], k["w"])
    order, seen = [], set()
    while len(order) < bones:
        for b in range(bones):
            if b not in seen and (parents[b] < 0 or parents[b] in seen):
                order.append(b)
                seen.add(b)
    rng = np.random.default_rng(seed)
    rows, t0 = [], time.time()
    for f in range(frames):
        local = local_rotations(mode, rng, bones)
        posed = np.empty_like(rest_rows)
        for b in order:
            p = parents[b]
            base = posed[p] @ np.linalg.inv(rest_rows[p]) @ rest_rows[b] if p >= 0 else rest_rows[b]
            posed[b] = base @ local[b]
        pose = np.ascontiguousarray(posed.transpose(0, 2, 1).reshape(-1)).astype(np.float32)
        out = deformer.deform(pose).copy()
        ratio, v, bone = check.largest(out, pose)
        rows.append((f, ratio, v, names[bone]))
        if ratio > output_check.RATIO_LIMIT:
            print("BEYOND", rows[-1], flush=True)
    rows.sort(key=lambda r: -r[1])
    print(f"{frames} frames in {time.time() - t0:.0f} s; worst:", rows[:5])


if __name__ == "__main__":
    main()
