/* C round trip of the inchworm HIL protocol through libinchworm_hil.a.
 * Built and run by tests/c_api.rs; prints one line and returns 0 on success. */
#include "inchworm_hil.h"

#include <stdio.h>
#include <string.h>

static int failures = 0;

#define CHECK(cond)                                                            \
    do {                                                                       \
        if (!(cond)) {                                                         \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__,   \
                    #cond);                                                    \
            failures++;                                                        \
        }                                                                      \
    } while (0)

/* The golden DAC frame of the Rust tests and docs/hil-protocol.md. */
static const uint8_t GOLDEN_DAC[24] = {
    0x49, 0x57, 0x01, 0x10, 0x34, 0x12, 0x01, 0x00, 0x0a, 0x00, 0xe8, 0x03,
    0x00, 0x00, 0x00, 0x80, 0x00, 0x00, 0xff, 0xff, 0x1a, 0x58, 0x6b, 0x82};

static void test_dac(void) {
    IwPacket p;
    memset(&p, 0, sizeof p);
    p.frame_type = IW_TYPE_DAC;
    p.seq = 0x1234;
    p.tick = 1000;
    p.codes[0] = 32768;
    p.codes[1] = 0;
    p.codes[2] = 65535;

    uint8_t buf[IW_MAX_FRAME];
    size_t n = iw_encode(&p, buf, sizeof buf);
    CHECK(n == sizeof GOLDEN_DAC);
    CHECK(memcmp(buf, GOLDEN_DAC, sizeof GOLDEN_DAC) == 0);
    CHECK(iw_encode(&p, buf, n - 1) == 0); /* too small */
    CHECK(iw_encode(NULL, buf, sizeof buf) == 0);
    CHECK(iw_encode(&p, NULL, sizeof buf) == 0);

    IwPacket q;
    memset(&q, 0xAB, sizeof q);
    CHECK(iw_decode(buf, n, &q) == IW_OK);
    CHECK(q.frame_type == IW_TYPE_DAC);
    CHECK(q.seq == 0x1234);
    CHECK(q.stream == IW_STREAM_DAC);
    CHECK(q.tick == 1000);
    CHECK(q.codes[0] == 32768 && q.codes[1] == 0 && q.codes[2] == 65535);
    CHECK(q.counts == 0 && q.status == 0 && q.echo_seq == 0);

    /* Every single flipped bit outside magic, version and length gives the CRC error;
       all flips give some error. */
    for (size_t bit = 0; bit < n * 8; bit++) {
        uint8_t bad[IW_MAX_FRAME];
        memcpy(bad, buf, n);
        bad[bit / 8] ^= (uint8_t)(1u << (bit % 8));
        int32_t rc = iw_decode(bad, n, &q);
        size_t byte = bit / 8;
        CHECK(rc < 0);
        if (!(byte < 3 || byte == 8 || byte == 9)) {
            CHECK(rc == IW_ERR_CRC);
        }
    }
    uint8_t bad[IW_MAX_FRAME];
    memcpy(bad, buf, n);
    bad[12] ^= 0x01;
    CHECK(iw_decode(bad, n, &q) == IW_ERR_CRC);
    CHECK(strcmp(iw_error_name(IW_ERR_CRC), "CRC mismatch") == 0);

    /* Other errors. */
    CHECK(iw_decode(buf, 5, &q) == IW_ERR_TOO_SHORT);
    CHECK(iw_decode(buf, n - 1, &q) == IW_ERR_TRUNCATED);
    CHECK(iw_decode(NULL, n, &q) == IW_ERR_NULL);
    CHECK(iw_decode(buf, n, NULL) == IW_ERR_NULL);
    memcpy(bad, buf, n);
    bad[0] = 'X';
    CHECK(iw_decode(bad, n, &q) == IW_ERR_BAD_MAGIC);
}

static void test_encoder(void) {
    IwPacket p;
    memset(&p, 0, sizeof p);
    p.frame_type = IW_TYPE_ENCODER;
    p.seq = 65535;
    p.tick = 4294967295u;
    p.counts = -123456789;
    p.status = IW_STATUS_ARMED | IW_STATUS_OVERRUN | IW_STATUS_LOCKSTEP;
    p.echo_seq = 0x1234;

    uint8_t buf[IW_MAX_FRAME];
    size_t n = iw_encode(&p, buf, sizeof buf);
    CHECK(n == IW_MAX_FRAME);
    CHECK(buf[3] == IW_TYPE_ENCODER);
    CHECK(iw_crc32(buf, n - 4) ==
          ((uint32_t)buf[n - 4] | (uint32_t)buf[n - 3] << 8 |
           (uint32_t)buf[n - 2] << 16 | (uint32_t)buf[n - 1] << 24));

    IwPacket q;
    memset(&q, 0xAB, sizeof q);
    CHECK(iw_decode(buf, n, &q) == IW_OK);
    CHECK(q.frame_type == IW_TYPE_ENCODER);
    CHECK(q.seq == 65535);
    CHECK(q.stream == IW_STREAM_ENCODER);
    CHECK(q.tick == 4294967295u);
    CHECK(q.counts == -123456789);
    CHECK(q.status == (IW_STATUS_ARMED | IW_STATUS_OVERRUN | IW_STATUS_LOCKSTEP));
    CHECK(q.echo_seq == 0x1234);
    CHECK(q.codes[0] == 0 && q.codes[1] == 0 && q.codes[2] == 0);

    uint8_t two[2 * IW_MAX_FRAME];
    memcpy(two, buf, n);
    memcpy(two + n, buf, n);
    CHECK(iw_decode(two, 2 * n, &q) == IW_ERR_TRAILING_BYTES);

    p.status = 0x10; /* undefined bit: refused by the encoder */
    CHECK(iw_encode(&p, buf, sizeof buf) == 0);

    /* Through COBS, as on the serial link. */
    p.status = IW_STATUS_SAFE;
    n = iw_encode(&p, buf, sizeof buf);
    uint8_t coded[IW_MAX_COBS_FRAME];
    size_t m = iw_cobs_encode(buf, n, coded, sizeof coded);
    CHECK(m > n && m <= IW_MAX_COBS_FRAME);
    CHECK(memchr(coded, 0, m) == NULL);
    uint8_t back[IW_MAX_FRAME];
    CHECK(iw_cobs_decode(coded, m, back, sizeof back) == (int32_t)n);
    CHECK(memcmp(back, buf, n) == 0);
    CHECK(iw_cobs_decode(coded, m, back, 3) == IW_ERR_BUFFER_TOO_SMALL);
    coded[1] = 0;
    CHECK(iw_cobs_decode(coded, m, back, sizeof back) == IW_ERR_COBS);
    const uint8_t zero[1] = {0};
    CHECK(iw_cobs_encode(zero, 1, coded, sizeof coded) == 2);
    CHECK(coded[0] == 1 && coded[1] == 1);
}

static void test_control(void) {
    IwPacket p;
    memset(&p, 0, sizeof p);
    p.frame_type = IW_TYPE_HELLO;
    p.hello_version = IW_VERSION;
    p.hello_role = IW_ROLE_BOARD;
    p.hello_period_us = 2000;
    p.hello_watchdog_periods = 3;
    p.hello_lockstep = 1;
    uint8_t buf[IW_MAX_FRAME];
    size_t n = iw_encode(&p, buf, sizeof buf);
    IwPacket q;
    CHECK(n == 22 && iw_decode(buf, n, &q) == IW_OK);
    CHECK(q.hello_version == 1 && q.hello_role == IW_ROLE_BOARD &&
          q.hello_period_us == 2000 && q.hello_watchdog_periods == 3 &&
          q.hello_lockstep == 1 && q.stream == IW_STREAM_CONTROL);
    p.hello_role = 9;
    CHECK(iw_encode(&p, buf, sizeof buf) == 0);

    memset(&p, 0, sizeof p);
    p.frame_type = IW_TYPE_FAULT;
    p.fault_reason = IW_FAULT_SEQUENCE_GAP;
    p.fault_detail = 42;
    n = iw_encode(&p, buf, sizeof buf);
    CHECK(n == 22 && iw_decode(buf, n, &q) == IW_OK);
    CHECK(q.fault_reason == IW_FAULT_SEQUENCE_GAP && q.fault_detail == 42);

    memset(&p, 0, sizeof p);
    p.frame_type = IW_TYPE_ARM;
    p.seq = 7;
    n = iw_encode(&p, buf, sizeof buf);
    CHECK(n == 14 && iw_decode(buf, n, &q) == IW_OK && q.frame_type == IW_TYPE_ARM &&
          q.seq == 7);

    p.frame_type = 0x42;
    CHECK(iw_encode(&p, buf, sizeof buf) == 0);

    CHECK(iw_crc32((const uint8_t *)"123456789", 9) == 0xCBF43926u);
    CHECK(iw_seq_distance(65535, 0) == 1);
    CHECK(iw_seq_distance(0, 65535) == -1);
}

static void test_watchdog(void) {
    const uint32_t limit = 3;
    const uint16_t requested[3] = {100, 200, 300};
    uint16_t out[3];
    IwWatchdog w;
    memset(&w, 0xFF, sizeof w);
    CHECK(iw_watchdog_state(&w) == IW_ERR_NULL); /* not initialised: refused */
    iw_watchdog_init(&w, limit);
    CHECK(iw_watchdog_state(&w) == IW_STATE_DISARMED);
    iw_watchdog_output(&w, requested, out);
    CHECK(out[0] == 0 && out[1] == 0 && out[2] == 0);

    iw_watchdog_arm(&w);
    CHECK(iw_watchdog_status(&w) == IW_STATUS_ARMED);
    iw_watchdog_output(&w, requested, out);
    CHECK(out[0] == 100 && out[1] == 200 && out[2] == 300);

    /* Frames keep it armed. */
    for (int i = 0; i < 10; i++) {
        iw_watchdog_frame_received(&w);
        CHECK(iw_watchdog_period_elapsed(&w) == 0);
    }
    /* limit - 1 silent periods: still armed. */
    for (uint32_t i = 1; i < limit; i++) {
        CHECK(iw_watchdog_period_elapsed(&w) == 0);
        CHECK(iw_watchdog_state(&w) == IW_STATE_ARMED);
        CHECK(iw_watchdog_missed(&w) == i);
    }
    /* The limit-th: safe, reported once. */
    CHECK(iw_watchdog_period_elapsed(&w) == IW_FAULT_SILENCE);
    CHECK(iw_watchdog_state(&w) == IW_STATE_SAFE);
    CHECK(iw_watchdog_status(&w) == IW_STATUS_SAFE);
    uint32_t detail = 0;
    CHECK(iw_watchdog_fault_reason(&w, &detail) == IW_FAULT_SILENCE && detail == limit);
    CHECK(iw_watchdog_period_elapsed(&w) == 0);
    iw_watchdog_output(&w, requested, out);
    CHECK(out[0] == 0 && out[1] == 0 && out[2] == 0);

    /* Latched: frames do not leave it. */
    iw_watchdog_frame_received(&w);
    CHECK(iw_watchdog_period_elapsed(&w) == 0);
    CHECK(iw_watchdog_state(&w) == IW_STATE_SAFE);
    CHECK(iw_watchdog_fault(&w, IW_FAULT_OPERATOR, 0) == IW_OK);
    CHECK(iw_watchdog_fault_reason(&w, NULL) == IW_FAULT_SILENCE); /* first kept */

    /* Only arm does. */
    iw_watchdog_arm(&w);
    CHECK(iw_watchdog_state(&w) == IW_STATE_ARMED);
    CHECK(iw_watchdog_missed(&w) == 0);
    iw_watchdog_output(&w, requested, out);
    CHECK(out[0] == 100 && out[1] == 200 && out[2] == 300);

    CHECK(iw_watchdog_fault(&w, 99, 0) == IW_ERR_INVALID_ARGUMENT);
    iw_watchdog_disarm(&w);
    CHECK(iw_watchdog_state(&w) == IW_STATE_DISARMED);
    CHECK(iw_watchdog_period_elapsed(NULL) == 0);
    iw_watchdog_output(NULL, requested, out);
    CHECK(out[0] == 0 && out[1] == 0 && out[2] == 0);
}

static void test_lockstep_watchdog(void) {
    const uint16_t requested[3] = {100, 200, 300};
    uint16_t out[3];
    uint32_t detail = 0;
    IwWatchdog w;
    iw_watchdog_init_lockstep(&w, 3, IW_LOCKSTEP_DEAD_LINK_PERIODS);
    CHECK(iw_watchdog_state(&w) == IW_STATE_DISARMED);
    iw_watchdog_arm(&w);
    iw_watchdog_frame_received(&w);
    /* A slow controller: wall-clock silence far past the limit is not a missed period. */
    for (uint32_t i = 1; i < IW_LOCKSTEP_DEAD_LINK_PERIODS; i++) {
        CHECK(iw_watchdog_period_elapsed(&w) == 0);
    }
    CHECK(iw_watchdog_state(&w) == IW_STATE_ARMED && iw_watchdog_missed(&w) == 0);
    /* Two lost transmissions are repaired by the repeat; three in a row latch. */
    CHECK(iw_watchdog_frames_lost(&w, 2) == 0);
    iw_watchdog_frame_received(&w);
    CHECK(iw_watchdog_period_elapsed(&w) == 0);
    CHECK(iw_watchdog_frames_lost(&w, 3) == IW_FAULT_SILENCE);
    CHECK(iw_watchdog_fault_reason(&w, &detail) == IW_FAULT_SILENCE && detail == 3);
    iw_watchdog_frame_received(&w);
    iw_watchdog_output(&w, requested, out);
    CHECK(out[0] == 0 && out[1] == 0 && out[2] == 0);

    /* A dead link: LinkDead at the bound, reported once. */
    iw_watchdog_arm(&w);
    for (uint32_t i = 1; i < IW_LOCKSTEP_DEAD_LINK_PERIODS; i++) {
        CHECK(iw_watchdog_period_elapsed(&w) == 0);
    }
    CHECK(iw_watchdog_period_elapsed(&w) == IW_FAULT_LINK_DEAD);
    CHECK(iw_watchdog_fault_reason(&w, &detail) == IW_FAULT_LINK_DEAD &&
          detail == IW_LOCKSTEP_DEAD_LINK_PERIODS);
    CHECK(iw_watchdog_period_elapsed(&w) == 0);

    /* A real-time watchdog leaves gaps to the wall clock; NULL is refused quietly. */
    iw_watchdog_init(&w, 3);
    iw_watchdog_arm(&w);
    CHECK(iw_watchdog_frames_lost(&w, 10) == 0);
    CHECK(iw_watchdog_state(&w) == IW_STATE_ARMED);
    CHECK(iw_watchdog_frames_lost(NULL, 10) == 0);
    iw_watchdog_init_lockstep(NULL, 3, 3);
}

int main(void) {
    test_dac();
    test_encoder();
    test_control();
    test_watchdog();
    test_lockstep_watchdog();
    if (failures != 0) {
        printf("inchworm_hil C round trip: %d check(s) FAILED\n", failures);
        return 1;
    }
    printf("inchworm_hil C round trip: all checks passed\n");
    return 0;
}
