#!/usr/bin/env bash
# Runs the command-line tool on the host (it cannot run inside Blender's Debian root) and leaves
# its outputs for test_cli_matches.py: the MakeHuman character of ../shared/data deformed by a
# CMU clip, with the poses it used.
#
#   tests/blender/cli_outputs.sh BUILD_DIR OUT_DIR
#
# Writes OUT_DIR/{bones.txt, run.poses, run.pc2, run.log}, or OUT_DIR/skipped.txt saying why
# nothing was written (the tool not built, or ../shared/data missing). Exit code 0 either way
# unless the tool itself fails.
set -euo pipefail
build="$1" out="$2"
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd -P)"
data="$repo/../shared/data"
tool="$build/native/tools/cli/sweepdeform"
mkdir -p "$out"
skip() { echo "$1" >"$out/skipped.txt"; exit 0; }
[[ -x "$tool" ]] || skip "the command-line tool is not built ($tool missing)"
[[ -f "$data/humans/mh_male_game_engine.glb" && -f "$data/mocap/cmu_09_11_run.bvh" ]] ||
  skip "../shared/data (mh_male_game_engine.glb, cmu_09_11_run.bvh) missing"
"$tool" "$data/humans/mh_male_game_engine.glb" --list-bones >"$out/bones.txt"
"$tool" "$data/humans/mh_male_game_engine.glb" "$data/mocap/cmu_09_11_run.bvh" \
  --frames 0:165:55 -o "$out/run.pc2" --write-poses "$out/run.poses" >"$out/run.log" 2>&1 ||
  { cat "$out/run.log" >&2; exit 1; }
