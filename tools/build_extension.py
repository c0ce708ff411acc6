"""Build the shippable cp_stylize extension: one zip per platform, with SciPy and xatlas inside.

Usage (from any directory, with the Python that has the ``bpy`` module)::

    python tools/build_extension.py --out dist
    python tools/build_extension.py --out dist --platforms linux-x64 windows-x64
    python tools/build_extension.py --out dist --no-wheels

For each requested Blender platform the script

1. downloads the wheels of SciPy, xatlas and libigl (the versions pinned in
   ``requirements.txt``) for each Python Blender runs: cp311 (Blender 4.2 to
   5.0) and cp313 (5.1 and newer), with ``pip download --only-binary=:all:
   --no-deps``; pip's cache makes later runs cheap.  Blender installs the
   wheels that match its Python.  NumPy is never shipped: Blender brings its
   own (1.24 in 4.2 and 4.3, 1.26 in 4.4 to 5.0, 2.3 from 5.1 on), and the
   pinned SciPy (1.15) is the newest that loads with all of them;
2. copies the extension source (the files git tracks plus untracked files it
   does not ignore; without git, the tree minus virtual environments, build
   output and wheels) into a staging directory, puts the wheels into its
   ``wheels/`` and writes a ``blender_manifest.toml`` there that adds
   ``platforms = ["<platform>"]`` and ``wheels = ["./wheels/...", ...]`` to the
   committed manifest, which stays untouched;
3. builds ``<id>-<version>-<platform>.zip`` (the names ``--split-platforms``
   would give) from the staging copy with Blender's ``blender_ext.py build`` and
   checks it with ``blender_ext.py validate``.

Each platform is built from its own staging copy with its own manifest rather
than with ``--split-platforms``, so that every zip's manifest lists exactly the
wheels it holds and a platform may lack a wheel the others have.

Wheel platform tags, the newest each Blender platform accepts (pip also takes
older ones):

- ``linux-x64``: ``manylinux_2_28_x86_64`` down to ``manylinux2014_x86_64``
  (Blender 4.2+ needs glibc 2.28; SciPy 1.17 only publishes
  ``manylinux_2_27/2_28`` wheels, xatlas 0.0.11 ``manylinux2014``);
- ``windows-x64``: ``win_amd64``;
- ``macos-arm64``: ``macosx_12_0_arm64`` (SciPy 1.17 publishes no macOS 11 arm64
  wheel, so this zip needs macOS 12 while Blender itself runs on 11.2);
- ``macos-x64``: ``macosx_11_0_x86_64`` (Blender's own minimum, macOS 11.2).

SciPy and libigl are required: a platform without a wheel of a pinned version fails the
build.  xatlas is optional: where the pinned version has no wheel, that
platform's zip is built without it (the script says so) and the add-on falls
back to the mesh's own UVs.  Older xatlas releases are not used as a
substitute, so every zip that ships xatlas ships the tested version.

``--no-wheels`` builds a single zip without wheels, for a Blender whose Python
already has SciPy; it declares ``platforms`` only when ``--platforms`` is given.

``blender_ext.py`` is ``--blender-ext PATH``, else the one in the ``bpy``
module this Python imports
(``bpy.utils.system_resource('SCRIPTS')/addons_core/bl_pkg/cli/blender_ext.py``),
else the one of the Blender binary ``--blender PATH`` (default: ``blender`` on
the PATH), which is asked where its scripts are.  It runs with this Python.  The exit
status is non-zero, with the reason on stderr, when any step fails.
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MANIFEST = "blender_manifest.toml"
#: The Pythons of the Blender versions the extension supports: 3.11 (4.2 to 5.0), 3.13 (5.1 and newer).
PYTHON_VERSIONS = ("3.11", "3.13")
REQUIRED = ("scipy", "libigl")
OPTIONAL = ("xatlas",)
PIP_PLATFORMS = {
    "linux-x64": tuple(f"manylinux_2_{minor}_x86_64" for minor in range(28, 16, -1)) + ("manylinux2014_x86_64",),
    "windows-x64": ("win_amd64",),
    "macos-arm64": ("macosx_12_0_arm64",),
    "macos-x64": ("macosx_11_0_x86_64",),
}
NEVER_SHIPPED = ("numpy",)
FALLBACK_SKIP_TOP = {".git", ".venv", "venv", "wheels", "dist", "build", ".pytest_cache"}


class BuildError(Exception):
    pass


def log(message=""):
    print(message, flush=True)


def pinned_versions(names, path=os.path.join(ROOT, "requirements.txt")):
    """``{name: version}`` of the ``name==version`` lines of ``requirements.txt``."""
    try:
        with open(path, encoding="utf-8") as fh:
            lines = fh.read().splitlines()
    except OSError as ex:
        raise BuildError(f"cannot read the pinned versions: {ex}") from None
    pins = {}
    for line in lines:
        line = line.split("#", 1)[0].strip()
        match = re.fullmatch(r"([A-Za-z0-9_.-]+)\s*==\s*([^\s;]+)", line)
        if match:
            pins[match.group(1).lower().replace("_", "-")] = match.group(2)
    missing = [name for name in names if name not in pins]
    if missing:
        raise BuildError(f"{path} pins no version (name==version) for: {', '.join(missing)}")
    return {name: pins[name] for name in names}


def blender_ext_path(override=None, blender=None):
    """Path of Blender's blender_ext.py: ``override``, the bpy module's, or the ``blender`` binary's."""
    if override:
        path = os.path.abspath(override)
    else:
        try:
            import bpy
            scripts = bpy.utils.system_resource("SCRIPTS")
        except ImportError:
            scripts = _binary_scripts(blender or shutil.which("blender"))
        path = os.path.join(scripts, "addons_core", "bl_pkg", "cli", "blender_ext.py")
    if not os.path.isfile(path):
        raise BuildError(f"blender_ext.py is not at {path}")
    return path


def _binary_scripts(blender):
    """The scripts folder of a Blender binary."""
    if not blender:
        raise BuildError("cannot find blender_ext.py: this Python has no bpy module and there is no `blender` on the "
                         "PATH; install requirements.txt, or pass --blender PATH or --blender-ext PATH")
    code = "import bpy; print('SCRIPTS=' + bpy.utils.system_resource('SCRIPTS'))"
    proc = run([blender, "-b", "--factory-startup", "--python-expr", code], f"{blender} (asked for its scripts)")
    found = re.findall(r"^SCRIPTS=(.*)$", proc.stdout, re.MULTILINE)
    if not found:
        raise BuildError(f"{blender} did not say where its scripts are:\n{proc.stdout[-2000:]}")
    return found[-1]


def run(cmd, what):
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        output = (proc.stdout + proc.stderr).strip()
        raise BuildError(f"{what} failed (exit {proc.returncode}):\n{output[-4000:]}")
    return proc


def released_versions(package):
    """The versions of ``package`` the package index lists for any platform (empty if it cannot be reached)."""
    proc = subprocess.run([sys.executable, "-m", "pip", "index", "versions", "--disable-pip-version-check", package],
                          capture_output=True, text=True)
    match = re.search(r"^Available versions:(.*)$", proc.stdout, re.MULTILINE)
    return [v.strip() for v in match.group(1).split(",")] if proc.returncode == 0 and match else []


def download_wheel(package, version, platform, python, dest):
    """The path of the wheel of ``package==version`` for a Blender platform and Python, or None if there is none."""
    os.makedirs(dest, exist_ok=True)
    cmd = [sys.executable, "-m", "pip", "download", "--disable-pip-version-check",
           "--only-binary=:all:", "--no-deps", "--python-version", python, "--implementation", "cp"]
    for tag in PIP_PLATFORMS[platform]:
        cmd += ["--platform", tag]
    cmd += ["--dest", dest, f"{package}=={version}"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    output = (proc.stdout + proc.stderr).strip()
    if proc.returncode != 0:
        if "No matching distribution found" in output and version in released_versions(package):
            return None
        raise BuildError(f"pip download {package}=={version} for {platform}, Python {python} failed "
                         f"(exit {proc.returncode}; is the package index reachable?):\n{output[-4000:]}")
    prefix = re.sub(r"[-_.]+", "_", package).lower() + "-"
    tag = "-cp" + python.replace(".", "")
    wheels = [n for n in os.listdir(dest) if n.endswith(".whl") and n.lower().startswith(prefix)
              and (tag in n or "-abi3-" in n or "-py3-" in n)]
    if len(wheels) != 1:
        raise BuildError(f"pip download {package}=={version} for {platform}, Python {python} left "
                         f"{wheels or 'no wheel'} in {dest}")
    return os.path.join(dest, wheels[0])


def minimum_os(wheel):
    """The oldest OS version a wheel's platform tag allows (None for tags without one), for the report."""
    tag = os.path.splitext(os.path.basename(wheel))[0].split("-")[-1]
    glibc = [(int(a), int(b)) for a, b in re.findall(r"manylinux_(\d+)_(\d+)_", tag)]
    glibc += [(2, 17)] * ("manylinux2014" in tag) + [(2, 12)] * ("manylinux2010" in tag) + [(2, 5)] * ("manylinux1" in tag)
    if glibc:
        return "glibc %d.%d" % min(glibc)
    macos = [(int(a), int(b)) for a, b in re.findall(r"macosx_(\d+)_(\d+)_", tag)]
    if macos:
        return "macOS %d.%d" % min(macos)
    return None


def source_files(root):
    """Root-relative paths of the extension source: git's view of the tree, or a filtered walk."""
    try:
        proc = subprocess.run(["git", "-C", root, "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                              capture_output=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        proc = None
    if proc is not None and proc.returncode == 0:
        names = sorted({n for n in proc.stdout.decode("utf-8").split("\0") if n})
        return [n for n in names if os.path.isfile(os.path.join(root, n))]
    names = []
    for dirpath, dirnames, filenames in os.walk(root):
        skip = FALLBACK_SKIP_TOP if dirpath == root else set()
        dirnames[:] = sorted(d for d in dirnames if d not in skip and d != "__pycache__")
        for filename in sorted(filenames):
            if not filename.endswith((".zip", ".pyc", ".whl")):
                names.append(os.path.relpath(os.path.join(dirpath, filename), root))
    return names


def stage_source(root, files, dest):
    for rel in files:
        target = os.path.join(dest, rel)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copy2(os.path.join(root, rel), target)


def staged_manifest(text, platforms, wheels):
    """The committed manifest's text with top-level ``platforms`` and ``wheels`` keys added."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as ex:
        raise BuildError(f"{MANIFEST} is not valid TOML: {ex}") from None
    for key in ("platforms", "wheels"):
        if key in data:
            raise BuildError(f"{MANIFEST} already sets {key!r}; this script writes it into the staged copy, "
                             "so the committed manifest must not")
    keys = ""
    if platforms:
        keys += f"platforms = {json.dumps(list(platforms))}\n"
    if wheels:
        keys += "wheels = [\n" + "".join(f"  {json.dumps(w)},\n" for w in wheels) + "]\n"
    lines = text.splitlines(keepends=True)
    header = re.compile(r"^\s*\[\[?\s*[A-Za-z0-9_\-.\"' ]+\]\]?\s*(#.*)?$")
    at = next((i for i, line in enumerate(lines) if header.match(line)), len(lines))
    head = "".join(lines[:at])
    if head and not head.endswith("\n"):
        head += "\n"
    new = head + keys + ("\n" if at < len(lines) else "") + "".join(lines[at:])
    parsed = tomllib.loads(new)
    assert parsed.get("platforms", None) == (list(platforms) or None), parsed.get("platforms")
    assert parsed.get("wheels", None) == (list(wheels) or None), parsed.get("wheels")
    return new


def build_zip(blender_ext, source_dir, zip_path):
    run([sys.executable, blender_ext, "build", "--source-dir", source_dir, "--output-filepath", zip_path],
        f"blender_ext.py build of {os.path.basename(zip_path)}")
    if not os.path.isfile(zip_path):
        raise BuildError(f"blender_ext.py build reported success but wrote no {zip_path}")
    run([sys.executable, blender_ext, "validate", zip_path], f"blender_ext.py validate {os.path.basename(zip_path)}")


def build(out, platforms, *, wheels=True, blender_ext=None, blender=None, explicit_platforms=False):
    """Build and validate the zips; returns ``[(zip_path, platform or None, [wheel names], [notes])]``."""
    blender_ext = blender_ext_path(blender_ext, blender)
    with open(os.path.join(ROOT, MANIFEST), encoding="utf-8") as fh:
        manifest_text = fh.read()
    manifest = tomllib.loads(manifest_text)
    stem = f"{manifest['id']}-{manifest['version']}"
    os.makedirs(out, exist_ok=True)
    files = source_files(ROOT)
    if MANIFEST not in files:
        raise BuildError(f"{MANIFEST} is not among the source files of {ROOT}")
    pins = pinned_versions(REQUIRED + OPTIONAL) if wheels else {}
    results = []
    with tempfile.TemporaryDirectory(prefix="cp_stylize_build_") as tmp:
        if not wheels:
            src = os.path.join(tmp, "src")
            stage_source(ROOT, files, src)
            declared = platforms if explicit_platforms else []
            with open(os.path.join(src, MANIFEST), "w", encoding="utf-8") as fh:
                fh.write(staged_manifest(manifest_text, declared, []))
            zip_path = os.path.join(out, f"{stem}.zip")
            log(f"building {os.path.basename(zip_path)} without wheels")
            build_zip(blender_ext, src, zip_path)
            return [(zip_path, None, [], ["no wheels: Blender's Python must already have SciPy"])]
        for platform in platforms:
            log(f"{platform}: downloading wheels")
            src = os.path.join(tmp, platform, "src")
            stage_source(ROOT, files, src)
            wheel_dir = os.path.join(src, "wheels")
            os.makedirs(wheel_dir)
            shipped, notes = [], []
            for package, python in ((p, v) for p in REQUIRED + OPTIONAL for v in PYTHON_VERSIONS):
                version = pins[package]
                wheel = download_wheel(package, version, platform, python,
                                       os.path.join(tmp, platform, "download", package, python))
                if wheel is None:
                    if package in REQUIRED:
                        raise BuildError(f"{package}=={version} has no wheel for {platform} and Python {python} "
                                         f"(pip platforms {', '.join(PIP_PLATFORMS[platform])})")
                    note = (f"{package}=={version} has no wheel for {platform} and Python {python}: building "
                            f"without it (there the add-on uses the mesh's own UVs only)")
                    log(f"  WARNING: {note}")
                    notes.append(note)
                    continue
                name = os.path.basename(wheel)
                if name.lower().startswith(NEVER_SHIPPED):
                    raise BuildError(f"refusing to ship {name}: Blender brings its own")
                shutil.copy2(wheel, os.path.join(wheel_dir, name))
                shipped.append(name)
                needs = minimum_os(wheel)
                log(f"  {name}" + (f" (needs {needs})" if needs else ""))
            with open(os.path.join(src, MANIFEST), "w", encoding="utf-8") as fh:
                fh.write(staged_manifest(manifest_text, [platform], [f"./wheels/{n}" for n in shipped]))
            zip_path = os.path.join(out, f"{stem}-{platform.replace('-', '_')}.zip")
            log(f"{platform}: building {os.path.basename(zip_path)}")
            build_zip(blender_ext, src, zip_path)
            results.append((zip_path, platform, shipped, notes))
    return results


def parse_args(argv):
    parser = argparse.ArgumentParser(
        prog="build_extension.py",
        description="Build and validate the cp_stylize extension zips, one per platform, with SciPy and xatlas wheels.")
    parser.add_argument("--out", default=os.path.join(ROOT, "dist"),
                        help="directory for the zips (created if missing; default: dist/ in the repository)")
    parser.add_argument("--platforms", nargs="+", choices=list(PIP_PLATFORMS), metavar="PLATFORM",
                        help=f"Blender platforms to build (default: all of {', '.join(PIP_PLATFORMS)})")
    parser.add_argument("--no-wheels", action="store_true",
                        help="build one zip without wheels (Blender's Python must already have SciPy)")
    parser.add_argument("--blender-ext", metavar="PATH",
                        help="blender_ext.py to use (default: the one in the installed bpy module, else the one "
                             "of the Blender binary --blender)")
    parser.add_argument("--blender", metavar="PATH",
                        help="a Blender binary whose blender_ext.py to use when this Python has no bpy module "
                             "(default: blender on the PATH)")
    return parser.parse_args(argv)


def main(argv=None):
    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    args = parse_args(argv)
    platforms = list(dict.fromkeys(args.platforms or PIP_PLATFORMS))
    try:
        results = build(os.path.abspath(args.out), platforms, wheels=not args.no_wheels,
                        blender_ext=args.blender_ext, blender=args.blender,
                        explicit_platforms=args.platforms is not None)
    except BuildError as ex:
        print(f"build_extension.py: error: {ex}", file=sys.stderr, flush=True)
        return 1
    log()
    log("wrote:")
    for zip_path, platform, shipped, notes in results:
        size = os.path.getsize(zip_path) / 1e6
        log(f"  {zip_path} ({size:.1f} MB; {platform or 'any platform'}; "
            f"wheels: {', '.join(shipped) if shipped else 'none'})")
        for note in notes:
            log(f"    note: {note}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
