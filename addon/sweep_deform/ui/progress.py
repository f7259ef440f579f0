# SPDX-License-Identifier: GPL-3.0-or-later
"""Progress of a modal operator that works in steps: the window manager's progress bar, the
status-bar text and the operator's timer."""

import bpy


class ModalProgress:
    """The progress bar, status-bar text and timer of a modal operator that works in steps
    (binding, baking): `_show_progress` at each step, `_end` once, whatever the outcome."""

    _timer = None

    def _show_progress(self, context, value, text):
        context.window_manager.progress_update(value)
        if context.workspace is not None and not bpy.app.background:
            context.workspace.status_text_set(text)

    def _end(self, context):
        context.window_manager.progress_end()
        if context.workspace is not None and not bpy.app.background:
            context.workspace.status_text_set(None)
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None
