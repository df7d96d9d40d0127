#!/usr/bin/env bash
# Installs the project's npm packages (Node.js + npm from the machine or Debian, packages from the
# npm registry, pinned by each package-lock.json) and builds the web viewer. Idempotent: a folder
# whose node_modules already matches its lock file is skipped, and web/dist is rebuilt only when
# it is older than its sources, so `make test` costs a few file comparisons, not a download.
# Folders: tools/gltf-validator (Khronos glTF Validator for the quantized map tiles), web (the
# viewer: three.js, bundled by esbuild into web/dist, which `glam serve` serves), tests/web (the
# browser test: playwright-core, 3d-tiles-renderer).
#   setup-node.sh                everything (make run / make test)
#   setup-node.sh --viewer-only  only web/ and web/dist (docker/Dockerfile's build stage)
set -euo pipefail
cd "$(dirname "$0")/.."

FOLDERS=(tools/gltf-validator web tests/web)
case "${1:-}" in
  --viewer-only) FOLDERS=(web) ;;
  "") ;;
  *) echo "usage: $0 [--viewer-only]" >&2; exit 2 ;;
esac

# A fresh Debian 12 has no Node.js: take Debian's (nodejs 18 + npm 9 run the validator, esbuild and
# playwright-core). Where Node.js is already installed (e.g. from NodeSource, which bundles npm),
# apt's npm would conflict with it, so apt is only used when npm is missing.
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

# web/dist: rebuilt when missing or older than any of its inputs.
stamp=web/dist/index.html
if [[ -f "$stamp" ]] &&
   [[ -z "$(find web/src web/index.html web/style.css web/build.mjs web/package-lock.json -newer "$stamp" -print -quit)" ]]; then
  echo "setup-node: web/dist up to date"
else
  echo "setup-node: building the web viewer (web/dist)"
  (cd web && npm run --silent build)
fi
