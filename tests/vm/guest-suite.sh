# The vivid checks, run inside the test VM by /init as /mnt/guest.sh (busybox sh).
# Inputs: /mnt/capture_probe, /mnt/glint, /mnt/in/loop.yuv, /mnt/in/scene.yuv, and the fast
# scene as /mnt/in/fast.grey and fast.uyvy. Outputs: /mnt/out/<check>.jsonl (the probe's or
# glint's JSON lines), <check>.err (its log), <check>.status (its exit status), and glint
# record's rec.yuv + rec.yuv.json, fast-grey.raw + .json and fast-uyvy.raw + .json. The host-side
# test (tests/vivid.rs) asserts on them; this script only drives the driver.
# Run the programs from RAM: loading them through 9p at every start is slow under TCG.
cp /mnt/capture_probe /tmp/capture_probe
cp /mnt/glint /tmp/glint
PROBE=/tmp/capture_probe
GLINT=/tmp/glint
OUT=/mnt/out
VIVID=/lib/modules/vivid.ko
UNBIND=/sys/bus/platform/drivers/vivid/unbind
BIND=/sys/bus/platform/drivers/vivid/bind
mkdir -p "$OUT"
echo "boot_s $(cut -d' ' -f1 /proc/uptime)" >"$OUT/timing"

probe() { # probe NAME ARGS...: runs the probe, keeping its output, log and status
    name=$1
    shift
    "$PROBE" "$@" >"$OUT/$name.jsonl" 2>"$OUT/$name.err"
    echo $? >"$OUT/$name.status"
}

# Waits until a device node exists (udev-less: devtmpfs creates it when the driver registers).
wait_node() {
    for _ in 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20; do
        [ -e "$1" ] && return 0
        sleep 0.1
    done
    echo "no $1"
    return 1
}

# Waits until probe NAME has printed N frames (so it is streaming), for at most 10 s.
wait_frames() {
    for _ in $(seq 100); do
        [ "$(grep -c '"event":"frame"' "$OUT/$1.jsonl" 2>/dev/null)" -ge "$2" ] && return 0
        sleep 0.1
    done
    echo "probe $1 did not stream"
    return 1
}

# Waits until NAME.jsonl has N lines and NAME.err holds PATTERN, for at most 30 s.
wait_output() {
    for _ in $(seq 300); do
        if [ "$(wc -l <"$OUT/$1.jsonl" 2>/dev/null)" -ge "$2" ] && grep -q "$3" "$OUT/$1.err"; then
            return 0
        fi
        sleep 0.1
    done
    echo "$1 did not produce $2 lines and \"$3\""
    return 1
}

# Starts feeding FILE to vivid's output node, looping; the feeder's pid is in $feeder. Returns
# once the feeder has queued FEED_WARM_BUFFERS buffers (v4l2-ctl prints a '>' for each), for at
# most 20 s: the output must stream before capture starts, or capture shows noise, and a fixed
# sleep was too short on a loaded machine under TCG.
FEED_WARM_BUFFERS=8
feed() {
    log="$OUT/feed-$(basename "$1").log"
    v4l2-ctl -d /dev/video1 --stream-out-mmap --stream-from="$1" --stream-loop >"$log" 2>&1 &
    feeder=$!
    for _ in $(seq 200); do
        [ "$(tr -cd '>' <"$log" | wc -c)" -ge "$FEED_WARM_BUFFERS" ] && return 0
        sleep 0.1
    done
    echo "feeder of $1 did not stream"
    return 1
}

# 1. The default webcam input: colour bars, 640x480 YUYV, frame rate set to 10 fps.
insmod "$VIVID"
wait_node /dev/video0
probe pattern --device /dev/video0 --size 640x480 --fps 10 --frames 12 --buffers 3 \
    --control brightness=200 --control no_such_control=1 --exposure-us 500
probe bad_size --device /dev/video0 --size 800x600 --frames 1
probe bad_fps --device /dev/video0 --size 640x480 --fps 30 --frames 1
"$PROBE" --list >"$OUT/list.txt" 2>&1
echo "pattern_done_s $(cut -d' ' -f1 /proc/uptime)" >>"$OUT/timing"

# 3. The device disappears while streaming: unbinding the vivid platform device unregisters its
#    nodes under the open file, as unplugging a USB camera does.
probe unplug_plain --device /dev/video0 --fps 10 --frames 1000 --stall-ms 3000 &
pid=$!
wait_frames unplug_plain 3
echo vivid.0 >"$UNBIND"
wait $pid
echo vivid.0 >"$BIND"
wait_node /dev/video0
probe unplug_reopen --device /dev/video0 --fps 10 --frames 30 --reopen --stall-ms 1000 &
pid=$!
wait_frames unplug_reopen 5
echo vivid.0 >"$UNBIND"
sleep 1
echo vivid.0 >"$BIND"
wait $pid
echo "unplug_done_s $(cut -d' ' -f1 /proc/uptime)" >>"$OUT/timing"

# 2. vivid's output-to-capture loop: one HDMI capture node (video0) and one HDMI output node
#    (video1) at 640x480p59.94, OSD text off so frames come back byte-exact. The output streams
#    first; in the other order capture shows noise.
rmmod vivid
insmod "$VIVID" n_devs=1 node_types=0x101 num_inputs=1 input_types=0x3 num_outputs=1 output_types=0x1
wait_node /dev/video1
v4l2-ctl -d /dev/video0 --set-dv-bt-timings index=0
v4l2-ctl -d /dev/video1 --set-dv-bt-timings index=0
v4l2-ctl -d /dev/video0 -c loop_video=1,osd_text_mode=2
v4l2-ctl -d /dev/video1 --set-fmt-video-out=width=640,height=480,pixelformat=YUYV
feed /mnt/in/loop.yuv
probe loop --device /dev/video0 --size 640x480 --frames 16
kill $feeder
wait $feeder 2>/dev/null
echo "loop_done_s $(cut -d' ' -f1 /proc/uptime)" >>"$OUT/timing"

# 4. glint itself on a rendered LED scene fed through the loop: `glint track --device` until
#    SIGTERM (with a summary every second and latency stats), then `glint record` and
#    `glint row-time`.
feed /mnt/in/scene.yuv
probe scene_loop --device /dev/video0 --size 640x480 --frames 8
"$GLINT" track --device /dev/video0 --size 640x480 --summary-every 1 --stats \
    --control no_such_control=1 >"$OUT/track.jsonl" 2>"$OUT/track.err" &
pid=$!
wait_output track 20 "last .* s: "
kill -TERM $pid
wait $pid
echo $? >"$OUT/track.status"
"$GLINT" record --device /dev/video0 --size 640x480 --frames 12 --out /tmp/rec.yuv \
    >"$OUT/record.out" 2>"$OUT/record.err"
echo $? >"$OUT/record.status"
cp /tmp/rec.yuv /tmp/rec.yuv.json "$OUT/"
# `glint row-time` reads the camera too; the loop's LED scene has no flicker bands.
"$GLINT" row-time --device /dev/video0 --size 640x480 --frames 12 \
    >"$OUT/row_time.out" 2>"$OUT/row_time.err"
echo $? >"$OUT/row_time.status"
kill $feeder
wait $feeder 2>/dev/null
"$GLINT" devices >"$OUT/devices.txt" 2>&1
echo "glint_done_s $(cut -d' ' -f1 /proc/uptime)" >>"$OUT/timing"

# 5. A mono camera's GREY and a UYVY camera: vivid loops both formats byte-exact when its
#    output and capture agree. The output is set to the format; glint itself asks the capture
#    node for it (`--format-in`). A fast LED (streaks of 13-40 px) is fed, `glint record`
#    records it, then `glint track --device` runs until FAST_TRACK_REPORTS lines are out.
FAST_RECORD_FRAMES=24
FAST_TRACK_REPORTS=5
for format in grey uyvy; do
    fourcc=$(echo "$format" | tr a-z A-Z)
    v4l2-ctl -d /dev/video1 --set-fmt-video-out=width=640,height=480,pixelformat="$fourcc"
    feed "/mnt/in/fast.$format"
    "$GLINT" record --device /dev/video0 --size 640x480 --format-in "$format" \
        --frames "$FAST_RECORD_FRAMES" --out "$OUT/fast-$format.raw" \
        >"$OUT/record_$format.out" 2>"$OUT/record_$format.err"
    echo $? >"$OUT/record_$format.status"
    "$GLINT" track --device /dev/video0 --size 640x480 --format-in "$format" \
        >"$OUT/track_$format.jsonl" 2>"$OUT/track_$format.err" &
    pid=$!
    wait_output "track_$format" "$FAST_TRACK_REPORTS" "mmap buffers"
    kill -TERM $pid
    wait $pid
    echo $? >"$OUT/track_$format.status"
    kill $feeder
    wait $feeder 2>/dev/null
    echo "${format}_done_s $(cut -d' ' -f1 /proc/uptime)" >>"$OUT/timing"
done
exit 0
