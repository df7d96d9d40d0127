#!/usr/bin/env bash
# Installs what the benchmarks under bench/ need beyond the build dependencies: COLMAP (CPU)
# for the side-by-side comparison and python3-numpy / python3-matplotlib for the Sim3
# alignment and the plots. Idempotent; not part of `make test` (tests never need COLMAP).
# Usage: bench/colmap/setup.sh
set -euo pipefail
PACKAGES=(colmap python3-numpy python3-matplotlib)
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "bench dependencies already installed: ${PACKAGES[*]}"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get -o DPkg::Lock::Timeout=600 update
$SUDO apt-get -o DPkg::Lock::Timeout=600 install -y --no-install-recommends "${missing[@]}"
