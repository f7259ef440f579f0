# SPDX-License-Identifier: GPL-3.0-or-later
"""The numpy-only layer (core/arrays.py, core/fit_report.py), without Blender: plain arrays in
and out. (That core/ imports no bpy is test_core_without_blender.py.)"""

import numpy as np

import addon_modules

arrays = addon_modules.import_core("arrays")


def test_dense_weights_keep_the_heaviest_bones():
    # vertex 0: groups 0 (0.2), 1 (0.5), 2 (0.3, no bone); vertex 1: none; vertex 2: group 1 (1.0)
    ids, w = arrays.dense_weights_from_flat([3, 0, 1], [0, 1, 2, 1], [0.2, 0.5, 0.3, 1.0], [4, 7, -1], 2)
    np.testing.assert_array_equal(ids, [[7, 4], [-1, -1], [7, -1]])
    np.testing.assert_allclose(w, [[0.5, 0.2], [0, 0], [1.0, 0]])
    assert ids.dtype == np.int32 and w.dtype == np.float32


def test_pose_order_and_gather():
    assert arrays.pose_order(["a", "b"], ["a", "b"]) is None
    order = arrays.pose_order(["b", "a"], ["a", "b", "c"])
    m = np.arange(48, dtype=np.float32)
    np.testing.assert_array_equal(arrays.gather_pose(m, order), np.concatenate([m[16:32], m[:16]]))
    try:
        arrays.pose_order(["x"], ["a"])
        assert False
    except KeyError as e:
        assert "x" in str(e)


def test_offsets_in_mesh_space():
    rng = np.random.default_rng(0)
    deformed = rng.normal(size=(5, 3)).astype(np.float32)
    rest = rng.normal(size=(5, 3)).astype(np.float32)
    out, scratch = np.empty_like(rest), np.empty_like(rest)
    np.testing.assert_array_equal(arrays.offsets_into(deformed, rest, None, out, scratch), deformed - rest)
    scale = np.diag([2.0, 2.0, 2.0])  # armature = 2 x mesh: mesh offsets are half
    to_mesh = np.linalg.inv(scale).T.astype(np.float32)
    np.testing.assert_allclose(arrays.offsets_into(deformed, rest, to_mesh, out, scratch), (deformed - rest) / 2,
                               rtol=1e-6)


def test_pack_frames_in_mesh_space():
    """The rows of J - I in mesh space, in place: a mesh-space move d maps to L^-1 J L d
    (L: mesh -> armature)."""
    rng = np.random.default_rng(1)
    V = 4
    frames = rng.normal(size=(V, 3, 3)).astype(np.float32)  # [vertex, row, column]
    blocks = np.ascontiguousarray(frames.transpose(1, 0, 2))  # [row, vertex, column], as the core writes
    got = arrays.pack_frames(blocks.copy(), np.eye(3), None)
    np.testing.assert_allclose(got.transpose(1, 0, 2) + np.eye(3, dtype=np.float32), frames, atol=1e-6)
    lin = np.array([[0.0, -2.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0]])  # turned and scaled
    to_mesh = np.linalg.inv(lin).T.astype(np.float32)
    got = arrays.pack_frames(blocks.copy(), lin, to_mesh).transpose(1, 0, 2)
    d = rng.normal(size=3)
    for v in range(V):
        np.testing.assert_allclose(got[v] @ d, np.linalg.inv(lin) @ frames[v] @ lin @ d - d, rtol=1e-5, atol=1e-6)


def test_fingerprints_see_connectivity_not_just_counts():
    a = arrays.topology_fingerprint([0, 1, 1, 2], [0, 1, 2], [3])
    b = arrays.topology_fingerprint([0, 1, 1, 2], [0, 2, 1], [3])
    assert a != b and a == arrays.topology_fingerprint(np.array([0, 1, 1, 2]), [0, 1, 2], [3])


def test_sweep_labels_prefer_the_fitting_report():
    report = '{"chains": [{"name": "arm_l", "sweep": 1}, {"name": "tail", "sweep": -1}]}'
    labels = addon_modules.import_core("fit_report").sweep_labels([[0, 1], [1, 2, 2]], ["a", "b", "c"], report)
    assert labels == ["a – b", "arm_l"]
