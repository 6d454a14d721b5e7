#!/bin/sh
# The guest kernel is Debian's PREEMPT_RT build: doctor must say so, in the table and in JSON.
rtplc --version
set +e
rtplc doctor
echo "(rtplc doctor exit status $?)"
set -e
rtplc doctor --json > /tmp/doctor.json || true
if ! grep -q '"realtime": true' /tmp/doctor.json; then
  echo "FAILED: rtplc doctor does not report a PREEMPT_RT kernel"
  exit 1
fi
rtplc doctor | grep -q 'is PREEMPT_RT'
echo "OK: rtplc doctor reports PREEMPT_RT ($(uname -v))"
