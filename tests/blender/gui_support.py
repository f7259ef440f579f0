# SPDX-License-Identifier: GPL-3.0-or-later
"""For the scripts the tests run in a GUI Blender (helpers.run_gui_blender): the result they
print as ``RESULT {json}`` before exiting, and steps (run by timers) that report an exception
in the result instead of leaving the Blender hanging."""

import json
import os
import traceback

result = {}


def finish():
    print("RESULT " + json.dumps(result), flush=True)
    os._exit(0)


def guarded(fn):
    def run():
        try:
            return fn()
        except Exception:
            result["error"] = traceback.format_exc()
            finish()
    return run
