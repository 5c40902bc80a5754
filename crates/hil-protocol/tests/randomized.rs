//! Seeded randomized robustness: decode and COBS decode never panic, and anything they
//! accept re-encodes to exactly the same bytes (so no two byte strings mean the same).

mod common;
use common::*;
use inchworm_hil_protocol::cobs;
use inchworm_hil_protocol::*;

const CASES: usize = 200_000;

/// FAULT's reserved bytes are ignored on decode and zero on encode; apart from them
/// an accepted frame must be byte-identical to its re-encoding.
fn canonical(bytes: &[u8]) -> Vec<u8> {
    let mut v = bytes.to_vec();
    if v.len() == MIN_FRAME + 8 && v[3] == frame_type::FAULT {
        v[11..14].fill(0);
        reseal(&mut v);
    }
    v
}

fn mutate(rng: &mut XorShift, base: &[u8]) -> Vec<u8> {
    let mut v = base.to_vec();
    for _ in 0..1 + rng.below(3) {
        match rng.below(6) {
            0 if !v.is_empty() => {
                let i = rng.below(v.len());
                v[i] ^= 1 << rng.below(8);
            }
            1 if !v.is_empty() => {
                let i = rng.below(v.len());
                v[i] = rng.byte();
            }
            2 => {
                let n = rng.below(v.len() + 1);
                v.truncate(n);
            }
            3 => {
                let n = rng.below(4);
                v.extend((0..n).map(|_| rng.byte()));
            }
            4 if v.len() > 10 => {
                // Edit a header or payload field, keeping the CRC valid.
                let i = 3 + rng.below(v.len() - 7);
                v[i] = rng.byte();
                if v.len() >= 4 {
                    reseal(&mut v);
                }
            }
            _ => {
                if v.len() >= 4 {
                    reseal(&mut v);
                }
            }
        }
    }
    v
}

#[test]
fn decode_random_and_mutated_frames() {
    let packets = all_packets();
    let mut rng = XorShift(0x1DEA_5EED_2024_0001);
    let (mut ok, mut err) = (0usize, 0usize);
    for i in 0..CASES {
        let bytes = if i % 4 == 0 {
            let n = rng.below(40);
            let mut v: Vec<u8> = (0..n).map(|_| rng.byte()).collect();
            if n >= 3 && rng.below(2) == 0 {
                v[..3].copy_from_slice(&[b'I', b'W', VERSION]);
                if n >= MIN_FRAME {
                    reseal(&mut v);
                }
            }
            v
        } else {
            let base = enc(&packets[rng.below(packets.len())]);
            mutate(&mut rng, &base)
        };
        match decode(&bytes) {
            Ok(p) => {
                ok += 1;
                assert_eq!(enc(&p), canonical(&bytes), "{bytes:02x?}");
            }
            Err(e) => {
                err += 1;
                assert!(!e.to_string().is_empty());
            }
        }
    }
    // The generator must exercise both outcomes substantially.
    assert!(ok > CASES / 20, "only {ok} accepted");
    assert!(err > CASES / 2, "only {err} refused");
}

#[test]
fn cobs_decode_random_and_mutated() {
    let packets = all_packets();
    let mut rng = XorShift(0xC0B5_0000_0000_0003);
    let mut ok = 0usize;
    let mut out = [0u8; 600];
    let mut re = [0u8; 700];
    for i in 0..CASES {
        let src: Vec<u8> = if i % 2 == 0 {
            let n = rng.below(if i % 10 == 0 { 520 } else { 40 });
            (0..n).map(|_| if rng.below(8) == 0 { 0 } else { rng.byte() }).collect()
        } else {
            let frame = enc(&packets[rng.below(packets.len())]);
            let mut c = vec![0u8; cobs::max_encoded_len(frame.len())];
            let n = cobs::encode(&frame, &mut c).unwrap();
            c.truncate(n);
            let mut m = mutate(&mut rng, &c);
            m.retain(|&b| b != 0 || rng.below(4) == 0);
            m
        };
        let small = rng.below(8) == 0;
        let dst = if small { &mut out[..rng.below(30)] } else { &mut out[..] };
        if let Ok(n) = cobs::decode(&src, dst) {
            ok += 1;
            let m = cobs::encode(&dst[..n], &mut re).unwrap();
            assert_eq!(&re[..m], &src[..], "decoded {:02x?}", &dst[..n]);
            let _ = decode(&dst[..n]);
        }
    }
    assert!(ok > CASES / 10, "only {ok} accepted");
}
