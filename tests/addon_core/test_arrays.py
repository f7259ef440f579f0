# SPDX-License-Identifier: GPL-3.0-or-later
"""The numpy-only layer (core/arrays.py, core/fit_report.py), without Blender: plain arrays in
and out. (That core/ imports no bpy is test_core_without_blender.py.)"""

import numpy as np
import pytest

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


def test_add_to_rows_adds_to_those_rows_alone():
    a = np.arange(18, dtype=np.float32).reshape(6, 3)
    rows = np.array([1, 4], np.int32)
    values = np.array([[10, 20, 30], [-1, -2, -3]], np.float32)
    expected = a.copy()
    expected[rows] += values
    arrays.add_to_rows(a, arrays.flat_rows(rows), values)
    np.testing.assert_array_equal(a, expected)
    with pytest.raises(ValueError):  # a strided view would be added to as a copy
        arrays.add_to_rows(np.zeros((6, 6), np.float32)[:, :3], arrays.flat_rows(rows), values)


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


def _report(legs_down=True, arms=2, neck=True):
    """A fitting report of a skeleton along +Z (hips at 0, head at 1.6): bones 0 torso, 1 neck,
    2-3 arms, 4-7 legs (down when `legs_down`, else forward, as a quadruped's)."""
    import json
    chains = [{"kind": "torso", "bones": [0], "end_bone": 1 if neck else -1}]
    if neck:
        chains.append({"kind": "neck", "bones": [1]})
    chains += [{"kind": "arm", "bones": [2 + i]} for i in range(arms)]
    chains += [{"kind": "leg", "bones": [4 + 2 * i, 5 + 2 * i]} for i in range(2)]
    return json.dumps({"body": {"up": [0, 0, 1]}, "chains": chains})


def _skeleton(legs_down=True):
    heads = np.zeros((8, 3))
    tails = np.zeros((8, 3))
    heads[0], tails[0] = (0, 0, 0), (0, 0, 1.2)
    heads[1], tails[1] = (0, 0, 1.2), (0, 0, 1.6)
    heads[2], tails[2] = (0.2, 0, 1.2), (0.8, 0, 1.2)
    heads[3], tails[3] = (-0.2, 0, 1.2), (-0.8, 0, 1.2)
    for i, x in enumerate((0.1, -0.1)):
        d = np.array((0, 0, -0.4)) if legs_down else np.array((0, 0.4, -0.05))
        heads[4 + 2 * i] = (x, 0, 0)
        tails[4 + 2 * i] = heads[5 + 2 * i] = heads[4 + 2 * i] + d
        tails[5 + 2 * i] = heads[5 + 2 * i] + d
    return heads, tails


def test_humanoid_check_names_what_is_missing():
    fit_report = addon_modules.import_core("fit_report")
    names = ["spine", "neck", "arm.L", "arm.R", "thigh.L", "shin.L", "thigh.R", "shin.R"]
    heads, tails = _skeleton()
    assert fit_report.humanoid_problem(_report(), heads, tails, names) is None
    assert "two arms (found 0)" in fit_report.humanoid_problem(_report(arms=0), heads, tails, names)
    assert "neck or head" in fit_report.humanoid_problem(_report(neck=False), heads, tails, names)
    heads, tails = _skeleton(legs_down=False)  # a quadruped's hind legs, along its spine's normal
    problem = fit_report.humanoid_problem(_report(), heads, tails, names)
    assert "no humanoid legs" in problem and "'thigh.L'–'shin.L'" in problem, problem
    assert "no readable description" in fit_report.humanoid_problem("{not json", heads, tails, names)
    assert fit_report.humanoid_refusal("x").startswith("Sweep Deform fits humanoid rigs only")


def test_output_check_on_two_bones():
    """core/output_check.py on the core's check (sd_output_check_*, the library named by
    $SWEEPDEFORM_LIBRARY, which `ctest -L addon` sets) on two bones along +Y: a vertex 0.1 from
    its bone (above the floor, 5 % of a body 1.0 across) may move off it up to the bound, not
    beyond; the fallback is the weighted rigid motion."""
    native = addon_modules.import_core("native")
    available, why = native.available()
    if not available:
        pytest.skip(f"no libsweepdeform to check with ({why}); ctest -L addon sets SWEEPDEFORM_LIBRARY")
    check = addon_modules.import_core("output_check")
    rest = np.eye(4, dtype=np.float32)
    second = np.eye(4, dtype=np.float32)
    second[3, 1] = 1.0  # column-major: translation in the last column
    mats = np.concatenate([rest.ravel(), second.ravel()])
    ids, w = np.array([[0, -1], [1, 0]]), np.array([[1.0, 0.0], [0.25, 0.75]], np.float32)
    pts = np.array([[0.1, 0.5, 0.0], [0.1, 1.5, 0.0]], np.float32)
    c = check.OutputCheck(pts, mats, np.array([1.0, 1.0]), ids, w)
    np.testing.assert_allclose(c.ratios(pts, mats), [1.0, 1.0])
    assert c.worst(pts, mats) == (0.0, -1, -1)  # every vertex within the bound
    moved = pts.copy()
    moved[0, 0] = 0.1 * check.RATIO_LIMIT * 0.99
    assert c.ratios(moved, mats)[0] < check.RATIO_LIMIT and c.worst(moved, mats) == (0.0, -1, -1)
    ratio, vertex, bone = c.largest(moved, mats)
    assert abs(ratio - check.RATIO_LIMIT * 0.99) < 1e-5 and vertex == 0 and bone == 0
    moved[0, 0] = 0.1 * check.RATIO_LIMIT * 1.5
    ratio, vertex, bone = c.worst(moved, mats)
    assert abs(ratio - check.RATIO_LIMIT * 1.5) < 1e-5 and vertex == 0 and bone == 0
    moved[1] = np.nan  # a non-finite output is beyond the bound too
    assert c.worst(moved, mats)[:2] == (np.inf, 1)
    shifted = mats.copy()
    shifted[12:15] = (1.0, 0.0, 0.0)  # bone 0 moves by +x
    lbs = c.linear_blend(shifted)
    np.testing.assert_allclose(lbs, [[1.1, 0.5, 0.0], [0.85, 1.5, 0.0]], atol=1e-6)
    with pytest.raises(ValueError):  # the wrong dtype never reaches C
        c.core.run(moved.astype(np.float64), shifted, 3.0)
