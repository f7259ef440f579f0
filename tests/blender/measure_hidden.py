# SPDX-License-Identifier: GPL-3.0-or-later
"""Ten bound characters in one scene, nine that do not show: what a played frame costs against
the visible character alone in the scene, in the same Blender run (issue 16: within 10 %).
Prints the figures and the ratio; never fails on speed (test_modifier.py counts the core calls).

    BLENDER_USER_RESOURCES=$(mktemp -d) scripts/blender --use 5.2 -b --factory-startup \\
        --python tests/blender/measure_hidden.py -- [--zip ZIP] [--frames N] [--rounds R] \\
        [--character fixture|fixture_full] [--how mixed|eye|disabled|excluded] [--deform sweep|armature]

The characters are Alt+D copies of the built-in one (``fixture``: 4,714 vertices, the default;
``fixture_full``: 75,394), bound with the product's fitting, each on its own armature with the
same keyed elbows and knees; the nine are hidden three ways each, mesh and armature: hidden in
the view layer (H), disabled in viewports, in an excluded collection. The two set-ups take
turns, R rounds of N played frames each (the first frames of a round not counted), so a busy
spell of the shared machine hits both alike; medians of the per-frame times. ``--how`` hides
all nine one way instead, to tell the ways' costs apart; ``--deform armature`` leaves the
characters unbound, deformed by Blender's Armature modifier: what Blender itself spends on
characters that do not show (an armature hidden with H is still animated and posed every frame).
"""

import os
import statistics
import sys
import time

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "scripts", "blender_support"))

import install  # noqa: E402

WARM = 3


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    opts = {"zip": install.default_zip(), "frames": 40, "rounds": 6, "character": "fixture", "how": "mixed",
            "deform": "sweep"}
    for i in range(0, len(argv) - 1, 2):
        opts[argv[i].lstrip("-")] = argv[i + 1]
    opts["frames"], opts["rounds"] = int(opts["frames"]), int(opts["rounds"])
    return opts


def hide_one_way(characters, scene, how):
    """All characters (mesh and armature) hidden one way: 'eye' (H), 'disabled' (in
    viewports), 'excluded' (an excluded collection)."""
    if how == "excluded":
        excluded = bpy.data.collections.new("Excluded")
        scene.collection.children.link(excluded)
        bpy.context.view_layer.layer_collection.children[excluded.name].exclude = True
    for pair in characters:
        for o in pair:
            if how == "eye":
                o.hide_set(True)
            elif how == "disabled":
                o.hide_viewport = True
            else:
                for c in list(o.users_collection):
                    c.objects.unlink(o)
                excluded.objects.link(o)


def main():
    opts = args()
    install.install(opts["zip"])
    import helpers
    import test_modifier
    char = helpers.load(opts["character"])
    obj = char.mesh
    bpy.context.view_layer.objects.active = obj
    if opts["deform"] == "sweep":
        assert bpy.ops.object.sweep_deform_add() == {'FINISHED'}
    scene = bpy.context.scene
    test_modifier.animate_elbows(char, ((1, 0.0), (40, 1.4), (80, 0.2), (120, 1.2)))
    others = []
    for i in range(9):
        obj_i, arm_i = helpers.duplicate_character(obj, char.armature, linked=True)
        arm_i.location.x += 1.0 + i
        others.append((obj_i, arm_i))
    scene.frame_set(1)
    bpy.context.view_layer.update()
    if opts["how"] == "mixed":
        test_modifier._hide(others, scene)
    else:  # all nine one way, to tell the ways' costs apart
        hide_one_way(others, scene, opts["how"])
    homes = {o.name: list(o.users_collection) for pair in others for o in pair}
    eye = {o.name for pair in others for o in pair if o.hide_get()}  # hidden with H: a view-layer flag

    def alone(yes):
        """The nine out of the scene (unlinked from their collections), or back."""
        for pair in others:
            for o in pair:
                for c in homes[o.name]:
                    if yes and o.name in c.objects:
                        c.objects.unlink(o)
                    elif not yes and o.name not in c.objects:
                        c.objects.link(o)
                if not yes and o.name in eye:
                    o.hide_set(True)  # a new link is shown: hidden again
        bpy.context.view_layer.update()

    handlers = helpers.sub("blender.handlers")
    frame = helpers.sub("blender.frame")
    inner, spent = handlers.evaluate_scene, []
    inner_frame, shown = frame.evaluate, []

    def timed(*a, **k):
        t = time.perf_counter()
        try:
            return inner(*a, **k)
        finally:
            spent.append(time.perf_counter() - t)

    def timed_frame(*a, **k):  # a character that shows (hidden ones never get here)
        t = time.perf_counter()
        try:
            return inner_frame(*a, **k)
        finally:
            shown.append(time.perf_counter() - t)

    handlers.evaluate_scene, frame.evaluate = timed, timed_frame
    n, results = opts["frames"], {True: [], False: []}
    addon, rest = {True: [], False: []}, {True: [], False: []}
    calls = {True: 0, False: 0}
    try:
        for r in range(opts["rounds"]):
            for is_alone in (False, True):
                alone(is_alone)
                start = 1 + (r * n) % 110
                frames = list(range(start, start + n))
                scene.frame_set(frames[0] - 1 if frames[0] > 1 else 120)
                spent.clear()
                before = frame.core_calls
                times = []
                for i, f in enumerate(frames):
                    mark, mark_shown = len(spent), len(shown)
                    t = time.perf_counter()
                    scene.frame_set(f)
                    dt = time.perf_counter() - t
                    if i >= WARM:
                        times.append(dt)
                        addon[is_alone].append(sum(spent[mark:]))
                        rest[is_alone].append(sum(spent[mark:]) - sum(shown[mark_shown:]))
                results[is_alone] += times
                calls[is_alone] += frame.core_calls - before
    finally:
        handlers.evaluate_scene, frame.evaluate = inner, inner_frame
        alone(False)
    frames_counted = opts["rounds"] * (n - WARM)
    hidden, single = statistics.median(results[False]), statistics.median(results[True])
    hidden_addon, single_addon = statistics.median(addon[False]), statistics.median(addon[True])
    deformed_by = "Sweep Deform" if opts["deform"] == "sweep" else "Blender's Armature modifier (not bound)"
    print(f"\n{opts['character']}: {len(obj.data.vertices):,} vertices a character, {deformed_by}, "
          f"hidden {opts['how']}, Blender {bpy.app.version_string}; "
          f"{opts['rounds']} rounds of {n - WARM} frames per set-up; median ms a frame")
    if opts["deform"] == "sweep":
        for label, key in (("ten characters, nine hidden:", False), ("the visible one alone:      ", True)):
            print(f"  {label} {1e3 * statistics.median(results[key]):.3f} ms (add-on "
                  f"{1e3 * statistics.median(addon[key]):.3f} ms, of which {1e3 * statistics.median(rest[key]):.3f} ms "
                  f"besides the visible character's frame; {calls[key] / (opts['rounds'] * n):.2f} core calls a frame)")
        print(f"  ratio nine hidden / alone: {hidden / single:.2f} (add-on {hidden_addon / single_addon:.2f}); "
              f"{frames_counted} frames each")
    else:
        print(f"  ten characters, nine hidden: {1e3 * hidden:.3f} ms; the visible one alone: {1e3 * single:.3f} ms")
        print(f"  ratio nine hidden / alone: {hidden / single:.2f}; {frames_counted} frames each")


if __name__ == "__main__":
    main()
