/*
 * glint.h: decoder for glint's serial position packets, for Arduino-class robots.
 *
 * Single header, C99 (also compiles as C++ for Arduino sketches), no malloc, no floating point
 * needed, about 130 bytes of RAM per decoder and message. The wire format is board/protocol/SPEC.md
 * (protocol version 3): COBS frames ending in 0x00, each holding a message id, a postcard body
 * and a CRC-16/CCITT-FALSE.
 *
 * Usage, in the manner of the Pixy2 library:
 *
 *     #include "glint.h"
 *     static struct glint_decoder decoder;
 *     static struct glint_message msg;
 *     static uint8_t mine; // the last frame was this robot's own position update
 *
 *     void setup() { Serial1.begin(115200); glint_decoder_init(&decoder); }
 *
 *     void loop() {
 *         while (Serial1.available() > 0) {
 *             enum glint_result got = glint_decoder_push(&decoder, (uint8_t)Serial1.read(), &msg);
 *             switch (got) {
 *             case GLINT_NONE: // a frame not complete yet
 *                 break;
 *             case GLINT_POSITION:       // a line of its own (one robot)
 *             case GLINT_ROBOT_POSITION: // a line shared by several robots (version 3)
 *                 if (!glint_update_is_for(got, &msg, MY_ROBOT_ID)) { mine = 0; break; }
 *                 mine = 1;
 *                 // msg.position.x, .y: mm when msg.position.units == GLINT_UNITS_FLOOR,
 *                 // else 1/8 px; msg.position.status == GLINT_STATUS_FOUND when seen this frame.
 *                 break;
 *             case GLINT_AGE:
 *                 // Arrives right after the position with msg.age.seq == msg.position.seq: the
 *                 // position was msg.age.age_us old when this frame's last byte arrived, so
 *                 // now it is msg.age.age_us + (micros() - the time this byte was read). On a
 *                 // shared line, only an age right after this robot's own update is its own.
 *                 if (mine) received_at_us = micros();
 *                 mine = 0;
 *                 break;
 *             case GLINT_LED:
 *                 // if (glint_led_is_for(&msg.led, MY_ROBOT_ID)): switch the LED off
 *                 // msg.led.delay_us from now, for msg.led.off_us (0: back on now).
 *                 break;
 *             default:
 *                 mine = 0;
 *                 break;
 *             }
 *         }
 *     }
 *
 * Every error costs one frame; the decoder resynchronises at the next 0x00 by itself. Unknown
 * message ids (from a newer glint) are reported as GLINT_UNKNOWN and can be ignored.
 */
#ifndef GLINT_H
#define GLINT_H

#include <stdint.h>

/* Encoded bytes a decoder holds: 64 takes every message of every protocol version; 23 is enough
 * for position updates alone on a line of its own, 24 for a shared line's robot positions (longer
 * frames are then reported as GLINT_ERR_OVERFLOW). */
#ifndef GLINT_BUFFER_LEN
#define GLINT_BUFFER_LEN 64
#endif
#if GLINT_BUFFER_LEN < 23 || GLINT_BUFFER_LEN > 255
#error "GLINT_BUFFER_LEN must be 23..255"
#endif

#define GLINT_PROTOCOL_VERSION 3
#define GLINT_ID_POSITION 0x01
#define GLINT_ID_HEARTBEAT 0x02
#define GLINT_ID_AGE 0x03
#define GLINT_ID_LED 0x04
#define GLINT_ID_ROBOT_POSITION 0x05

/* The robot id of a LED request addressed to every robot (never a robot position's address). */
#define GLINT_EVERY_ROBOT 0

/* Position units: GLINT_UNITS_FLOOR = 1 mm (mm/s); GLINT_UNITS_PIXELS = 1/8 px (1/8 px/s). */
#define GLINT_UNITS_PIXELS 0
#define GLINT_UNITS_FLOOR 1

#define GLINT_STATUS_LOST 0
#define GLINT_STATUS_FOUND 1
#define GLINT_STATUS_PREDICTED 2

#define GLINT_TRACKER_STARTING 0
#define GLINT_TRACKER_SEARCHING 1
#define GLINT_TRACKER_TRACKING 2
#define GLINT_TRACKER_COASTING 3

/* What one pushed byte produced. */
enum glint_result {
    GLINT_NONE = 0,      /* frame not complete yet (or an empty frame) */
    GLINT_POSITION,      /* msg->position is filled in */
    GLINT_HEARTBEAT,     /* msg->heartbeat is filled in */
    GLINT_AGE,           /* msg->age is filled in (version 2) */
    GLINT_LED,           /* msg->led is filled in (version 2) */
    GLINT_ROBOT_POSITION, /* msg->robot and msg->position are filled in (version 3) */
    GLINT_UNKNOWN,       /* valid frame with an id this decoder does not know: msg->id; skip it */
    GLINT_ERR_OVERFLOW,  /* frame longer than GLINT_BUFFER_LEN, dropped */
    GLINT_ERR_COBS,      /* invalid COBS, dropped */
    GLINT_ERR_SHORT,     /* too short for an id and a CRC, dropped */
    GLINT_ERR_CRC,       /* CRC mismatch (line noise), dropped */
    GLINT_ERR_MALFORMED  /* CRC good but the body of a known id is malformed: msg->id, dropped */
};

struct glint_position {
    uint8_t seq;           /* +1 per update, wraps at 256 */
    uint32_t timestamp_us; /* frame capture time, wraps every 2^32 us: subtract modulo 2^32 */
    uint8_t units;         /* GLINT_UNITS_FLOOR or GLINT_UNITS_PIXELS */
    int16_t x, y;          /* position in units (1 mm or 1/8 px) */
    int16_t vx_per_s, vy_per_s; /* velocity in units per second */
    uint8_t status;        /* GLINT_STATUS_* */
    uint8_t quality;       /* 0 (none) .. 255 (best) */
};

struct glint_heartbeat {
    uint8_t protocol_version;
    uint16_t frame_rate_centihz; /* 3000 = 30.00 frames per second */
    uint32_t dropped_frames;
    uint8_t tracker_state; /* GLINT_TRACKER_* */
};

/* The age of the position update sent just before it (same seq). */
struct glint_age {
    uint8_t seq;       /* the position's seq */
    uint32_t age_us;   /* capture to the last byte of this frame leaving glint, in us */
    uint8_t predicted; /* 1: the position's x, y were extrapolated by age_us */
};

/* "Robot `robot`, switch your LED off for off_us, starting delay_us after at_us." */
struct glint_led {
    uint8_t robot;     /* GLINT_EVERY_ROBOT (0) or one robot's id */
    uint8_t request;   /* +1 per request, wraps at 256 */
    uint32_t at_us;    /* glint's clock (as timestamp_us) when this frame's last byte left */
    uint32_t delay_us; /* from then (or from arrival) until the LED goes off; 0 = at once */
    uint32_t off_us;   /* how long it stays off; 0 = switch it back on now */
};

struct glint_message {
    uint8_t id;    /* the message id of the last frame that had a good CRC */
    uint8_t robot; /* the robot a GLINT_ROBOT_POSITION is for (1..255) */
    struct glint_position position;
    struct glint_heartbeat heartbeat;
    struct glint_age age;
    struct glint_led led;
};

/* Whether a LED request is addressed to the robot with id `my_id`. */
static inline int glint_led_is_for(const struct glint_led *led, uint8_t my_id) {
    return led->robot == GLINT_EVERY_ROBOT || led->robot == my_id;
}

/* Whether a position update (`result` GLINT_POSITION or GLINT_ROBOT_POSITION) is for the robot
 * with id `my_id`: a plain position comes on a line of its own, so it is; a robot position only if
 * addressed to `my_id`. Anything else is not a position update for anyone. */
static inline int glint_update_is_for(enum glint_result result, const struct glint_message *msg,
                                      uint8_t my_id) {
    return result == GLINT_POSITION || (result == GLINT_ROBOT_POSITION && msg->robot == my_id);
}

struct glint_decoder {
    uint8_t buf[GLINT_BUFFER_LEN];
    uint8_t len;
    uint8_t overflowed;
};

static inline void glint_decoder_init(struct glint_decoder *d) {
    d->len = 0;
    d->overflowed = 0;
}

/* CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, not reflected, no final XOR. Bitwise, to spare
 * the 512-byte table on small AVRs; a 20-byte payload is a few hundred cycles. */
static inline uint16_t glint_crc16(const uint8_t *data, uint8_t len) {
    uint16_t crc = 0xFFFFu;
    uint8_t i, bit;
    for (i = 0; i < len; i++) {
        crc = (uint16_t)(crc ^ ((unsigned)data[i] << 8));
        for (bit = 0; bit < 8; bit++) {
            crc = (uint16_t)(((crc & 0x8000u) != 0u) ? (((unsigned)crc << 1) ^ 0x1021u)
                                                     : ((unsigned)crc << 1));
        }
    }
    return crc;
}

/* COBS-decodes buf[0..len) in place; returns the payload length, or -1 if invalid. */
static inline int glint_cobs_decode(uint8_t *buf, uint8_t len) {
    uint8_t src = 0, dst = 0, code, k;
    while (src < len) {
        code = buf[src];
        if (code == 0 || (uint16_t)src + code > len) {
            return -1;
        }
        src++;
        for (k = 1; k < code; k++) {
            buf[dst++] = buf[src++];
        }
        if (code != 0xFF && src < len) {
            buf[dst++] = 0;
        }
    }
    return dst;
}

/* A bounds-checked reader over a payload body; `ok` drops to 0 on any error and stays there. */
struct glint_reader {
    const uint8_t *p;
    uint8_t len, pos, ok;
};

static inline uint8_t glint_read_u8(struct glint_reader *r) {
    if (!r->ok || r->pos >= r->len) {
        r->ok = 0;
        return 0;
    }
    return r->p[r->pos++];
}

static inline uint32_t glint_read_u32_fixed(struct glint_reader *r) {
    uint32_t v = 0;
    uint8_t i;
    for (i = 0; i < 4; i++) {
        v |= (uint32_t)glint_read_u8(r) << (8 * i);
    }
    return v;
}

/* Unsigned LEB128 of at most max_bytes bytes whose last byte is at most last_max (postcard's
 * limits: 3 and 0x03 for 16 bits, 5 and 0x0F for 32 bits). */
static inline uint32_t glint_read_varint(struct glint_reader *r, uint8_t max_bytes, uint8_t last_max) {
    uint32_t v = 0;
    uint8_t i, b;
    for (i = 0; i < max_bytes; i++) {
        b = glint_read_u8(r);
        v |= (uint32_t)(b & 0x7Fu) << (7 * i);
        if ((b & 0x80u) == 0) {
            if (i == max_bytes - 1 && b > last_max) {
                r->ok = 0;
            }
            return v;
        }
    }
    r->ok = 0;
    return 0;
}

static inline uint16_t glint_read_u16_varint(struct glint_reader *r) {
    return (uint16_t)glint_read_varint(r, 3, 0x03);
}

static inline uint32_t glint_read_u32_varint(struct glint_reader *r) {
    return glint_read_varint(r, 5, 0x0F);
}

/* Zigzag: 0 -> 0, 1 -> -1, 2 -> 1, 3 -> -2 ... (no implementation-defined conversions). */
static inline int16_t glint_read_i16_varint(struct glint_reader *r) {
    uint16_t z = glint_read_u16_varint(r);
    uint16_t magnitude = (uint16_t)(z >> 1);
    return (z & 1u) ? (int16_t)(-(int32_t)magnitude - 1) : (int16_t)magnitude;
}

static inline int glint_parse_position(struct glint_reader *r, struct glint_position *p) {
    uint8_t flags;
    p->seq = glint_read_u8(r);
    p->timestamp_us = glint_read_u32_fixed(r);
    flags = glint_read_u8(r);
    p->x = glint_read_i16_varint(r);
    p->y = glint_read_i16_varint(r);
    p->vx_per_s = glint_read_i16_varint(r);
    p->vy_per_s = glint_read_i16_varint(r);
    p->quality = glint_read_u8(r);
    p->status = flags & 0x03u;
    p->units = (flags & 0x04u) ? GLINT_UNITS_FLOOR : GLINT_UNITS_PIXELS;
    return (flags & 0xF8u) == 0 && p->status <= GLINT_STATUS_PREDICTED;
}

static inline int glint_parse_heartbeat(struct glint_reader *r, struct glint_heartbeat *h) {
    h->protocol_version = glint_read_u8(r);
    h->frame_rate_centihz = glint_read_u16_varint(r);
    h->dropped_frames = glint_read_u32_varint(r);
    h->tracker_state = glint_read_u8(r);
    return h->tracker_state <= GLINT_TRACKER_COASTING;
}

static inline int glint_parse_age(struct glint_reader *r, struct glint_age *a) {
    uint8_t flags;
    a->seq = glint_read_u8(r);
    a->age_us = glint_read_u32_varint(r);
    flags = glint_read_u8(r);
    a->predicted = flags & 0x01u;
    return (flags & 0xFEu) == 0;
}

static inline int glint_parse_led(struct glint_reader *r, struct glint_led *l) {
    l->robot = glint_read_u8(r);
    l->request = glint_read_u8(r);
    l->at_us = glint_read_u32_fixed(r);
    l->delay_us = glint_read_u32_varint(r);
    l->off_us = glint_read_u32_varint(r);
    return 1;
}

/* Checks and parses the COBS-decoded payload id ‖ body ‖ crc_lo ‖ crc_hi. */
static inline enum glint_result glint_parse_payload(const uint8_t *payload, uint8_t len,
                                                    struct glint_message *msg) {
    struct glint_reader r;
    uint16_t sent_crc;
    int valid;
    enum glint_result kind;
    if (len < 3) {
        return GLINT_ERR_SHORT;
    }
    sent_crc = (uint16_t)(payload[len - 2] | ((uint16_t)payload[len - 1] << 8));
    if (glint_crc16(payload, (uint8_t)(len - 2)) != sent_crc) {
        return GLINT_ERR_CRC;
    }
    msg->id = payload[0];
    r.p = payload + 1;
    r.len = (uint8_t)(len - 3);
    r.pos = 0;
    r.ok = 1;
    if (msg->id == GLINT_ID_POSITION) {
        valid = glint_parse_position(&r, &msg->position);
        kind = GLINT_POSITION;
    } else if (msg->id == GLINT_ID_HEARTBEAT) {
        valid = glint_parse_heartbeat(&r, &msg->heartbeat);
        kind = GLINT_HEARTBEAT;
    } else if (msg->id == GLINT_ID_AGE) {
        valid = glint_parse_age(&r, &msg->age);
        kind = GLINT_AGE;
    } else if (msg->id == GLINT_ID_LED) {
        valid = glint_parse_led(&r, &msg->led);
        kind = GLINT_LED;
    } else if (msg->id == GLINT_ID_ROBOT_POSITION) {
        msg->robot = glint_read_u8(&r);
        valid = glint_parse_position(&r, &msg->position) && msg->robot != GLINT_EVERY_ROBOT;
        kind = GLINT_ROBOT_POSITION;
    } else {
        return GLINT_UNKNOWN;
    }
    /* Every field read, and every byte used: anything else is not what the id claims. */
    return (valid && r.ok && r.pos == r.len) ? kind : GLINT_ERR_MALFORMED;
}

/* Feeds one byte from the UART. Returns GLINT_NONE until a frame completes, then what it held. */
static inline enum glint_result glint_decoder_push(struct glint_decoder *d, uint8_t byte,
                                                   struct glint_message *msg) {
    enum glint_result result;
    int payload_len;
    if (byte != 0) {
        if (d->len < GLINT_BUFFER_LEN) {
            d->buf[d->len++] = byte;
        } else {
            d->overflowed = 1;
        }
        return GLINT_NONE;
    }
    if (d->overflowed) {
        result = GLINT_ERR_OVERFLOW;
    } else if (d->len == 0) {
        result = GLINT_NONE;
    } else {
        payload_len = glint_cobs_decode(d->buf, d->len);
        result = payload_len < 0 ? GLINT_ERR_COBS
                                 : glint_parse_payload(d->buf, (uint8_t)payload_len, msg);
    }
    d->len = 0;
    d->overflowed = 0;
    return result;
}

#endif /* GLINT_H */
