#!/usr/bin/env bash
# Checks scripts/deploy against a staging root (no systemd needed).
set -euo pipefail
src="$1" bin="$2"
root="$(mktemp -d)"
trap 'rm -rf "$root"' EXIT
fail() { echo "FAILED: $*"; exit 1; }

"$src/scripts/deploy" --root "$root" --binary "$bin" --cpus "1" --name demo "$src/examples/plant.yaml"
unit="$root/etc/systemd/system/rtplc-demo.service"
[ -f "$unit" ] || fail "no unit written"
grep -q '^ExecStart=/usr/local/bin/rtplc run /etc/rtplc/demo/plant.yaml --name demo$' "$unit" || fail "ExecStart"
grep -q '^LimitMEMLOCK=infinity$' "$unit" || fail "memlock limit"
grep -q '^LimitRTPRIO=98$' "$unit" || fail "rtprio limit"
grep -q '^CPUAffinity=1$' "$unit" || fail "affinity"
grep -q '^Restart=on-failure$' "$unit" || fail "restart policy"
[ -x "$root/usr/local/bin/rtplc" ] || fail "binary not installed"
[ -f "$root/etc/rtplc/demo/flow.fbd" ] || fail "programs not copied"
# The staged configuration is complete: it checks from its new place.
"$bin" check "$root/etc/rtplc/demo/plant.yaml" >/dev/null || fail "installed config does not check"

# A broken configuration installs nothing.
bad="$(mktemp -d)"
printf 'tasks:\n  - program: nowhere.fbd\n' > "$bad/bad.yaml"
if "$src/scripts/deploy" --root "$root/second" --binary "$bin" "$bad/bad.yaml" 2>/dev/null; then
  fail "a broken config was deployed"
fi
[ ! -e "$root/second/etc/systemd" ] || fail "a broken config left files behind"
rm -rf "$bad"

"$src/scripts/deploy" --root "$root" --name demo --uninstall
[ ! -e "$unit" ] || fail "unit not removed"
echo "OK: deploy stages, checks and removes a service"
