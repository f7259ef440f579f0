# SPDX-License-Identifier: GPL-3.0-or-later
"""A simple sweep rig for tests: key ellipses sitting on the bones of named chains.

TEST SUPPORT ONLY, not part of the product: the add-on's binding path is the core's automatic
fitting (sd_fit_rig). This is the Python twin of tests/support/bone_rig.cpp: a joint key at
every joint, `intermediate` keys on every link, each sized from the second moments of the
chain's skin around it, and sweep weights summed from the character's own skin weights. It
lets the Blender tests bind characters independently of the fitting (installed in place of
``bind.fitter``).
"""

import numpy as np

MAKEHUMAN_CHAINS = [("", ["pelvis", "spine_01", "spine_02", "spine_03"], "neck_01"),
                    ("spine_03", ["neck_01"], "head")]
for _s in ("_l", "_r"):
    MAKEHUMAN_CHAINS += [("spine_03", ["clavicle" + _s, "upperarm" + _s, "lowerarm" + _s], "hand" + _s),
                         ("pelvis", ["thigh" + _s, "calf" + _s], "foot" + _s)]

FIXTURE_CHAINS = [("", ["pelvis", "spine_01", "spine_02", "spine_03"], "neck"), ("spine_03", ["neck"], "head")]
for _s in (".L", ".R"):
    FIXTURE_CHAINS += [("spine_03", ["clavicle" + _s, "upper_arm" + _s, "forearm" + _s], "hand" + _s),
                       ("pelvis", ["thigh" + _s, "shin" + _s], "foot" + _s)]


def _quat_from_matrix(m):
    """(w, x, y, z) of a rotation matrix (columns = frame axes)."""
    t = np.trace(m)
    if t > 0:
        s = np.sqrt(t + 1.0) * 2
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    q = np.array(q)
    return q / np.linalg.norm(q)


def _size_key(positions, in_chain_vertex, center, frame, slab, reach):
    d = positions[in_chain_vertex] - center
    local = d @ frame  # columns of frame: x, y, n
    sel = (np.abs(local[:, 2]) <= slab) & (np.hypot(local[:, 0], local[:, 1]) <= reach)
    pts = local[sel][:, :2]
    if len(pts) < 8:
        return frame, 0.3 * reach, 0.3 * reach
    m = pts.T @ pts / len(pts)
    w, v = np.linalg.eigh(m)
    major = v[:, 1]
    a = np.sqrt(2.0 * w[1])
    b = max(np.sqrt(2.0 * max(w[0], 0.0)), 0.3 * a)
    x = frame[:, 0] * major[0] + frame[:, 1] * major[1]
    z = frame[:, 2]
    return np.column_stack([x, np.cross(z, x), z]), a, b


def make_bone_rig(inp, chains, intermediate=2):
    """(rig, sweep_ids, sweep_weights, bone_ids, bone_weights, report) for bind.BindInputs."""
    from bl_ext.user_default.sweep_deform.core import native  # the add-on's own binding
    names = list(inp.bone_names)
    index = {n: i for i, n in enumerate(names)}
    heads = np.asarray(inp.heads, np.float64).reshape(-1, 3)
    tails = np.asarray(inp.tails, np.float64).reshape(-1, 3)
    positions = np.asarray(inp.positions, np.float64)
    V, B = len(positions), len(names)
    skin_ids, skin_w = inp.skin_bones, inp.skin_weights
    top = skin_ids[np.arange(V), np.argmax(skin_w, axis=1)]

    rig = native.Rig.create(inp.parents, inp.rest, inp.heads, inp.tails)
    chain_of_bone = np.full(B, -1, np.int32)
    for start_name, link_names, end_name in chains:
        links = [index[n] for n in link_names]
        start = index[start_name] if start_name else -1
        end = index[end_name] if end_name else -1
        keys = []  # center, bone, joint_parent, fractions
        # A link runs from its head to the next joint: the next link's (or end bone's) head,
        # not necessarily its own tail (glTF imports may point tails elsewhere).
        ends = [heads[links[i + 1]] for i in range(len(links) - 1)]
        ends.append(heads[end] if end >= 0 else tails[links[-1]])
        for i, l in enumerate(links):
            keys.append([heads[l], l, start if i == 0 else links[i - 1], (0.5, 0.5)])
            for j in range(1, intermediate + 1):
                keys.append([heads[l] + (ends[i] - heads[l]) * j / (intermediate + 1), l, -1, (0.5, 0.5)])
        keys.append([ends[-1], end if end >= 0 else links[-1], links[-1] if end >= 0 else -1, (0.5, 1.0)])
        centers = np.array([k[0] for k in keys])
        length = np.linalg.norm(np.diff(centers, axis=0), axis=1).sum()
        in_chain = np.isin(top, links)
        chain_of_bone[links] = rig.sweep_count
        K = len(keys)
        orient, half = np.zeros((K, 4)), np.zeros((K, 2))
        for k in range(K):
            prev, nxt = centers[max(k - 1, 0)], centers[min(k + 1, K - 1)]
            n = (nxt - prev) / np.linalg.norm(nxt - prev)
            ref = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
            x = ref - ref.dot(n) * n
            x /= np.linalg.norm(x)
            frame = np.column_stack([x, np.cross(n, x), n])
            gap = np.linalg.norm(nxt - prev) / (1.0 if k in (0, K - 1) else 2.0)
            frame, a, b = _size_key(positions, in_chain, centers[k], frame, 0.3 * gap, 0.5 * length)
            orient[k] = _quat_from_matrix(frame)
            half[k] = (a, b)
        rig.add_sweep(centers, orient, half, [k[1] for k in keys], [k[2] for k in keys],
                      np.array([k[3] for k in keys]))

    # Sweep weights: a vertex's weight on a chain is the sum of its skin weights on the
    # chain's links (two heaviest chains kept); other bones keep theirs.
    S = skin_ids.shape[1]
    sweep_ids = np.full((V, 2), -1, np.int32)
    sweep_w = np.zeros((V, 2), np.float32)
    bone_ids = np.full((V, S), -1, np.int32)
    bone_w = np.zeros((V, S), np.float32)
    valid = skin_ids >= 0
    chain = np.where(valid, chain_of_bone[np.where(valid, skin_ids, 0)], -1)
    on_bone = valid & (chain < 0) & (skin_w > 0)
    bone_ids[on_bone] = skin_ids[on_bone]
    bone_w[on_bone] = skin_w[on_bone]
    per_chain = np.zeros((V, rig.sweep_count), np.float32)
    for s in range(S):
        m = chain[:, s] >= 0
        np.add.at(per_chain, (np.flatnonzero(m), chain[m, s]), skin_w[m, s])
    order = np.argsort(-per_chain, axis=1)[:, :2]
    for i in range(min(2, rig.sweep_count)):
        w = per_chain[np.arange(V), order[:, i]]
        has = w > 0
        sweep_ids[has, i] = order[has, i]
        sweep_w[has, i] = w[has]
    # Vertices with no influence at all follow the first root bone.
    none = (sweep_w.sum(1) + bone_w.sum(1)) <= 0
    bone_ids[none, 0] = int(np.flatnonzero(np.asarray(inp.parents) < 0)[0])
    bone_w[none, 0] = 1.0
    return rig, sweep_ids, sweep_w, bone_ids, bone_w, '{"test_rig": true}'


def fitter_for(chains):
    """A replacement for bind.fitter that builds this rig."""
    return lambda inp: make_bone_rig(inp, chains)
