# Sourced by the client tests' shell scripts (with_ajard.sh, blackbox_replay_test.sh): one ajard
# in the background.
#   ajard_start AJARD CONFIG DIR LOG: ajard --config CONFIG on 127.0.0.1 port 0 with DIR/port and
#     DIR/state, output to LOG; waits (at most 20 s) for the port file. Sets ajard_pid, and
#     ajard_port (empty when ajard did not come up: then it returns 1).
#   ajard_stop: SIGTERM, at most 10 s to end, then SIGKILL; nothing when none runs.
ajard_pid=""
ajard_port=""
ajard_start() {
  local ajard=$1 config=$2 dir=$3 log=$4
  "$ajard" --config "$config" --listen 127.0.0.1:0 --port-file "$dir/port" \
    --state-dir "$dir/state" >"$log" 2>&1 &
  ajard_pid=$!
  for _ in $(seq 1 400); do
    [[ -s "$dir/port" ]] && break
    kill -0 "$ajard_pid" 2>/dev/null || break
    sleep 0.05
  done
  ajard_port=""
  [[ -s "$dir/port" ]] || return 1
  ajard_port=$(cat "$dir/port")
}
ajard_stop() {
  if [[ -n "$ajard_pid" ]] && kill -0 "$ajard_pid" 2>/dev/null; then
    kill -TERM "$ajard_pid" 2>/dev/null
    for _ in $(seq 1 200); do kill -0 "$ajard_pid" 2>/dev/null || break; sleep 0.05; done
    kill -KILL "$ajard_pid" 2>/dev/null
    wait "$ajard_pid" 2>/dev/null
  fi
  ajard_pid=""
}
