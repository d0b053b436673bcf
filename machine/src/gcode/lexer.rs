//! Lexer: one source line into words (letter + exact decimal number), with no floating point.
//!
//! Numbers become integers scaled by 10^6 ("micro units"): `1.` `.5` `-.25` `+3` `007` all parse,
//! spaces are allowed anywhere (as in RS274NGC), `( )` and `;` comments are skipped, and the caller
//! learns the byte columns of every word for error carets.

use super::error::ErrorCode;

/// Scale of [`Word::value`]: the number times 10^6.
pub(crate) const MICRO: i64 = 1_000_000;

/// Largest magnitude of any number (< 10^9 before the point).
const MAX_INTEGER_DIGITS: u32 = 9;

/// One word of a block.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Word {
    /// Upper-case letter.
    pub letter: u8,
    /// The number times 10^6, rounded half away from zero at the 7th decimal.
    pub value: i64,
    /// What the rounding of `value` dropped, in 10^-9 (−500..=500): the number is exactly
    /// `value × 1000 + nano` to nine decimals (inch words use it: 10^-6 in = 25.4 nm).
    pub nano: i16,
    /// A decimal point was written.
    pub has_point: bool,
    /// Number of digits written before the decimal point (leading zeros included).
    pub int_digits: u8,
    /// Byte columns of the word: start (0-based), end (exclusive).
    pub cols: (u16, u16),
}

impl Word {
    /// The value as a whole number, if it has no fraction.
    pub fn integer(&self) -> Option<i64> {
        // A 32-bit division when the value fits (the Cortex-M4 has no 64-bit divide).
        if let Ok(v) = i32::try_from(self.value) {
            const M: i32 = MICRO as i32;
            return (v % M == 0).then_some((v / M) as i64);
        }
        if self.value % MICRO == 0 {
            Some(self.value / MICRO)
        } else {
            None
        }
    }
}

/// What kind of line the lexer found before the words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineStart {
    /// An ordinary block (possibly empty or comment-only).
    Block,
    /// A line starting with `%` (tape framing; the rest of the line is ignored).
    Percent,
    /// A line holding only `E` (end of tape).
    EndOfTape,
}

/// A lexer error: code and the columns to blame.
pub(crate) type LexError = (ErrorCode, (u16, u16));

/// Word scanner over one line.
pub struct Lexer<'a> {
    line: &'a [u8],
    pos: usize,
    semicolon_comments: bool,
    /// The block started with `/` (block delete).
    pub block_delete: bool,
    word_end: usize,
}

fn col(i: usize) -> u16 {
    i.min(u16::MAX as usize) as u16
}

impl<'a> Lexer<'a> {
    /// Prepares a lexer; `semicolon_comments` makes `;` start a comment to the end of the line.
    pub fn new(line: &'a [u8], semicolon_comments: bool) -> Self {
        Lexer {
            line,
            pos: 0,
            semicolon_comments,
            block_delete: false,
            word_end: 0,
        }
    }

    /// Classifies the line (framing, end of tape, block) and consumes a leading `/`.
    pub fn start(&mut self) -> LineStart {
        let trimmed = trim(self.line);
        // `%` framing, possibly followed by a comment or a program name on the same line.
        if trimmed.first() == Some(&b'%') {
            return LineStart::Percent;
        }
        if trimmed == b"E" || trimmed == b"e" {
            return LineStart::EndOfTape;
        }
        self.skip_blanks();
        if self.pos < self.line.len() && self.line[self.pos] == b'/' {
            self.block_delete = true;
            self.pos += 1;
        }
        LineStart::Block
    }

    #[inline(always)]
    fn skip_blanks(&mut self) {
        while self.pos < self.line.len() && blank(self.line[self.pos]) {
            self.pos += 1;
        }
    }

    /// Skips blanks and comments; returns an error for an unclosed `(`.
    fn skip_ignorable(&mut self) -> Result<(), LexError> {
        loop {
            self.skip_blanks();
            if self.pos >= self.line.len() {
                return Ok(());
            }
            match self.line[self.pos] {
                b'(' => {
                    let start = self.pos;
                    // `get` rather than slicing: no bounds-check panic paths.
                    let rest = self.line.get(start..).unwrap_or_default();
                    match rest.iter().position(|&c| c == b')') {
                        Some(off) => {
                            // rs274 stops on `(a (b)`: a comment may not hold another `(`.
                            if let Some(inner) = rest
                                .get(1..off)
                                .unwrap_or_default()
                                .iter()
                                .position(|&c| c == b'(')
                            {
                                let at = start + 1 + inner;
                                return Err((ErrorCode::NestedComment, (col(at), col(at + 1))));
                            }
                            self.pos = start + off + 1
                        }
                        None => {
                            return Err((
                                ErrorCode::UnclosedComment,
                                (col(start), col(self.line.len())),
                            ))
                        }
                    }
                }
                b';' if self.semicolon_comments => {
                    self.pos = self.line.len();
                    return Ok(());
                }
                b'\n' => {
                    self.pos = self.line.len();
                    return Ok(());
                }
                _ => return Ok(()),
            }
        }
    }

    /// The next word, `Ok(None)` at the end of the line.
    pub(crate) fn next_word(&mut self) -> Result<Option<Word>, LexError> {
        self.skip_ignorable()?;
        if self.pos >= self.line.len() {
            return Ok(None);
        }
        let start = self.pos;
        let c = self.line[start];
        let letter = match c {
            b'a'..=b'z' => c - 32,
            b'A'..=b'Z' => c,
            b':' => b'O',
            // LinuxCNC's polar coordinates: radius `@`, angle `^` (the block refuses them in
            // the gixa dialect).
            b'@' | b'^' => c,
            // Parameters and expressions (in the gixa dialect, which has none; the ngc dialect
            // substitutes them before the lexer).
            b'#' | b'[' => return Err((ErrorCode::NotSupported, (col(start), col(start + 1)))),
            _ => return Err((ErrorCode::UnexpectedCharacter, (col(start), col(start + 1)))),
        };
        self.pos += 1;
        let mut word = self.number(start)?;
        word.letter = letter;
        word.cols = (col(start), col(self.word_end));
        Ok(Some(word))
    }

    /// Parses an optionally signed decimal number (spaces allowed between its characters).
    /// Digits accumulate in 32-bit integers on a local cursor: at most 9 significant integer
    /// digits, 6 + 3 decimals (a 64-bit multiply per digit was a large part of a short line's
    /// cost on the Cortex-M4, target-tests/src/bin/bench_motion.rs). The integer digits and the
    /// decimals are read by two loops of their own (one state test per character less than a
    /// single loop that asks at every digit which side of the point it is on).
    fn number(&mut self, word_start: usize) -> Result<Word, LexError> {
        let line = self.line;
        let mut pos = self.pos;
        while pos < line.len() && blank(line[pos]) {
            pos += 1;
        }
        let mut negative = false;
        if pos < line.len() && matches!(line[pos], b'+' | b'-') {
            negative = line[pos] == b'-';
            pos += 1;
        }
        let mut int_part: u32 = 0;
        let mut int_digits: u32 = 0;
        let mut significant: u32 = 0;
        let mut end = pos;
        // Integer digits (a blank between them is skipped; `end` stays after the last digit).
        while let Some(d) = next_digit(line, &mut pos) {
            int_digits += 1;
            if significant > 0 || d != 0 {
                significant += 1;
                if significant > MAX_INTEGER_DIGITS {
                    self.pos = pos - 1;
                    return Err((ErrorCode::NumberOutOfRange, (col(word_start), col(pos))));
                }
            }
            int_part = int_part * 10 + d;
            end = pos;
        }
        let mut frac: u32 = 0;
        let mut frac_digits: usize = 0;
        let mut round_up = false;
        let mut extra: u32 = 0;
        let has_point = line.get(pos) == Some(&b'.');
        if has_point {
            pos += 1;
            end = pos;
            // Decimals: six into `frac`, the 7th to 9th into `extra`, any further ones dropped.
            while let Some(d) = next_digit(line, &mut pos) {
                if frac_digits < 6 {
                    frac = frac * 10 + d;
                    frac_digits += 1;
                } else if frac_digits < 9 {
                    if frac_digits == 6 {
                        round_up = d >= 5;
                    }
                    extra = extra * 10 + d;
                    frac_digits += 1;
                }
                end = pos;
            }
        }
        let any_digit = int_digits > 0 || frac_digits > 0;
        self.pos = pos;
        self.word_end = end;
        if !any_digit {
            return Err((
                ErrorCode::MissingNumber,
                (col(word_start), col(pos.max(word_start + 1))),
            ));
        }
        // Scale the decimals to 6 and 3 places (frac_digits ≤ 9).
        const SCALE: [u32; 10] = [
            1_000_000_000,
            100_000_000,
            10_000_000,
            1_000_000,
            100_000,
            10_000,
            1_000,
            100,
            10,
            1,
        ];
        let (frac, extra) = if frac_digits <= 6 {
            (frac * SCALE[frac_digits + 3], 0)
        } else {
            // At most 9 digits (`min`: no bounds-check panic path).
            (frac, extra * SCALE[frac_digits.min(9)])
        };
        let mut value = int_part as i64 * MICRO + frac as i64;
        let mut nano = extra as i16;
        if round_up {
            value += 1;
            nano -= 1000;
        }
        if negative {
            value = -value;
            nano = -nano;
        }
        Ok(Word {
            letter: 0,
            value,
            nano,
            has_point,
            int_digits: int_digits.min(255) as u8,
            cols: (0, 0),
        })
    }
}

/// A blank inside a line (space, tab, a stray carriage return): skipped between and inside words.
#[inline(always)]
fn blank(c: u8) -> bool {
    matches!(c, b' ' | b'\t' | b'\r')
}

/// The digit at `pos` or after the blanks there (`pos` moves past it), or `None` at anything
/// else (`pos` stops on it, after the blanks). Numbers may have blanks between their digits.
#[inline(always)]
fn next_digit(line: &[u8], pos: &mut usize) -> Option<u32> {
    while let Some(&c) = line.get(*pos) {
        let d = c.wrapping_sub(b'0');
        if d <= 9 {
            *pos += 1;
            return Some(u32::from(d));
        }
        if !blank(c) {
            return None;
        }
        *pos += 1;
    }
    None
}

fn trim(line: &[u8]) -> &[u8] {
    let mut s = line;
    while let [first, rest @ ..] = s {
        if first.is_ascii_whitespace() {
            s = rest;
        } else {
            break;
        }
    }
    while let [rest @ .., last] = s {
        if last.is_ascii_whitespace() {
            s = rest;
        } else {
            break;
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(line: &str) -> Result<heapless::Vec<(u8, i64), 16>, LexError> {
        let mut lx = Lexer::new(line.as_bytes(), true);
        lx.start();
        let mut out = heapless::Vec::new();
        while let Some(w) = lx.next_word()? {
            out.push((w.letter, w.value)).unwrap();
        }
        Ok(out)
    }

    #[test]
    fn numbers_in_every_spelling() {
        let w = words("g01x1.y.5 Z-.25 a+3 (comment) b 1 0 . 5 ; rest").unwrap();
        assert_eq!(
            &w[..],
            &[
                (b'G', 1_000_000),
                (b'X', 1_000_000),
                (b'Y', 500_000),
                (b'Z', -250_000),
                (b'A', 3_000_000),
                (b'B', 10_500_000),
            ]
        );
    }

    #[test]
    fn nine_decimals_are_kept_beside_the_rounded_value() {
        let mut lx = Lexer::new(b"X1.0000005 Y-0.123456789 Z2.0000004", true);
        lx.start();
        let w: heapless::Vec<Word, 3> = core::iter::from_fn(|| lx.next_word().unwrap()).collect();
        assert_eq!((w[0].value, w[0].nano), (1_000_001, -500));
        assert_eq!((w[1].value, w[1].nano), (-123_457, 211));
        assert_eq!((w[2].value, w[2].nano), (2_000_000, 400));
    }

    #[test]
    fn seven_to_nine_decimals_and_long_integers() {
        let mut lx = Lexer::new(
            b"X123456789.123456789 Y-0.12345678 Z000000000012.5 A.1234567",
            true,
        );
        lx.start();
        let w: heapless::Vec<Word, 4> = core::iter::from_fn(|| lx.next_word().unwrap()).collect();
        assert_eq!((w[0].value, w[0].nano), (123_456_789_123_457, -211));
        assert_eq!((w[1].value, w[1].nano), (-123_457, 220));
        assert_eq!(
            (w[2].value, w[2].nano, w[2].int_digits),
            (12_500_000, 0, 12)
        );
        assert_eq!((w[3].value, w[3].nano), (123_457, -300));
    }

    /// Word of a one-word line: (value, nano, columns).
    fn one(line: &str) -> Result<(i64, i16, (u16, u16)), LexError> {
        let mut lx = Lexer::new(line.as_bytes(), true);
        lx.start();
        let w = lx.next_word()?.unwrap();
        Ok((w.value, w.nano, w.cols))
    }

    #[test]
    fn signs_points_and_blanks_inside_numbers() {
        assert_eq!(one("X+.5"), Ok((500_000, 0, (0, 4))));
        assert_eq!(one("X-.5"), Ok((-500_000, 0, (0, 4))));
        assert_eq!(one("X-0"), Ok((0, 0, (0, 3))));
        assert_eq!(one("X5."), Ok((5_000_000, 0, (0, 3))));
        // Blanks between sign, digits and point; the word ends at its last digit.
        assert_eq!(one("X + 1 2 "), Ok((12_000_000, 0, (0, 7))));
        assert_eq!(one("X1 .5"), Ok((1_500_000, 0, (0, 5))));
        assert_eq!(one("X - 0 . 2 5"), Ok((-250_000, 0, (0, 11))));
        assert_eq!(one("X. "), Err((ErrorCode::MissingNumber, (0, 3))));
        assert_eq!(one("X-"), Err((ErrorCode::MissingNumber, (0, 2))));
        assert_eq!(one("X(c)1"), Err((ErrorCode::MissingNumber, (0, 1))));
        // A second point starts a new (bad) word.
        assert_eq!(
            words("X1.2.3").unwrap_err(),
            (ErrorCode::UnexpectedCharacter, (4, 5))
        );
    }

    #[test]
    fn decimals_past_the_sixth_and_integer_overflow() {
        assert_eq!(one("X0.0000015"), Ok((2, -500, (0, 10))));
        assert_eq!(one("X-0.999999999"), Ok((-1_000_000, 1, (0, 13))));
        // A 10th decimal is read and dropped.
        assert_eq!(one("X1.1234567891"), Ok((1_123_457, -211, (0, 13))));
        assert_eq!(one("X999999999"), Ok((999_999_999_000_000, 0, (0, 10))));
        // Leading zeros are not significant; the 10th significant digit is blamed.
        assert_eq!(
            one("X1000000000"),
            Err((ErrorCode::NumberOutOfRange, (0, 11)))
        );
        assert_eq!(
            one("X0001234567890"),
            Err((ErrorCode::NumberOutOfRange, (0, 14)))
        );
        assert_eq!(
            one("X 9 9 9 9 9 9 9 9 9 9"),
            Err((ErrorCode::NumberOutOfRange, (0, 21)))
        );
    }

    #[test]
    fn comments_end_numbers() {
        assert_eq!(
            &words("X1(c)Y2 (d)").unwrap()[..],
            &[(b'X', 1_000_000), (b'Y', 2_000_000)]
        );
        assert_eq!(&words("X1;Y2").unwrap()[..], &[(b'X', 1_000_000)]);
        assert_eq!(
            words("X1 (a) . 5").unwrap_err(),
            (ErrorCode::UnexpectedCharacter, (7, 8))
        );
    }

    #[test]
    fn seventh_decimal_rounds() {
        assert_eq!(&words("X1.0000005").unwrap()[..], &[(b'X', 1_000_001)]);
        assert_eq!(&words("X-1.0000004").unwrap()[..], &[(b'X', -1_000_000)]);
    }

    #[test]
    fn errors_carry_columns() {
        assert_eq!(
            words("G0 X").unwrap_err(),
            (ErrorCode::MissingNumber, (3, 4))
        );
        assert_eq!(
            words("G0 (open").unwrap_err(),
            (ErrorCode::UnclosedComment, (3, 8))
        );
        assert_eq!(
            words("G0 (a (b) X1").unwrap_err(),
            (ErrorCode::NestedComment, (6, 7))
        );
        assert_eq!(
            words("G0 $1").unwrap_err(),
            (ErrorCode::UnexpectedCharacter, (3, 4))
        );
        // LinuxCNC's polar words are words of their own (radius `@`, angle `^`).
        let polar = words("G0 @1.5 ^60").unwrap();
        assert_eq!((polar[1].0, polar[2].0), (b'@', b'^'));
        assert_eq!(
            words("X1234567890").unwrap_err().0,
            ErrorCode::NumberOutOfRange
        );
    }
}
