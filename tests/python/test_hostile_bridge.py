"""Hostile input for the HIL bridge (docs/hil-protocol.md, "Sessions"): corrupt datagrams,
stray peers, out-of-range durations and cut logs, each against the `inchworm` binary in
its own subprocess with a time limit, so a crash or a hang fails the case. Only
127.0.0.1 (and 127.0.0.2, also loopback) is used."""
import os
import pathlib
import random
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

BIN = ROOT / "target" / "release" / "inchworm"
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


def hello(lockstep=False, seq=1):
    return frame(0x01, 0, struct.pack("<BBIBB", 1, 1, 2000, 3, int(lockstep)), seq)


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
