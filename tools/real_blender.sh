#!/usr/bin/env bash
# A real Blender binary, Python 3.13 and a virtual screen, from Debian's own packages, in a Debian 13
# chroot: Blender 4.3.2 (its Python 3.13, NumPy 2.2, SciPy 1.15), Xvfb, xdotool, ImageMagick, pytest.
#
#   tools/real_blender.sh setup                 # once (about 5 minutes, 2 GB; idempotent); needs root
#   tools/real_blender.sh venv NAME REQS...     # a venv /opt/NAME inside (system site-packages), pip-installs REQS
#   tools/real_blender.sh run CMD...            # CMD inside, in this checkout (bind-mounted)
#   tools/real_blender.sh run --gui CMD...       # the same on a virtual 1600x1000 X screen
#
# ROOT is $CP_STYLIZE_BLENDER_ROOT or /opt/cp_stylize-blender.  Downloaded packages are kept under
# ${XDG_CACHE_HOME:-~/.cache}/cp_stylize (Debian packages) and pip's own cache is shared with the chroot,
# so a second setup on the same machine downloads little.  Blender ignores PYTHONPATH unless it gets
# --python-use-system-env.
set -euo pipefail
ROOT=${CP_STYLIZE_BLENDER_ROOT:-/opt/cp_stylize-blender}
CACHE=${XDG_CACHE_HOME:-$HOME/.cache}
HERE=$(cd "$(dirname "$0")/.." && pwd)

mount_system() {
  for d in proc sys dev dev/pts; do
    mountpoint -q "$ROOT/$d" || mount --bind "/$d" "$ROOT/$d"
  done
  mkdir -p "$CACHE/pip" "$ROOT/root/.cache/pip"
  mountpoint -q "$ROOT/root/.cache/pip" || mount --bind "$CACHE/pip" "$ROOT/root/.cache/pip"
}

setup() {
  if [ -f "$ROOT/.ready" ]; then echo "real Blender ready in $ROOT"; return; fi
  export DEBIAN_FRONTEND=noninteractive
  command -v debootstrap >/dev/null || { apt-get update -qq; apt-get install -y -qq debootstrap >/dev/null; }
  mkdir -p "$CACHE/cp_stylize/debootstrap" "$CACHE/cp_stylize/apt"
  [ -x "$ROOT/bin/bash" ] || debootstrap --variant=minbase --cache-dir="$CACHE/cp_stylize/debootstrap" \
    trixie "$ROOT" http://deb.debian.org/debian >/dev/null
  cp /etc/resolv.conf "$ROOT/etc/" 2>/dev/null || true
  mount_system
  mountpoint -q "$ROOT/var/cache/apt/archives" || mount --bind "$CACHE/cp_stylize/apt" "$ROOT/var/cache/apt/archives"
  chroot "$ROOT" apt-get update -qq
  chroot "$ROOT" apt-get install -y -qq --no-install-recommends \
    blender xvfb xauth xdotool imagemagick python3-scipy python3-pytest python3-pip python3-venv \
    ca-certificates >/dev/null
  umount "$ROOT/var/cache/apt/archives"
  # the host's certificates and pip settings, so that pip inside reaches the package index
  cp /etc/ssl/certs/ca-certificates.crt "$ROOT/etc/ssl/certs/ca-certificates.crt"
  [ -f /etc/pip.conf ] && cp /etc/pip.conf "$ROOT/etc/pip.conf"
  chroot "$ROOT" env -u PIP_FIND_LINKS pip install -q --break-system-packages --root-user-action=ignore \
    "xatlas==$(sed -n 's/^xatlas==//p' "$HERE/requirements.txt")"
  touch "$ROOT/.ready"
  chroot "$ROOT" blender --version | head -n 1
}

venv() {
  local name=$1; shift
  [ -f "$ROOT/.ready" ] || { echo "run $0 setup first" >&2; exit 2; }
  mount_system
  [ -x "$ROOT/opt/$name/bin/python" ] || chroot "$ROOT" python3 -m venv --system-site-packages "/opt/$name"
  chroot "$ROOT" env -u PIP_FIND_LINKS HOME=/root "/opt/$name/bin/pip" install -q --disable-pip-version-check \
    --root-user-action=ignore "$@"
}

run() {
  [ -f "$ROOT/.ready" ] || { echo "run $0 setup first" >&2; exit 2; }
  local gui=0
  [ "${1:-}" = "--gui" ] && { gui=1; shift; }
  mount_system
  # a mount point of its own for each run, so that runs can overlap
  at="/mnt/checkout_$$"   # a Python identifier: pytest imports the checkout root as a package
  mkdir -p "$ROOT$at"
  mount --bind "$PWD" "$ROOT$at"
  # a window's X server may still be closing when the run ends: then the mount is detached lazily
  trap 'umount "$ROOT$at" 2>/dev/null || umount -l "$ROOT$at"; rmdir "$ROOT$at"' EXIT
  local cmd
  cmd=$(printf '%q ' "$@")
  if [ $gui = 1 ]; then
    chroot "$ROOT" bash -c "cd $at && HOME=/root xvfb-run -a -s '-screen 0 1600x1000x24' $cmd"
  else
    chroot "$ROOT" bash -c "cd $at && HOME=/root $cmd"
  fi
}

case "${1:-}" in
  setup) shift; setup "$@" ;;
  venv) shift; venv "$@" ;;
  run) shift; run "$@" ;;
  *) sed -n '2,15p' "$0"; exit 2 ;;
esac
