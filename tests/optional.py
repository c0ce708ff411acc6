"""Markers for tests that need an optional dependency: without it they skip, saying why."""

import pytest


def installed(module):
    """Whether ``module`` imports here."""
    try:
        __import__(module)
    except ImportError:
        return False
    return True


#: xatlas is optional (the add-on's zips ship it where it has wheels); without it, charts make new UV maps.
needs_xatlas = pytest.mark.skipif(not installed("xatlas"), reason="xatlas is not installed (pip install xatlas)")
