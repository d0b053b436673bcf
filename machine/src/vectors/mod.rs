//! Cross-target test vectors: deterministic runs of core logic reduced to a 32-bit digest.
//!
//! The host test suite and the QEMU (Cortex-M4) harness run the same vectors and compare each digest
//! with the expected value recorded here, which proves the core bit-identical on both instruction sets.
//! The interpreter's vectors are in [`gcode`], the planner's, prep's and the step kernel's in
//! [`motion`]; this module sits above both (tests/tests/import_graph.rs).

mod gcode;
mod motion;

pub use gcode::digest_program;

/// FNV-1a over a stream of words: cheap, order-sensitive and identical on every target.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Digest(u32);

impl Default for Digest {
    fn default() -> Self {
        Self::new()
    }
}

impl Digest {
    pub const fn new() -> Self {
        Digest(0x811c_9dc5)
    }

    pub fn bytes(&mut self, data: &[u8]) {
        for &b in data {
            self.0 ^= b as u32;
            self.0 = self.0.wrapping_mul(0x0100_0193);
        }
    }

    pub fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }

    pub fn i64(&mut self, v: i64) {
        self.bytes(&v.to_le_bytes());
    }

    pub fn finish(self) -> u32 {
        self.0
    }
}

/// One named vector: a run of core logic and the digest it must produce.
pub struct Vector {
    pub name: &'static str,
    pub run: fn() -> u32,
    pub expected: u32,
}

/// Every group of vectors, in the order the harnesses run them.
pub(crate) const GROUPS: &[&[Vector]] = &[gcode::VECTORS, motion::VECTORS];

/// Every vector of every group.
pub fn all() -> impl Iterator<Item = &'static Vector> {
    GROUPS.iter().flat_map(|g| g.iter())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_vector_matches_on_the_host() {
        for v in all() {
            assert_eq!(
                (v.run)(),
                v.expected,
                "vector {} = {:#x}",
                v.name,
                (v.run)()
            );
        }
    }
}
