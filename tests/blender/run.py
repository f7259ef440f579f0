# SPDX-License-Identifier: GPL-3.0-or-later
"""Runs the Blender tests with pytest inside Blender (4.3 or 5.2).

    BLENDER_USER_RESOURCES=$(mktemp -d) scripts/blender --use 5.2 -b --factory-startup \
        --python-exit-code 1 --python tests/blender/run.py -- [--zip ZIP] [pytest args]

(tests/blender/run_tests.sh does all of that, and builds the zip.)

1. Installs the extension zip exactly as a user would (install.py), into
   $BLENDER_USER_RESOURCES, which must be a scratch directory: the roots' $HOME is shared.
2. Runs pytest on tests/blender (or the paths given); the exit code is pytest's.
"""

import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
# install.py, flexion.py, limb_volume.py: shared with the demo and scripts/render_*.py.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "scripts", "blender_support"))

import install  # noqa: E402


def _args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    zip_path, rest, i = install.default_zip(), [], 0
    while i < len(argv):
        if argv[i] == "--zip":
            zip_path = argv[i + 1]
            i += 2
        else:
            rest.append(argv[i])
            i += 1
    return zip_path, rest


def main():
    zip_path, pytest_args = _args()
    install.install(zip_path)
    import pytest
    paths = [a for a in pytest_args if not a.startswith("-") and os.path.exists(a.split("::")[0])]
    args = ["-p", "no:cacheprovider", "-o", "console_output_style=classic"] + ([] if paths else [HERE]) + pytest_args
    code = pytest.main(args)
    sys.stdout.flush()
    sys.exit(int(code))


main()
