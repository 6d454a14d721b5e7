#!/usr/bin/env bash
# Checks scripts/deploy against a staging root (no systemd needed).
set -euo pipefail
src="$1" bin="$2"
root="$(mktemp -d)"
trap 'rm -rf "$root"' EXIT
fail() { echo "FAILED: $*"; exit 1; }

# examples/plant.yaml keeps its retained values in /tmp: lost at every reboot, so
# deploy refuses it, installs nothing, and points at the fix.
if out="$("$src/scripts/deploy" --root "$root/volatile" --binary "$bin" --name demo "$src/examples/plant.yaml" 2>&1)"; then
  fail "a retain_file under /tmp was deployed without --volatile-retain-ok"
fi
grep -q "lost at every reboot" <<<"$out" || fail "no reason given for the volatile retain file: $out"
grep -q "docs/deploy.md" <<<"$out" || fail "the refusal does not cite docs/deploy.md: $out"
[ ! -e "$root/volatile/etc" ] || fail "a refused deploy left files behind"
[ -f "$src/docs/deploy.md" ] || fail "docs/deploy.md, which the script cites, does not exist"

out="$("$src/scripts/deploy" --root "$root" --binary "$bin" --cpus "1" --name demo --volatile-retain-ok \
        "$src/examples/plant.yaml" 2>&1)" || fail "deploy with --volatile-retain-ok: $out"
grep -q "WARNING: retain_file .*LOST AT EVERY REBOOT" <<<"$out" || fail "no loud warning: $out"
unit="$root/etc/systemd/system/rtplc-demo.service"
[ -f "$unit" ] || fail "no unit written"
grep -q '^ExecStart=/usr/local/bin/rtplc run /etc/rtplc/demo/plant.yaml --name demo$' "$unit" || fail "ExecStart"
grep -q '^LimitMEMLOCK=infinity$' "$unit" || fail "memlock limit"
grep -q '^LimitRTPRIO=98$' "$unit" || fail "rtprio limit"
grep -q '^CPUAffinity=1$' "$unit" || fail "affinity"
grep -q '^Restart=on-failure$' "$unit" || fail "restart policy"
[ -x "$root/usr/local/bin/rtplc" ] || fail "binary not installed"
# The web console's unit: beside the runtime's, an ordinary niced process, no login link.
web_unit="$root/etc/systemd/system/rtplc-demo-web.service"
[ -f "$web_unit" ] || fail "no web console unit written"
grep -q '^ExecStart=/usr/local/bin/rtplc web --name demo --no-link$' "$web_unit" || fail "web ExecStart"
grep -q '^After=rtplc-demo.service$' "$web_unit" || fail "web unit ordering"
grep -q '^Nice=10$' "$web_unit" || fail "web unit nice"
! grep -q 'LimitRTPRIO' "$web_unit" || fail "the web unit may not get real-time limits"
[ -f "$root/etc/rtplc/demo/flow.fbd" ] || fail "programs not copied"
# Only the programs the configuration names: not the other examples beside it.
for p in flow.fbd level.fbd temperature.fbd; do
  [ -f "$root/etc/rtplc/demo/$p" ] || fail "$p not copied"
done
[ ! -e "$root/etc/rtplc/demo/sixteen" ] || fail "sixteen/* copied though plant.yaml does not name it"
[ ! -e "$root/etc/rtplc/demo/seed_pid.fbd" ] || fail "seed_pid.fbd copied though plant.yaml does not name it"
# The staged configuration is complete: it checks from its new place.
"$bin" check "$root/etc/rtplc/demo/plant.yaml" >/dev/null || fail "installed config does not check"

# A program in a subfolder keeps its relative path; a stray .fbd stays behind;
# a config without retain_file (the default on disk) installs without warning.
sub="$(mktemp -d)"
mkdir -p "$sub/loops"
cp "$src/examples/seed_pid.fbd" "$sub/loops/pid.fbd"
cp "$src/examples/seed_pid.fbd" "$sub/stray.fbd"
printf 'runtime:\n  name: subdemo\ntasks:\n  - {name: pid, program: loops/pid.fbd}\ndrivers:\n  - kind: sim\n' > "$sub/sub.yaml"
out="$("$src/scripts/deploy" --root "$root/sub" --binary "$bin" "$sub/sub.yaml" 2>&1)" || fail "subfolder deploy: $out"
! grep -q WARNING <<<"$out" || fail "a warning without a reason: $out"
[ -f "$root/sub/etc/rtplc/subdemo/loops/pid.fbd" ] || fail "loops/pid.fbd not installed at its relative path"
[ ! -e "$root/sub/etc/rtplc/subdemo/stray.fbd" ] || fail "a .fbd the config does not name was copied"
"$bin" check "$root/sub/etc/rtplc/subdemo/sub.yaml" >/dev/null || fail "installed subfolder config does not check"
rm -rf "$sub"

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
[ ! -e "$web_unit" ] || fail "web unit not removed"
echo "OK: deploy stages, checks and removes a service"
