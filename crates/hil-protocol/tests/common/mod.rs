// Shared helpers for the integration tests.
#![allow(dead_code)]

use inchworm_hil_protocol::*;

/// Parses "49 57 01 ..." into bytes.
pub fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace().map(|b| u8::from_str_radix(b, 16).unwrap()).collect()
}

/// Recomputes the CRC trailer of a frame after a deliberate edit, so the test reaches
/// the semantic checks behind the CRC.
pub fn reseal(frame: &mut [u8]) {
    let body = frame.len() - 4;
    let crc = crc32(&frame[..body]);
    frame[body..].copy_from_slice(&crc.to_le_bytes());
}

pub fn enc(packet: &Packet) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME];
    let n = encode(packet, &mut buf).unwrap();
    buf[..n].to_vec()
}

/// One packet of every frame type, including edge values.
pub fn all_packets() -> Vec<Packet> {
    let frames = [
        Frame::Hello(Hello {
            version: VERSION,
            role: Role::Controller,
            period_us: 2000,
            watchdog_periods: 3,
            lockstep: false,
        }),
        Frame::Hello(Hello {
            version: 255,
            role: Role::Board,
            period_us: u32::MAX,
            watchdog_periods: 255,
            lockstep: true,
        }),
        Frame::Arm,
        Frame::Disarm,
        Frame::Fault(Fault { reason: FaultReason::Silence, detail: 3 }),
        Frame::Fault(Fault { reason: FaultReason::SequenceGap, detail: u32::MAX }),
        Frame::Fault(Fault { reason: FaultReason::LinkDead, detail: 0 }),
        Frame::Fault(Fault { reason: FaultReason::Corrupt, detail: 17 }),
        Frame::Fault(Fault { reason: FaultReason::Overrun, detail: 1 }),
        Frame::Fault(Fault { reason: FaultReason::Operator, detail: 0 }),
        Frame::Fault(Fault { reason: FaultReason::ProtocolMismatch, detail: 2 }),
        Frame::Dac(DacSample { tick: 0, codes: [0, 0, 0] }),
        Frame::Dac(DacSample { tick: u32::MAX, codes: [65535, 1, 32768] }),
        Frame::Encoder(EncoderSample {
            tick: u32::MAX,
            counts: i32::MIN,
            status: status::ALL,
            echo_seq: 65535,
        }),
        Frame::Encoder(EncoderSample { tick: 1, counts: -1, status: 0, echo_seq: 0 }),
        Frame::Encoder(EncoderSample {
            tick: 2,
            counts: i32::MAX,
            status: status::SAFE | status::OVERRUN,
            echo_seq: 9,
        }),
    ];
    let mut out = Vec::new();
    for f in frames {
        for seq in [0u16, 1, 0x1234, 65534, 65535] {
            out.push(Packet { seq, frame: f });
        }
    }
    out
}

/// Tiny xorshift64* PRNG: deterministic, seedable, no dependency.
pub struct XorShift(pub u64);

impl XorShift {
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    pub fn byte(&mut self) -> u8 {
        self.next_u64() as u8
    }
}
