// SPDX-License-Identifier: GPL-3.0-or-later
//
// Flamenco 3 custom job type: bake Sweep Deform characters to PC2 point caches on many
// workers, then render from the caches alone.
//
// Install: copy this file into the `scripts/` directory beside the Flamenco Manager executable
// and restart the Manager; "Sweep Deform Bake" then appears in the Flamenco add-on's job
// types. See docs/pipeline.md.
//
// Tasks of a job, per clip (an Action of the character's armature):
//   bake-<clip>-<a>-<b>   (type "blender", one per chunk of frames, in parallel)
//       blender -b FILE.blend --python-expr BAKE: sets the clip, steps through the chunk's
//       frames (the extension's frame handler deforms the mesh) and writes the mesh's
//       evaluated positions as <cache_dir>/<clip>.<a>-<b>.pc2. Needs the extension.
//   merge-<clip>          (type "misc", depends on every bake task of the clip)
//       blender --factory-startup --python-expr MERGE: joins the chunks into
//       <cache_dir>/<clip>.pc2 (checks that they are contiguous and of one vertex count).
//   render-<clip>-<a>-<b> (type "blender", depends only on merge-<clip>)
//       blender -b FILE.blend --python-expr RENDER: switches the Sweep Deform and Armature
//       modifiers off, puts a Mesh Cache modifier reading <clip>.pc2 first in the stack and
//       renders the chunk. Needs only the cache: not the extension.
//
// The Python run inside Blender is in BAKE_PY, MERGE_PY and RENDER_PY below; each gets its
// parameters as one JSON string literal appended to the expression.

const JOB_TYPE = {
    label: "Sweep Deform Bake",
    description: "Bake Sweep Deform characters to PC2 caches in chunks, then render from the caches",
    settings: [
        // Settings for artists to determine:
        { key: "object", type: "string", required: true, eval: "C.object.name",
          evalInfo: { showLinkButton: true, description: "Active object" },
          description: "The mesh object with the Sweep Deform modifier (bound)" },
        { key: "clips", type: "string", required: false, default: "",
          description: "Actions of its armature to bake, comma-separated, one cache each; empty = the armature's current action" },
        { key: "frames", type: "string", required: true,
          eval: "f'{C.scene.frame_start}-{C.scene.frame_end}'",
          evalInfo: { showLinkButton: true, description: "Scene frame range" },
          description: "Frames to bake (and render), one range 'A-B'" },
        { key: "chunk_size", type: "int32", default: 200, propargs: { min: 1, max: 100000 }, visible: "submission",
          description: "Frames baked by one task" },
        { key: "cache_dir", type: "string", subtype: "dir_path", required: true, visible: "submission",
          eval: "str(Path(bpy.path.abspath('//'), 'sweep_deform_cache', jobname))",
          description: "Directory of the PC2 caches (shared storage, seen by every worker)" },
        { key: "keep_chunks", type: "bool", default: false, visible: "submission",
          description: "Keep the per-chunk caches after merging" },
        { key: "render", type: "bool", default: true, visible: "submission",
          description: "Render every clip from its cache after baking" },
        { key: "render_chunk_size", type: "int32", default: 10, propargs: { min: 1, max: 100000 }, visible: "submission",
          description: "Frames rendered by one task" },
        { key: "render_output_root", type: "string", subtype: "dir_path", required: false, visible: "submission",
          eval: "str(Path(bpy.path.abspath('//'), 'render'))",
          description: "Base directory of the renders: <root>/<job>/<clip>/######" },

        // Automatically evaluated settings:
        { key: "blendfile", type: "string", required: true, description: "Path of the Blend file", visible: "web" },
        { key: "scene", type: "string", required: true, eval: "C.scene.name", visible: "web",
          description: "Name of the scene" },
        { key: "format", type: "string", required: true, eval: "C.scene.render.image_settings.file_format", visible: "web" },
        { key: "image_file_extension", type: "string", required: true, eval: "C.scene.render.file_extension", visible: "hidden",
          description: "File extension used when rendering images" },
    ]
};

// ---- Python run inside Blender ----------------------------------------------------------

// Bakes frames [start, end] of one clip into one PC2 file (object space, the mesh's own vertex
// order): the Sweep Deform modifier's output with the modifiers after it switched off.
const BAKE_PY = `
import array, json, os, struct, sys, bpy

def _sweep_deform_bake(p):
    scene = bpy.context.scene  # Blender was started with --scene
    if scene.name != p["scene"]:
        raise RuntimeError("scene %r is active, not %r" % (scene.name, p["scene"]))
    obj = bpy.data.objects.get(p["object"])
    if obj is None or obj.type != 'MESH':
        raise RuntimeError("no mesh object %r in %s" % (p["object"], bpy.data.filepath))
    if not hasattr(obj, "sweep_deform"):
        raise RuntimeError("the Sweep Deform extension is not enabled on this worker")
    sd = obj.sweep_deform
    if sd.state != 'BOUND' or sd.armature is None:
        raise RuntimeError("%r is not bound (state %s): bind it before baking" % (obj.name, sd.state))
    arm = sd.armature
    if p["clip"]:
        action = bpy.data.actions.get(p["clip"])
        if action is None:
            raise RuntimeError("no action %r" % p["clip"])
        if arm.animation_data is None:
            arm.animation_data_create()
        arm.animation_data.action = action
    # Evaluate the mesh up to the Sweep Deform modifier: later ones (subdivision, ...) would
    # change the vertex count the cache is for.
    after = False
    for md in obj.modifiers:
        if after:
            md.show_viewport = False
        if md.type == 'NODES' and md.node_group is not None and md.node_group.get("sweep_deform_group", 0) >= 1:
            after = True
    if not after:
        raise RuntimeError("%r has no Sweep Deform modifier" % obj.name)
    n = len(obj.data.vertices)
    frames = list(range(p["start"], p["end"] + 1))
    os.makedirs(os.path.dirname(p["path"]), exist_ok=True)
    tmp = p["path"] + ".part"
    co = array.array('f', bytes(12 * n))
    try:
        _sweep_deform_write(scene, obj, n, frames, p, tmp, co)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    os.replace(tmp, p["path"])
    print("Sweep Deform: baked %s frames %d-%d (%d vertices) to %s" % (p["clip"] or "current action", p["start"], p["end"], n, p["path"]))

def _sweep_deform_write(scene, obj, n, frames, p, tmp, co):
    with open(tmp, "wb") as f:
        f.write(struct.pack("<12siiffi", b"POINTCACHE2\\0", 1, n, float(p["start"]), 1.0, len(frames)))
        for frame in frames:
            scene.frame_set(frame)
            depsgraph = bpy.context.evaluated_depsgraph_get()
            evaluated = obj.evaluated_get(depsgraph)
            mesh = evaluated.to_mesh()
            if len(mesh.vertices) != n:
                raise RuntimeError("frame %d: %d vertices, not %d" % (frame, len(mesh.vertices), n))
            mesh.vertices.foreach_get("co", co)
            evaluated.to_mesh_clear()
            if sys.byteorder != "little":
                co.byteswap()
            f.write(co.tobytes())

_sweep_deform_bake(json.loads(`;

// Joins chunk caches into one; plain Python (runs in Blender's or any Python 3).
const MERGE_PY = `
import json, os, struct

def _sweep_deform_merge(p):
    tmp = p["path"] + ".part"
    try:
        points, start, samples = _sweep_deform_join(p, tmp)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    os.replace(tmp, p["path"])
    if not p["keep_chunks"]:
        for path in p["chunks"]:
            os.remove(path)
    print("Sweep Deform: merged %d chunks, %d frames from %g, into %s" % (len(p["chunks"]), samples, start, p["path"]))

def _sweep_deform_join(p, tmp):
    header = struct.Struct("<12siiffi")
    points = start = None
    samples = 0
    with open(tmp, "wb") as out:
        out.write(bytes(header.size))
        for path in p["chunks"]:
            with open(path, "rb") as f:
                magic, version, n, first, rate, count = header.unpack(f.read(header.size))
                if magic != b"POINTCACHE2\\0" or version != 1 or rate != 1.0:
                    raise RuntimeError("%s is not a Sweep Deform chunk cache" % path)
                if points is None:
                    points, start = n, first
                if n != points:
                    raise RuntimeError("%s has %d points, the first chunk %d" % (path, n, points))
                if first != start + samples:
                    raise RuntimeError("%s starts at frame %g, expected %g" % (path, first, start + samples))
                data = f.read()
                if len(data) != 12 * n * count:
                    raise RuntimeError("%s is truncated" % path)
                out.write(data)
                samples += count
        out.seek(0)
        out.write(header.pack(b"POINTCACHE2\\0", 1, points, start, 1.0, samples))
    return points, start, samples

_sweep_deform_merge(json.loads(`;

// Replaces the Sweep Deform (and Armature) deformation by a Mesh Cache modifier on the cache.
// Uses no part of the extension, so render workers need not have it.
const RENDER_PY = `
import json, bpy

def _sweep_deform_use_cache(p):
    obj = bpy.data.objects.get(p["object"])
    if obj is None or obj.type != 'MESH':
        raise RuntimeError("no mesh object %r in %s" % (p["object"], bpy.data.filepath))
    arm = None
    for md in obj.modifiers:
        sweep = md.type == 'NODES' and md.node_group is not None and md.node_group.get("sweep_deform_group", 0) >= 1
        if md.type == 'ARMATURE':
            arm = md.object
        if sweep or md.type == 'ARMATURE':
            md.show_viewport = md.show_render = False
    if p["clip"] and arm is not None:
        # Objects parented to the armature's bones follow the clip too.
        action = bpy.data.actions.get(p["clip"])
        if action is None:
            raise RuntimeError("no action %r" % p["clip"])
        if arm.animation_data is None:
            arm.animation_data_create()
        arm.animation_data.action = action
    md = obj.modifiers.new("Sweep Deform Cache", 'MESH_CACHE')
    md.cache_format = 'PC2'
    md.filepath = p["cache"]
    md.time_mode = 'FRAME'
    md.play_mode = 'SCENE'
    md.frame_start = p["start"]       # scene frame of the cache's first sample
    md.deform_mode = 'OVERWRITE'
    md.interpolation = 'LINEAR'
    index = len(obj.modifiers) - 1
    if hasattr(obj.modifiers, "move"):
        obj.modifiers.move(index, 0)
    else:
        with bpy.context.temp_override(object=obj, active_object=obj):
            bpy.ops.object.modifier_move_to_index(modifier=md.name, index=0)
    print("Sweep Deform: %r renders from %s" % (obj.name, p["cache"]))

_sweep_deform_use_cache(json.loads(`;

/// A Python expression: the code, then its parameters as a JSON string literal (which is a
/// valid Python string literal too) closed by the two parentheses the code left open.
function pythonCall(code, params) {
    return code + JSON.stringify(JSON.stringify(params)) + "))\n";
}

// ---- the job ------------------------------------------------------------------------------

/// "A-B" (or "A..B", or a single frame) -> [A, B]; anything else is refused: a PC2 cache holds
/// evenly spaced frames.
function frameRange(frames) {
    const m = /^\s*(-?\d+)\s*(?:(?:-|\.\.)\s*(-?\d+)\s*)?$/.exec(`${frames}`);
    if (!m) {
        throw `Sweep Deform Bake needs one frame range "A-B", not "${frames}"`;
    }
    const start = parseInt(m[1], 10);
    const end = m[2] === undefined ? start : parseInt(m[2], 10);
    if (end < start) {
        throw `Frame range "${frames}" ends before it starts`;
    }
    return [start, end];
}

/// A chunk from frameChunker ("A-B" or "A") -> [A, B].
function chunkRange(chunk) {
    return frameRange(chunk);
}

/// Clip names from the comma-separated setting; [""] = the current action.
function clipNames(clips) {
    const names = `${clips || ""}`.split(",").map((s) => s.trim()).filter((s) => s.length > 0);
    const seen = new Set();
    for (const n of names) {
        if (seen.has(n)) {
            throw `Clip "${n}" is listed twice`;
        }
        seen.add(n);
    }
    return names.length > 0 ? names : [""];
}

/// A file-name-safe version of a clip name ("" = "current").
function clipSlug(clip) {
    return clip === "" ? "current" : clip.replace(/[^A-Za-z0-9_.-]+/g, "_");
}

function blenderCommand(blendfile, args) {
    return author.Command("blender-render", {
        exe: "{blender}",
        exeArgs: "{blenderArgs}",
        argsBefore: [],
        blendfile: blendfile,
        args: args,
    });
}

function compileJob(job) {
    print("Sweep Deform Bake job submitted");
    print("job: ", job);
    const settings = job.settings;
    const [start, end] = frameRange(settings.frames);
    if (!settings.object) {
        throw "No object to bake (the 'object' setting is empty)";
    }
    if (!(settings.chunk_size >= 1) || !(settings.render_chunk_size >= 1 || !settings.render)) {
        throw "Chunk sizes must be at least 1";
    }
    const cacheDir = settings.cache_dir;
    const renderRoot = settings.render_output_root || path.join(path.dirname(settings.blendfile), "render");
    const clips = clipNames(settings.clips);
    const slugs = new Set();
    for (const clip of clips) {
        const slug = clipSlug(clip);
        if (slugs.has(slug)) {
            throw `Clips "${clip}" and another one share the file name "${slug}"`;
        }
        slugs.add(slug);
    }

    for (const clip of clips) {
        const slug = clipSlug(clip);
        const cache = path.join(cacheDir, `${slug}.pc2`);

        // Bake tasks, one per chunk of frames, independent of each other.
        const bakeTasks = [];
        const chunkFiles = [];
        for (const chunk of frameChunker(`${start}-${end}`, settings.chunk_size)) {
            const [a, b] = chunkRange(chunk);
            const chunkFile = path.join(cacheDir, `${slug}.${a}-${b}.pc2`);
            chunkFiles.push(chunkFile);
            const task = author.Task(`bake-${slug}-${a}-${b}`, "blender");
            task.addCommand(blenderCommand(settings.blendfile, [
                "--scene", settings.scene,
                "--python-exit-code", "3",
                "--python-expr", pythonCall(BAKE_PY, {
                    scene: settings.scene, object: settings.object, clip: clip,
                    start: a, end: b, path: chunkFile,
                }),
            ]));
            bakeTasks.push(task);
            job.addTask(task);
        }

        // Merge: after every bake task of the clip.
        const merge = author.Task(`merge-${slug}`, "misc");
        merge.addCommand(author.Command("exec", {
            exe: "{blender}",
            args: ["--background", "--factory-startup", "--python-exit-code", "3",
                   "--python-expr", pythonCall(MERGE_PY, {
                       chunks: chunkFiles, path: cache, keep_chunks: !!settings.keep_chunks,
                   })],
        }));
        for (const t of bakeTasks) {
            merge.addDependency(t);
        }
        job.addTask(merge);

        // Render tasks: need only this clip's cache.
        if (!settings.render) {
            continue;
        }
        const output = path.join(renderRoot, job.name || "sweep_deform", slug, "######");
        for (const chunk of frameChunker(`${start}-${end}`, settings.render_chunk_size)) {
            const task = author.Task(`render-${slug}-${chunk}`, "blender");
            task.addCommand(blenderCommand(settings.blendfile, [
                "--scene", settings.scene,
                "--python-exit-code", "3",
                "--python-expr", pythonCall(RENDER_PY, {
                    scene: settings.scene, object: settings.object, clip: clip, cache: cache, start: start,
                }),
                "--render-output", output,
                "--render-format", settings.format,
                "--render-frame", chunk.replaceAll("-", ".."), // Blender's frame range notation
            ]));
            task.addDependency(merge);
            job.addTask(task);
        }
    }
}
