/* Test driver for board/arduino/glint.h: decodes stdin byte by byte and prints one line per
 * event, in the text form of SPEC.md's test vectors, for tests/c_decoder.rs to compare. Built
 * against the frozen version 1 and 2 headers (tests/c/v1, tests/c/v2) too, which know fewer
 * messages. */
#include <stdio.h>

#include "glint.h"

static const char *units_name(uint8_t units) {
    return units == GLINT_UNITS_FLOOR ? "floor" : "pixels";
}

static const char *status_name(uint8_t status) {
    static const char *const names[] = {"lost", "found", "predicted"};
    return status <= GLINT_STATUS_PREDICTED ? names[status] : "?";
}

static const char *tracker_name(uint8_t state) {
    static const char *const names[] = {"starting", "searching", "tracking", "coasting"};
    return state <= GLINT_TRACKER_COASTING ? names[state] : "?";
}

static void print_position(const struct glint_position *p) {
    printf("seq=%u timestamp_us=%lu units=%s x=%d y=%d vx_per_s=%d vy_per_s=%d status=%s "
           "quality=%u\n",
           (unsigned)p->seq, (unsigned long)p->timestamp_us, units_name(p->units), (int)p->x,
           (int)p->y, (int)p->vx_per_s, (int)p->vy_per_s, status_name(p->status),
           (unsigned)p->quality);
}

int main(void) {
    struct glint_decoder decoder;
    struct glint_message msg;
    int c;
    glint_decoder_init(&decoder);
    while ((c = getchar()) != EOF) {
        switch (glint_decoder_push(&decoder, (uint8_t)c, &msg)) {
        case GLINT_NONE:
            break;
        case GLINT_POSITION:
            printf("position ");
            print_position(&msg.position);
            break;
        case GLINT_HEARTBEAT:
            printf("heartbeat protocol_version=%u frame_rate_centihz=%u dropped_frames=%lu "
                   "tracker_state=%s\n",
                   (unsigned)msg.heartbeat.protocol_version,
                   (unsigned)msg.heartbeat.frame_rate_centihz,
                   (unsigned long)msg.heartbeat.dropped_frames,
                   tracker_name(msg.heartbeat.tracker_state));
            break;
#if GLINT_PROTOCOL_VERSION >= 2
        case GLINT_AGE:
            printf("age seq=%u age_us=%lu predicted=%s\n", (unsigned)msg.age.seq,
                   (unsigned long)msg.age.age_us, msg.age.predicted ? "true" : "false");
            break;
        case GLINT_LED:
            printf("led robot=%u request=%u at_us=%lu delay_us=%lu off_us=%lu\n",
                   (unsigned)msg.led.robot, (unsigned)msg.led.request,
                   (unsigned long)msg.led.at_us, (unsigned long)msg.led.delay_us,
                   (unsigned long)msg.led.off_us);
            break;
#endif
#if GLINT_PROTOCOL_VERSION >= 3
        case GLINT_ROBOT_POSITION:
            printf("robot-position robot=%u ", (unsigned)msg.robot);
            print_position(&msg.position);
            break;
#endif
        case GLINT_UNKNOWN:
            printf("unknown id=0x%02x\n", (unsigned)msg.id);
            break;
        case GLINT_ERR_OVERFLOW:
            printf("error overflow\n");
            break;
        case GLINT_ERR_COBS:
            printf("error cobs\n");
            break;
        case GLINT_ERR_SHORT:
            printf("error short\n");
            break;
        case GLINT_ERR_CRC:
            printf("error crc\n");
            break;
        case GLINT_ERR_MALFORMED:
            printf("error malformed id=0x%02x\n", (unsigned)msg.id);
            break;
        }
    }
    return 0;
}
