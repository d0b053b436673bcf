//! Frame check sequence: CRC-32/ISO-HDLC (the Ethernet/zlib CRC).
//!
//! Why 32 bits rather than CRC-16/CCITT: the link tests push hundreds of
//! thousands of deliberately corrupted frames through the decoder, and a real
//! job streams millions of frames. A 16-bit check lets about 1 in 65 536
//! corrupted frames through; at those counts that is several undetected bad
//! blocks, which for a machine tool means a wrong move. CRC-32 (Hamming
//! distance 4 up to ~11 kB, far beyond our 256-byte frames) makes that 1 in
//! 4·10⁹ for the cost of two more bytes per frame.
//! ISO-HDLC is the most widely implemented 32-bit variant, so any host tool
//! (Python `zlib.crc32`, Wireshark) can check a captured frame.
//!
//! Four bits at a time from a 16-entry table (64 bytes of flash): two lookups per byte instead
//! of eight shift-and-conditional-xor steps (the bitwise form cost ~179 instructions per received
//! byte on the Cortex-M4 with COBS; the byte-wide 256-entry table would cost 1 KiB of the F411's
//! flash). The STM32F4's CRC unit is not used: it computes CRC-32/MPEG-2 (not reflected) on
//! 32-bit words only, so it would change the protocol's check on both ends, need a software tail
//! for frames that are not whole words, and tie the shared core to one chip's peripheral, for a
//! saving of a few instructions per byte over this table (target-tests `bench_link`).

/// Number of CRC bytes at the end of a raw frame (little-endian).
pub const CRC_LEN: usize = 4;

/// The reflected CRC-32/ISO-HDLC polynomial (0x04C11DB7 bit-reversed).
const POLY_REFLECTED: u32 = 0xEDB8_8320;

/// The CRC of each 4-bit value shifted through the register: entry `n` is `n` after four steps.
const NIBBLE_TABLE: [u32; 16] = {
    let mut table = [0u32; 16];
    let mut n = 0;
    while n < 16 {
        let mut c = n as u32;
        let mut bit = 0;
        while bit < 4 {
            c = if c & 1 != 0 {
                (c >> 1) ^ POLY_REFLECTED
            } else {
                c >> 1
            };
            bit += 1;
        }
        table[n] = c;
        n += 1;
    }
    table
};

/// The register after one nibble: the low four bits shift out through the table.
#[inline(always)]
fn step_nibble(crc: u32) -> u32 {
    // `& 15` keeps the index in the table: the compiler drops the bounds check.
    (crc >> 4) ^ NIBBLE_TABLE[(crc & 15) as usize]
}

/// CRC-32/ISO-HDLC of `bytes`.
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        crc = step_nibble(step_nibble(crc));
    }
    !crc
}

#[cfg(test)]
mod tests {
    use super::crc32;
    use ::crc::{Crc, CRC_32_ISO_HDLC};

    #[test]
    fn check_value() {
        // The catalogue check value for "123456789".
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
    }

    #[test]
    fn equals_the_crc_crate_on_every_length_and_byte() {
        let reference = Crc::<u32>::new(&CRC_32_ISO_HDLC);
        // Every byte value in every position of frames up to the protocol's 256 raw bytes,
        // from a fixed pseudo-random sequence.
        let mut bytes = [0u8; 300];
        let mut x = 0x1234_5678u32;
        for b in bytes.iter_mut() {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            *b = x as u8;
        }
        for len in 0..=bytes.len() {
            assert_eq!(
                crc32(&bytes[..len]),
                reference.checksum(&bytes[..len]),
                "len {len}"
            );
        }
        for v in 0..=255u8 {
            let one = [v; 7];
            assert_eq!(crc32(&one), reference.checksum(&one), "byte {v:#04x}");
        }
    }
}
