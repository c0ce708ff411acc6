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
