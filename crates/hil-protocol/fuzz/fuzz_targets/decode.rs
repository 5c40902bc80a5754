//! Arbitrary bytes into the frame decoder and the COBS decoder: neither may panic, and
//! anything either accepts must re-encode to exactly the input bytes (FAULT's reserved
//! bytes, which the decoder ignores, excepted), so no two byte strings mean the same.
#![no_main]

use inchworm_hil_protocol::{cobs, crc32, decode, encode, frame_type, MAX_FRAME, MIN_FRAME};
use libfuzzer_sys::fuzz_target;

fn check_frame(data: &[u8]) {
    if let Ok(packet) = decode(data) {
        let mut buf = [0u8; MAX_FRAME];
        let n = encode(&packet, &mut buf).expect("a decoded packet always encodes");
        let mut want = [0u8; MAX_FRAME];
        want[..data.len()].copy_from_slice(data);
        if data.len() == MIN_FRAME + 8 && data[3] == frame_type::FAULT {
            want[11..14].fill(0);
            let crc = crc32(&want[..18]);
            want[18..22].copy_from_slice(&crc.to_le_bytes());
        }
        assert_eq!(&buf[..n], &want[..data.len()], "re-encoding differs");
        assert_eq!(decode(&buf[..n]), Ok(packet));
    }
}

fuzz_target!(|data: &[u8]| {
    check_frame(data);

    let mut out = [0u8; 1024];
    if let Ok(n) = cobs::decode(data, &mut out) {
        let mut re = [0u8; 1100];
        let m = cobs::encode(&out[..n], &mut re).expect("re-encoding fits");
        assert_eq!(&re[..m], data, "COBS re-encoding differs");
        check_frame(&out[..n]);
    }
});
