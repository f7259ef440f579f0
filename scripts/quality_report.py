"""Writes REPORT.md for a scripts/quality run (inside Blender, for its image I/O):

  blender -b --factory-startup --python scripts/quality_report.py -- OUT_DIR [--publish DOCS_DIR]

With --publish, also docs/quality.md: the same tables, and the pictures of the tests artists
look at first (PUBLISHED_TESTS) at half size in DOCS_DIR/images/quality/.

OUT_DIR/<blender version>/<character>/<method>.json are the instrument's results; this adds, per
character, the table of every test for LBS, DQS, Sweep and Sweep + effects, the criteria of
issue 14 for plain Sweep Deform against LBS and DQS of the same run, and one picture per test
with REST | LBS | DQS | Sweep | Sweep + effects side by side (JPEG next to the JSON files).
"""
import datetime
import json
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from quality_criteria import criteria, get  # noqa: E402  (beside this script)

METHODS = ["lbs", "dqs", "sweep", "sweep_fx"]
LABELS = {"lbs": "LBS", "dqs": "DQS", "sweep": "Sweep", "sweep_fx": "Sweep+fx"}
PUBLISHED_TESTS = ("shoulder_abd_160", "spine_bend_45", "forearm_twist_180", "elbow_flex_150", "knee_flex_135",
                   "hip_flex_90")


def fmt(x, nd=1, signed=False):
    if x is None:
        return "–"
    if isinstance(x, int):
        return str(x)
    return (f"{{:+.{nd}f}}" if signed else f"{{:.{nd}f}}").format(x)


def load_png(path):
    if not path or not os.path.isfile(path):
        return None
    img = bpy.data.images.load(path, check_existing=False)
    w, h = img.size
    px = np.empty(w * h * 4, np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(h, w, 4)


def side_by_side(paths, out_path, step=1):
    tiles = [load_png(p) for p in paths]
    tiles = [t[::step, ::step] if t is not None else None for t in tiles]
    first = next((t for t in tiles if t is not None), None)
    if first is None:
        return False
    h, w = first.shape[:2]
    grey = np.full((h, w, 4), 0.5, np.float32)
    grey[..., 3] = 1
    row = np.concatenate([t if t is not None and t.shape == first.shape else grey for t in tiles], axis=1)
    img = bpy.data.images.new("side_by_side", row.shape[1], row.shape[0])
    img.pixels.foreach_set(row.ravel())
    img.filepath_raw = out_path
    img.file_format = "JPEG"
    img.save()
    bpy.data.images.remove(img)
    return True


def character_section(out, use, stem, lines, totals, publish=None):
    d = os.path.join(out, use, stem)
    res = {}
    for m in METHODS:
        p = os.path.join(d, m + ".json")
        if os.path.isfile(p):
            with open(p) as f:
                res[m] = json.load(f)
    if not res:
        return
    any_res = next(iter(res.values()))
    mesh = any_res.get("mesh", {})
    lines.append(f"### {stem} (Blender {use}, {mesh.get('verts', '?')} vertices)\n")
    for m in METHODS:
        if m not in res:
            lines.append(f"- {LABELS[m]}: not measured (see `skipped.txt` or `{m}.log`).")
    rests = {m: get(r, "rest", "rest_shift_rel") for m, r in res.items()}
    lines.append("- rest shift / diagonal: " + ", ".join(
        f"{LABELS[m]} {v:.1e}" if v is not None else f"{LABELS[m]} –" for m, v in rests.items()))
    if rests.get("sweep") is not None:
        ok = rests["sweep"] <= 1e-6
        totals["rest"] = totals.get("rest", [0, 0])
        totals["rest"][0] += ok
        totals["rest"][1] += 1
    for m, r in res.items():
        for w in r.get("warnings", []):
            lines.append(f"- warning ({LABELS[m]}): {w}")
    lines.append("")
    head = ("| test | pairs L/D/S/S+fx | crease p99.9 ° L/D/S | ΔV region % L/D/S | min section L/D/S "
            "| r_max L/D/S | issue 14, plain Sweep |")
    lines += [head, "|" + "---|" * 7]
    tests = list(get(res.get("lbs") or any_res, "tests") or {})
    pictures = []
    for name in tests:
        recs = {m: get(r, "tests", name) for m, r in res.items()}
        if any(rec is None or rec.get("status") != "ok" for rec in recs.values()):
            why = "; ".join(f"{LABELS[m]}: {rec.get('status')} {rec.get('reason') or rec.get('error') or ''}"
                            for m, rec in recs.items() if rec and rec.get("status") != "ok")
            lines.append(f"| {name} | {why or 'missing'} | | | | | |")
            totals.setdefault("not measured", [0, 0])[1] += 1
            continue

        def row(path, nd=1, signed=False, ms=("lbs", "dqs", "sweep")):
            return " / ".join(fmt(get(recs.get(m), *path), nd, signed) for m in ms)
        crit = criteria(name, recs.get("sweep"), recs.get("lbs"), recs.get("dqs")) if "sweep" in recs else []
        for what, ok, _ in crit:
            t = totals.setdefault(what, [0, 0])
            t[0] += ok
            t[1] += 1
        verdict = "all met" if crit and all(ok for _, ok, _ in crit) else "; ".join(
            f"**{what}** {detail}" for what, ok, detail in crit if not ok)
        lines.append(f"| {name} | {row(('selfint', 'pose', 'pairs'), ms=METHODS)} "
                     f"| {row(('crease', 'crease_new_deg_p999'), 0)} "
                     f"| {row(('volume', 'dV_region_pct'), 2, True)} "
                     f"| {row(('cross_section', 'min_ratio'), 2)} "
                     f"| {row(('axis_distance_ratio', 'max'), 2)} | {verdict} |")
        pngs = [get(recs.get("lbs") or recs.get("sweep"), "png_rest")] + [get(recs.get(m), "png") for m in METHODS]
        jpg = os.path.join(d, "pictures", name + ".jpg")
        os.makedirs(os.path.dirname(jpg), exist_ok=True)
        if publish is not None:
            if name not in PUBLISHED_TESTS:
                continue
            jpg = os.path.join(publish, "images", "quality", f"{use}_{stem}_{name}.jpg")
            os.makedirs(os.path.dirname(jpg), exist_ok=True)
            if side_by_side(pngs, jpg, step=2):
                pictures.append((name, os.path.relpath(jpg, publish)))
        elif side_by_side(pngs, jpg):
            pictures.append((name, os.path.relpath(jpg, out)))
    lines.append("")
    if pictures:
        lines.append("REST | LBS | DQS | Sweep | Sweep + effects:\n")
        for name, rel in pictures:
            lines.append(f"**{name}**  \n![{stem} {name}]({rel})\n")


def write_report(out, path, publish=None):
    lines = [f"# Quality report — {datetime.date.today().isoformat()}\n",
             "Made by `scripts/quality` with the shared instrument (`../shared/skineval`). "
             "Columns: L = Armature modifier (LBS), D = Preserve Volume (DQS), S = Sweep Deform, "
             "S+fx = Sweep Deform with the anatomical effects. The last column checks issue 14's "
             "criteria for plain Sweep Deform against LBS and DQS of the same run.\n"]
    skipped = os.path.join(out, "skipped.txt")
    if os.path.isfile(skipped) and os.path.getsize(skipped):
        lines.append("Skipped:\n")
        lines += [f"- {s.strip()}" for s in open(skipped) if s.strip()]
        lines.append("")
    totals = {}
    body = []
    for use in sorted(x for x in os.listdir(out) if x[0].isdigit()):
        body.append(f"## Blender {use}\n")
        for stem in sorted(os.listdir(os.path.join(out, use))):
            if os.path.isdir(os.path.join(out, use, stem)):
                character_section(out, use, stem, body, totals, publish)
    missing = totals.pop("not measured", [0, 0])[1]
    lines.append("Criteria met by plain Sweep Deform (over every character and test): " + ", ".join(
        f"{k} {v[0]}/{v[1]}" for k, v in totals.items()) + "\n")
    if missing:
        # A test the instrument could not run (an error in one of the methods) is in no count
        # above: say so, or a broken run reads as a short one.
        lines.append(f"**{missing} character-tests were not measured** (an error in at least one method; "
                     "see the warnings and the rows below).\n")
    with open(path, "w") as f:
        f.write("\n".join(lines + body) + "\n")
    return totals


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    out = os.path.abspath(argv[0])
    totals = write_report(out, os.path.join(out, "REPORT.md"))
    with open(os.path.join(out, "criteria.json"), "w") as f:
        json.dump(totals, f, indent=1)
    if "--publish" in argv:
        docs = os.path.abspath(argv[argv.index("--publish") + 1])
        write_report(out, os.path.join(docs, "quality_report.md"), publish=docs)


main()
