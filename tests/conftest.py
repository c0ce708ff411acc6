"""Shared fixtures and markers.

Tests that need Blender (the ``bpy`` module) carry the ``blender`` marker; they
run in-process with the bpy wheel and, through ``tests/blender_runner.py``, under
``blender -b`` where a Blender binary exists.
"""

import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)


def pytest_unconfigure(config):
    """End the run with its own exit status where this Blender would crash at exit (4.2 to 4.4.2, see
    ``blender_support``): the result is already reported, only the interpreter's teardown is skipped."""
    bpy = sys.modules.get("bpy")
    if bpy is None:
        return
    from blender_support import exit_crashes

    if exit_crashes(bpy):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(getattr(config, "_cp_stylize_status", 0))


def pytest_sessionfinish(session, exitstatus):
    session.config._cp_stylize_status = int(exitstatus)
