#!/usr/bin/env bash
# The web console in a real browser: a runtime on the simulated plant, `rtplc
# web` beside it, and tests/web/browser_test.js driving Debian's chromium.
# Skips (exit 77, saying why) without chromium or playwright-core
# (scripts/setup-deps and scripts/setup-browser-test install them).
set -euo pipefail
src="$1" bin="$2" build="$3"
[ -x /usr/bin/chromium ] || { echo "SKIP: /usr/bin/chromium is not installed (scripts/setup-deps installs it)"; exit 77; }
mods="${RTPLC_BROWSER_TEST_DIR:-$src/build/browser-test}/node_modules"
[ -d "$mods/playwright-core" ] || { echo "SKIP: playwright-core is not in $mods (scripts/setup-browser-test)"; exit 77; }
dir="$(mktemp -d)"
name="web$$"
run_pid="" web_pid="" slave_pid=""
cleanup() {
  [ -n "$slave_pid" ] && kill "$slave_pid" 2>/dev/null || true
  [ -n "$web_pid" ] && kill "$web_pid" 2>/dev/null || true
  [ -n "$run_pid" ] && kill "$run_pid" 2>/dev/null || true
  wait 2>/dev/null || true
  rm -rf "$dir"
}
trap cleanup EXIT
cp "$src/examples/seed_pid.fbd" "$src/examples/seed_pid_v2.fbd" "$src/examples/bad.fbd" "$dir/"
# The measuring tank's chart, on p3 (seed_pid's loop has p0).
sed 's/(p0, /(p3, /' "$src/examples/tank.sfc" > "$dir/tank.sfc"
# A field task on a Modbus fake slave (its channels turn bad when the slave dies).
cat > "$dir/field.fbd" <<'FBD'
%%
stime(0.1)
F1 = prr(p1, d0, c0, "FieldLevel")
pwr(F1, p1, d0, c1, "FieldEcho")
END
FBD
# An operator panel in ST with Beremiz SVGHMI variables: the console marks them.
cat > "$dir/panel.st" <<'ST'
PROGRAM Panel
VAR
  speed : HMI_REAL := 2.5;
  doubled : HMI_REAL;
  shown : STRING[24];
END_VAR
  doubled := speed * 2.0;
  shown := CONCAT('speed ', REAL_TO_STRING(speed));
END_PROGRAM
ST
port="$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')"
"$bin" modbus fake-slave --port "$port" --set hr:0:f32=21.5 > "$dir/slave.log" 2>&1 &
slave_pid=$!
echo "$slave_pid" > "$dir/slave.pid"
cat > "$dir/web.yaml" <<YAML
runtime:
  name: $name
  socket: $dir/run/$name.sock
  retain_file: $dir/state/$name.retain
  lock_memory: false
tasks:
  - program: seed_pid.fbd
    setpoints: {Setpoint: {min: 0, max: 100}}
  - {name: sequence, program: tank.sfc, period: 100ms}
  - {name: field, program: field.fbd, period: 100ms}
  - {name: panel, program: panel.st, period: 100ms}
drivers:
  - kind: sim
  - kind: modbus
    name: plc
    period: 10ms
    slaves:
      - {name: s1, address: 127.0.0.1, port: $port, unit: 1, poll: 50ms, timeout: 200ms, retries: 1}
    read:
      - {device: R, channel: p1.d0.c0, slave: s1, address: 0, type: f32}
    write:
      - {device: R, channel: p1.d0.c1, slave: s1, address: 2, type: f32}
YAML
"$bin" run "$dir/web.yaml" > "$dir/run.log" 2>&1 &
run_pid=$!
echo "$run_pid" > "$dir/run.pid"
for _ in $(seq 1 100); do "$bin" status --name "$name" >/dev/null 2>&1 && break; sleep 0.1; done
mkdir -p "$dir/ws"
cp "$src"/examples/*.fbd "$src"/examples/*.sfc "$src"/examples/plcopen_*.xml "$dir/ws/"
echo "editor-password-1" | "$bin" web user add eddie --role engineer --password-stdin --users "$dir/users" > /dev/null
"$bin" web --name "$name" --listen 127.0.0.1:0 --users "$dir/users" --workspace "$dir/ws" > "$dir/web.log" 2>&1 &
web_pid=$!
link=""
for _ in $(seq 1 100); do
  link="$(grep -o 'http://127.0.0.1:[0-9]*/login?token=[0-9a-f]*' "$dir/web.log" || true)"
  [ -n "$link" ] && break
  sleep 0.1
done
[ -n "$link" ] || { cat "$dir/web.log"; echo "FAILED: rtplc web printed no login link"; exit 1; }
shots="$build/web-screenshots"
base="${link%%/login*}"
NODE_PATH="$mods" node "$src/tests/web/editor_test.js" "$base" eddie editor-password-1 "$shots" "$dir/ws" "$bin" || {
  echo "--- rtplc web"; cat "$dir/web.log"; exit 1;
}
NODE_PATH="$mods" node "$src/tests/web/browser_test.js" "$link" "$shots" "$dir/run.pid" "$dir" || {
  echo "--- rtplc web"; cat "$dir/web.log"; echo "--- rtplc run"; cat "$dir/run.log"; exit 1;
}
echo "screenshots in $shots"
