# SPDX-License-Identifier: GPL-3.0-or-later
"""Issue 14's criteria for plain Sweep Deform on one test of the shared instrument (skineval),
against LBS and DQS of the same run: what scripts/quality_report.py tabulates and
scripts/quality_compare.py compares between two runs. Plain Python, no Blender."""

VOLUME_TESTS = {"elbow_flex_90", "elbow_flex_120", "elbow_flex_150", "knee_flex_90", "knee_flex_135",
                "hip_flex_90", "spine_bend_45"}
CREASE_PREFIXES = ("spine_bend", "hip_", "shoulder_", "forearm_twist")


def get(rec, *path):
    for p in path:
        if not isinstance(rec, dict) or rec.get(p) is None:
            return None
        rec = rec[p]
    return rec


def criteria(name, sweep, lbs, dqs):
    """The issue's criteria for plain Sweep Deform on one test: a list of (what, ok, detail)."""
    out = []
    p = [get(r, "selfint", "pose", "pairs") for r in (sweep, lbs, dqs)]
    if None not in p:
        bound = min(p[1], p[2])
        out.append(("pairs", p[0] <= bound, f"{p[0]} vs ≤{bound}"))
    if name.startswith(CREASE_PREFIXES):
        c = [get(r, "crease", "crease_new_deg_p999") for r in (sweep, dqs)]
        if None not in c:
            out.append(("crease", c[0] <= c[1] + 10, f"{c[0]:.0f}° vs ≤{c[1] + 10:.0f}°"))
    if name in VOLUME_TESTS:
        v = get(sweep, "volume", "dV_region_pct")
        if v is not None:
            out.append(("volume", abs(v) <= 1.0, f"{v:+.2f} %"))
    x = [get(r, "cross_section", "min_ratio") for r in (sweep, dqs)]
    if None not in x:
        bound = 0.9 if x[1] >= 0.9 else x[1]
        out.append(("section", x[0] >= bound - 1e-9, f"{x[0]:.2f} vs ≥{bound:.2f}"))
    r = [get(rec, "axis_distance_ratio", "max") for rec in (sweep, dqs)]
    if None not in r:
        out.append(("r_max", r[0] <= r[1] + 1e-9, f"{r[0]:.2f} vs ≤{r[1]:.2f}"))
    return out
