"""The worst vertices of a test's skin-to-bone distance ratio (r_max), for one or two methods of
the same body and test, from the files `scripts/quality --vertices` writes beside the instrument's
JSON (out/quality/<blender>/<body>/<method>.json.<test>.npz, scripts/skineval_vertices.py):

  scripts/blender --use 4.3 --exec python3 scripts/quality_vertices.py SWEEP.npz [DQS.npz] [--top N]

For the first file: r_max, then its N worst vertices (index, r, rest distance, the nearest rest
segment's index, the rest position); with a second file of another method, that method's r at the
same vertices beside them. The instrument leaves out vertices nearer their bone than a quarter of
the median distance; so does this.
"""
import argparse

import numpy as np


def ratios(z):
    d0, d1 = z["d0"], z["d1"]
    ok = d0 > 0.25 * np.median(d0)
    return np.where(ok, d1 / np.where(d0 > 0, d0, 1.0), np.nan)


def main():
    p = argparse.ArgumentParser(prog="quality_vertices.py")
    p.add_argument("first")
    p.add_argument("second", nargs="?")
    p.add_argument("--top", type=int, default=12)
    a = p.parse_args()
    z = np.load(a.first)
    r = ratios(z)
    other = None
    if a.second:
        w = np.load(a.second)
        if not np.array_equal(w["vertex"], z["vertex"]):
            raise SystemExit("quality_vertices.py: the two files hold different vertices (another body or test?)")
        other = ratios(w)
    head = "%s: r_max %.4f" % (a.first, np.nanmax(r))
    print(head + ("; %s: %.4f" % (a.second, np.nanmax(other)) if a.second else ""))
    for i in np.argsort(-np.nan_to_num(r, nan=-1.0))[: a.top]:
        line = "  v%-7d r %.4f  d0 %.4f  segment %d  rest (%.3f, %.3f, %.3f)" % (
            z["vertex"][i], r[i], z["d0"][i], z["seg0"][i], *z["rest"][i])
        if other is not None:
            line += "  | other r %.4f" % other[i]
        print(line)


if __name__ == "__main__":
    main()
