//! COBS: published vectors, strictness, and round trips of every frame.

mod common;
use common::*;
use inchworm_hil_protocol::cobs::{self, CobsError};
use inchworm_hil_protocol::*;

fn c_enc(src: &[u8]) -> Vec<u8> {
    let mut dst = vec![0u8; cobs::max_encoded_len(src.len())];
    let n = cobs::encode(src, &mut dst).unwrap();
    dst.truncate(n);
    dst
}

fn c_dec(src: &[u8]) -> Result<Vec<u8>, CobsError> {
    let mut dst = vec![0u8; src.len()];
    cobs::decode(src, &mut dst).map(|n| dst[..n].to_vec())
}

/// The examples of the COBS article on Wikipedia (delimiter removed).
#[test]
fn published_vectors() {
    let seq = |a: u16, b: u16| (a..=b).map(|x| x as u8).collect::<Vec<u8>>();
    let mut cases: Vec<(Vec<u8>, Vec<u8>)> = vec![
        (vec![], vec![0x01]),
        (vec![0x00], vec![0x01, 0x01]),
        (vec![0x00, 0x00], vec![0x01, 0x01, 0x01]),
        (vec![0x00, 0x11, 0x00], vec![0x01, 0x02, 0x11, 0x01]),
        (vec![0x11, 0x22, 0x00, 0x33], vec![0x03, 0x11, 0x22, 0x02, 0x33]),
        (vec![0x11, 0x22, 0x33, 0x44], vec![0x05, 0x11, 0x22, 0x33, 0x44]),
        (vec![0x11, 0x00, 0x00, 0x00], vec![0x02, 0x11, 0x01, 0x01, 0x01]),
    ];
    // 01..FE (254 nonzero bytes) -> FF 01..FE
    cases.push((seq(1, 254), [vec![0xFF], seq(1, 254)].concat()));
    // 00 01..FE (255 bytes) -> 01 FF 01..FE
    cases.push(([vec![0], seq(1, 254)].concat(), [vec![0x01, 0xFF], seq(1, 254)].concat()));
    // 01..FF (255 bytes) -> FF 01..FE 02 FF
    cases.push((seq(1, 255), [vec![0xFF], seq(1, 254), vec![0x02, 0xFF]].concat()));
    // 02..FF 00 (255 bytes) -> FF 02..FF 01 01
    cases.push((
        [seq(2, 255), vec![0]].concat(),
        [vec![0xFF], seq(2, 255), vec![0x01, 0x01]].concat(),
    ));
    // 03..FF 00 01 (255 bytes) -> FE 03..FF 02 01
    cases.push((
        [seq(3, 255), vec![0, 1]].concat(),
        [vec![0xFE], seq(3, 255), vec![0x02, 0x01]].concat(),
    ));
    for (raw, coded) in cases {
        assert_eq!(c_enc(&raw), coded, "encode {raw:02x?}");
        assert!(coded.len() <= cobs::max_encoded_len(raw.len()));
        if raw.is_empty() {
            assert_eq!(c_dec(&coded), Ok(vec![]));
        } else {
            assert_eq!(c_dec(&coded), Ok(raw.clone()), "decode {coded:02x?}");
        }
    }
}

#[test]
fn strict_decoder() {
    assert_eq!(c_dec(&[]), Err(CobsError::Empty));
    assert_eq!(c_dec(&[0x03, 0x11, 0x00]), Err(CobsError::ZeroByte { at: 2 }));
    assert_eq!(c_dec(&[0x05, 0x11, 0x22]), Err(CobsError::Truncated { at: 0 }));
    assert_eq!(c_dec(&[0x02, 0x11, 0x03, 0x22]), Err(CobsError::Truncated { at: 2 }));
    let mut full: Vec<u8> = vec![0xFF];
    full.extend(1..=254u8);
    full.push(0x01); // empty final group after a full one: decodable, not canonical
    assert_eq!(c_dec(&full), Err(CobsError::NonCanonical));
    let mut small = [0u8; 1];
    assert_eq!(
        cobs::decode(&[0x03, 1, 2], &mut small),
        Err(CobsError::OutputTooSmall { needed: 2 })
    );
    let mut small = [0u8; 2];
    assert_eq!(cobs::encode(&[1, 2], &mut small), Err(EncodeError::BufferTooSmall { needed: 3 }));
}

#[test]
fn max_encoded_len_bounds() {
    assert_eq!(cobs::max_encoded_len(0), 1);
    assert_eq!(cobs::max_encoded_len(MAX_FRAME), 27);
    let mut rng = XorShift(7);
    for len in 0..800 {
        let data: Vec<u8> =
            (0..len).map(|_| if rng.below(4) == 0 { 0 } else { rng.byte() | 1 }).collect();
        assert!(c_enc(&data).len() <= cobs::max_encoded_len(len));
        let ones = vec![1u8; len];
        assert!(c_enc(&ones).len() <= cobs::max_encoded_len(len));
    }
}

#[test]
fn every_frame_round_trips_through_cobs_without_zeros() {
    for p in all_packets() {
        let frame = enc(&p);
        let coded = c_enc(&frame);
        assert!(!coded.contains(&0), "{coded:02x?}");
        assert!(coded.len() <= cobs::max_encoded_len(MAX_FRAME));
        let back = c_dec(&coded).unwrap();
        assert_eq!(back, frame);
        assert_eq!(decode(&back), Ok(p));
    }
}

/// A serial byte stream: frames split on 0x00, garbage and a cut frame in between.
#[test]
fn stream_resynchronises_at_delimiters() {
    let packets = all_packets();
    let mut wire = vec![0x13, 0x37, 0x00]; // garbage, then a delimiter
    for p in &packets {
        wire.extend(c_enc(&enc(p)));
        wire.push(0);
    }
    let cut = c_enc(&enc(&packets[0]));
    wire.extend(&cut[..cut.len() / 2]); // a frame cut short by a reset
    wire.push(0);
    wire.push(0); // empty frame
    let mut got = Vec::new();
    let mut bad = 0;
    for chunk in wire.split(|&b| b == 0) {
        match c_dec(chunk).ok().and_then(|f| decode(&f).ok()) {
            Some(p) => got.push(p),
            None => bad += 1,
        }
    }
    assert_eq!(got, packets);
    assert!(bad >= 2);
}
