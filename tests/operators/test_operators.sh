#!/usr/bin/env bash
# A runtime that is not root, and the other local users around it:
#   - a member of its monitor_group reads its image (rtplc monitor, stats);
#   - runtime.operators grants roles: an operator sets a set-point within its
#     limits but may not force or stop; a viewer reads status but may not set;
#     a user with no grant is refused; every refusal is in the audit trail;
#   - `rtplc whoami` says who the runtime takes each one for.
# Needs root (it adds four users and a group, and removes them at the end).
set -euo pipefail
src="$1" bin="$2"
if [ "$(id -u)" -ne 0 ]; then echo "SKIP: needs root to add local users"; exit 77; fi
command -v useradd >/dev/null && command -v runuser >/dev/null || { echo "SKIP: no useradd/runuser"; exit 77; }

tag="rt$$"
own="${tag}own" op="${tag}op" view="${tag}view" none="${tag}none" grp="${tag}watch"
dir="$(mktemp -d)"
pid=""
cleanup() {
  [ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null || true
  for u in "$own" "$op" "$view" "$none"; do userdel "$u" 2>/dev/null || true; done
  groupdel "$grp" 2>/dev/null || true
  rm -rf "$dir"
}
trap cleanup EXIT
fail() {
  echo "FAILED: $*"
  [ -f "$dir/run.log" ] && { echo "--- runtime log"; cat "$dir/run.log"; }
  exit 1
}

groupadd "$grp"
for u in "$own" "$op" "$view" "$none"; do useradd --no-create-home --shell /usr/sbin/nologin "$u"; done
usermod -aG "$grp" "$own"   # a runtime shares its image only with a group it is in
usermod -aG "$grp" "$op"
usermod -aG "$grp" "$view"
as() { local u="$1"; shift; runuser -u "$u" -- "$@"; }

chmod 755 "$dir"
mkdir "$dir/rt"
cp "$src/examples/seed_pid.fbd" "$dir/rt/"
name="ops$$"
cat > "$dir/rt/ops.yaml" <<YAML
runtime:
  name: $name
  socket: $dir/rt/run/$name.sock
  retain_file: $dir/rt/state/$name.retain
  monitor_group: $grp
  operators: {$op: operator, group:$grp: viewer}
  lock_memory: false
  cpu_dma_latency: false
tasks:
  - program: seed_pid.fbd
    setpoints: {Setpoint: {min: 0, max: 100}}
drivers:
  - kind: sim
YAML
chown -R "$own" "$dir/rt"
sock="$dir/rt/run/$name.sock"

as "$own" env HOME="$dir/rt" "$bin" run "$dir/rt/ops.yaml" > "$dir/run.log" 2>&1 &
pid=$!
for _ in $(seq 1 100); do
  as "$own" "$bin" status --socket "$sock" >/dev/null 2>&1 && break
  sleep 0.1
done
as "$own" "$bin" status --socket "$sock" >/dev/null || fail "the runtime did not come up as $own"
[ "$(stat -c %a "$dir/rt/run")" = 711 ] || fail "socket folder mode $(stat -c %a "$dir/rt/run"), want 711"
[ "$(stat -c %a "$sock")" = 666 ] || fail "socket mode $(stat -c %a "$sock"), want 666"

# monitor_group: a member reads the image of a runtime that is not root's.
out="$(as "$view" "$bin" monitor --once --name "$name" 2>&1)" || fail "monitor as a group member: $out"
grep -q "Setpoint" <<<"$out" || fail "monitor shows no Setpoint: $out"
out="$(as "$view" "$bin" stats --name "$name" 2>&1)" || fail "stats as a group member: $out"
grep -q "^T:" <<<"$out" || fail "stats shows no task line: $out"
out="$(as "$none" "$bin" monitor --once --name "$name" 2>&1)" && fail "monitor by a non-member worked: $out"
grep -q "monitor_group" <<<"$out" || fail "the refusal does not point at monitor_group: $out"

# Roles, each named by whoami.
out="$(as "$own" "$bin" whoami --socket "$sock")"; grep -q "admin" <<<"$out" || fail "owner: $out"
out="$(as "$op" "$bin" whoami --socket "$sock")"; grep -q "($op): operator" <<<"$out" || fail "operator: $out"
out="$(as "$view" "$bin" whoami --socket "$sock")"; grep -q "($view): viewer" <<<"$out" || fail "viewer: $out"

# The operator: set-points within limits; not force, not stop.
out="$(as "$op" "$bin" set Setpoint 61 --socket "$sock" 2>&1)" || fail "operator set: $out"
grep -q "Setpoint = 61 (was 50)" <<<"$out" || fail "operator set answer: $out"
out="$(as "$op" "$bin" set Setpoint 150 --socket "$sock" 2>&1)" && fail "out-of-limits set accepted: $out"
out="$(as "$op" "$bin" force ProcVal 3 --socket "$sock" 2>&1)" && fail "operator force accepted: $out"
grep -q "needs the role engineer" <<<"$out" || fail "operator force refusal: $out"
out="$(as "$op" "$bin" stop --socket "$sock" 2>&1)" && fail "operator stop accepted: $out"
grep -q "needs the role admin" <<<"$out" || fail "operator stop refusal: $out"

# The viewer reads, never writes.
out="$(as "$view" "$bin" status --socket "$sock" 2>&1)" || fail "viewer status: $out"
grep -q "runtime $name" <<<"$out" || fail "viewer status answer: $out"
out="$(as "$view" "$bin" set Setpoint 62 --socket "$sock" 2>&1)" && fail "viewer set accepted: $out"
grep -q "needs the role operator" <<<"$out" || fail "viewer set refusal: $out"

# No grant: refused, and said why.
out="$(as "$none" "$bin" status --socket "$sock" 2>&1)" && fail "a user with no role read status: $out"
grep -q "not an operator of runtime $name" <<<"$out" || fail "no-role refusal: $out"

# The value is what the operator set; the trail names every caller.
out="$(as "$own" "$bin" monitor --once --name "$name" --filter Setpoint)"
grep -Eq "Setpoint +setpoint .* 61 " <<<"$out" || fail "Setpoint is not 61: $out"
trail="$(as "$own" "$bin" audit --socket "$sock")"
grep -q "($op) \[operator\] set label=Setpoint value=61: Setpoint = 61 (was 50)" <<<"$trail" || fail "audit of the set: $trail"
grep -q "($op) \[operator\] force .*refused: .*needs the role engineer" <<<"$trail" || fail "audit of the refused force: $trail"
grep -q "($view) \[viewer\] set .*refused" <<<"$trail" || fail "audit of the viewer's set: $trail"
grep -q "($none) \[none\] status: refused" <<<"$trail" || fail "audit of the no-role status: $trail"

as "$own" "$bin" stop --socket "$sock" >/dev/null || fail "owner stop"
wait "$pid" || fail "the runtime exited with $?"
pid=""
echo "OK: monitor_group and runtime.operators work for a runtime that is not root, with four local users"
