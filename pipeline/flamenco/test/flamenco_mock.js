// SPDX-License-Identifier: GPL-3.0-or-later
//
// A small stand-in for the JavaScript environment Flamenco Manager 3 gives job compiler
// scripts (https://flamenco.blender.org/usage/job-types/ and the built-in
// simple_blender_render.js): the globals `author` (Task, Command), `print`, `path`,
// `frameChunker` and `formatTimestampLocal`, and a `job` with `settings` and `addTask()`.
// It records what a script authors so tests can check tasks, commands and dependencies.
"use strict";

const fs = require("node:fs");
const nodePath = require("node:path");
const vm = require("node:vm");

class AuthoredCommand {
    constructor(name, parameters) {
        if (typeof name !== "string" || name.length === 0) throw new Error("author.Command: no command name");
        if (parameters === null || typeof parameters !== "object") throw new Error("author.Command: parameters must be an object");
        this.name = name;
        // Flamenco stores parameters as JSON: keep a plain copy (and fail on what JSON cannot hold).
        this.parameters = JSON.parse(JSON.stringify(parameters));
    }
}

class AuthoredTask {
    constructor(name, type) {
        if (typeof name !== "string" || name.length === 0) throw new Error("author.Task: no task name");
        if (typeof type !== "string" || type.length === 0) throw new Error("author.Task: no task type");
        this.name = name;
        this.type = type;
        this.commands = [];
        this.dependencies = [];
    }
    addCommand(command) {
        if (!(command instanceof AuthoredCommand)) throw new Error(`task ${this.name}: addCommand() wants an author.Command`);
        this.commands.push(command);
    }
    addDependency(task) {
        if (!(task instanceof AuthoredTask)) throw new Error(`task ${this.name}: addDependency() wants an author.Task`);
        if (task === this) throw new Error(`task ${this.name} cannot depend on itself`);
        this.dependencies.push(task);
    }
}

/// Flamenco's frame range syntax: "1-10", "3, 5-10, 47", also Blender's "1..10".
function explodeFrames(frames) {
    const out = [];
    for (const part of `${frames}`.split(",")) {
        const p = part.trim();
        if (p === "") continue;
        const m = /^(-?\d+)\s*(?:(?:-|\.\.)\s*(-?\d+))?$/.exec(p);
        if (!m) throw new Error(`frameChunker: invalid frame range "${frames}"`);
        const a = parseInt(m[1], 10), b = m[2] === undefined ? a : parseInt(m[2], 10);
        for (let f = a; f <= b; ++f) out.push(f);
    }
    return out;
}

/// Consecutive runs as "a-b" (or "a"), comma-separated: Flamenco's chunk notation.
function compressFrames(frames) {
    const parts = [];
    let i = 0;
    while (i < frames.length) {
        let j = i;
        while (j + 1 < frames.length && frames[j + 1] === frames[j] + 1) ++j;
        parts.push(i === j ? `${frames[i]}` : `${frames[i]}-${frames[j]}`);
        i = j + 1;
    }
    return parts.join(",");
}

function frameChunker(frames, chunkSize) {
    if (!(chunkSize >= 1)) throw new Error(`frameChunker: chunk size ${chunkSize} < 1`);
    const all = explodeFrames(frames);
    const chunks = [];
    for (let i = 0; i < all.length; i += chunkSize) chunks.push(compressFrames(all.slice(i, i + chunkSize)));
    return chunks;
}

/// Loads a job compiler script into a fresh context with the mock globals.
function loadJobType(file) {
    const log = [];
    const sandbox = {
        author: {
            Task: (name, type) => new AuthoredTask(name, type),
            Command: (name, parameters) => new AuthoredCommand(name, parameters),
        },
        print: (...args) => log.push(args.map((a) => (typeof a === "string" ? a : JSON.stringify(a))).join(" ")),
        path: {
            join: (...parts) => nodePath.posix.join(...parts),
            dirname: (p) => nodePath.posix.dirname(p),
            basename: (p) => nodePath.posix.basename(p),
            stem: (p) => nodePath.posix.basename(p, nodePath.posix.extname(p)),
        },
        frameChunker,
        formatTimestampLocal: (d) => new Date(d).toISOString().replace(/[-:]/g, "").replace("T", "-").slice(0, 15),
    };
    const context = vm.createContext(sandbox);
    const code = fs.readFileSync(file, "utf8");
    vm.runInContext(`${code}\n;this.__exports = { JOB_TYPE, compileJob };`, context, { filename: file });
    const { JOB_TYPE, compileJob } = context.__exports;

    /// Runs compileJob() on a job with these settings; defaults from JOB_TYPE fill the rest,
    /// as the Manager does. Returns { tasks, log, settings }.
    function compile(settings, name = "test-job") {
        const full = {};
        for (const s of JOB_TYPE.settings) if (s.default !== undefined) full[s.key] = s.default;
        Object.assign(full, settings);
        const tasks = [];
        const job = {
            name,
            created: "2025-01-02T03:04:05Z",
            settings: full,
            metadata: {},
            addTask(task) {
                if (!(task instanceof AuthoredTask)) throw new Error("job.addTask() wants an author.Task");
                if (tasks.includes(task)) throw new Error(`task ${task.name} added twice`);
                tasks.push(task);
            },
        };
        compileJob(job);
        for (const t of tasks)
            for (const d of t.dependencies)
                if (!tasks.includes(d)) throw new Error(`task ${t.name} depends on ${d.name}, which is not in the job`);
        return { tasks, log, settings: full };
    }
    return { JOB_TYPE, compileJob, compile, log };
}

module.exports = { loadJobType, frameChunker, AuthoredTask, AuthoredCommand };
