#!/usr/bin/env bash
# No Docker engine runs in CI, so this checks what can be checked without one: every stage of
# docker/Dockerfile installs its apt packages only through scripts/setup-deps.sh (the single
# package list), never with a second `apt-get install` list that could drift from it, and the
# list the script prints is non-empty and free of duplicates.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
DOCKERFILE="$ROOT/docker/Dockerfile"
fail() { echo "check_docker_packages: $*" >&2; exit 1; }

[[ -f "$DOCKERFILE" ]] || fail "missing $DOCKERFILE"
stages=$(grep -c '^FROM ' "$DOCKERFILE")
uses=$(grep -c 'setup-deps.sh &&' "$DOCKERFILE" || true)
[[ "$stages" -ge 1 ]] || fail "no FROM line"
[[ "$uses" -eq "$stages" ]] || fail "$stages stages but setup-deps.sh runs in $uses of them"
if grep -nE 'apt-get[^&|;]*install|apt install' "$DOCKERFILE"; then
  fail "the Dockerfile installs packages itself; add them to scripts/setup-deps.sh instead"
fi
grep -q '^FROM debian:12' "$DOCKERFILE" || fail "base image must be debian:12"
mapfile -t packages < <(bash "$ROOT/scripts/setup-deps.sh" --print)
[[ ${#packages[@]} -gt 10 ]] || fail "setup-deps.sh --print lists only ${#packages[@]} packages"
dups=$(printf '%s\n' "${packages[@]}" | sort | uniq -d)
[[ -z "$dups" ]] || fail "duplicate packages in setup-deps.sh: $dups"
# The healthcheck and the demo need curl; the image must get it from the same list.
printf '%s\n' "${packages[@]}" | grep -qx curl || fail "curl (healthcheck) missing from setup-deps.sh"
echo "check_docker_packages: ok (${#packages[@]} packages, $stages stages, one list)"
