#!/usr/bin/env bash
# Installs the project's npm test tools (Node.js + npm from the machine or Debian, packages from the npm
# registry, pinned by each package-lock.json). Idempotent: a folder whose node_modules already
# matches its lock file is skipped, so `make test` costs a file comparison, not a download.
# Folders: tools/gltf-validator (Khronos glTF Validator for the quantized map tiles).
set -euo pipefail
cd "$(dirname "$0")/.."

FOLDERS=(tools/gltf-validator)

# A fresh Debian 12 has no Node.js: take Debian's (nodejs 18 + npm 9 run the validator). Where
# Node.js is already installed (e.g. from NodeSource, which bundles npm), apt's npm would
# conflict with it, so apt is only used when npm is missing.
if ! command -v npm >/dev/null 2>&1; then
  SUDO=""
  if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
  echo "setup-node: npm not found; installing Debian's nodejs and npm"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get -o DPkg::Lock::Timeout=600 update -qq
  $SUDO apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends nodejs npm
fi

for dir in "${FOLDERS[@]}"; do
  # npm ci records the installed tree in node_modules/.package-lock.json.
  if [[ -f "$dir/node_modules/.package-lock.json" ]] &&
     [[ "$dir/node_modules/.package-lock.json" -nt "$dir/package-lock.json" ]]; then
    echo "setup-node: $dir up to date"
    continue
  fi
  echo "setup-node: npm ci in $dir"
  (cd "$dir" && npm ci --prefer-offline --no-audit --no-fund --loglevel=error)
done
