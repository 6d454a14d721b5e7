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
run_pid="" web_pid=""
cleanup() {
  [ -n "$web_pid" ] && kill "$web_pid" 2>/dev/null || true
  [ -n "$run_pid" ] && kill "$run_pid" 2>/dev/null || true
  wait 2>/dev/null || true
  rm -rf "$dir"
}
trap cleanup EXIT
cp "$src/examples/seed_pid.fbd" "$dir/"
cat > "$dir/web.yaml" <<YAML
runtime:
  name: $name
  socket: $dir/run/$name.sock
  retain_file: $dir/state/$name.retain
  lock_memory: false
tasks:
  - program: seed_pid.fbd
    setpoints: {Setpoint: {min: 0, max: 100}}
drivers:
  - kind: sim
YAML
"$bin" run "$dir/web.yaml" > "$dir/run.log" 2>&1 &
run_pid=$!
echo "$run_pid" > "$dir/run.pid"
for _ in $(seq 1 100); do "$bin" status --name "$name" >/dev/null 2>&1 && break; sleep 0.1; done
"$bin" web --name "$name" --listen 127.0.0.1:0 --users "$dir/users" > "$dir/web.log" 2>&1 &
web_pid=$!
link=""
for _ in $(seq 1 100); do
  link="$(grep -o 'http://127.0.0.1:[0-9]*/login?token=[0-9a-f]*' "$dir/web.log" || true)"
  [ -n "$link" ] && break
  sleep 0.1
done
[ -n "$link" ] || { cat "$dir/web.log"; echo "FAILED: rtplc web printed no login link"; exit 1; }
shots="$build/web-screenshots"
NODE_PATH="$mods" node "$src/tests/web/browser_test.js" "$link" "$shots" "$dir/run.pid" || {
  echo "--- rtplc web"; cat "$dir/web.log"; echo "--- rtplc run"; cat "$dir/run.log"; exit 1;
}
echo "screenshots in $shots"
