//! The streamed program the benchmarks feed the board: short G1 lines
//! (`G1 Y-6.789 F3000`, 0.1 mm apart, every number changing from line to line), built
//! without `core::fmt` (`src/bin/bench_motion.rs`, `src/bin/bench_link.rs`).

/// One line of text in a fixed buffer.
pub struct TextLine {
    bytes: [u8; 96],
    len: usize,
}

impl TextLine {
    fn new() -> Self {
        TextLine {
            bytes: [0; 96],
            len: 0,
        }
    }

    fn push(&mut self, b: u8) {
        if let Some(slot) = self.bytes.get_mut(self.len) {
            *slot = b;
            self.len += 1;
        }
    }

    fn push_str(&mut self, s: &[u8]) {
        for &b in s {
            self.push(b);
        }
    }

    fn push_int(&mut self, v: u64) {
        let mut digits = [0u8; 20];
        let mut n = 0;
        let mut v = v;
        loop {
            digits[n] = b'0' + (v % 10) as u8;
            n += 1;
            v /= 10;
            if v == 0 {
                break;
            }
        }
        while n > 0 {
            n -= 1;
            self.push(digits[n]);
        }
    }

    /// `value` thousandths as a decimal with three places (`-6.789`).
    fn push_milli(&mut self, value: i64) {
        if value < 0 {
            self.push(b'-');
        }
        let v = value.unsigned_abs();
        self.push_int(v / 1000);
        self.push(b'.');
        let frac = v % 1000;
        self.push(b'0' + (frac / 100) as u8);
        self.push(b'0' + (frac / 10 % 10) as u8);
        self.push(b'0' + (frac % 10) as u8);
    }

    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..self.len]
    }

    /// The line without its blanks, as `gantry stream` sends it (host-sender/src/program.rs
    /// `strip`; a comment keeps its blanks, and this program's have none).
    pub fn without_blanks(&self) -> TextLine {
        let mut l = TextLine::new();
        for &b in self.as_bytes().iter().filter(|b| !b.is_ascii_whitespace()) {
            l.push(b);
        }
        l
    }

    pub fn as_str(&self) -> &str {
        core::str::from_utf8(self.as_bytes()).unwrap_or("")
    }
}

/// Line `i` of the streamed program: `G1 Y-6.789 F3000`, 0.1 mm steps along X (the
/// last digit wandering) on a gentle zigzag in Y, every number changing from line to line.
pub fn program_line(i: u32) -> TextLine {
    let mut l = TextLine::new();
    let x = -100_000 + i as i64 * 100 + (i % 7) as i64;
    let y = if i.is_multiple_of(2) { -6_789 } else { -6_788 };
    l.push_str(b"G1 X");
    l.push_milli(x);
    l.push_str(b" Y");
    l.push_milli(y);
    l.push_str(b" F3000");
    l
}

/// Line `i` of a contour whose speed the look-ahead bounds: 0.03 mm chords of a 20 mm circle
/// at F3000 (the 128-block ring holds 3.84 mm, so the speed is that of a stop within it), as
/// `G1 X.. Y.. F3000` with the circle's centre at (−20, 0) mm.
pub fn contour_line(i: u32) -> TextLine {
    // 0.0015 rad a chord (0.03 mm at r = 20 mm), in binary-angle units.
    let step = (gantry_machine::arith::TURN as i128 * 15_000 / 62_831_853) as i64;
    let (x, y) = gantry_machine::arith::polar(20_000, step * i64::from(i));
    let mut l = TextLine::new();
    l.push_str(b"G1 X");
    l.push_milli(x - 20_000);
    l.push_str(b" Y");
    l.push_milli(y);
    l.push_str(b" F3000");
    l
}

/// [`program_line`] with `pad` more bytes: a trailing comment (`(...)`), for the per-byte share
/// of a cost.
pub fn padded_line(i: u32, pad: usize) -> TextLine {
    let mut l = program_line(i);
    if pad >= 2 {
        l.push(b'(');
        for _ in 0..pad - 2 {
            l.push(b'.');
        }
        l.push(b')');
    }
    l
}
