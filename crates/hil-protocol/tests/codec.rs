//! Frame codec: golden bytes, round trips and every kind of malformed input.

mod common;
use common::*;
use inchworm_hil_protocol::*;

const GOLDEN_DAC: &str = "49 57 01 10 34 12 01 00 0a 00 e8 03 00 00 00 80 00 00 ff ff 1a 58 6b 82";
const GOLDEN_ENCODER: &str =
    "49 57 01 11 07 00 02 00 0c 00 e8 03 00 00 fe ff ff ff 09 00 34 12 b6 c9 c5 43";

fn golden_dac_packet() -> Packet {
    Packet { seq: 0x1234, frame: Frame::Dac(DacSample { tick: 1000, codes: [32768, 0, 65535] }) }
}

fn golden_encoder_packet() -> Packet {
    Packet {
        seq: 7,
        frame: Frame::Encoder(EncoderSample {
            tick: 1000,
            counts: -2,
            status: status::ARMED | status::LOCKSTEP,
            echo_seq: 0x1234,
        }),
    }
}

#[test]
fn crc_matches_zlib_check_values() {
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    assert_eq!(crc32(b""), 0);
    assert_eq!(crc32(b"The quick brown fox jumps over the lazy dog"), 0x414F_A339);
}

#[test]
fn golden_dac_frame() {
    let bytes = hex(GOLDEN_DAC);
    assert_eq!(enc(&golden_dac_packet()), bytes);
    assert_eq!(decode(&bytes), Ok(golden_dac_packet()));
    assert_eq!(bytes.len(), 24);
}

#[test]
fn golden_encoder_frame() {
    let bytes = hex(GOLDEN_ENCODER);
    assert_eq!(enc(&golden_encoder_packet()), bytes);
    assert_eq!(decode(&bytes), Ok(golden_encoder_packet()));
    assert_eq!(bytes.len(), MAX_FRAME);
}

#[test]
fn control_frames_golden_layout() {
    let arm = enc(&Packet { seq: 65535, frame: Frame::Arm });
    assert_eq!(&arm[..10], &hex("49 57 01 02 ff ff 00 00 00 00")[..]);
    assert_eq!(arm.len(), MIN_FRAME);
    let fault = enc(&Packet {
        seq: 1,
        frame: Frame::Fault(Fault { reason: FaultReason::Overrun, detail: 0x0102_0304 }),
    });
    assert_eq!(&fault[..18], &hex("49 57 01 04 01 00 00 00 08 00 05 00 00 00 04 03 02 01")[..]);
    let hello = enc(&Packet {
        seq: 0,
        frame: Frame::Hello(Hello {
            version: 1,
            role: Role::Board,
            period_us: 2000,
            watchdog_periods: 3,
            lockstep: true,
        }),
    });
    assert_eq!(&hello[..18], &hex("49 57 01 01 00 00 00 00 08 00 01 02 d0 07 00 00 03 01")[..]);
}

#[test]
fn every_frame_type_round_trips() {
    let mut types = std::collections::BTreeSet::new();
    for p in all_packets() {
        let bytes = enc(&p);
        assert_eq!(bytes.len(), p.frame.encoded_len());
        assert!(bytes.len() <= MAX_FRAME);
        assert_eq!(bytes[3], p.frame.frame_type());
        assert_eq!(u16::from_le_bytes([bytes[6], bytes[7]]), p.frame.stream());
        assert_eq!(decode(&bytes), Ok(p), "{p:?}");
        types.insert(p.frame.frame_type());
    }
    assert_eq!(types.len(), 6);
}

#[test]
fn encode_refuses_small_buffer_and_writes_nothing() {
    let p = golden_encoder_packet();
    let mut buf = [0xAAu8; MAX_FRAME - 1];
    assert_eq!(encode(&p, &mut buf), Err(EncodeError::BufferTooSmall { needed: 26 }));
    assert!(buf.iter().all(|&b| b == 0xAA));
    let mut big = [0u8; 64];
    assert_eq!(encode(&p, &mut big), Ok(26));
}

#[test]
fn too_short_inputs() {
    assert_eq!(decode(&[]), Err(DecodeError::TooShort { len: 0 }));
    let g = hex(GOLDEN_DAC);
    for n in 1..MIN_FRAME {
        assert_eq!(decode(&g[..n]), Err(DecodeError::TooShort { len: n }));
    }
    // Long enough for a header but shorter than announced.
    for n in MIN_FRAME..g.len() {
        assert_eq!(decode(&g[..n]), Err(DecodeError::Truncated { len: n, needed: 24 }));
    }
}

#[test]
fn bad_magic_and_version() {
    let mut g = hex(GOLDEN_DAC);
    g[0] = b'X';
    reseal(&mut g);
    assert_eq!(decode(&g), Err(DecodeError::BadMagic));
    let mut g = hex(GOLDEN_DAC);
    g[1] = b'w';
    assert_eq!(decode(&g), Err(DecodeError::BadMagic));
    let mut g = hex(GOLDEN_DAC);
    g[2] = 2;
    reseal(&mut g);
    assert_eq!(decode(&g), Err(DecodeError::UnsupportedVersion(2)));
    g[2] = 0;
    reseal(&mut g);
    assert_eq!(decode(&g), Err(DecodeError::UnsupportedVersion(0)));
}

#[test]
fn unknown_type() {
    for t in [0x00u8, 0x05, 0x0F, 0x12, 0xFF] {
        let mut g = hex(GOLDEN_DAC);
        g[3] = t;
        reseal(&mut g);
        assert_eq!(decode(&g), Err(DecodeError::UnknownType(t)));
    }
}

#[test]
fn wrong_stream_for_type() {
    let mut g = hex(GOLDEN_DAC);
    g[6] = 2; // DAC on the encoder stream
    reseal(&mut g);
    assert_eq!(decode(&g), Err(DecodeError::WrongStream { frame_type: 0x10, stream: 2 }));
    let mut g = hex(GOLDEN_ENCODER);
    g[6] = 0;
    reseal(&mut g);
    assert_eq!(decode(&g), Err(DecodeError::WrongStream { frame_type: 0x11, stream: 0 }));
    let mut arm = enc(&Packet { seq: 0, frame: Frame::Arm });
    arm[7] = 1; // stream 256
    reseal(&mut arm);
    assert_eq!(decode(&arm), Err(DecodeError::WrongStream { frame_type: 0x02, stream: 256 }));
}

/// Builds a frame with the golden DAC header but an arbitrary payload length (and
/// matching buffer), CRC valid.
fn dac_with_payload_len(n: usize) -> Vec<u8> {
    let g = hex(GOLDEN_DAC);
    let mut f = g[..10].to_vec();
    f[8..10].copy_from_slice(&(n as u16).to_le_bytes());
    f.extend(vec![0x5A; n]);
    f.extend([0; 4]);
    reseal(&mut f);
    f
}

#[test]
fn length_field_mismatch() {
    // Too long and too short, consistent with the buffer: BadLength.
    for n in [0usize, 9, 11, 12, 300] {
        assert_eq!(
            decode(&dac_with_payload_len(n)),
            Err(DecodeError::BadLength { frame_type: 0x10, len: n as u16 })
        );
    }
    // Announcing more than the buffer holds: Truncated.
    let mut g = hex(GOLDEN_DAC);
    g[8] = 11;
    assert_eq!(decode(&g), Err(DecodeError::Truncated { len: 24, needed: 25 }));
    g[8] = 0xFF;
    g[9] = 0xFF;
    assert_eq!(decode(&g), Err(DecodeError::Truncated { len: 24, needed: 14 + 65535 }));
    // Announcing less than the buffer holds: TrailingBytes.
    let mut g = hex(GOLDEN_DAC);
    g[8] = 8;
    assert_eq!(decode(&g), Err(DecodeError::TrailingBytes { extra: 2 }));
}

#[test]
fn trailing_bytes_refused() {
    for extra in [1usize, 2, 26, 1000] {
        let mut g = hex(GOLDEN_ENCODER);
        g.extend(vec![0; extra]);
        assert_eq!(decode(&g), Err(DecodeError::TrailingBytes { extra }));
    }
    // Two frames back to back are not one frame.
    let mut two = hex(GOLDEN_DAC);
    two.extend(hex(GOLDEN_DAC));
    assert_eq!(decode(&two), Err(DecodeError::TrailingBytes { extra: 24 }));
}

#[test]
fn every_single_bit_flip_is_refused() {
    for p in all_packets() {
        let good = enc(&p);
        for bit in 0..good.len() * 8 {
            let mut bad = good.clone();
            bad[bit / 8] ^= 1 << (bit % 8);
            let r = decode(&bad);
            assert!(r.is_err(), "bit {bit} of {p:?} gave {r:?}");
            // Outside magic, version and length the CRC must be what catches it.
            let byte = bit / 8;
            if !(byte < 3 || byte == 8 || byte == 9) {
                assert!(matches!(r, Err(DecodeError::BadCrc { .. })), "bit {bit}: {r:?}");
            }
        }
    }
}

#[test]
fn bad_crc_reports_both_values() {
    let mut g = hex(GOLDEN_DAC);
    g[12] ^= 0x10;
    let found = crc32(&g[..20]);
    assert_eq!(decode(&g), Err(DecodeError::BadCrc { expected: 0x826B_581A, found }));
    let msg = decode(&g).unwrap_err().to_string();
    assert!(msg.starts_with("CRC mismatch: frame says 0x826b581a, bytes give 0x"), "{msg}");
}

#[test]
fn bad_payload_values() {
    let hello = enc(&Packet {
        seq: 0,
        frame: Frame::Hello(Hello {
            version: 1,
            role: Role::Controller,
            period_us: 2000,
            watchdog_periods: 3,
            lockstep: false,
        }),
    });
    for role in [0u8, 3, 255] {
        let mut f = hello.clone();
        f[11] = role;
        reseal(&mut f);
        assert!(matches!(decode(&f), Err(DecodeError::BadPayload(_))), "role {role}");
    }
    for flags in [2u8, 0x80, 0xFF] {
        let mut f = hello.clone();
        f[17] = flags;
        reseal(&mut f);
        assert!(matches!(decode(&f), Err(DecodeError::BadPayload(_))), "flags {flags}");
    }
    let fault = enc(&Packet {
        seq: 0,
        frame: Frame::Fault(Fault { reason: FaultReason::Operator, detail: 0 }),
    });
    for reason in [0u8, 9, 255] {
        let mut f = fault.clone();
        f[10] = reason;
        reseal(&mut f);
        assert!(matches!(decode(&f), Err(DecodeError::BadPayload(_))), "reason {reason}");
    }
    for bit in 4..16 {
        let mut f = hex(GOLDEN_ENCODER);
        let s = (status::ARMED | 1 << bit).to_le_bytes();
        f[18..20].copy_from_slice(&s);
        reseal(&mut f);
        assert!(matches!(decode(&f), Err(DecodeError::BadPayload(_))), "status bit {bit}");
    }
}

#[test]
fn fault_reserved_bytes_are_zero_on_encode_and_ignored_on_decode() {
    let p =
        Packet { seq: 3, frame: Frame::Fault(Fault { reason: FaultReason::Corrupt, detail: 5 }) };
    let mut f = enc(&p);
    assert_eq!(&f[11..14], &[0, 0, 0]);
    f[11..14].copy_from_slice(&[1, 2, 3]);
    reseal(&mut f);
    assert_eq!(decode(&f), Ok(p));
}

#[test]
fn error_messages_are_readable() {
    let cases: Vec<(DecodeError, &str)> = vec![
        (DecodeError::TooShort { len: 3 }, "frame too short: 3 bytes"),
        (DecodeError::BadMagic, "bad magic"),
        (DecodeError::UnsupportedVersion(9), "unsupported protocol version 9"),
        (DecodeError::UnknownType(0x42), "unknown frame type 0x42"),
        (
            DecodeError::WrongStream { frame_type: 0x10, stream: 2 },
            "frame type 0x10 does not travel on stream 2",
        ),
        (DecodeError::BadLength { frame_type: 0x10, len: 3 }, "fixed payload length, not 3"),
        (DecodeError::TrailingBytes { extra: 2 }, "2 trailing bytes"),
        (
            DecodeError::Truncated { len: 20, needed: 24 },
            "truncated frame: 20 bytes, the header announces 24",
        ),
        (DecodeError::BadPayload("x"), "invalid payload: x"),
    ];
    for (e, want) in cases {
        assert!(e.to_string().contains(want), "{e}");
    }
    assert_eq!(
        EncodeError::BufferTooSmall { needed: 26 }.to_string(),
        "output buffer too small: the frame needs 26 bytes"
    );
}
