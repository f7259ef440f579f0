#!/usr/bin/env bash
# Runs the Blender tests in one Blender version: builds the extension zip if asked, installs it
# into a scratch user directory and runs pytest inside Blender.
#
#   tests/blender/run_tests.sh 4.3|5.2 [--build DIR] [--no-build] [pytest args...]
#
# --build DIR: the CMake build directory (default: build); its addon_package target is built
# first unless --no-build is given (then the zip already there is tested).
# Exit code: pytest's (0 all passed, 1 failures, ...), 2 when the zip cannot be built.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd -P)"
repo="$(cd "$here/../.." && pwd -P)"
[[ $# -ge 1 ]] || { echo "usage: $0 4.3|5.2 [--build DIR] [pytest args...]" >&2; exit 2; }
use="$1"; shift
build="$repo/build"
no_build=0
while [[ $# -gt 0 ]]; do
  case "$1" in
    --build) build="$(cd "$2" && pwd -P)"; shift 2 ;;
    --no-build) no_build=1; shift ;;
    *) break ;;
  esac
done
if [[ $no_build -eq 0 ]]; then
  if ! log="$(cmake --build "$build" --target addon_package 2>&1)"; then
    echo "$log" >&2
    echo "run_tests.sh: building the addon_package target failed" >&2
    exit 2
  fi
fi
zip=("$build"/sweep_deform-*.zip)
scratch="$(mktemp -d "${TMPDIR:-/tmp}/sweepdeform-blender-$use.XXXXXX")"
trap 'rm -rf "$scratch"' EXIT
export BLENDER_USER_RESOURCES="$scratch/user"
export SWEEPDEFORM_TEST_TMP="$scratch/tmp"
mkdir -p "$BLENDER_USER_RESOURCES" "$SWEEPDEFORM_TEST_TMP"
# The command-line tool runs here, on the host; test_cli_matches.py compares inside Blender.
export SWEEPDEFORM_CLI_OUTPUT="$scratch/cli"
"$here/cli_outputs.sh" "$build" "$SWEEPDEFORM_CLI_OUTPUT"
cd "$repo"
exec_rc=0
"$repo/scripts/blender" --use "$use" -b --factory-startup --python-exit-code 1 \
  --python "$here/run.py" -- --zip "${zip[0]}" "$@" || exec_rc=$?
exit "$exec_rc"
