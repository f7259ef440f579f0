# SPDX-License-Identifier: GPL-3.0-or-later
"""The product's binding path end to end: ``bpy.ops.object.sweep_deform_add()`` with the core's
automatic fitting (sd_fit_rig), on every character. Runs in a child Blender, so a crash in
the native fitting fails this test instead of ending the whole run."""

import json
import os
import subprocess

import bpy
import pytest

import helpers

SCRIPT = r'''
import bpy, json, sys, time
sys.path.insert(0, {here!r})
bpy.ops.preferences.addon_enable(module="bl_ext.user_default.sweep_deform")
import helpers, numpy as np
out = {{}}
for key in {keys!r}:
    r = out[key] = {{}}
    try:
        char = helpers.load(key)
        obj = char.mesh
        bpy.context.view_layer.objects.active = obj
        t = time.perf_counter()
        r["result"] = list(bpy.ops.object.sweep_deform_add())
        r["seconds"] = time.perf_counter() - t
        r["state"], r["sweeps"] = obj.sweep_deform.state, obj.sweep_deform.sweep_count
        r["labels"] = helpers.sub("runtime").entry(obj).labels
        helpers.pose_limbs(char, elbow=1.2, knee=1.1)
        bpy.context.view_layer.update()
        co, _ = helpers.evaluated_positions(obj)
        expected, raw = helpers.core_expectation(obj)
        base = helpers.base_positions(obj)
        r["equals_core"] = bool(np.array_equal(co, expected))
        r["moved"] = float(np.abs(co - base).max() / helpers.diagonal(base))
        lbs = helpers.armature_modifier_positions(obj)
        err = np.linalg.norm(co - lbs, axis=1) / helpers.diagonal(base)
        r["vs_armature_mean"], r["vs_armature_max"] = float(err.mean()), float(err.max())
    except Exception:
        import traceback
        r["error"] = traceback.format_exc()
print("RESULT " + json.dumps(out), flush=True)
'''


def test_add_with_automatic_fitting_on_every_character():
    keys = [k for k in helpers.CHARACTERS if helpers.available(k)]
    if not keys:
        pytest.skip("no character available")
    script = os.path.join(helpers.tmp_dir(), "fit_child.py")
    with open(script, "w") as f:
        f.write(SCRIPT.format(here=helpers.HERE, keys=keys))
    proc = subprocess.run([bpy.app.binary_path, "-b", "--factory-startup", "--python", script],
                          capture_output=True, text=True, timeout=300)
    lines = [l for l in proc.stdout.splitlines() if l.startswith("RESULT ")]
    assert lines, f"child Blender ended with {proc.returncode}:\n" + proc.stdout[-3000:] + proc.stderr[-3000:]
    out = json.loads(lines[-1][len("RESULT "):])
    for key, r in out.items():
        assert "error" not in r, f"{key}: {r['error']}"
        print(f"{key}: fitted and bound in {r['seconds']:.2f} s, {r['sweeps']} sweeps {r['labels']}; "
              f"vs Armature modifier mean {r['vs_armature_mean']:.2e} max {r['vs_armature_max']:.2e} x diagonal")
        assert r["result"] == ["FINISHED"] and r["state"] == "BOUND"
        assert r["sweeps"] >= 5  # torso, arms and legs at least
        assert r["equals_core"] and r["moved"] > 0.05
        assert r["vs_armature_mean"] < 0.01 and r["vs_armature_max"] < 0.1
