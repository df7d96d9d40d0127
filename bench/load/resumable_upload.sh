#!/usr/bin/env bash
# Upload throughput of `glam serve` (not a test): a one-shot multipart upload with curl against
# resumable uploads with `glam upload` at two chunk sizes, and an upload cut halfway (the
# client killed) and continued with --upload-id. The file is random bytes, so every run ends
# with the server's 422 (not a video) after the last byte: what is timed is the transfer, the
# per-chunk fsync and the hand-off, on loopback (no network limit). Then the same for photos:
# SIZE_MB in 5 MB "photos" (random bytes named .JPG) as multipart fields against `glam upload
# FOLDER` (an image set, one PUT per photo), and 2000 photos of 100 kB, where the per-photo
# cost (a request, an fsync, the set's listing) shows.
#
# usage: bench/load/resumable_upload.sh [BUILD_DIR] [SIZE_MB]   (defaults: build, 1000)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
build="${1:-$root/build}"
size_mb="${2:-1000}"
glam="$build/server/glam"
[[ -x "$glam" ]] || { echo "missing $glam (build target glam)" >&2; exit 2; }

work="$(mktemp -d /tmp/glam_upload_bench.XXXXXX)"
source "$here/server.sh"
trap 'stop_server; rm -rf "$work"' EXIT

head -c "$((size_mb * 1000000))" /dev/urandom > "$work/flight.bin"
start_server "$glam" "$work"
url="http://127.0.0.1:$port"
echo "file: $size_mb MB of random bytes, $(nproc) cores, loopback"

now() { date +%s.%N; }
rate() { echo "scale=1; $size_mb / ($2 - $1)" | bc; }
report() { printf "%-40s %6.2f s  %6s MB/s\n" "$1" "$(echo "$3 - $2" | bc)" "$(rate "$2" "$3")"; }

t0=$(now)
curl -s -o /dev/null -F "video=@$work/flight.bin" "$url/api/v1/jobs"
report "multipart POST /jobs (curl)" "$t0" "$(now)"

for chunk in 16 4; do
  t0=$(now)
  "$glam" --log-level error upload "$work/flight.bin" --server "$url" --no-gps --chunk-mb "$chunk" \
    > /dev/null 2>&1 || true  # 422 at the end: random bytes are no video
  report "glam upload, $chunk MiB chunks" "$t0" "$(now)"
done

# Cut halfway: the client is killed mid-transfer, then continued from the server's offset.
t0=$(now)
"$glam" --log-level info upload "$work/flight.bin" --server "$url" --no-gps > /dev/null 2> "$work/cut.log" &
client=$!
for _ in $(seq 600); do
  id="$(sed -n 's/.*upload \([0-9a-f]\{16\}\) opened.*/\1/p' "$work/cut.log" | head -1)"
  if [[ -n "$id" ]]; then
    offset="$(curl -s "$url/api/v1/uploads/$id" | sed -n 's/.*"offset":\([0-9]*\).*/\1/p')"
    [[ -n "$offset" && "$offset" -ge "$((size_mb * 500000))" ]] && break
  fi
  sleep 0.05
done
kill -9 "$client" 2>/dev/null || true
wait "$client" 2>/dev/null || true
kept="$(curl -s "$url/api/v1/uploads/$id" | sed -n 's/.*"offset":\([0-9]*\).*/\1/p')"
"$glam" --log-level error upload "$work/flight.bin" --server "$url" --no-gps --upload-id "$id" \
  > /dev/null 2>&1 || true
report "cut at $((kept / 1000000)) MB, continued (--upload-id)" "$t0" "$(now)"

# Photos: multipart fields in one request against an image set.
photos() {  # photos DIR COUNT KB
  mkdir -p "$1"
  for i in $(seq -w 1 "$2"); do head -c "$(($3 * 1000))" /dev/urandom > "$1/DJI_$i.JPG"; done
}
for spec in "$((size_mb / 5)) 5000" "2000 100"; do
  read -r count kb <<<"$spec"
  rm -rf "$work/photos" && photos "$work/photos" "$count" "$kb"
  mb=$((count * kb / 1000))
  args=()
  for f in "$work"/photos/*.JPG; do args+=(-F "images=@$f"); done
  t0=$(now)
  curl -s -o /dev/null "${args[@]}" "$url/api/v1/jobs"
  t1=$(now)
  printf "%-40s %6.2f s  %6s MB/s\n" "$count photos of $kb kB, multipart (curl)" "$(echo "$t1 - $t0" | bc)" \
    "$(echo "scale=1; $mb / ($t1 - $t0)" | bc)"
  t0=$(now)
  "$glam" --log-level error upload "$work/photos" --server "$url" > /dev/null 2>&1 || true  # 422: not JPEGs
  t1=$(now)
  printf "%-40s %6.2f s  %6s MB/s  %5.1f ms/photo\n" "$count photos of $kb kB, glam upload FOLDER" \
    "$(echo "$t1 - $t0" | bc)" "$(echo "scale=1; $mb / ($t1 - $t0)" | bc)" "$(echo "scale=1; 1000 * ($t1 - $t0) / $count" | bc)"
done
left="$(ls "$work/data/resumable" | wc -l)"
echo "files left in DIR/resumable: $left (0: every upload was handed over)"

stop_server
