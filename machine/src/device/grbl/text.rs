//! The grbl front end's text: the outgoing byte queue and the few number formats grbl's reports
//! use (integers, fixed-point decimals), written by hand so that no `core::fmt` machinery is
//! linked into the firmware; and the decimal parser for `$x=value` and `$J=` words.

use heapless::Deque;

/// Bytes waiting for the host (the longest answer, `$$`, is about 600 bytes).
pub(crate) const TX_SIZE: usize = 1024;

/// The outgoing text. Answers are pushed whole (the caller checks [`Out::room`] first), so a
/// status report never lands inside another line.
pub struct Out {
    bytes: Deque<u8, TX_SIZE>,
}

impl Default for Out {
    fn default() -> Self {
        Self::new()
    }
}

impl Out {
    pub const fn new() -> Self {
        Out {
            bytes: Deque::new(),
        }
    }

    /// Free bytes.
    pub fn room(&self) -> usize {
        TX_SIZE - self.bytes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    pub fn clear(&mut self) {
        self.bytes.clear();
    }

    /// Moves up to `out.len()` bytes into `out`; returns how many.
    pub(crate) fn drain_into(&mut self, out: &mut [u8]) -> usize {
        let mut n = 0;
        while n < out.len() {
            let Some(b) = self.bytes.pop_front() else {
                break;
            };
            out[n] = b;
            n += 1;
        }
        n
    }

    #[inline(never)]
    pub fn byte(&mut self, b: u8) {
        // Callers reserve room for whole answers; a byte that still does not fit is dropped.
        let _ = self.bytes.push_back(b);
    }

    pub fn str(&mut self, s: &str) {
        for &b in s.as_bytes() {
            self.byte(b);
        }
    }

    /// Ends a line as grbl does (`\r\n`).
    pub(crate) fn eol(&mut self) {
        self.str("\r\n");
    }

    pub fn line(&mut self, s: &str) {
        self.str(s);
        self.eol();
    }

    pub(crate) fn uint(&mut self, v: u64) {
        // Digits from the last one (a u64 has at most 20), written out from the first.
        let mut digits = [0u8; 20];
        let mut first = digits.len();
        let mut v = v;
        for d in digits.iter_mut().rev() {
            *d = b'0' + (v % 10) as u8;
            first -= 1;
            v /= 10;
            if v == 0 {
                break;
            }
        }
        for &d in digits.get(first..).unwrap_or_default() {
            self.byte(d);
        }
    }

    pub fn int(&mut self, v: i64) {
        if v < 0 {
            self.byte(b'-');
        }
        self.uint(v.unsigned_abs());
    }

    /// `value / per_unit` with `decimals` decimals (at most 9), rounded half away from zero
    /// (e.g. nm as mm: `fixed(nm, 1_000_000, 3)`). 64-bit arithmetic only (`per_unit` up to
    /// 2^31): 128-bit division costs the firmware flash.
    #[inline(never)]
    pub fn fixed(&mut self, value: i64, per_unit: i64, decimals: u32) {
        let scale = 10u64.pow(decimals);
        let den = per_unit.unsigned_abs().max(1);
        let abs = value.unsigned_abs();
        let mut whole = abs / den;
        let mut frac = ((abs % den) * scale + den / 2) / den;
        if frac >= scale {
            whole += 1;
            frac -= scale;
        }
        if value < 0 && (whole != 0 || frac != 0) {
            self.byte(b'-');
        }
        self.uint(whole);
        if decimals > 0 {
            self.byte(b'.');
            let mut div = scale / 10;
            while div > 0 {
                self.byte(b'0' + (frac / div % 10) as u8);
                div /= 10;
            }
        }
    }
}

/// Parses a decimal number (`-12.5`, `+3`, `.25`) and returns it times `scale` (at most 2^31),
/// rounded to the nearest integer; `None` for anything else or a result beyond ±2^62. Digits past
/// the ninth decimal are ignored.
pub(crate) fn parse_scaled(s: &[u8], scale: i64) -> Option<i64> {
    let (neg, digits) = match s.split_first() {
        Some((b'-', rest)) => (true, rest),
        Some((b'+', rest)) => (false, rest),
        _ => (false, s),
    };
    let mut num: u64 = 0;
    let mut den: u64 = 1;
    let mut seen_digit = false;
    let mut seen_point = false;
    for &c in digits {
        match c {
            b'0'..=b'9' => {
                seen_digit = true;
                if seen_point && den >= 1_000_000_000 {
                    continue;
                }
                num = num.checked_mul(10)?.checked_add(u64::from(c - b'0'))?;
                if seen_point {
                    den *= 10;
                }
            }
            b'.' if !seen_point => seen_point = true,
            _ => return None,
        }
    }
    if !seen_digit {
        return None;
    }
    let scale = scale.unsigned_abs();
    // `den` is a power of ten from 1; `max(1)` leaves no division-by-zero panic path.
    let den = den.max(1);
    let v = (num / den)
        .checked_mul(scale)?
        .checked_add((num % den * scale + den / 2) / den)?;
    if v > 1 << 62 {
        return None;
    }
    Some(if neg { -(v as i64) } else { v as i64 })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(f: impl FnOnce(&mut Out)) -> heapless::String<64> {
        let mut o = Out::new();
        f(&mut o);
        let mut buf = [0u8; 64];
        let n = o.drain_into(&mut buf);
        heapless::String::try_from(core::str::from_utf8(&buf[..n]).unwrap()).unwrap()
    }

    #[test]
    fn fixed_point_rounds_half_away_from_zero() {
        assert_eq!(text(|o| o.fixed(1_234_500, 1_000_000, 3)), "1.235");
        assert_eq!(text(|o| o.fixed(-1_234_500, 1_000_000, 3)), "-1.235");
        assert_eq!(text(|o| o.fixed(-400, 1_000_000, 3)), "0.000");
        assert_eq!(text(|o| o.fixed(25_400_000, 25_400_000, 4)), "1.0000");
        assert_eq!(text(|o| o.fixed(7, 1, 0)), "7");
        assert_eq!(text(|o| o.int(-42)), "-42");
    }

    #[test]
    fn decimals_parse_exactly() {
        assert_eq!(parse_scaled(b"12.5", 1_000_000), Some(12_500_000));
        assert_eq!(parse_scaled(b"-0.001", 1_000_000), Some(-1_000));
        assert_eq!(parse_scaled(b".25", 1000), Some(250));
        assert_eq!(parse_scaled(b"80", 1000), Some(80_000));
        assert_eq!(parse_scaled(b"1.2.3", 1000), None);
        assert_eq!(parse_scaled(b"", 1000), None);
        assert_eq!(parse_scaled(b"-", 1000), None);
        assert_eq!(parse_scaled(b"1e3", 1000), None);
    }
}
