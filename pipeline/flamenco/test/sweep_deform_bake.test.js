// SPDX-License-Identifier: GPL-3.0-or-later
//
// The "Sweep Deform Bake" Flamenco job type under Node (node --test pipeline/flamenco/test):
// its JOB_TYPE settings, the tasks, commands and dependencies compileJob() authors against a
// mock of Flamenco's author API (flamenco_mock.js), and the Python it hands to Blender, run
// with python3 against a stand-in `bpy` (fake_bpy/bpy.py): bake chunks, merge them, switch a
// render to the cache. Blender itself is not needed.
"use strict";

const test = require("node:test");
const assert = require("node:assert/strict");
const fs = require("node:fs");
const os = require("node:os");
const nodePath = require("node:path");
const { spawnSync } = require("node:child_process");
const { loadJobType } = require("./flamenco_mock.js");

const SCRIPT = nodePath.join(__dirname, "..", "sweep_deform_bake.js");
const FAKE_BPY = nodePath.join(__dirname, "fake_bpy");
const jobType = loadJobType(SCRIPT);

const python = ["python3", "python"].find((p) => spawnSync(p, ["--version"]).status === 0);

function baseSettings(extra) {
    return Object.assign({
        blendfile: "/farm/shot.blend", object: "Body", scene: "Scene", frames: "1-450",
        cache_dir: "/farm/cache", render_output_root: "/farm/render", format: "PNG", image_file_extension: ".png",
    }, extra);
}

/// The value after a flag in a command's args.
function argAfter(args, flag) {
    const i = args.indexOf(flag);
    assert.ok(i >= 0 && i + 1 < args.length, `${flag} missing in ${JSON.stringify(args)}`);
    return args[i + 1];
}

/// The JSON parameters at the end of a generated Python expression.
function pythonParams(expr) {
    const m = /json\.loads\(("(?:[^"\\]|\\.)*")\)\)\n$/.exec(expr);
    assert.ok(m, "the expression ends in json.loads(<string literal>))");
    return JSON.parse(JSON.parse(m[1]));
}

function runPython(expr, env) {
    const r = spawnSync(python, ["-c", expr], {
        env: Object.assign({}, process.env, { PYTHONPATH: FAKE_BPY }, env || {}), encoding: "utf8",
    });
    return { status: r.status, out: r.stdout + r.stderr };
}

function tmpdir() {
    return fs.mkdtempSync(nodePath.join(os.tmpdir(), "sweep-deform-flamenco-"));
}

function readPc2(file) {
    const b = fs.readFileSync(file);
    return {
        magic: b.subarray(0, 12).toString("latin1"), version: b.readInt32LE(12), points: b.readInt32LE(16),
        start: b.readFloatLE(20), rate: b.readFloatLE(24), samples: b.readInt32LE(28),
        data: Array.from({ length: (b.length - 32) / 4 }, (_, i) => b.readFloatLE(32 + 4 * i)),
    };
}

test("JOB_TYPE follows Flamenco's setting schema", () => {
    const { JOB_TYPE } = jobType;
    assert.equal(JOB_TYPE.label, "Sweep Deform Bake");
    const keys = new Set();
    for (const s of JOB_TYPE.settings) {
        assert.match(s.key, /^[a-z_]+$/);
        assert.ok(!keys.has(s.key), `duplicate setting ${s.key}`);
        keys.add(s.key);
        assert.ok(["string", "int32", "float", "bool"].includes(s.type), `${s.key}: type ${s.type}`);
        if (s.visible !== undefined) assert.ok(["visible", "hidden", "submission", "web"].includes(s.visible), s.key);
        if (s.subtype !== undefined) assert.ok(["file_path", "dir_path", "hashed_file_path"].includes(s.subtype), s.key);
        if (s.default !== undefined) {
            const t = typeof s.default;
            assert.equal(t, { string: "string", int32: "number", float: "number", bool: "boolean" }[s.type], s.key);
        }
    }
    for (const k of ["blendfile", "object", "frames", "chunk_size", "cache_dir", "scene", "format", "render"])
        assert.ok(keys.has(k), `setting ${k}`);
});

test("eval expressions are valid Python", { skip: !python && "python3 not found" }, () => {
    for (const s of jobType.JOB_TYPE.settings) {
        if (s.eval === undefined) continue;
        const r = spawnSync(python, ["-c", "import sys; compile(sys.argv[1], 'eval', 'eval')", s.eval], { encoding: "utf8" });
        assert.equal(r.status, 0, `${s.key}: ${r.stderr}`);
    }
});

test("two long clips: chunked bakes, a merge per clip, renders that need only their clip's cache", () => {
    const { tasks } = jobType.compile(baseSettings({ clips: "walk, run", chunk_size: 200, render_chunk_size: 50 }), "shot-010");
    const byName = new Map(tasks.map((t) => [t.name, t]));
    assert.equal(byName.size, tasks.length, "task names are unique");
    for (const clip of ["walk", "run"]) {
        const bakes = tasks.filter((t) => t.name.startsWith(`bake-${clip}-`));
        assert.deepEqual(bakes.map((t) => t.name), [`bake-${clip}-1-200`, `bake-${clip}-201-400`, `bake-${clip}-401-450`]);
        for (const [i, t] of bakes.entries()) {
            assert.equal(t.type, "blender");
            assert.deepEqual(t.dependencies, [], "bakes run in parallel");
            assert.equal(t.commands.length, 1);
            const c = t.commands[0];
            assert.equal(c.name, "blender-render");
            assert.equal(c.parameters.exe, "{blender}");
            assert.equal(c.parameters.blendfile, "/farm/shot.blend");
            assert.equal(argAfter(c.parameters.args, "--scene"), "Scene");
            assert.equal(argAfter(c.parameters.args, "--python-exit-code"), "3");
            const p = pythonParams(argAfter(c.parameters.args, "--python-expr"));
            assert.deepEqual(p, {
                scene: "Scene", object: "Body", clip, start: [1, 201, 401][i], end: [200, 400, 450][i],
                path: `/farm/cache/${clip}.${[1, 201, 401][i]}-${[200, 400, 450][i]}.pc2`,
            });
        }
        const merge = byName.get(`merge-${clip}`);
        assert.ok(merge);
        assert.deepEqual(new Set(merge.dependencies), new Set(bakes), "the merge waits for every bake of its clip, only those");
        const mc = merge.commands[0];
        assert.equal(mc.name, "exec");
        assert.equal(mc.parameters.exe, "{blender}");
        assert.deepEqual(mc.parameters.args.slice(0, 4), ["--background", "--factory-startup", "--python-exit-code", "3"]);
        const mp = pythonParams(argAfter(mc.parameters.args, "--python-expr"));
        assert.deepEqual(mp.chunks, bakes.map((t) => pythonParams(argAfter(t.commands[0].parameters.args, "--python-expr")).path));
        assert.equal(mp.path, `/farm/cache/${clip}.pc2`);
        assert.equal(mp.keep_chunks, false);
        const renders = tasks.filter((t) => t.name.startsWith(`render-${clip}-`));
        assert.equal(renders.length, 9);
        for (const t of renders) {
            assert.equal(t.type, "blender");
            assert.deepEqual(t.dependencies, [merge], "a render needs only its clip's merged cache");
            const a = t.commands[0].parameters.args;
            const rp = pythonParams(argAfter(a, "--python-expr"));
            assert.deepEqual(rp, { scene: "Scene", object: "Body", clip, cache: `/farm/cache/${clip}.pc2`, start: 1 });
            assert.equal(argAfter(a, "--render-output"), `/farm/render/shot-010/${clip}/######`);
            assert.equal(argAfter(a, "--render-format"), "PNG");
            assert.match(argAfter(a, "--render-frame"), /^\d+\.\.\d+$/);
            assert.ok(a.indexOf("--python-expr") < a.indexOf("--render-frame"), "the cache is set up before rendering");
        }
        assert.equal(argAfter(renders[0].commands[0].parameters.args, "--render-frame"), "1..50");
        assert.equal(argAfter(renders[8].commands[0].parameters.args, "--render-frame"), "401..450");
        // Dependencies point backwards: tasks are added after what they wait for.
        for (const t of tasks) for (const d of t.dependencies) assert.ok(tasks.indexOf(d) < tasks.indexOf(t));
    }
    assert.equal(tasks.length, 2 * (3 + 1 + 9));
});

test("defaults: the current action, no renders when switched off, single frames", () => {
    let r = jobType.compile(baseSettings({ frames: "10-12", render: false }));
    assert.deepEqual(r.tasks.map((t) => t.name), ["bake-current-10-12", "merge-current"]);
    assert.equal(pythonParams(argAfter(r.tasks[0].commands[0].parameters.args, "--python-expr")).clip, "");
    r = jobType.compile(baseSettings({ frames: "7", chunk_size: 1, render_chunk_size: 1, clips: "Walk Cycle.001" }));
    assert.deepEqual(r.tasks.map((t) => t.name), ["bake-Walk_Cycle.001-7-7", "merge-Walk_Cycle.001", "render-Walk_Cycle.001-7"]);
    assert.equal(argAfter(r.tasks[2].commands[0].parameters.args, "--render-frame"), "7");
    r = jobType.compile(baseSettings({ frames: "1..4", keep_chunks: true }));
    assert.equal(pythonParams(argAfter(r.tasks[1].commands[0].parameters.args, "--python-expr")).keep_chunks, true);
});

test("clear errors for what cannot be baked", () => {
    assert.throws(() => jobType.compile(baseSettings({ frames: "1-10, 20-30" })), /one frame range "A-B"/);
    assert.throws(() => jobType.compile(baseSettings({ frames: "30-10" })), /ends before it starts/);
    assert.throws(() => jobType.compile(baseSettings({ object: "" })), /No object/);
    assert.throws(() => jobType.compile(baseSettings({ clips: "walk,walk" })), /listed twice/);
    assert.throws(() => jobType.compile(baseSettings({ clips: "a b,a/b" })), /share the file name/);
    assert.throws(() => jobType.compile(baseSettings({ chunk_size: 0 })), /at least 1/);
});

test("the Python of every task compiles", { skip: !python && "python3 not found" }, () => {
    const { tasks } = jobType.compile(baseSettings({ clips: "walk,\"quoted\" clip\\name", frames: "1-30" }));
    for (const t of tasks) {
        const args = t.commands[0].parameters.args;
        const expr = argAfter(args, "--python-expr");
        const r = spawnSync(python, ["-c", "import sys; compile(sys.argv[1], 'expr', 'exec')", expr], { encoding: "utf8" });
        assert.equal(r.status, 0, `${t.name}: ${r.stderr}`);
    }
});

test("bake chunks, merge them, render from the cache (Python against a stand-in bpy)", { skip: !python && "python3 not found" }, () => {
    const dir = tmpdir();
    const { tasks } = jobType.compile(baseSettings({ clips: "run", frames: "1-5", chunk_size: 2, cache_dir: dir }));
    const bakes = tasks.filter((t) => t.name.startsWith("bake-"));
    assert.equal(bakes.length, 3);
    // Any order: they are independent.
    for (const t of [bakes[2], bakes[0], bakes[1]]) {
        const r = runPython(argAfter(t.commands[0].parameters.args, "--python-expr"));
        assert.equal(r.status, 0, r.out);
        assert.match(r.out, /Sweep Deform: baked run frames/);
    }
    const chunk = readPc2(nodePath.join(dir, "run.3-4.pc2"));
    assert.deepEqual([chunk.magic, chunk.version, chunk.points, chunk.start, chunk.rate, chunk.samples],
                     ["POINTCACHE2\0", 1, 3, 3, 1, 2]);
    // Subdivision after Sweep Deform was switched off: 3 vertices, not 12; vertex v at frame f
    // is (v, f, 10 * clip).
    assert.deepEqual(chunk.data, [0, 3, 20, 1, 3, 20, 2, 3, 20, 0, 4, 20, 1, 4, 20, 2, 4, 20]);
    const merge = tasks.find((t) => t.name === "merge-run");
    let r = runPython(argAfter(merge.commands[0].parameters.args, "--python-expr"));
    assert.equal(r.status, 0, r.out);
    const all = readPc2(nodePath.join(dir, "run.pc2"));
    assert.deepEqual([all.points, all.start, all.rate, all.samples], [3, 1, 1, 5]);
    for (let f = 0; f < 5; ++f) assert.deepEqual(all.data.slice(9 * f, 9 * f + 3), [0, f + 1, 20]);
    assert.deepEqual(fs.readdirSync(dir).sort(), ["run.pc2"], "chunks removed, nothing left half-written");
    // Render setup: Sweep Deform and Armature off, a Mesh Cache first in the stack.
    const render = tasks.find((t) => t.name.startsWith("render-run-"));
    const check = "\nimport bpy\nm = bpy.data.objects['Body'].modifiers\n" +
        "print('STACK', [(x.name, x.type, x.show_render) for x in m])\n" +
        "c = m[0]\nprint('CACHE', c.cache_format, c.filepath, c.frame_start, c.time_mode, c.deform_mode)\n" +
        "print('ACTION', bpy.data.objects['Armature'].animation_data.action.name)\n";
    r = runPython(argAfter(render.commands[0].parameters.args, "--python-expr") + check);
    assert.equal(r.status, 0, r.out);
    assert.match(r.out, /STACK \[\('Sweep Deform Cache', 'MESH_CACHE', True\), \('Armature', 'ARMATURE', False\), \('Sweep Deform', 'NODES', False\), \('Subdivision', 'SUBSURF', True\)\]/);
    assert.ok(r.out.includes(`CACHE PC2 ${nodePath.join(dir, "run.pc2")} 1 FRAME OVERWRITE`), r.out);
    assert.match(r.out, /ACTION run/);
    // The render needs no extension.
    r = runPython(argAfter(render.commands[0].parameters.args, "--python-expr"), { SWEEP_DEFORM_NO_EXTENSION: "1" });
    assert.equal(r.status, 0, r.out);
    fs.rmSync(dir, { recursive: true });
});

test("bake and merge fail loudly", { skip: !python && "python3 not found" }, () => {
    const dir = tmpdir();
    const { tasks } = jobType.compile(baseSettings({ clips: "walk", frames: "1-4", chunk_size: 2, cache_dir: dir }));
    const bake = (i, env) => runPython(argAfter(tasks[i].commands[0].parameters.args, "--python-expr"), env);
    let r = bake(0, { SWEEP_DEFORM_NO_EXTENSION: "1" });
    assert.notEqual(r.status, 0);
    assert.match(r.out, /extension is not enabled on this worker/);
    r = bake(0, { SWEEP_DEFORM_STATE: "UNBOUND" });
    assert.notEqual(r.status, 0);
    assert.match(r.out, /is not bound/);
    assert.equal(bake(0).status, 0);
    // The second chunk is missing: the merge refuses.
    const merge = tasks.find((t) => t.name === "merge-walk");
    r = runPython(argAfter(merge.commands[0].parameters.args, "--python-expr"));
    assert.notEqual(r.status, 0);
    assert.match(r.out, /No such file/);
    // A chunk of another clip length in its place: the frames do not follow on.
    const other = jobType.compile(baseSettings({ clips: "walk", frames: "5-6", chunk_size: 2, cache_dir: dir })).tasks[0];
    assert.equal(runPython(argAfter(other.commands[0].parameters.args, "--python-expr")).status, 0);
    fs.renameSync(nodePath.join(dir, "walk.5-6.pc2"), nodePath.join(dir, "walk.3-4.pc2"));
    r = runPython(argAfter(merge.commands[0].parameters.args, "--python-expr"));
    assert.notEqual(r.status, 0);
    assert.match(r.out, /starts at frame 5, expected 3/);
    assert.ok(!fs.existsSync(nodePath.join(dir, "walk.pc2")), "no merged cache from a failed merge");
    assert.deepEqual(fs.readdirSync(dir).filter((f) => f.endsWith(".part")), [], "no half-written file left");
    fs.rmSync(dir, { recursive: true });
});
