#!/usr/bin/env bash
# docs/api.md's endpoint table must list exactly the routes of api/openapi.yaml (method + path),
# so the prose reference cannot drift from the machine-readable one. The OpenAPI file itself is
# checked against the routes the server registers by HttpApiTest.OpenApiDocumentsEveryRoute.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
fail() { echo "check_api_doc: $*" >&2; exit 1; }

# Path keys are indented 2 spaces under `paths:`, operations 4 (the layout of api/openapi.yaml).
openapi=$(awk '/^paths:/{p=1;next} /^[^ #]/{p=0}
  p && /^  \/[^:]+:[[:space:]]*$/{path=$1; sub(":$","",path)}
  p && /^    (get|post|put|delete|patch):/{m=$1; sub(":","",m); print toupper(m) " /api/v1" path}' \
  "$ROOT/api/openapi.yaml" | sort)
documented=$(grep -oE '^\| `(GET|POST|PUT|DELETE|PATCH) /api/v1[^`]*`' "$ROOT/docs/api.md" |
  sed -E 's/^\| `//; s/`$//' | sort)

[[ $(wc -l <<<"$openapi") -ge 10 ]] || fail "found too few operations in api/openapi.yaml"
if [[ "$openapi" != "$documented" ]]; then
  diff <(echo "$openapi") <(echo "$documented") | sed 's/^</  only in openapi.yaml:/; s/^>/  only in docs\/api.md:/' >&2 || true
  fail "docs/api.md endpoint table and api/openapi.yaml disagree"
fi
dups=$(uniq -d <<<"$documented")
[[ -z "$dups" ]] || fail "listed twice in docs/api.md: $dups"
echo "check_api_doc: ok ($(wc -l <<<"$openapi") operations)"
