#!/bin/sh
# Memory soak of a long capture, run by hand (not by the tests or CI): boots the vivid VM and
# runs `glint track --device` on vivid's test pattern (640x480 YUYV at 25 fps) for SECONDS,
# sampling the process's resident set every 10 s. Memory should stay flat: everything is
# allocated when the camera opens.
#
# Usage: tests/vm/soak.sh GLINT_BINARY [SECONDS]      (default 600; use a release build)
# Prints one line per sample: guest uptime (s), VmRSS (kB), VmHWM = peak RSS (kB); then glint's
# exit status after SIGTERM, and its last summaries and latency table.
set -eu

HERE=$(cd "$(dirname "$0")" && pwd)
glint=${1:?usage: soak.sh GLINT_BINARY [SECONDS]}
seconds=${2:-600}
share=$(mktemp -d)
trap 'rm -rf "$share"' EXIT

strip -o "$share/glint" "$glint" 2>/dev/null || cp "$glint" "$share/glint"
cat >"$share/guest.sh" <<EOF
cp /mnt/glint /tmp/glint
mkdir -p /mnt/out
insmod /lib/modules/vivid.ko
for _ in \$(seq 50); do [ -e /dev/video0 ] && break; sleep 0.1; done
/tmp/glint track --device /dev/video0 --size 640x480 --fps 25 --summary-every 60 --stats \
    >/dev/null 2>/mnt/out/soak.err &
pid=\$!
end=\$((\$(cut -d. -f1 /proc/uptime) + $seconds))
echo "uptime_s rss_kb peak_rss_kb" >/mnt/out/rss.txt
while [ "\$(cut -d. -f1 /proc/uptime)" -lt "\$end" ]; do
    sleep 10
    status=/proc/\$pid/status
    echo "\$(cut -d' ' -f1 /proc/uptime) \$(awk '/VmRSS/{print \$2}' \$status) \$(awk '/VmHWM/{print \$2}' \$status)" >>/mnt/out/rss.txt
done
kill -TERM \$pid
wait \$pid
echo "exit status \$?" >>/mnt/out/rss.txt
EOF

GLINT_VM_TIMEOUT=$((seconds + 120)) "$HERE/run.sh" "$share"
cat "$share/out/rss.txt"
tail -n 12 "$share/out/soak.err"
