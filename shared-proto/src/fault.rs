//! Fault injection for tests: a one-way byte pipe that drops, corrupts,
//! duplicates and delays bytes with given probabilities, driven by a seeded
//! deterministic PRNG so every failure reproduces from its seed.
//!
//! It is no_std and allocation-free (a fixed ring of `N` bytes), so the same
//! pipe serves unit tests, the whole-system tests in `tests/` and, if ever
//! wanted, an on-target soak test. Order is preserved: a delayed byte also
//! holds back the bytes behind it, like a stalled USB endpoint.

use crate::frame::MAX_FRAME_LEN;
use heapless::Deque;

/// SplitMix64: tiny, fast, good enough for test randomness; not cryptographic.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub const fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub fn next_u32(&mut self) -> u32 {
        (self.next_u64() >> 32) as u32
    }

    /// Uniform in `0..n` (`n` > 0).
    pub fn below(&mut self, n: u32) -> u32 {
        ((self.next_u32() as u64 * n as u64) >> 32) as u32
    }

    /// True with probability `ppm` parts per million.
    pub fn chance(&mut self, ppm: u32) -> bool {
        ppm != 0 && self.below(1_000_000) < ppm
    }

    /// Fills `buf` with random bytes.
    pub fn fill(&mut self, buf: &mut [u8]) {
        for chunk in buf.chunks_mut(8) {
            let v = self.next_u64().to_le_bytes();
            chunk.copy_from_slice(&v[..chunk.len()]);
        }
    }
}

/// Fault probabilities, per byte, in parts per million (10 000 = 1 %).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Faults {
    /// The byte is lost.
    pub drop_ppm: u32,
    /// The byte is replaced by a different random value.
    pub corrupt_ppm: u32,
    /// The byte is delivered twice.
    pub duplicate_ppm: u32,
    /// The byte (and everything after it) is held back for 1..=`max_delay`.
    pub delay_ppm: u32,
    /// Longest delay, in the caller's time unit.
    pub max_delay: u32,
}

impl Faults {
    /// A perfect pipe.
    pub const NONE: Faults = Faults {
        drop_ppm: 0,
        corrupt_ppm: 0,
        duplicate_ppm: 0,
        delay_ppm: 0,
        max_delay: 0,
    };

    /// `pct_each` percent of drops, corruptions and duplicates.
    pub const fn uniform(ppm_each: u32) -> Faults {
        Faults {
            drop_ppm: ppm_each,
            corrupt_ppm: ppm_each,
            duplicate_ppm: ppm_each,
            delay_ppm: 0,
            max_delay: 0,
        }
    }
}

/// What the pipe did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FaultStats {
    pub written: u64,
    pub delivered: u64,
    pub dropped: u64,
    pub corrupted: u64,
    pub duplicated: u64,
    pub delayed: u64,
    /// Bytes lost because the ring was full.
    pub overflowed: u64,
}

/// A one-way lossy pipe holding at most `N` bytes in transit.
pub struct FaultyPipe<const N: usize> {
    rng: Rng,
    faults: Faults,
    ring: Deque<(u32, u8), N>,
    last_release: u32,
    stats: FaultStats,
}

impl<const N: usize> FaultyPipe<N> {
    pub fn new(seed: u64, faults: Faults) -> Self {
        Self {
            rng: Rng::new(seed),
            faults,
            ring: Deque::new(),
            last_release: 0,
            stats: FaultStats::default(),
        }
    }

    /// Changes the fault probabilities from now on.
    pub fn set_faults(&mut self, faults: Faults) {
        self.faults = faults;
    }

    pub fn stats(&self) -> FaultStats {
        self.stats
    }

    /// Bytes in transit.
    pub fn len(&self) -> usize {
        self.ring.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ring.is_empty()
    }

    /// Loses everything in transit (a cable pull).
    pub fn clear(&mut self) {
        self.ring.clear();
    }

    fn put(&mut self, release: u32, b: u8) {
        if self.ring.push_back((release, b)).is_err() {
            self.stats.overflowed += 1;
        }
    }

    /// Writes `bytes` at time `now`, applying the faults.
    pub fn write(&mut self, now: u32, bytes: &[u8]) {
        let f = self.faults;
        for &b in bytes {
            self.stats.written += 1;
            if self.rng.chance(f.drop_ppm) {
                self.stats.dropped += 1;
                continue;
            }
            let mut b = b;
            if self.rng.chance(f.corrupt_ppm) {
                b ^= 1 + self.rng.below(255) as u8;
                self.stats.corrupted += 1;
            }
            let mut release = now;
            if f.max_delay > 0 && self.rng.chance(f.delay_ppm) {
                release = now.wrapping_add(1 + self.rng.below(f.max_delay));
                self.stats.delayed += 1;
            }
            // Keep order: never release before the byte ahead of us.
            if (release.wrapping_sub(self.last_release) as i32) < 0 && !self.ring.is_empty() {
                release = self.last_release;
            }
            self.last_release = release;
            self.put(release, b);
            if self.rng.chance(f.duplicate_ppm) {
                self.stats.duplicated += 1;
                self.put(release, b);
            }
        }
    }

    /// Reads the bytes due at `now` into `out`; returns how many.
    pub fn read(&mut self, now: u32, out: &mut [u8]) -> usize {
        let mut n = 0;
        while n < out.len() {
            match self.ring.front() {
                Some(&(t, b)) if (now.wrapping_sub(t) as i32) >= 0 => {
                    out[n] = b;
                    n += 1;
                    self.ring.pop_front();
                }
                _ => break,
            }
        }
        self.stats.delivered += n as u64;
        n
    }
}

/// Two lossy pipes joining endpoint `a` and endpoint `b`, with a helper that
/// runs one step of both (for whole-system tests: the sender on one side, the
/// emulated board on the other).
pub struct Duplex<const N: usize> {
    pub a_to_b: FaultyPipe<N>,
    pub b_to_a: FaultyPipe<N>,
    chunking: Rng,
}

impl<const N: usize> Duplex<N> {
    /// Both directions with the same fault probabilities, seeded from `seed`.
    pub fn new(seed: u64, faults: Faults) -> Self {
        Self {
            a_to_b: FaultyPipe::new(seed, faults),
            b_to_a: FaultyPipe::new(seed ^ 0x5555_5555_5555_5555, faults),
            chunking: Rng::new(seed.wrapping_add(1)),
        }
    }

    /// Sets the faults of both directions (e.g. 100 % drop for a cable pull).
    pub fn set_faults(&mut self, faults: Faults) {
        self.a_to_b.set_faults(faults);
        self.b_to_a.set_faults(faults);
    }

    /// At time `now`: both endpoints transmit everything due, then every byte
    /// due is delivered in random chunk sizes (1..=64 bytes); the board's queued
    /// messages go to `sink`.
    pub fn step(
        &mut self,
        now: u32,
        a: &mut crate::HostEndpoint,
        b: &mut crate::BoardEndpoint,
        sink: &mut impl crate::channel::QueuedSink,
    ) {
        let mut buf = [0u8; MAX_FRAME_LEN];
        while let Some(n) = a.poll_transmit(now, &mut buf) {
            self.a_to_b.write(now, &buf[..n]);
        }
        while let Some(n) = b.poll_transmit(now, &mut buf) {
            self.b_to_a.write(now, &buf[..n]);
        }
        let mut chunk = [0u8; 64];
        loop {
            let want = 1 + self.chunking.below(64) as usize;
            let n = self.a_to_b.read(now, &mut chunk[..want]);
            if n == 0 {
                break;
            }
            b.on_bytes(now, &chunk[..n], sink);
        }
        loop {
            let want = 1 + self.chunking.below(64) as usize;
            let n = self.b_to_a.read(now, &mut chunk[..want]);
            if n == 0 {
                break;
            }
            a.on_bytes(now, &chunk[..n]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perfect_pipe_is_transparent() {
        let mut p: FaultyPipe<64> = FaultyPipe::new(1, Faults::NONE);
        p.write(0, b"hello");
        let mut out = [0u8; 16];
        assert_eq!(p.read(0, &mut out), 5);
        assert_eq!(&out[..5], b"hello");
    }

    #[test]
    fn delays_keep_order() {
        let f = Faults {
            delay_ppm: 300_000,
            max_delay: 20,
            ..Faults::NONE
        };
        let mut p: FaultyPipe<4096> = FaultyPipe::new(7, f);
        let data: [u8; 200] = core::array::from_fn(|i| i as u8);
        p.write(0, &data);
        let mut got = std::vec::Vec::new();
        let mut out = [0u8; 32];
        for t in 0..1000 {
            let n = p.read(t, &mut out);
            got.extend_from_slice(&out[..n]);
        }
        assert_eq!(got, data);
        assert!(p.stats().delayed > 0);
    }

    #[test]
    fn duplex_connects_a_host_and_a_board() {
        use crate::channel::{QueuedSink, Refusal};
        use crate::{BoardEndpoint, Config, HostEndpoint, HostMsg};
        /// Keeps the payloads it is given.
        struct Got(std::vec::Vec<std::vec::Vec<u8>>);
        impl QueuedSink for Got {
            fn deliver(&mut self, payload: &[u8]) -> Result<Option<u32>, Refusal> {
                self.0.push(payload.to_vec());
                Ok(None)
            }
            fn room(&self) -> u16 {
                100
            }
        }
        let mut d: Duplex<4096> = Duplex::new(3, Faults::uniform(10_000));
        let mut host = HostEndpoint::new_host(Config::USB_MS, 1);
        let mut board = BoardEndpoint::new_board(Config::USB_MS, 2, 100);
        let mut got = Got(std::vec::Vec::new());
        host.send(HostMsg::Start { id: 1 }).unwrap();
        for t in 0..5_000 {
            d.step(t, &mut host, &mut board, &mut got);
            if let Some(p) = got.0.first() {
                assert_eq!(
                    crate::codec::decode::<HostMsg>(p),
                    Some(HostMsg::Start { id: 1 })
                );
                return;
            }
        }
        panic!("not delivered");
    }
}
