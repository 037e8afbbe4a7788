#!/usr/bin/env bash
# Install the system packages swarmshot needs, only when missing: at run time
# Mesa's software Vulkan driver (lavapipe) and the Vulkan loader; at build time
# cmake and nasm, with which the `turbojpeg` crate builds libjpeg-turbo (the JPEG
# encoder, with its SIMD code) from source. Building needs no -dev packages
# (Vulkan, EGL and X11 are loaded at run time).
set -euo pipefail

need=()
ls /usr/share/vulkan/icd.d/lvp_icd.*.json >/dev/null 2>&1 || need+=(mesa-vulkan-drivers)
ldconfig -p 2>/dev/null | grep -q 'libvulkan.so.1 ' || need+=(libvulkan1)
command -v cmake >/dev/null 2>&1 || need+=(cmake)
command -v nasm >/dev/null 2>&1 || need+=(nasm)
for pkg in "$@"; do
  dpkg -s "$pkg" >/dev/null 2>&1 || need+=("$pkg")
done

if [ ${#need[@]} -gt 0 ]; then
  echo "setup: installing ${need[*]}" >&2
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
fi
