//! Property tests of the frame codec and COBS (crates/properties: 10 000 cases each, a
//! fixed seed): every packet proptest can build encodes and decodes back to itself; a
//! frame damaged in transit (a bit flipped, a burst of up to 32 bits, bytes cut or added)
//! is refused, never read as another frame; any bytes at all decode or are refused with a
//! reason, and what is accepted re-encodes to the same bytes; COBS round-trips any bytes
//! and its output never holds the zero delimiter.

mod common;
use common::*;
use inchworm_hil_protocol::*;
use inchworm_properties::{apply, check, edits, Edit};
use proptest::collection::vec;
use proptest::prelude::*;

fn role() -> impl Strategy<Value = Role> {
    prop_oneof![Just(Role::Controller), Just(Role::Board)]
}

fn reason() -> impl Strategy<Value = FaultReason> {
    (1u8..=8).prop_map(|r| FaultReason::from_u8(r).expect("1..=8 are the reasons"))
}

/// Every frame the protocol defines, with any field values it allows.
fn frame() -> impl Strategy<Value = Frame> {
    prop_oneof![
        (any::<u8>(), role(), any::<u32>(), any::<u8>(), any::<bool>()).prop_map(
            |(version, role, period_us, watchdog_periods, lockstep)| {
                Frame::Hello(Hello { version, role, period_us, watchdog_periods, lockstep })
            }
        ),
        Just(Frame::Arm),
        Just(Frame::Disarm),
        (reason(), any::<u32>())
            .prop_map(|(reason, detail)| Frame::Fault(Fault { reason, detail })),
        (any::<u32>(), any::<[u16; 3]>())
            .prop_map(|(tick, codes)| Frame::Dac(DacSample { tick, codes })),
        (any::<u32>(), any::<i32>(), 0..=status::ALL, any::<u16>()).prop_map(
            |(tick, counts, status, echo_seq)| {
                Frame::Encoder(EncoderSample { tick, counts, status, echo_seq })
            }
        ),
    ]
}

fn packet() -> impl Strategy<Value = Packet> {
    (any::<u16>(), frame()).prop_map(|(seq, frame)| Packet { seq, frame })
}

#[test]
fn every_packet_round_trips() {
    check("hil: encode then decode", packet(), |p| {
        let bytes = enc(&p);
        prop_assert_eq!(bytes.len(), p.frame.encoded_len());
        prop_assert_eq!(decode(&bytes), Ok(p));
        Ok(())
    });
}

/// CRC-32 detects every error burst of up to 32 bits: a frame with any such burst, or
/// a frame cut or lengthened, is refused (a damaged frame read as another is the one
/// failure a control link must not have).
#[test]
fn a_damaged_frame_is_refused() {
    let damage = (packet(), any::<usize>(), 1u32..=u32::MAX, 0usize..4, 0u8..3);
    check("hil: a damaged frame", damage, |(p, at, burst, cut, kind)| {
        let mut bytes = enc(&p);
        match kind {
            0 => {
                // A burst of at most 32 bits starting on a byte.
                let i = at % (bytes.len() - 3);
                for (k, b) in burst.to_le_bytes().iter().enumerate() {
                    bytes[i + k] ^= b;
                }
            }
            1 => bytes.truncate(bytes.len() - 1 - cut),
            _ => bytes.extend(std::iter::repeat_n(0xA5, cut + 1)),
        }
        prop_assert!(decode(&bytes).is_err(), "{:?} accepted as {:?}", bytes, decode(&bytes));
        Ok(())
    });
}

/// Any bytes: refused with a reason, or a packet whose encoding is exactly those bytes
/// (FAULT's reserved bytes aside, which decode ignores and encode zeroes).
#[test]
fn any_bytes_decode_or_are_refused_and_accepted_ones_are_canonical() {
    let seeds: Vec<Vec<u8>> = all_packets().iter().map(enc).collect();
    let n = seeds.len();
    let input = prop_oneof![
        vec(any::<u8>(), 0..40),
        (0..n, edits()).prop_map(move |(i, e)| (i, e)).prop_map({
            let seeds = seeds.clone();
            move |(i, e)| apply(&seeds[i], &e)
        }),
        // Edits behind a valid CRC: the checks after it.
        (0..n, edits()).prop_map({
            let seeds = seeds.clone();
            move |(i, e)| {
                let mut v = apply(&seeds[i], &e);
                if v.len() >= MIN_FRAME {
                    reseal(&mut v);
                }
                v
            }
        }),
    ];
    check("hil: any bytes", input, |bytes| {
        if let Ok(p) = decode(&bytes) {
            let mut want = bytes.clone();
            if p.frame.frame_type() == frame_type::FAULT {
                want[11..14].fill(0);
                reseal(&mut want);
            }
            prop_assert_eq!(enc(&p), want);
        }
        Ok(())
    });
}

#[test]
fn cobs_round_trips_any_bytes_without_a_zero() {
    check("hil: COBS", vec(any::<u8>(), 0..600), |data| {
        let mut framed = vec![0u8; cobs::max_encoded_len(data.len())];
        let n = cobs::encode(&data, &mut framed).expect("sized by max_encoded_len");
        prop_assert!(!framed[..n].contains(&0), "a zero in the COBS output");
        let mut back = vec![0u8; data.len().max(1)];
        let m = cobs::decode(&framed[..n], &mut back).expect("its own output decodes");
        prop_assert_eq!(&back[..m], &data[..]);
        Ok(())
    });
}

/// COBS decode of any edit of a valid encoding: bytes or a reason, within the output.
#[test]
fn cobs_decodes_any_edit_or_refuses_it() {
    let input = (vec(any::<u8>(), 0..80), edits());
    check("hil: COBS of edited input", input, |(data, e): (Vec<u8>, Vec<Edit>)| {
        let mut framed = vec![0u8; cobs::max_encoded_len(data.len())];
        let n = cobs::encode(&data, &mut framed).expect("sized by max_encoded_len");
        let edited = apply(&framed[..n], &e);
        let mut out = vec![0u8; 128];
        if let Ok(m) = cobs::decode(&edited, &mut out) {
            prop_assert!(m <= out.len());
        }
        Ok(())
    });
}
