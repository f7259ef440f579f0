# SPDX-License-Identifier: GPL-3.0-or-later
"""What a change did to plain Sweep Deform, test by test: two runs of scripts/quality side by side,
the criteria of issue 14 each test won and lost, and every test whose figures moved.

    python3 scripts/quality_compare.py BEFORE AFTER [--use 4.3] [--all]

BEFORE and AFTER are scripts/quality --out directories (Sweep measured in each; LBS and DQS, which
do not depend on our code, taken from AFTER where it has them, else from BEFORE). A change is tried
in minutes so: `scripts/quality --use 4.3 --methods lbs,dqs,sweep --no-render --out out/before`
once, then `--methods sweep --no-render --out out/after` per change. Plain Python, no Blender.
"""

import argparse
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from quality_criteria import criteria, get  # noqa: E402  (beside this script)

#: The figures a row shows: (label, path in the instrument's record, format).
FIGURES = (("pairs", ("selfint", "pose", "pairs"), "{:.0f}"),
           ("crease", ("crease", "crease_new_deg_p999"), "{:.0f}°"),
           ("volume", ("volume", "dV_region_pct"), "{:+.2f} %"),
           ("section", ("cross_section", "min_ratio"), "{:.3f}"),
           ("r_max", ("axis_distance_ratio", "max"), "{:.4f}"))


def load(run, use, body, method):
    path = os.path.join(run, use, body, method + ".json")
    if not os.path.isfile(path):
        return None
    with open(path) as f:
        return json.load(f).get("tests", {})


def compare(before, after, use, show_all=False):
    """Lines of the report, and the misses per criterion before and after."""
    lines, misses = [], {"before": {}, "after": {}}
    bodies = sorted(b for b in os.listdir(os.path.join(after, use))
                    if os.path.isfile(os.path.join(after, use, b, "sweep.json")))
    for body in bodies:
        new, old = load(after, use, body, "sweep"), load(before, use, body, "sweep")
        lbs = load(after, use, body, "lbs") or load(before, use, body, "lbs")
        dqs = load(after, use, body, "dqs") or load(before, use, body, "dqs")
        if old is None or lbs is None or dqs is None:
            lines.append(f"{body}: not in both runs with LBS and DQS, skipped")
            continue
        for test, rec in new.items():
            if rec.get("status") != "ok" or (old.get(test) or {}).get("status") != "ok" \
                    or test not in lbs or test not in dqs:
                continue
            verdicts = {}
            for when, sweep in (("before", old[test]), ("after", rec)):
                verdicts[when] = {what for what, ok, _ in criteria(test, sweep, lbs[test], dqs[test]) if not ok}
                for what in verdicts[when]:
                    misses[when][what] = misses[when].get(what, 0) + 1
            # As printed: a move below the last digit shown is no move.
            moved = [(label, fmt(form, get(old[test], *path)), fmt(form, get(rec, *path)))
                     for label, path, form in FIGURES]
            changed = any(a != b for _, a, b in moved)
            if not changed and not show_all:
                continue
            won, lost = sorted(verdicts["before"] - verdicts["after"]), sorted(verdicts["after"] - verdicts["before"])
            figures = ", ".join(f"{label} {a} → {b}" if a != b else f"{label} {b}" for label, a, b in moved)
            verdict = (f"  WON {', '.join(won)}" if won else "") + (f"  LOST {', '.join(lost)}" if lost else "")
            lines.append(f"{body} {test}: {figures}{verdict}")
    for when in ("before", "after"):
        lines.append(f"misses {when}: " + (", ".join(f"{k} {v}" for k, v in sorted(misses[when].items())) or "none"))
    return lines, misses


def fmt(form, x):
    return "–" if x is None else form.format(x)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("before")
    p.add_argument("after")
    p.add_argument("--use", default="4.3", help="the Blender whose results to compare (default 4.3)")
    p.add_argument("--all", action="store_true", help="also the tests whose figures did not move")
    args = p.parse_args(argv)
    for run in (args.before, args.after):
        if not os.path.isdir(os.path.join(run, args.use)):
            p.error(f"{run}: no Blender {args.use} results (a scripts/quality --out directory?)")
    lines, _ = compare(args.before, args.after, args.use, args.all)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
