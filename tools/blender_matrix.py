"""Run the tests in every kind of Blender cp_stylize supports, with one extension zip built here.

    python tools/blender_matrix.py                # every entry; prints a table of pass counts
    python tools/blender_matrix.py --only 4.2 window --zip dist/cp_stylize-0.1.0-linux_x64.zip

Entries (the oldest and newest Blender, the real binary in the background and in a window):

=========  ==============================================  ==========================================
name       Blender                                         what runs
=========  ==============================================  ==========================================
5.0        bpy 5.0.1, Python 3.11 (requirements.txt)       the build tests, with the matrix's zip
4.2        bpy 4.2.23 LTS, Python 3.11, NumPy 1.24         the suite without its slow runs (-m "not slow")
4.5        bpy 4.5.15 LTS, Python 3.11, NumPy 1.26         the Blender tests
5.3        bpy 5.3.0, Python 3.13, NumPy 2.2 (chroot)      the suite without its slow runs
binary     Debian's Blender 4.3.2 binary, background        the Blender tests (tests/blender_runner.py)
window     the same binary in a window on a virtual screen  the window tests (tests/gui)
=========  ==============================================  ==========================================

(bpy 5.0.1 runs its whole suite with the README's test command; the slow runs,
the reference scheme's, the benchmark's and the looks measured on whole
pictures, run there only.)  The bpy
module entries get virtual environments under ``.matrix/`` (Python 3.11; bpy,
NumPy as that Blender bundles it, and SciPy, xatlas, libigl, pytest and
pytest-xdist pinned as in ``requirements.txt``); the chroot entries use
``tools/real_blender.sh`` (needs root; the bpy entry there adds libigl and
pytest-xdist to the chroot's own NumPy, SciPy and pytest).  The module entries
run their tests on two processes, a file each at a time, as the README's
command does.  Every entry tests the same linux-x64 zip (``--zip``, else built
first with ``tools/build_extension.py``): its tests install it with Blender's
own installer and stylize an image-textured and a procedural object.
Screenshots of the window tests go to ``.matrix/screenshots``.  Each entry
prints the free disk space before it starts; ``--clean`` removes a module
entry's virtual environment once it has run (pip's cache keeps the wheels, so
a later run installs them again without downloading), which keeps the matrix
within about 3 GB of disk beyond the chroot.  The exit status is non-zero if
any entry fails.
"""

import argparse
import os
import re
import shlex
import shutil
import subprocess
import sys
import time

from build_extension import pinned_versions

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REAL_BLENDER = os.path.join(ROOT, "tools", "real_blender.sh")
WORK = os.path.join(ROOT, ".matrix")

#: name: (description, bpy version, NumPy pin, where, pytest arguments)
ENTRIES = {
    "5.0": ("bpy 5.0.1, Python 3.11, NumPy 1.26 (requirements.txt)", None, None, "main",
            ["tests/blender/test_build.py"]),
    "4.2": ("bpy 4.2.23 LTS, Python 3.11, NumPy 1.24", "4.2.23", "1.24.3", "venv", ["-m", "not slow", "tests"]),
    "4.5": ("bpy 4.5.15 LTS, Python 3.11, NumPy 1.26", "4.5.15", "1.26.4", "venv", ["tests/blender"]),
    "5.3": ("bpy 5.3.0, Python 3.13, NumPy 2.2 (Debian 13 chroot)", "5.3.0", None, "chroot",
            ["-m", "not slow", "tests"]),
    "binary": ("Blender 4.3.2 binary (Debian 13), background", None, None, "binary", ["tests/blender"]),
    "window": ("Blender 4.3.2 binary in a window (Xvfb)", None, None, "window", ["tests/gui"]),
}


def run(cmd, *, env=None, log=None):
    print("$", " ".join(cmd), flush=True)
    proc = subprocess.run(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if log:
        with open(log, "w", encoding="utf-8") as fh:
            fh.write(proc.stdout)
    return proc


def must(cmd, **kwargs):
    proc = run(cmd, **kwargs)
    if proc.returncode != 0:
        sys.exit(f"blender_matrix: {' '.join(cmd)} failed:\n{proc.stdout[-4000:]}")
    return proc


#: The test runner's packages, pinned as in requirements.txt: pytest, and pytest-xdist (with execnet) for the
#: module entries' two processes (:data:`PARALLEL`).
RUNNER = ("pytest", "pytest-xdist", "execnet")
#: How the module entries run their tests: on two processes, a file each at a time, as the README's command
#: does (the binary's entries run inside one Blender).
PARALLEL = ["-n", "2", "--dist", "loadfile"]


def requirements(bpy, numpy):
    shared = pinned_versions(["scipy", "xatlas", "libigl", *RUNNER])
    reqs = [f"bpy=={bpy}"] + [f"{name}=={shared[name]}" for name in ("scipy", "xatlas", "libigl", *RUNNER)]
    return reqs + ([f"numpy=={numpy}"] if numpy else [])


def venv(name, bpy, numpy):
    """A Python 3.11 virtual environment with that bpy module; returns its python."""
    path = os.path.join(WORK, f"bpy-{bpy}")
    python = os.path.join(path, "bin", "python")
    if not os.path.exists(python):
        must([sys.executable, "-m", "venv", path])
    must([python, "-m", "pip", "install", "--quiet", "--disable-pip-version-check", *requirements(bpy, numpy)])
    return python


def summary(output):
    """Counts of pytest's last summary line: ``{'passed': 85, ...}`` (empty if there is none)."""
    lines = [l for l in output.splitlines() if re.search(r"\b(passed|failed|error|errors)\b.* in [\d.]+s", l)]
    if not lines:
        return {}
    return {kind: int(n) for n, kind in re.findall(r"(\d+) (passed|failed|errors?|skipped|xfailed)", lines[-1])}


def free_space():
    """Free disk space where the matrix works, as text (``12.3 GiB free``)."""
    return f"{shutil.disk_usage(WORK).free / 2**30:.1f} GiB free"


def run_entry(name, zip_path, clean=False):
    description, bpy, numpy, where, tests = ENTRIES[name]
    print(f"== {name}: {description} ({free_space()} in {WORK})", flush=True)
    env = dict(os.environ, CP_STYLIZE_ZIP=os.path.relpath(zip_path, ROOT),
               CP_STYLIZE_SCREENSHOTS=os.path.relpath(os.path.join(WORK, "screenshots"), ROOT))
    pytest_args = ["-q", "-p", "no:cacheprovider", *tests]
    log = os.path.join(WORK, f"{name}.log")
    if where == "main":   # the README's environment, whose whole suite runs on its own
        cmd = [sys.executable, "-m", "pytest", *pytest_args]
    elif where == "venv":
        cmd = [venv(name, bpy, numpy), "-m", "pytest", *PARALLEL, *pytest_args]
    else:
        must([REAL_BLENDER, "setup"])
        inside = ["env", f"CP_STYLIZE_ZIP={env['CP_STYLIZE_ZIP']}",
                  f"CP_STYLIZE_SCREENSHOTS={env['CP_STYLIZE_SCREENSHOTS']}"]
        if where == "chroot":
            # the chroot's own NumPy and SciPy (Debian's), with bpy and the mesh filters' libigl
            must([REAL_BLENDER, "venv", f"bpy-{bpy}", *[r for r in requirements(bpy, numpy)
                                                     if r.startswith(("bpy==", "libigl==", "pytest-xdist==",
                                                                      "execnet=="))]])
            cmd = [REAL_BLENDER, "run", *inside, f"/opt/bpy-{bpy}/bin/python", "-m", "pytest", *PARALLEL,
                   *pytest_args]
        elif where == "binary":
            cmd = [REAL_BLENDER, "run", *inside, "blender", "-b", "--factory-startup", "--python-exit-code", "1",
                   "--python", "tests/blender_runner.py", "--", *pytest_args]
        else:
            cmd = [REAL_BLENDER, "run", "--gui", *inside, "python3", "-m", "pytest", "-s", *pytest_args]
    start = time.perf_counter()
    proc = run(cmd, env=env, log=log)
    counts = summary(proc.stdout)
    ok = proc.returncode == 0 and counts.get("passed", 0) > 0 and not counts.get("failed") \
        and not counts.get("error") and not counts.get("errors")
    if clean and where == "venv":
        shutil.rmtree(os.path.join(WORK, f"bpy-{bpy}"), ignore_errors=True)
    tail = "\n".join(proc.stdout.splitlines()[-15:])
    print(tail, flush=True)
    return {"name": name, "blender": description, "tests": shlex.join(tests), "ok": ok, "counts": counts,
            "seconds": time.perf_counter() - start, "exit": proc.returncode, "log": log}


def table(results):
    rows = ["| Blender | ran | result | time |", "|---|---|---|---|"]
    for r in results:
        counts = ", ".join(f"{n} {k}" for k, n in r["counts"].items()) or f"no summary (exit {r['exit']})"
        rows.append(f"| {r['blender']} | `{r['tests']}` | {'PASS' if r['ok'] else 'FAIL'}: {counts} "
                    f"| {r['seconds'] / 60:.1f} min |")
    return "\n".join(rows)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", nargs="+", choices=list(ENTRIES), help="entries to run (default: all)")
    parser.add_argument("--zip", help="the linux-x64 extension zip to test (default: build one)")
    parser.add_argument("--clean", action="store_true",
                        help="remove each module entry's virtual environment once it has run")
    args = parser.parse_args(argv)
    os.makedirs(WORK, exist_ok=True)
    zip_path = args.zip
    if not zip_path:
        out = os.path.join(WORK, "dist")
        must([sys.executable, os.path.join(ROOT, "tools", "build_extension.py"), "--out", out,
              "--platforms", "linux-x64"])
        zip_path = next(os.path.join(out, f) for f in os.listdir(out) if f.endswith("-linux_x64.zip"))
    zip_path = os.path.abspath(zip_path)
    if os.path.commonpath([zip_path, ROOT]) != ROOT:   # the chroot sees only the checkout
        shutil.copy2(zip_path, WORK)
        zip_path = os.path.join(WORK, os.path.basename(zip_path))
    results = [run_entry(name, zip_path, args.clean) for name in (args.only or ENTRIES)]
    print("\n" + table(results))
    for r in results:
        if not r["ok"]:
            print(f"FAILED: {r['blender']}; log: {r['log']}")
    return 0 if all(r["ok"] for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
