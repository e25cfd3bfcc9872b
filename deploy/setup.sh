#!/usr/bin/env bash
# Set up cavesim on a Debian machine: the headless OpenGL packages where missing, then a
# virtualenv in .venv with cavesim installed (editable). Safe to run again: it only does
# what is missing. Usage: deploy/setup.sh [--test]   (--test adds the test dependencies:
# the Python ones, iproute2 and iptables for the multi-host test's network namespaces,
# glslang-tools for the shader portability gate, xvfb and xdotool for the window tests)
set -euo pipefail
cd "$(dirname "$0")/.."

# EGL dispatch, Mesa's EGL, llvmpipe; GL and GLX dispatch and Mesa's GLX for live windows
GL_PACKAGES=(libegl1 libegl-mesa0 libgl1-mesa-dri libgl1 libglx-mesa0)
# tests/cluster/test_multihost.py: `ip netns`, veth, packet loss; tests/gpu/test_shader_gate.py: the
# Khronos reference GLSL front-end; tests/windows/test_live_walls.py: an X server and a keyboard
TEST_PACKAGES=(iproute2 iptables glslang-tools xvfb xdotool)

packages=("${GL_PACKAGES[@]}")
[ "${1:-}" = "--test" ] && packages+=("${TEST_PACKAGES[@]}")
missing=()
for package in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" \
        || missing+=("$package")
done
if ((${#missing[@]})); then
    echo "setup: installing ${missing[*]}" >&2
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    $sudo apt-get update -q
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends \
        "${missing[@]}"
fi

extras=""
[ "${1:-}" = "--test" ] && extras="[test]"
stamp=".venv/.installed${extras}"
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
# reinstall when pyproject.toml changed since the last install of these extras
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
    echo "setup: installing cavesim${extras} into .venv" >&2
    .venv/bin/python -m pip install -q --upgrade pip
    .venv/bin/python -m pip install -q -e ".${extras}"
    touch "$stamp"
fi
