#!/usr/bin/env bash
# Sets up a fresh Debian machine for skelcore; safe to run again.
#   .ci/setup.sh          the engine and the inspector
#   .ci/setup.sh --test   the same plus the test tools and Debian's chromium for the browser tests
# System packages: libusb-1.0-0 (open3d), SuiteSparse + OpenBLAS (CHOLMOD for scikit-sparse), chromium.
set -euo pipefail
cd "$(dirname "$0")/.."

want=(libusb-1.0-0 libsuitesparse-dev libopenblas0-pthread)
[ "${1:-}" = "--test" ] && want+=(chromium)
missing=()
for package in "${want[@]}"; do
    dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
done
if [ ${#missing[@]} -gt 0 ]; then
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -q
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

[ -x .venv/bin/python ] || python3 -m venv .venv
pip=(.venv/bin/python -m pip install -q --disable-pip-version-check)
"${pip[@]}" --upgrade pip
extras="cholmod"
[ "${1:-}" = "--test" ] && extras="cholmod,test"
"${pip[@]}" -e ".[$extras]"
