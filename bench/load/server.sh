# Sourced by the bench/load scripts: starts `glam serve` on a temporary data directory and a
# free port, and stops it (and removes the directory) when the script exits.
#   start_server GLAM WORK [serve options...]   sets server_pid and port
server_pid=""
stop_server() {
  if [[ -n "$server_pid" ]]; then kill "$server_pid" 2>/dev/null || true; wait "$server_pid" 2>/dev/null || true; fi
  server_pid=""
}
start_server() {
  local glam="$1" work="$2"
  shift 2
  "$glam" --log-level warn serve --data "$work/data" --port 0 "$@" > "$work/stdout" &
  server_pid=$!
  for _ in $(seq 100); do
    grep -q '"port"' "$work/stdout" 2>/dev/null && break
    sleep 0.1
  done
  port="$(sed -n 's/.*"port": \([0-9]*\).*/\1/p' "$work/stdout" | head -1)"
  [[ -n "$port" ]] || { echo "server did not start" >&2; exit 1; }
}
