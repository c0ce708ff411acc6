"""Markers for tests that need an optional dependency: without it they skip, saying why."""

import importlib.util

import pytest


def installed(module):
    """Whether ``module`` can be imported here: found, not imported (as cp_stylize.atlas decides about xatlas;
    importing setuptools after bpy, for one, fails)."""
    return importlib.util.find_spec(module) is not None


#: xatlas is optional (the add-on's zips ship it where it has wheels); without it, charts make new UV maps.
needs_xatlas = pytest.mark.skipif(not installed("xatlas"), reason="xatlas is not installed (pip install xatlas)")
