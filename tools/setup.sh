#!/usr/bin/env bash
# rigsim set-up for a fresh Debian 12 / Ubuntu 22.04+ machine, then one job.
#
#   bash tools/setup.sh demo      # install, then run the demo study and print where its report is
#   bash tools/setup.sh test      # install, then run the test suite (what CI runs)
#   bash tools/setup.sh install   # install only
#
# What it installs:
#   system (apt, needs root or sudo): libLLVM >= 16 for Mitsuba/Dr.Jit's LLVM backend (Debian 12's
#     default libLLVM 15 crashes Dr.Jit 1.5 with "Cannot select ... fminimum"), the EGL/Mesa libraries
#     PyVista needs to render off screen, python3-venv, and Chromium for the UI's browser tests;
#   python: a virtual environment in .venv with rigsim and its dependencies (PyPI).
# Without root/sudo or on another OS it says what is missing and carries on: rigsim then falls
# back to Mitsuba's scalar (slow) variant with a warning.
set -euo pipefail

job="${1:-install}"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"
venv="$here/.venv"

say() { printf '\033[1m[setup]\033[0m %s\n' "$*" >&2; }

# ---------------------------------------------------------------- system packages
have_pkg() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }

system_packages() {
  if ! command -v apt-get >/dev/null 2>&1; then
    say "not a Debian/Ubuntu system: install libLLVM >= 16 (for Dr.Jit), EGL + Mesa (for PyVista off screen)"
    say "and Python >= 3.11 with venv yourself; rigsim falls back to Mitsuba's scalar variant without LLVM."
    return 0
  fi
  local SUDO=""
  if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then SUDO="sudo -n"; else SUDO="none"; fi
  fi
  local want=(libegl1 libegl-mesa0 libgl1-mesa-dri python3-venv chromium)
  local llvm_pkg=""
  for v in 19 18 17 16; do
    if have_pkg "libllvm$v"; then llvm_pkg="libllvm$v"; break; fi
  done
  local missing=()
  for p in "${want[@]}"; do have_pkg "$p" || missing+=("$p"); done
  if [ -z "$llvm_pkg" ]; then missing+=("LLVM"); fi
  if [ ${#missing[@]} -eq 0 ]; then
    say "system packages present ($llvm_pkg, EGL/Mesa, venv, chromium)"
    return 0
  fi
  if [ "$SUDO" = "none" ]; then
    say "missing system packages: ${missing[*]}; not root and no password-less sudo."
    say "ask an administrator to run: apt-get install -y libllvm19 libegl1 libegl-mesa0 libgl1-mesa-dri python3-venv chromium"
    say "continuing: rendering falls back to Mitsuba's slow scalar variant; off-screen 3D views and browser tests may be skipped."
    return 0
  fi
  say "installing system packages: ${missing[*]} (apt-get)"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq || say "apt-get update failed; trying to install from the current package lists"
  local pkgs=()
  for p in "${want[@]}"; do have_pkg "$p" || pkgs+=("$p"); done
  if [ -z "$llvm_pkg" ]; then
    for v in 19 18 17 16; do
      if apt-cache show "libllvm$v" >/dev/null 2>&1; then pkgs+=("libllvm$v"); llvm_pkg="libllvm$v"; break; fi
    done
    [ -n "$llvm_pkg" ] || say "no libLLVM >= 16 in the package lists: rendering will use the scalar variant"
  fi
  # chromium is only needed for the UI tests: do not fail the set-up if it cannot be had
  local core=() optional=()
  for p in "${pkgs[@]}"; do if [ "$p" = chromium ]; then optional+=("$p"); else core+=("$p"); fi; done
  if [ ${#core[@]} -gt 0 ]; then $SUDO apt-get install -y -qq --no-install-recommends "${core[@]}" >/dev/null; fi
  if [ ${#optional[@]} -gt 0 ]; then
    $SUDO apt-get install -y -qq --no-install-recommends "${optional[@]}" >/dev/null \
      || say "could not install ${optional[*]}: browser tests of the UI will be skipped"
  fi
}

# ---------------------------------------------------------------- python environment
python_env() {
  local py=""
  for cand in python3.13 python3.12 python3.11 python3; do
    if command -v "$cand" >/dev/null 2>&1 && "$cand" -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
      py="$cand"; break
    fi
  done
  if [ -z "$py" ]; then say "Python >= 3.11 is required (found: $(python3 --version 2>&1 || echo none))"; exit 1; fi
  if [ ! -x "$venv/bin/python" ]; then
    say "creating virtual environment .venv with $($py --version)"
    "$py" -m venv "$venv"
  fi
  local stamp="$venv/.rigsim-installed"
  if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
    # uv (Astral's installer, from PyPI into the venv) resolves the same versions as pip and installs them in
    # seconds: on 2026-12-07, 2 cores, an empty venv: 7 s against pip's 47 s.  pip where uv cannot be had or fails
    # (uv does not read pip.conf: a machine that reaches PyPI only through a mirror gets pip).
    if "$venv/bin/python" -m pip install -q uv >/dev/null 2>&1 \
        && "$venv/bin/uv" pip install -q --python "$venv/bin/python" -e ".[test]"; then
      say "installed rigsim and its dependencies into .venv (uv)"
    else
      say "installing rigsim and its dependencies into .venv (pip)"
      "$venv/bin/python" -m pip install -q --upgrade pip
      "$venv/bin/python" -m pip install -q -e ".[test]"
    fi
    touch "$stamp"
  else
    say "python environment up to date"
  fi
  # opencv-python must never sit beside opencv-contrib-python-headless (both provide cv2)
  if "$venv/bin/python" -m pip show -q opencv-python >/dev/null 2>&1; then
    say "removing opencv-python pulled in by a dependency (rigsim uses opencv-contrib-python-headless)"
    "$venv/bin/python" -m pip uninstall -q -y opencv-python
    "$venv/bin/python" -m pip install -q --force-reinstall --no-deps opencv-contrib-python-headless
  fi
}

system_packages
python_env
export PATH="$venv/bin:$PATH"

case "$job" in
  install) say "done. Activate with: source .venv/bin/activate" ;;
  test)
    # a real camera raw photo for the development tests, from a PyPI package archive (cached)
    "$venv/bin/python" -m rigsim.cli sample-raw >/dev/null 2>&1 \
      || say "could not download the sample raw file from files.pythonhosted.org (tests that need it will say why)"
    say "running the test suite"
    set +e
    # one worker per core (pytest-xdist): the suite is mostly single-threaded numpy and browser waits;
    # on 2 cores on 2026-12-04, fresh clones with a cold kernel cache: 37 min 53 s with two workers, 52 min 57 s with one
    "$venv/bin/python" -m pytest -m "not slow" -q -n auto --durations=15 "${@:2}"
    rc=$?
    set -e
    exit $rc
    ;;
  demo)
    say "running the demo"
    exec "$venv/bin/python" -m rigsim.cli demo "${@:2}"
    ;;
  *) say "unknown job '$job' (demo | test | install)"; exit 2 ;;
esac
