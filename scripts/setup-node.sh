#!/usr/bin/env bash
# Installs the project's npm test tools (Node 20 + npm from the machine, packages from the npm
# registry, pinned by each package-lock.json). Idempotent: a folder whose node_modules already
# matches its lock file is skipped, so `make test` costs a file comparison, not a download.
# Folders: tools/gltf-validator (Khronos glTF Validator for the quantized map tiles).
set -euo pipefail
cd "$(dirname "$0")/.."

FOLDERS=(tools/gltf-validator)

if ! command -v npm >/dev/null 2>&1; then
  echo "setup-node: npm not found; the glTF validation tests will fail until Node.js 20 + npm are installed" >&2
  exit 0
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
