"""Hostile input for the HIL bridge (docs/hil-protocol.md, "Sessions"): corrupt datagrams,
stray peers, out-of-range durations and cut logs, each against the `inchworm` binary in
its own subprocess with a time limit, so a crash or a hang fails the case. Only
127.0.0.1 (and 127.0.0.2, also loopback) is used."""
import os
import pathlib
import random
import re
import select
import signal
import socket
import struct
import subprocess
import threading
import time
import zlib

import pytest

from conftest import ROOT, built_fmu

# INCHWORM_BIN runs the cases against another build (an older binary, to see which of them
# it fails).
BIN = pathlib.Path(os.environ.get("INCHWORM_BIN", ROOT / "target" / "release" / "inchworm"))
LIMIT = 30  # s: far above what any case needs; reaching it is a hang.

SESSION_REFUSED = 8
BUSY, NOT_ALLOWED, NO_SESSION = 1, 2, 3


def binary():
    if not BIN.exists():
        pytest.fail(f"{BIN} is missing: run `cargo build --release -p inchworm` first")
    return str(BIN)


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def frame(ftype, stream, payload, seq=1, version=1):
    """A frame as docs/hil-protocol.md lays it out: header, payload, CRC-32 (zlib's)."""
    body = b"IW" + bytes([version, ftype]) + struct.pack("<HHH", seq, stream, len(payload)) + payload
    return body + struct.pack("<I", zlib.crc32(body))


def hello(lockstep=False, seq=1, period_us=2000):
    return frame(0x01, 0, struct.pack("<BBIBB", 1, 1, period_us, 3, int(lockstep)), seq)


def arm(seq=2):
    return frame(0x02, 0, b"", seq)


def disarm(seq=3):
    return frame(0x03, 0, b"", seq)


def dac(seq, tick=0, codes=(0, 0, 0)):
    return frame(0x10, 1, struct.pack("<IHHH", tick, *codes), seq)


def parse(datagram):
    """(type, seq, payload) of a frame the board sent, after checking every header field
    and the CRC."""
    assert datagram[:3] == b"IW\x01", datagram.hex()
    ftype = datagram[3]
    seq, stream, n = struct.unpack("<HHH", datagram[4:10])
    assert len(datagram) == 14 + n, datagram.hex()
    assert struct.unpack("<I", datagram[10 + n:])[0] == zlib.crc32(datagram[:10 + n]), datagram.hex()
    return ftype, stream, datagram[10:10 + n]


def expect_refusal(sock, detail):
    sock.settimeout(2)
    data = sock.recv(256)
    ftype, stream, payload = parse(data)
    assert (ftype, stream) == (0x04, 0), data.hex()
    # FAULT SessionRefused: reason 8, three reserved zero bytes, the detail.
    assert payload == struct.pack("<B3xI", SESSION_REFUSED, detail), data.hex()


class Board:
    """`inchworm bridge --role board` on 127.0.0.1, up once it has printed its first line
    (its socket is bound by then)."""

    def __init__(self, *extra, lockstep=False, watchdog=25):
        self.port = free_port()
        self.addr = f"127.0.0.1:{self.port}"
        args = [binary(), "bridge", "--role", "board", "--addr", self.addr, "--duration", "60",
                "--watchdog", str(watchdog), "--fmu", built_fmu("InchwormPlant"), *extra]
        if lockstep:
            args.append("--lockstep")
        self.proc = subprocess.Popen(args, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        ready, _, _ = select.select([self.proc.stdout], [], [], LIMIT)
        assert ready, "the board printed nothing"
        first = self.proc.stdout.readline().decode()
        assert first.startswith("virtual board:"), first + self.proc.stderr.read().decode()

    def stop(self):
        """SIGTERM, then its exit status and everything it printed."""
        self.proc.send_signal(signal.SIGTERM)
        try:
            out, err = self.proc.communicate(timeout=LIMIT)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, err = self.proc.communicate()
            pytest.fail("the board did not stop on SIGTERM:\n" + out.decode() + err.decode())
        return self.proc.returncode, out.decode(), err.decode()

    def kill(self):
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.communicate()


@pytest.fixture
def board_factory():
    boards = []

    def make(*extra, **kw):
        b = Board(*extra, **kw)
        boards.append(b)
        return b

    yield make
    for b in boards:
        b.kill()


def sender(ip="127.0.0.1"):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind((ip, 0))
    return s


def controller(addr, *extra, duration="0.3"):
    """A whole controller run; its exit status and output."""
    r = subprocess.run(
        [binary(), "bridge", "--role", "controller", "--addr", addr, "--duration", duration,
         "--dead-after", "25", "--fmu", built_fmu("InchwormController"), *extra],
        cwd=ROOT, capture_output=True, text=True, timeout=LIMIT)
    return r.returncode, r.stdout + r.stderr


def source_line(sock, malformed=0, foreign=0, refused=0, not_allowed=0):
    host, port = sock.getsockname()
    return (f"source {host}:{port}: {malformed} malformed, {foreign} foreign, "
            f"{refused} HELLO refused, {not_allowed} not allowed")


def test_random_bytes_are_counted_per_source_and_lock_nobody_out(board_factory):
    board = board_factory()
    rng = random.Random(13)
    junk = sender()
    datagrams = [b""] + [bytes(rng.randrange(256) for _ in range(rng.randrange(1, 120))) for _ in range(199)]
    for d in datagrams:
        junk.sendto(d, ("127.0.0.1", board.port))
    rc, text = controller(board.addr)
    assert rc == 0, text
    assert "150 ticks in" in text, text
    rc, out, err = board.stop()
    assert rc == 0, out + err
    assert "sessions: 1\n" in out, out
    assert source_line(junk, malformed=200) + "\n" in out, out
    # The refusals are logged, at 1, 2, 4, … per sender.
    assert f"malformed datagram from 127.0.0.1:{junk.getsockname()[1]} refused (" in err, err
    assert "128 from it so far" in err, err


def test_truncated_frames_bad_crc_and_a_huge_datagram_are_refused(board_factory):
    board = board_factory()
    good = hello()
    bad_crc = good[:-1] + bytes([good[-1] ^ 0xFF])
    flipped = bytearray(good)
    flipped[12] ^= 0x04  # period_us, under the CRC
    # The log reports a sender's 1st, 2nd, 4th, 8th, … refusal: the kinds worth reading
    # go first.
    cases = [bad_crc, frame(0x01, 0, good[10:18], version=2), bytes(flipped)]
    cases += [good + bytes(65507 - len(good))]  # the largest UDP datagram, a frame in front
    cases += [good[:n] for n in range(len(good))]  # every truncation, 0 bytes included
    s = sender()
    for c in cases:
        s.sendto(c, ("127.0.0.1", board.port))
    time.sleep(0.2)
    rc, text = controller(board.addr)
    assert rc == 0, text
    rc, out, err = board.stop()
    assert rc == 0, out + err
    assert source_line(s, malformed=len(cases)) + "\n" in out, out
    assert "sessions: 1\n" in out, out
    who = f"malformed datagram from 127.0.0.1:{s.getsockname()[1]} refused"
    for n, why in [(1, "CRC mismatch"), (2, "unsupported protocol version 2"),
                   (4, f"{65507 - len(good)} trailing bytes after the frame"), (16, "frame too short")]:
        assert f"{who} ({why}" in err and f"; {n} from it so far" in err, (why, err)


def test_a_stray_peer_is_told_it_has_no_session_and_binds_nothing(board_factory):
    board = board_factory()
    stray = sender()
    stray.sendto(arm(), ("127.0.0.1", board.port))
    expect_refusal(stray, NO_SESSION)
    stray.sendto(dac(5, codes=(65535, 65535, 65535)), ("127.0.0.1", board.port))
    expect_refusal(stray, NO_SESSION)
    for run in range(2):
        rc, text = controller(board.addr)
        assert rc == 0, (run, text)
    rc, out, err = board.stop()
    assert rc == 0, out + err
    assert "sessions: 2\n" in out, out
    assert source_line(stray, foreign=2) + "\n" in out, out
    assert "ARM frame from" in err and "dropped: it holds no session (the session is nobody's)" in err, err


def test_a_rogue_hello_during_an_armed_session_is_refused_with_the_reason(board_factory):
    # This test is the armed controller itself (a DAC frame every 2 ms from a thread),
    # so it knows the session is armed while the rogue and a whole controller knock. A
    # 500 ms watchdog keeps a Python thread's hiccup from ending the session.
    board = board_factory(watchdog=250)
    owner = sender()
    dest = ("127.0.0.1", board.port)
    owner.sendto(hello(), dest)
    owner.settimeout(2)
    ftype, _, payload = parse(owner.recv(256))
    assert ftype == 0x01 and payload[1] == 2, payload.hex()  # the board's HELLO
    owner.sendto(arm(), dest)
    deadline = time.monotonic() + 2
    while True:
        ftype, _, payload = parse(owner.recv(256))
        if ftype == 0x11 and struct.unpack("<H", payload[8:10])[0] & 1:
            break  # an ENCODER frame that says ARMED
        assert time.monotonic() < deadline, "the board did not arm"
    stop = threading.Event()

    def feed():
        seq = 1
        while not stop.is_set():
            owner.sendto(dac(seq), dest)
            seq = (seq + 1) % 65536
            time.sleep(0.002)

    t = threading.Thread(target=feed)
    t.start()
    try:
        rogue = sender()
        rogue.sendto(hello(), dest)
        expect_refusal(rogue, BUSY)
        rc, text = controller(board.addr)
    finally:
        stop.set()
        t.join(timeout=LIMIT)
    assert rc == 1, text
    assert ("the board refused the session for 5.0 s: SessionRefused: "
            "the board is armed in a session with another controller") in text, text
    owner.sendto(disarm(), dest)
    time.sleep(0.05)
    rc, text = controller(board.addr)
    assert rc == 0, text
    rc, out, err = board.stop()
    assert rc == 0, out + err
    owner_port = owner.getsockname()[1]
    assert "sessions: 2\n" in out, out
    assert f"session 1: controller 127.0.0.1:{owner_port} from tick " in out, out
    assert "1 ARM; ended: disarmed\n" in out, out
    assert source_line(rogue, refused=1) + "\n" in out, out
    assert (f"HELLO from 127.0.0.1:{rogue.getsockname()[1]} refused: "
            f"session 1 with 127.0.0.1:{owner_port} is armed") in err, err


def test_allow_keeps_an_address_out_and_tells_it_why(board_factory):
    board = board_factory("--allow", "127.0.0.1")
    outsider = sender("127.0.0.2")
    outsider.sendto(hello(), ("127.0.0.1", board.port))
    expect_refusal(outsider, NOT_ALLOWED)
    rc, text = controller(board.addr)
    assert rc == 0, text
    rc, out, err = board.stop()
    assert rc == 0, out + err
    assert "sessions: 1\n" in out, out
    assert source_line(outsider, not_allowed=1) + "\n" in out, out
    assert "ignored: not an allowed peer (--allow)" in err, err


@pytest.mark.parametrize("role", ["board", "controller"])
@pytest.mark.parametrize("value", ["inf", "NaN", "-5", "0", "-inf", "1e10", "ten"])
def test_durations_out_of_range_are_refused_before_starting(role, value):
    fmu = built_fmu("InchwormPlant" if role == "board" else "InchwormController")
    r = subprocess.run(
        [binary(), "bridge", "--role", role, "--addr", f"127.0.0.1:{free_port()}",
         "--duration", value, "--fmu", fmu],
        cwd=ROOT, capture_output=True, text=True, timeout=LIMIT)
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"invalid value '{value}' for '--duration <DURATION>'" in r.stderr, r.stderr
    assert "--duration takes a finite number of seconds, 0 < D ≤ 1e9" in r.stderr, r.stderr
    assert "virtual board" not in r.stdout and "controller bridge" not in r.stdout, r.stdout


def records(data):
    """Byte offsets of the records of a run log (docs/hil-protocol.md, "Run log")."""
    assert data[:8] == b"IWLOG\x00\x01\x00"
    at, out = 8, []
    while at < len(data):
        n = struct.unpack("<H", data[at:at + 2])[0]
        out.append((at, data[at + 2]))
        at += 3 + n + 4
    assert at == len(data)
    return out


def replay(log):
    r = subprocess.run([binary(), "replay", str(log), "--fmu", built_fmu("InchwormController")],
                       cwd=ROOT, capture_output=True, text=True, timeout=LIMIT)
    return r.returncode, r.stdout + r.stderr


def test_replay_says_what_a_cut_or_damaged_log_holds(board_factory, tmp_path):
    board = board_factory(lockstep=True)
    log = tmp_path / "controller.log"
    rc, text = controller(board.addr, "--lockstep", "--log", str(log), duration="0.2")
    assert rc == 0, text
    board.stop()
    data = log.read_bytes()
    recs = records(data)
    # Meta, 100 samples, the DISARM event, the end record (kind 5).
    assert len(recs) == 103 and recs[-1][1] == 5, recs[-3:]
    rc, text = replay(log)
    assert rc == 0, text
    assert "103 complete records (100 controller samples, 1 events); end record: completed: 100 ticks, disarmed" in text, text

    end_at = recs[-1][0]
    cases = {
        # As a SIGKILL leaves it: every record whole, no end record.
        "boundary.log": (data[:end_at], 3, ["102 complete records (100 controller samples, 1 events); "
                                            "no end record: the run did not finish cleanly",
                                            "exit status 3: the log is incomplete"]),
        "mid-record.log": (data[:end_at + 5], 3, [f"then a record cut short at byte {end_at}",
                                                  "no end record: the run did not finish cleanly"]),
        "header.log": (data[:5], 1, ["not an inchworm bridge log"]),
        "empty.log": (b"", 1, ["not an inchworm bridge log"]),
    }
    damaged = bytearray(data)
    damaged[recs[10][0] + 5] ^= 0x01
    cases["damaged.log"] = (bytes(damaged), 1, [f"record at byte {recs[10][0]}: CRC mismatch"])
    meta_only = data[:recs[1][0]]
    cases["meta-only.log"] = (meta_only, 1, ["no controller samples", "1 complete records (0 controller samples"])
    for name, (content, code, says) in cases.items():
        p = tmp_path / name
        p.write_bytes(content)
        rc, text = replay(p)
        assert rc == code, (name, text)
        for s in says:
            assert s in text, (name, s, text)


# ---------------------------------------------------------------------------------------
# Sessions that cannot be stolen, floods that grow nothing, outside text cut,
# and what a killed process's log may lose (docs/hil-protocol.md, "Sessions", "Run log").

MODES = [pytest.param(False, id="real-time"), pytest.param(True, id="lock-step")]
ENCODER, FAULT, HELLO = 0x11, 0x04, 0x01


def next_frame(sock, wanted, limit=2.0):
    """The next frame of a type in `wanted` the board sends `sock` (the real-time board
    streams ENCODER frames to its session's peer, which are skipped unless wanted)."""
    sock.settimeout(limit)
    deadline = time.monotonic() + limit
    while True:
        ftype, stream, payload = parse(sock.recv(256))
        if ftype in wanted:
            return ftype, payload
        assert time.monotonic() < deadline, f"no frame of type {wanted} within {limit} s"


def armed(payload):
    return struct.unpack("<H", payload[8:10])[0] & 1 == 1


def handshake_half(sock, port, lockstep):
    """HELLO, and the board's answer: the first half of a handshake, no ARM yet."""
    sock.sendto(hello(lockstep), ("127.0.0.1", port))
    ftype, payload = next_frame(sock, {HELLO, FAULT})
    assert ftype == HELLO and payload[1] == 2, payload.hex()  # the board's HELLO


def summary(out):
    return [l for l in out.splitlines() if l.startswith("session")]


@pytest.mark.parametrize("lockstep", MODES)
def test_a_hello_between_a_controllers_hello_and_arm_takes_nothing(board_factory, lockstep):
    # The real controller had its HELLO answered; a second sender HELLOs before its ARM.
    # It must not take the session: the real controller's ARM is accepted.
    board = board_factory(lockstep=lockstep, watchdog=250)
    owner, rogue = sender(), sender()
    handshake_half(owner, board.port, lockstep)
    handshake_half(rogue, board.port, lockstep)
    owner.sendto(arm(), ("127.0.0.1", board.port))
    ftype, payload = next_frame(owner, {ENCODER, FAULT})
    assert ftype == ENCODER and armed(payload), payload.hex()
    # The rogue completes second: refused, with the reason.
    rogue.sendto(arm(), ("127.0.0.1", board.port))
    expect_refusal(rogue, BUSY)
    rc, out, err = board.stop()
    assert rc == 0, out + err
    lines = summary(out)
    assert lines[0] == "sessions: 1", out
    assert lines[1].startswith(f"session 1: controller 127.0.0.1:{owner.getsockname()[1]} "), out


@pytest.mark.parametrize("lockstep", MODES)
def test_fifty_hellos_during_a_handshake_leave_it_whole(board_factory, lockstep):
    board = board_factory(lockstep=lockstep, watchdog=250)
    owner = sender()
    rogues = [sender() for _ in range(50)]
    handshake_half(owner, board.port, lockstep)
    for r in rogues:
        r.sendto(hello(lockstep), ("127.0.0.1", board.port))
    owner.sendto(arm(), ("127.0.0.1", board.port))
    ftype, payload = next_frame(owner, {ENCODER, FAULT})
    assert ftype == ENCODER and armed(payload), payload.hex()
    for r in rogues:
        r.sendto(arm(), ("127.0.0.1", board.port))
    for r in rogues:
        ftype, payload = next_frame(r, {FAULT})  # after the board's HELLO to it
        assert payload == struct.pack("<B3xI", SESSION_REFUSED, BUSY), payload.hex()
    rc, out, err = board.stop()
    assert rc == 0, out + err
    assert summary(out)[0] == "sessions: 1", out


@pytest.mark.parametrize("lockstep", MODES)
def test_a_hello_that_never_arms_holds_nothing(board_factory, lockstep):
    board = board_factory(lockstep=lockstep)
    idle = sender()
    handshake_half(idle, board.port, lockstep)
    rc, text = controller(board.addr, *(["--lockstep"] if lockstep else []))
    assert rc == 0, text
    assert "150 ticks in" in text, text
    rc, out, err = board.stop()
    assert rc == 0, out + err
    lines = summary(out)
    # One session, the controller's; the unanswered half-handshake is no session at all.
    assert lines[0] == "sessions: 1", out
    assert f"127.0.0.1:{idle.getsockname()[1]}" not in lines[1], out


def flood(port, stop, lockstep, ports=200):
    socks = [sender() for _ in range(ports)]
    datagram = hello(lockstep)
    sent = 0
    while not stop.is_set():
        for s in socks:
            s.sendto(datagram, ("127.0.0.1", port))
        sent += len(socks)
    return sent


@pytest.mark.parametrize("lockstep", MODES)
def test_a_controller_gets_in_through_a_hello_flood_from_many_ports(board_factory, lockstep):
    board = board_factory(lockstep=lockstep)
    stop = threading.Event()
    result = {}
    t = threading.Thread(target=lambda: result.update(sent=flood(board.port, stop, lockstep)))
    t.start()
    try:
        time.sleep(0.1)  # the flood is under way before the controller starts
        rc, text = controller(board.addr, *(["--lockstep"] if lockstep else []))
    finally:
        stop.set()
        t.join(timeout=LIMIT)
    assert rc == 0, text
    assert "150 ticks in" in text, text
    rc, out, err = board.stop()
    assert rc == 0, out + err
    assert result["sent"] > 1000, result
    lines = summary(out)
    assert lines[0] == "sessions: 1", out[:3000]
    # The summary and the log stay small whatever the flood's size: at most one line per
    # counted sender, a burst of 32 refusal lines then 8 a second, the session's events.
    assert len(out.splitlines()) < 100, len(out.splitlines())
    assert len(err.splitlines()) < 32 + 8 * 10 + 10, err[-3000:]


@pytest.mark.parametrize("lockstep", MODES)
def test_many_sessions_leave_a_bounded_summary_that_counts_them_all(board_factory, lockstep):
    board = board_factory(lockstep=lockstep, watchdog=250)
    n = 40
    for i in range(n):
        s = sender()
        handshake_half(s, board.port, lockstep)
        s.sendto(arm(), ("127.0.0.1", board.port))
        ftype, payload = next_frame(s, {ENCODER, FAULT})
        assert ftype == ENCODER and armed(payload), (i, payload.hex())
        s.sendto(disarm(), ("127.0.0.1", board.port))
        s.close()
    rc, out, err = board.stop()
    assert rc == 0, out + err
    lines = summary(out)
    assert lines[0] == f"sessions: {n}", out
    assert lines[1].startswith("sessions 1 to 8: not listed (the board keeps the last 32 "), out
    listed = [l for l in lines if l.startswith("session ") and ": controller " in l]
    assert len(listed) == 32 and listed[0].startswith("session 9: "), out


@pytest.mark.parametrize("lockstep", MODES)
def test_a_hello_flood_on_an_idle_board_writes_a_bounded_log(board_factory, lockstep):
    board = board_factory(lockstep=lockstep)
    socks = [sender() for _ in range(500)]
    for _ in range(4):
        for s in socks:
            s.sendto(hello(lockstep), ("127.0.0.1", board.port))
    # The kernel drops what a flood overfills the board's socket with; a probe HELLO,
    # repeated every 100 ms as a controller repeats it, answered means every datagram
    # that got in before it was handled.
    probe_until_answered(board.port, lockstep)
    rc, out, err = board.stop()
    assert rc == 0, out + err
    assert summary(out)[0] == "sessions: 0", out[:3000]
    assert len(err.splitlines()) < 20, err[:3000]
    assert len(out.splitlines()) < 20, out[:3000]


def refusal_lines(err, why):
    return [l for l in err.splitlines() if why in l]


def probe_until_answered(port, lockstep):
    probe = sender()
    deadline = time.monotonic() + LIMIT
    while True:
        probe.sendto(hello(lockstep), ("127.0.0.1", port))
        ready, _, _ = select.select([probe], [], [], 0.1)
        if ready:
            ftype, _, _ = parse(probe.recv(256))
            assert ftype == HELLO, ftype
            return
        assert time.monotonic() < deadline, "the board never answered the probe"


def test_mismatched_hellos_from_many_ports_are_logged_within_a_budget(board_factory):
    board = board_factory()
    socks = [sender() for _ in range(200)]
    # In batches, each answered before the next, so no datagram is lost to a full socket
    # buffer and every count below is exact.
    for batch in range(0, 200, 25):
        for s in socks[batch:batch + 25]:
            s.sendto(hello(period_us=1000), ("127.0.0.1", board.port))
        for s in socks[batch:batch + 25]:
            next_frame(s, {FAULT})
    rc, out, err = board.stop()
    assert rc == 0, out + err
    logged = refusal_lines(err, "refused: period 1000 µs (board: 2000 µs)")
    # A burst of 32 lines, then 8 a second; the rest are counted in the summary.
    assert 32 <= len(logged) < 32 + 8 * 10, len(logged)
    held = re.search(r"refusal log lines held back by the rate limit \(32 at once, then 8/s\): (\d+)", out)
    assert held and len(logged) + int(held.group(1)) == 64 + 8, (len(logged), out[-1500:])
    assert "sources beyond the first 64: 0 malformed, 0 foreign, 136 HELLO refused, 0 not allowed" in out, out[-1500:]


def test_a_mismatched_hello_flood_from_one_port_is_logged_at_powers_of_two(board_factory):
    board = board_factory()
    s = sender()
    for _ in range(300):
        s.sendto(hello(lockstep=True), ("127.0.0.1", board.port))
        next_frame(s, {FAULT})
    rc, out, err = board.stop()
    assert rc == 0, out + err
    logged = refusal_lines(err, "refused: lock-step true (board: false)")
    assert [l.split("; ")[-1] for l in logged] == [
        f"{n} refused from it so far" for n in (1, 2, 4, 8, 16, 32, 64, 128, 256)], logged
    assert source_line(s, refused=300) + "\n" in out, out


@pytest.mark.parametrize("flag", ["--allow", "--overrun"])
def test_a_megabyte_token_is_cut_in_the_message(flag):
    token = "x" * 100_000
    r = subprocess.run(
        [binary(), "bridge", "--role", "board", "--addr", f"127.0.0.1:{free_port()}",
         flag, token, "--fmu", built_fmu("InchwormPlant")],
        cwd=ROOT, capture_output=True, text=True, timeout=LIMIT)
    assert r.returncode == 2, r.stdout + r.stderr[:2000]
    # clap quotes the value it could not parse once; the bridge's own explanation cuts it.
    assert r.stderr.count(token) == 1, len(r.stderr)
    assert f"{'x' * 64}… (100000 bytes in all)" in r.stderr, r.stderr[-500:]


def log_records(path):
    """(kind, payload) of every whole record of a run log."""
    data = path.read_bytes()
    if len(data) < 8:
        return []  # created, its header not written yet
    assert data[:8] == b"IWLOG\x00\x01\x00"
    at, out = 8, []
    while at + 3 <= len(data):
        n = struct.unpack("<H", data[at:at + 2])[0]
        if at + 3 + n + 4 > len(data):
            break
        out.append((data[at + 2], data[at + 3:at + 3 + n]))
        at += 3 + n + 4
    return out


def wait_for_samples(path, n, kind=2):
    deadline = time.monotonic() + LIMIT
    while True:
        if path.exists() and sum(k == kind for k, _ in log_records(path)) >= n:
            return
        assert time.monotonic() < deadline, f"fewer than {n} samples in {path} within {LIMIT} s"
        time.sleep(0.01)


@pytest.mark.parametrize("lockstep", MODES)
def test_a_killed_controllers_log_lacks_at_most_the_frame_in_flight(board_factory, tmp_path, lockstep):
    board_log = tmp_path / "board.log"
    board = board_factory("--log", str(board_log), lockstep=lockstep)
    log = tmp_path / "controller.log"
    proc = subprocess.Popen(
        [binary(), "bridge", "--role", "controller", "--addr", board.addr, "--duration", "30",
         "--dead-after", "25", "--fmu", built_fmu("InchwormController"), "--log", str(log),
         *(["--lockstep"] if lockstep else [])],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        wait_for_samples(log, 200)
    finally:
        proc.kill()
        proc.communicate(timeout=LIMIT)
    rc, out, err = board.stop()
    assert rc == 0, out + err
    # Controller samples: tick u32, time, reference, counts, 3 codes, status, then seq u16.
    seqs = [struct.unpack("<H", p[32:34])[0] for k, p in log_records(log) if k == 2]
    # Board samples: tick, 3 codes, counts, status, then the DAC seq it took.
    board_seqs = [struct.unpack("<H", p[16:18])[0] for k, p in log_records(board_log) if k == 3]
    assert len(seqs) >= 200, len(seqs)
    assert max(board_seqs) - seqs[-1] in (0, 1), (max(board_seqs), seqs[-1])
    rc, text = replay(log)
    assert rc == 3, text
    assert "no end record: the run did not finish cleanly" in text, text
