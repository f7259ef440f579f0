# SPDX-License-Identifier: GPL-3.0-or-later
"""Issue 15: extreme poses never show shards. 200 seeded frames with every bone at up to ±170°
about each axis, on the built-in character bound with the product's fitting: no frame's
largest skin-to-bone distance ratio (measured here, independently of the add-on) is above
the add-on's stated bound (core/output_check.py), and a frame that needed the fallback says so
in the panel and shows the linear blend skinning of its pose."""

import bpy
import numpy as np

import helpers

SEED, FRAMES, LIMIT = 15, 200, np.radians(170.0)


def random_pose(arm, rng):
    for pb in arm.pose.bones:
        pb.rotation_mode = 'XYZ'
        pb.rotation_euler = rng.uniform(-LIMIT, LIMIT, size=3)


def segment_distance(points, heads, tails):
    ab = tails - heads
    t = np.einsum("ij,ij->i", points - heads, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-20)
    t = np.clip(t, 0.0, 1.0)
    return np.linalg.norm(points - heads - t[:, None] * ab, axis=1)


class Measure:
    """Each vertex's distance to the nearer of its two heaviest skin bones (from the vertex
    groups), posed against rest, over the add-on's floor (5 % of the rest body)."""

    def __init__(self, obj, arm):
        names = [b.name for b in arm.data.bones]
        V = len(obj.data.vertices)
        top = np.full((V, 2), -1)
        topw = np.zeros((V, 2))
        for v in obj.data.vertices:
            for g in v.groups:
                n = obj.vertex_groups[g.group].name
                b = arm.data.bones.get(n)
                if b is None or not b.use_deform or g.weight <= 0.0:
                    continue
                i = names.index(n)
                if g.weight > topw[v.index, 0]:
                    top[v.index, 1], topw[v.index, 1] = top[v.index, 0], topw[v.index, 0]
                    top[v.index, 0], topw[v.index, 0] = i, g.weight
                elif g.weight > topw[v.index, 1]:
                    top[v.index, 1], topw[v.index, 1] = i, g.weight
        top[:, 1] = np.where(top[:, 1] >= 0, top[:, 1], top[:, 0])
        self.skinned = top[:, 0] >= 0
        self.top = np.where(top >= 0, top, 0)
        self.names, self.obj, self.arm = names, obj, arm
        m = np.array(arm.matrix_world.inverted() @ obj.matrix_world)
        self.m = m
        rest = helpers.base_positions(obj) @ m[:3, :3].T + m[:3, 3]
        heads = np.array([b.head_local for b in arm.data.bones])
        tails = np.array([b.tail_local for b in arm.data.bones])
        floor = helpers.sub("core.output_check").FLOOR_SHARE * helpers.diagonal(rest)
        self.rest = np.maximum(self._distance(rest, heads, tails), floor)

    def _distance(self, p, heads, tails):
        return np.minimum(segment_distance(p, heads[self.top[:, 0]], tails[self.top[:, 0]]),
                          segment_distance(p, heads[self.top[:, 1]], tails[self.top[:, 1]]))

    def ratio(self, co):
        p = co @ self.m[:3, :3].T + self.m[:3, 3]
        heads = np.array([self.arm.pose.bones[n].head for n in self.names])
        tails = np.array([self.arm.pose.bones[n].tail for n in self.names])
        r = self._distance(p, heads, tails) / self.rest
        return float(r[self.skinned].max())


def bound_character():
    char = helpers.load("fixture")
    obj = char.mesh
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.object.sweep_deform_add() == {'FINISHED'}  # the product's own fitting
    return char, obj


def test_200_extreme_frames_stay_within_the_bound():
    check = helpers.sub("core.output_check")
    char, obj = bound_character()
    measure = Measure(obj, char.armature)
    cache = helpers.sub("blender.deformer_cache")
    rng = np.random.default_rng(SEED)
    worst, fallbacks = [], []
    for f in range(1, FRAMES + 1):
        bpy.context.scene.frame_current = f
        random_pose(char.armature, rng)
        bpy.context.view_layer.update()
        co, _ = helpers.evaluated_positions(obj)
        assert np.isfinite(co).all(), f
        r = measure.ratio(co)
        worst.append((r, f))
        e = cache.peek(obj)
        assert obj.sweep_deform.state == 'BOUND' and not e.error, (f, obj.sweep_deform.message, e.error)
        if e.warning:
            assert e.warning.startswith(f"Frame {f}: pose beyond what the sweeps can follow"), e.warning
            fallbacks.append(f)
    worst.sort(reverse=True)
    print(f"largest skin-to-bone distance ratios (bound {check.RATIO_LIMIT}): {worst[:5]}; "
          f"frames shown with the fallback: {fallbacks}")
    assert worst[0][0] <= check.RATIO_LIMIT + 1e-3, worst[:5]
    assert helpers.sub("blender.handlers")._reported == set()


class Exploding:
    """The character's deformer, but on `frames` its output turned into shards about twice
    the body's size (what issue 15 saw on one extreme frame)."""

    def __init__(self, inner, frames):
        self.inner, self.frames = inner, set(frames)

    def deform(self, pose, out=None):
        r = self.inner.deform(pose, out)
        if bpy.context.scene.frame_current in self.frames:
            self._explode(r)
        return r

    def deform_frame(self, pose, moved, displacements, out, turned, check, ratio_limit, *composition):
        """The one-pass frame (sd_deform_frame), its output checked again after the shards."""
        verdict = self.inner.deform_frame(pose, moved, displacements, out, turned, check, ratio_limit, *composition)
        if bpy.context.scene.frame_current not in self.frames or check is None:
            return verdict
        self._explode(out)
        return check.run(out, pose, ratio_limit)

    @staticmethod
    def _explode(r):
        rng = np.random.default_rng(bpy.context.scene.frame_current)
        c = r.mean(axis=0)
        r[...] = c + 2.0 * (r - c) + rng.normal(scale=0.2, size=r.shape).astype(np.float32)

    def __getattr__(self, name):
        return getattr(self.inner, name)


def test_exploded_frames_fall_back_to_linear_blend_skinning_with_a_warning():
    """Frames whose output breaks the bound (shards injected into the deformer's output) show
    Blender's own linear blend skinning of the pose, and the panel names the frame and bone;
    the frames around them show the sweeps, and the warning goes with the next good frame."""
    check = helpers.sub("core.output_check")
    char, obj = bound_character()
    measure = Measure(obj, char.armature)
    cache = helpers.sub("blender.deformer_cache")
    bpy.context.view_layer.update()
    e = cache.entry(obj)
    bad = {3, 4, 7}
    e.deformer = Exploding(e.deformer, bad)
    rng = np.random.default_rng(SEED)
    from test_deform import check_equals_core
    for f in range(1, 10):
        bpy.context.scene.frame_current = f
        random_pose(char.armature, rng)
        bpy.context.view_layer.update()
        assert cache.peek(obj) is e and obj.sweep_deform.state == 'BOUND'
        co, _ = helpers.evaluated_positions(obj)
        assert measure.ratio(co) <= check.RATIO_LIMIT, f
        if f in bad:
            assert e.warning.startswith(f"Frame {f}: pose beyond what the sweeps can follow (vertex "), e.warning
            assert "× its rest distance from '" in e.warning and f"limit {check.RATIO_LIMIT:g}×" in e.warning
            lbs = helpers.armature_modifier_positions(obj)
            assert np.abs(co - lbs).max() <= 1e-4 * helpers.diagonal(lbs), (f, np.abs(co - lbs).max())
        else:
            assert e.warning == "", (f, e.warning)
            check_equals_core(obj)
    assert e.fallback_frames == len(bad)


def test_a_tighter_bound_sends_real_frames_to_linear_blend_skinning(monkeypatch):
    """The frame's own check, in the core's one pass (sd_deform_frame), with the bound lowered
    to 1.1× so that real poses cross it: a frame beyond it shows Blender's linear blend skinning
    and names itself; a frame within it shows the sweeps, exactly the core's, and is within the
    bound by the independent measure."""
    check = helpers.sub("core.output_check")
    monkeypatch.setattr(check, "RATIO_LIMIT", 1.1)
    char, obj = bound_character()
    measure = Measure(obj, char.armature)
    cache = helpers.sub("blender.deformer_cache")
    bpy.context.view_layer.update()
    e = cache.entry(obj)
    rng = np.random.default_rng(SEED + 1)
    beyond, within = [], []
    from test_deform import check_equals_core
    for f in range(1, 13):  # bones turned by up to 5° on odd frames, 60° on even ones
        bpy.context.scene.frame_current = f
        amplitude = np.radians(5.0 if f % 2 else 60.0)
        for pb in char.armature.pose.bones:
            pb.rotation_mode = 'XYZ'
            pb.rotation_euler = rng.uniform(-amplitude, amplitude, size=3)
        bpy.context.view_layer.update()
        co, _ = helpers.evaluated_positions(obj)
        if e.warning:
            assert e.warning.startswith(f"Frame {f}: pose beyond what the sweeps can follow (vertex "), e.warning
            assert "limit 1.1×" in e.warning, e.warning
            lbs = helpers.armature_modifier_positions(obj)
            assert np.abs(co - lbs).max() <= 1e-4 * helpers.diagonal(lbs), (f, np.abs(co - lbs).max())
            beyond.append(f)
        else:
            check_equals_core(obj)
            assert measure.ratio(co) <= 1.1 + 1e-4, (f, measure.ratio(co))
            within.append(f)
    assert beyond and within, (beyond, within)  # both sides of the bound were seen
    print(f"beyond 1.1x: frames {beyond}; within: {within}")
    assert e.fallback_frames == len(beyond)
