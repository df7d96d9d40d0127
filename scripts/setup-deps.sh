#!/usr/bin/env bash
# Installs every system dependency of GLAM server from Debian 12 packages.
# Idempotent and non-interactive: packages already present are skipped, so running
# it on every `make run` / `make test` costs a dpkg query, not an apt transaction.
# The list below is the single source of truth; docker/Dockerfile must install the same
# (tests/tools/check_docker_packages.sh compares them).
#   setup-deps.sh              runtime + build packages (make run, docker/Dockerfile)
#   setup-deps.sh --with-test  also TEST_PACKAGES, needed only by the test suite (make test)
#   setup-deps.sh --print      the runtime + build list (what the Docker image gets)
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config git ca-certificates
  libopencv-dev libeigen3-dev libceres-dev libflann-dev
  libtinygltf-dev libdraco-dev libcpp-httplib-dev nlohmann-json3-dev
  libspdlog-dev libfmt-dev libsqlite3-dev libtbb-dev libcli11-dev libexif-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  ffmpeg libavcodec-dev libavformat-dev libavutil-dev libswscale-dev
  curl jq
)

# Only for tests, never in the image: the browser test (tests/web) drives Debian's chromium.
TEST_PACKAGES=(
  chromium
)

case "${1:-}" in
  --print) printf '%s\n' "${PACKAGES[@]}"; exit 0 ;;
  --with-test) PACKAGES+=("${TEST_PACKAGES[@]}") ;;
  "") ;;
  *) echo "usage: $0 [--with-test | --print]" >&2; exit 2 ;;
esac

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "setup-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
echo "setup-deps: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get -o DPkg::Lock::Timeout=600 update -qq
$SUDO apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends "${missing[@]}"
