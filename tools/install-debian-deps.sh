#!/usr/bin/env bash
# Installs the Debian/Ubuntu packages shadowsense needs, only those missing.
# Usage: tools/install-debian-deps.sh [--python]   (--python adds python3-torch and
# python3-opencv for tools/ and the torchvision golden tests)
set -euo pipefail
packages=(cmake g++ make libopencv-dev libopencv-videoio-dev libopencv-highgui-dev libeigen3-dev doctest-dev catch2 pkg-config liblo-dev liblo-tools python3-dev pybind11-dev python3-numpy python3-pytest libcpp-httplib-dev)
if [[ "${1:-}" == "--python" ]]; then packages+=(python3 python3-numpy python3-torch python3-torchvision python3-opencv); fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then exit 0; fi
echo "installing: ${missing[*]}" >&2
sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then sudo_cmd=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
