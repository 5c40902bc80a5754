//! CRC-32 as used by IEEE 802.3, zlib and PNG, table-driven with the table built at
//! compile time, so the firmware needs neither a crate nor RAM for it.

const POLY: u32 = 0xEDB8_8320; // 0x04C11DB7 reflected

const TABLE: [u32; 256] = {
    let mut table = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 { POLY ^ (c >> 1) } else { c >> 1 };
            k += 1;
        }
        table[i] = c;
        i += 1;
    }
    table
};

/// CRC-32 of `bytes` (reflected, init 0xFFFFFFFF, final xor 0xFFFFFFFF): the value
/// zlib's `crc32()` and Python's `zlib.crc32` give, so a frame can be checked with any
/// stock tool. Check value: `crc32(b"123456789") == 0xCBF43926`.
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in bytes {
        c = TABLE[((c ^ b as u32) & 0xFF) as usize] ^ (c >> 8);
    }
    c ^ 0xFFFF_FFFF
}
