"""Run the tests inside a Blender binary (4.2 or newer).

    blender -b --factory-startup --python-exit-code 1 --python tests/blender_runner.py -- [pytest arguments]

Blender's own Python needs pytest, scipy and xatlas: install them into it
(``<blender python> -m pip install -r requirements.txt`` without the bpy line),
or use a Blender that runs the system's Python (as Debian's does, see
``tools/real_blender.sh``), or point PYTHONPATH at a site-packages of the same
Python version and add ``--python-use-system-env`` (Blender ignores PYTHONPATH
without it).  Tests that start a fresh Blender use this same binary
(``blender -b --python-use-system-env``).
"""

import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    try:
        import pytest
    except ImportError:
        print("blender_runner: pytest is not importable from Blender's Python; see this file's docstring")
        return 2
    sys.path.insert(0, ROOT)
    os.chdir(ROOT)
    return pytest.main(["-c", os.path.join(ROOT, "pytest.ini"), "--rootdir", ROOT, *args])


if __name__ == "__main__":
    sys.exit(main())
