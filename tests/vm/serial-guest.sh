# The serial check, run inside the test VM by /init as /mnt/guest.sh (busybox sh): glint sends
# position packets through the guest's second UART (/dev/ttyS1, the kernel's 8250 driver), which
# qemu connects to a host pty that the host-side test (tests/serial.rs) reads and decodes.
# Inputs: /mnt/glint, /mnt/in/dots.yuv, /mnt/in/args. Outputs: /mnt/out/serial.jsonl (glint's
# reports), serial.err (its log), serial.status (its exit status).
# Run glint from RAM: loading it through 9p at every page fault is slow under TCG.
cp /mnt/glint /tmp/glint
OUT=/mnt/out
mkdir -p "$OUT"
# Raw line, and held open for the whole run: a closed 8250 port drops what arrives, and the
# host's go byte must not be echoed back.
stty -F /dev/ttyS1 115200 raw -echo
exec 3<>/dev/ttyS1
# Handshake: "r" tells the host the port is open; its "g" says it is reading.
printf r >&3
head -c 1 <&3 >/dev/null
# shellcheck disable=SC2046 # the arguments are words on one line
/tmp/glint -v track --input /mnt/in/dots.yuv $(cat /mnt/in/args) --serial /dev/ttyS1 \
    >"$OUT/serial.jsonl" 2>"$OUT/serial.err"
echo $? >"$OUT/serial.status"
exec 3>&-
