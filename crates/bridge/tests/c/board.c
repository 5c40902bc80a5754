/* A driver-board firmware loop in C on the project's C library (libinchworm_hil.a): the
 * lock-step board of docs/hil-protocol.md with the library's codec and watchdog, and a
 * stand-in mechanism with integer arithmetic the Rust test can repeat exactly:
 *     counts += extension_code / 16 - earth_code / 64
 * The watchdog counts in the lock-step sense (docs/hil-protocol.md, "Lock-step: what a
 * missed period is"): DAC transmissions lost in a row, from the sequence gap, latch it;
 * wall-clock silence only counts towards the dead-link bound, since the controller may
 * be slow.
 * Usage: board <udp-port>. Exits after DISARM, or after 1 s without any frame.
 * Prints one summary line: "c board: <steps> steps, <malformed> malformed, counts <n>,
 * state <0|1|2>, fault <reason>". */
#define _POSIX_C_SOURCE 200809L
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>

#include "inchworm_hil.h"

static int sock;
static struct sockaddr_in peer;
static socklen_t peer_len;
static uint16_t enc_seq, ctl_seq;
static uint16_t dac_seq; /* last accepted DAC seq, valid when have_dac_seq */
static int have_dac_seq;

static uint64_t now_us(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static void send_packet(IwPacket *p, uint8_t *keep, size_t *keep_len) {
    uint8_t buf[IW_MAX_FRAME];
    p->seq = (p->frame_type == IW_TYPE_ENCODER) ? ++enc_seq : ++ctl_seq;
    size_t n = iw_encode(p, buf, sizeof buf);
    if (n == 0) {
        fprintf(stderr, "c board: iw_encode refused a frame of type %u\n", p->frame_type);
        exit(3);
    }
    if (keep) {
        memcpy(keep, buf, n);
        *keep_len = n;
    }
    sendto(sock, buf, n, 0, (struct sockaddr *)&peer, peer_len);
}

/* The watchdog just latched: tell the controller why, once. */
static void send_latch(const IwWatchdog *wd, uint8_t *fault) {
    uint32_t detail = 0;
    IwPacket f = {0};
    f.frame_type = IW_TYPE_FAULT;
    f.fault_reason = iw_watchdog_fault_reason(wd, &detail);
    f.fault_detail = detail;
    *fault = f.fault_reason;
    send_packet(&f, NULL, NULL);
}

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: board <udp-port>\n");
        return 2;
    }
    sock = socket(AF_INET, SOCK_DGRAM, 0);
    struct sockaddr_in me = {0};
    me.sin_family = AF_INET;
    me.sin_port = htons((uint16_t)atoi(argv[1]));
    me.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (bind(sock, (struct sockaddr *)&me, sizeof me) != 0) {
        perror("c board: bind");
        return 2;
    }

    IwWatchdog wd;
    iw_watchdog_init_lockstep(&wd, IW_DEFAULT_WATCHDOG_PERIODS, IW_LOCKSTEP_DEAD_LINK_PERIODS);
    uint32_t tick = 0, steps = 0, malformed = 0;
    int32_t counts = 0;
    uint8_t reply[IW_MAX_FRAME];
    size_t reply_len = 0;
    uint64_t last_frame = now_us(), boundary = last_frame + 2000;
    uint8_t fault = 0;

    for (;;) {
        uint64_t now = now_us();
        if (now >= boundary) {
            /* A wall-clock period without a valid DAC frame: towards the dead-link bound. */
            if (iw_watchdog_period_elapsed(&wd) > 0) {
                send_latch(&wd, &fault);
            }
            boundary += 2000;
            if (now - last_frame > 1000000) {
                break;
            }
            continue;
        }
        struct pollfd pfd = {sock, POLLIN, 0};
        if (poll(&pfd, 1, (int)((boundary - now + 999) / 1000)) <= 0) {
            continue;
        }
        uint8_t buf[64];
        peer_len = sizeof peer;
        ssize_t n = recvfrom(sock, buf, sizeof buf, 0, (struct sockaddr *)&peer, &peer_len);
        if (n < 0) {
            continue;
        }
        last_frame = now_us();
        IwPacket p;
        if (iw_decode(buf, (size_t)n, &p) != IW_OK) {
            malformed++;
            continue;
        }
        IwPacket out = {0};
        switch (p.frame_type) {
        case IW_TYPE_HELLO:
            out.frame_type = IW_TYPE_HELLO;
            out.hello_version = IW_VERSION;
            out.hello_role = IW_ROLE_BOARD;
            out.hello_period_us = 2000;
            out.hello_watchdog_periods = IW_DEFAULT_WATCHDOG_PERIODS;
            out.hello_lockstep = 1;
            if (p.hello_version != IW_VERSION || !p.hello_lockstep || p.hello_period_us != 2000) {
                out.frame_type = IW_TYPE_FAULT;
                out.fault_reason = IW_FAULT_PROTOCOL_MISMATCH;
                out.fault_detail = p.hello_version;
            }
            send_packet(&out, NULL, NULL);
            break;
        case IW_TYPE_ARM:
            iw_watchdog_arm(&wd);
            have_dac_seq = 0;
            iw_watchdog_frame_received(&wd);
            boundary = now_us() + 2000;
            out.frame_type = IW_TYPE_ENCODER;
            out.tick = tick;
            out.counts = counts;
            out.status = (uint16_t)(iw_watchdog_status(&wd) | IW_STATUS_LOCKSTEP);
            send_packet(&out, reply, &reply_len);
            break;
        case IW_TYPE_DISARM:
            iw_watchdog_disarm(&wd);
            printf("c board: %u steps, %u malformed, counts %d, state %d, fault %u\n", steps, malformed, counts,
                   iw_watchdog_state(&wd), fault);
            return 0;
        case IW_TYPE_FAULT:
            iw_watchdog_fault(&wd, p.fault_reason, p.fault_detail);
            if (!fault) {
                fault = p.fault_reason;
            }
            break;
        case IW_TYPE_DAC:
            if (have_dac_seq) {
                int16_t d = iw_seq_distance(dac_seq, p.seq);
                if (d <= 0) {
                    break; /* duplicate or stale */
                }
                /* Each lost transmission is a period the controller waited in vain. */
                if (d > 1 && iw_watchdog_frames_lost(&wd, (uint32_t)(d - 1)) > 0) {
                    send_latch(&wd, &fault);
                }
            }
            dac_seq = p.seq;
            have_dac_seq = 1;
            if (iw_watchdog_state(&wd) != IW_STATE_ARMED) {
                out.frame_type = IW_TYPE_ENCODER;
                out.tick = tick;
                out.counts = counts;
                out.status = (uint16_t)(iw_watchdog_status(&wd) | IW_STATUS_LOCKSTEP);
                send_packet(&out, NULL, NULL);
            } else if (p.tick == tick) {
                uint16_t applied[3];
                iw_watchdog_frame_received(&wd);
                boundary = now_us() + 2000;
                iw_watchdog_output(&wd, p.codes, applied);
                counts += (int32_t)(applied[2] / 16) - (int32_t)(applied[0] / 64);
                tick++;
                steps++;
                out.frame_type = IW_TYPE_ENCODER;
                out.tick = tick;
                out.counts = counts;
                out.status = (uint16_t)(iw_watchdog_status(&wd) | IW_STATUS_LOCKSTEP);
                out.echo_seq = p.seq;
                send_packet(&out, reply, &reply_len);
            } else if (p.tick + 1 == tick && reply_len > 0) {
                iw_watchdog_frame_received(&wd);
                boundary = now_us() + 2000;
                sendto(sock, reply, reply_len, 0, (struct sockaddr *)&peer, peer_len);
            }
            break;
        default:
            malformed++;
        }
    }
    printf("c board: %u steps, %u malformed, counts %d, state %d, fault %u\n", steps, malformed, counts,
           iw_watchdog_state(&wd), fault);
    return 0;
}
