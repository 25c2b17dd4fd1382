#!/usr/bin/env bash
# Install everything auralize needs on a fresh Debian/Ubuntu machine into ./.venv:
# system libraries (PortAudio, libsndfile, Mesa/EGL for off-screen VTK, Xvfb and the
# xcb libraries Qt needs, ALSA tools for the file-backed test device) and the Python
# packages (pyproject.toml's ranges, at the exact versions CI tests in constraints.txt, with
# the gui and dev extras), then compiles the numba kernels once (auralize warmup).
set -euo pipefail
cd "$(dirname "$0")/.."

APT_PACKAGES=(
  libportaudio2 libsndfile1 libasound2-plugins alsa-utils
  libegl1 libgl1-mesa-dri libglu1-mesa
  xvfb xauth libxcb-icccm4 libxcb-keysyms1 libxkbcommon-x11-0 libxcb-cursor0
  libxcb-image0 libxcb-render-util0 libxcb-shape0 libxcb-xinerama0 libxcb-randr0 libdbus-1-3
)
if command -v apt-get >/dev/null 2>&1; then
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  missing=()
  for p in "${APT_PACKAGES[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
  done
  if [ "${#missing[@]}" -gt 0 ]; then
    echo "installing system packages: ${missing[*]}"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  fi
else
  echo "note: no apt-get; install PortAudio, libsndfile, Mesa/EGL and Xvfb with your package manager" >&2
fi

PY=${PYTHON:-python3}
[ -x .venv/bin/python ] || "$PY" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
.venv/bin/python -m pip install -q -c constraints.txt -e ".[gui,dev]"
echo "auralize installed in $(pwd)/.venv"
# compile the kernels now, with a visible step, so that the first command starts at full speed
.venv/bin/auralize warmup
