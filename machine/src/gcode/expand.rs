//! Parameter substitution: one source line with `#` references, `[expressions]` and assignments
//! becomes a plain line the word lexer reads, plus the assignments to apply.
//!
//! `G1 X[#1 + 2] Y#<y>` becomes `G1 X12.000000000 Y3.500000000`; `#1 = [#1 + 1]` is taken out of
//! the line and returned, so every value on the line is read before any assignment of the line
//! takes effect (RS274NGC). Comments are copied untouched.

use super::error::ErrorCode;
use super::expr::{self, Cursor, Fx, ParamRead, ParamRef, ONE};

/// Longest line after substitution.
pub(crate) const EXPANDED_MAX: usize = 384;
/// Most assignments on one line.
pub(crate) const MAX_ASSIGNMENTS: usize = 12;

/// The substituted line.
pub(crate) type Expanded = heapless::Vec<u8, EXPANDED_MAX>;
/// The assignments of one line, in order: target, value, column of the target's `#`.
pub(crate) type Assignments = heapless::Vec<(ParamRef, Fx, u16), MAX_ASSIGNMENTS>;

/// An error and the columns in the source line.
pub(crate) type ExpandError = (ErrorCode, (u16, u16));

fn cols(at: usize) -> (u16, u16) {
    (at as u16, at as u16 + 1)
}

/// True if the line needs substitution (a `#` or `[` outside comments).
pub(crate) fn needs_expansion(line: &[u8]) -> bool {
    let mut in_comment = false;
    for &c in line {
        match c {
            b'(' => in_comment = true,
            b')' => in_comment = false,
            b';' if !in_comment => return false,
            b'#' | b'[' if !in_comment => return true,
            _ => {}
        }
    }
    false
}

/// Writes a value as a decimal with nine places; false if the line is full.
pub(crate) fn write_fx(out: &mut Expanded, v: Fx) -> bool {
    // Written from the end (nine decimals, the point, the integer's digits, the sign: at most
    // 9 + 1 + 20 + 1 bytes) through an iterator over the slots: no indexing, so no
    // bounds-check panic paths.
    let mut buf = [0u8; 31];
    let mut len = 0;
    let mut slots = buf.iter_mut().rev();
    let mut put = |c: u8| {
        if let Some(slot) = slots.next() {
            *slot = c;
            len += 1;
        }
    };
    let a = v.unsigned_abs();
    let (mut int, mut frac) = (a / ONE as u64, a % ONE as u64);
    for _ in 0..9 {
        put(b'0' + (frac % 10) as u8);
        frac /= 10;
    }
    put(b'.');
    loop {
        put(b'0' + (int % 10) as u8);
        int /= 10;
        if int == 0 {
            break;
        }
    }
    if v < 0 {
        put(b'-');
    }
    let text = buf.get(buf.len() - len..).unwrap_or(&[]);
    out.extend_from_slice(text).is_ok()
}

/// True if a function name followed by `[` starts at the cursor.
fn function_starts(c: &mut Cursor<'_>) -> bool {
    const NAMES: [&[u8]; 14] = [
        b"ABS", b"ACOS", b"ASIN", b"ATAN", b"COS", b"EXP", b"FIX", b"FUP", b"ROUND", b"LN", b"SIN",
        b"SQRT", b"TAN", b"EXISTS",
    ];
    let save = c.pos;
    let found = NAMES.iter().any(|w| {
        c.pos = save;
        c.keyword(w) && c.peek() == Some(b'[')
    });
    c.pos = save;
    found
}

/// Substitutes `line` into `out` and collects its assignments.
pub(crate) fn expand(
    line: &[u8],
    params: &dyn ParamRead,
    out: &mut Expanded,
    assignments: &mut Assignments,
) -> Result<(), ExpandError> {
    let too_long = (ErrorCode::ExpressionSyntax, (0, line.len() as u16));
    let full = |_| too_long;
    let mut i = 0;
    while let Some(rest) = line.get(i..) {
        let Some(&ch) = rest.first() else {
            break;
        };
        match ch {
            b'(' => {
                // The comment through its `)` (the rest of the line without one).
                let comment = rest
                    .iter()
                    .position(|&c| c == b')')
                    .and_then(|p| rest.get(..=p))
                    .unwrap_or(rest);
                out.extend_from_slice(comment).map_err(full)?;
                i += comment.len();
            }
            b';' => {
                out.extend_from_slice(rest).map_err(full)?;
                break;
            }
            b'#' => {
                // An assignment `#ref = value` where a word would start.
                let mut c = Cursor::new(line, i + 1);
                let target = expr::read_param_ref(&mut c, params, 0)
                    .map_err(|(code, at)| (code, cols(at)))?;
                if c.peek() != Some(b'=') {
                    return Err((ErrorCode::ExpressionSyntax, cols(c.pos.min(line.len()))));
                }
                c.pos += 1;
                let value =
                    expr::real_value(&mut c, params, 0).map_err(|(code, at)| (code, cols(at)))?;
                assignments
                    .push((target, value, i as u16))
                    .map_err(|_| (ErrorCode::ParameterTableFull, cols(i)))?;
                i = c.pos;
            }
            // A word's letter (LinuxCNC's polar words `@` and `^` too): a value computed by an
            // expression or a parameter is written out as a number.
            b'a'..=b'z' | b'A'..=b'Z' | b'@' | b'^' => {
                out.push(ch).map_err(|_| too_long)?;
                let mut c = Cursor::new(line, i + 1);
                let computed = match c.peek() {
                    Some(b'#' | b'[') => true,
                    Some(b'-' | b'+') => {
                        let save = c.pos;
                        c.pos += 1;
                        let next = c.peek();
                        let f = matches!(next, Some(b'#' | b'[')) || function_starts(&mut c);
                        c.pos = save;
                        f
                    }
                    Some(b'A'..=b'Z') => function_starts(&mut c),
                    _ => false,
                };
                if computed {
                    let v = expr::real_value(&mut c, params, 0)
                        .map_err(|(code, at)| (code, cols(at)))?;
                    if v == expr::VACANT {
                        // Fanuc: an address with a vacant value is omitted.
                        out.pop();
                        i = c.pos;
                        continue;
                    }
                    if !write_fx(out, v) {
                        return Err(too_long);
                    }
                    i = c.pos;
                } else {
                    i += 1;
                }
            }
            _ => {
                out.push(ch).map_err(|_| too_long)?;
                i += 1;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    struct P;
    impl ParamRead for P {
        fn read(&self, p: ParamRef) -> Result<Fx, ErrorCode> {
            match p {
                ParamRef::Numbered(n) => Ok(n as Fx * ONE),
                ParamRef::Named { .. } => Ok(-ONE / 4),
            }
        }
        fn exists(&self, _: ParamRef) -> bool {
            true
        }
    }

    extern crate std;
    use std::string::String;

    fn run(s: &str) -> Result<(String, usize), ErrorCode> {
        let mut out = Expanded::new();
        let mut a = Assignments::new();
        expand(s.as_bytes(), &P, &mut out, &mut a).map_err(|e| e.0)?;
        Ok((String::from_utf8(out.to_vec()).unwrap(), a.len()))
    }

    #[test]
    fn substitutes_values_and_takes_out_assignments() {
        assert_eq!(
            run("G1 X[#1 + 2] Y#<y> Z-#3 (#4 stays)").unwrap(),
            (
                "G1 X3.000000000 Y-0.250000000 Z-3.000000000(#4 stays)".into(),
                0
            )
        );
        assert_eq!(run("#1 = [2 * 3] #<a>=#2 G0").unwrap(), (" G0".into(), 2));
        assert_eq!(run("X SIN[0] Y2").unwrap(), ("X0.000000000 Y2".into(), 0));
        assert_eq!(
            run("@#2 ^[360/6]").unwrap(),
            ("@2.000000000^60.000000000".into(), 0)
        );
        assert_eq!(run("#1 5").unwrap_err(), ErrorCode::ExpressionSyntax);
        // A comment without `)` runs to the end of the line; `;` ends it.
        assert_eq!(
            run("X#1 (open [#2").unwrap(),
            ("X1.000000000(open [#2".into(), 0)
        );
        assert_eq!(run("Y#2;#3").unwrap(), ("Y2.000000000;#3".into(), 0));
    }

    #[test]
    fn values_are_written_with_nine_places_at_both_extremes() {
        let written = |v: Fx| {
            let mut out = Expanded::new();
            assert!(write_fx(&mut out, v));
            String::from_utf8(out.to_vec()).unwrap()
        };
        assert_eq!(written(0), "0.000000000");
        assert_eq!(written(-1), "-0.000000001");
        assert_eq!(written(12 * ONE + 5), "12.000000005");
        assert_eq!(written(Fx::MAX), "9223372036.854775807");
        assert_eq!(written(Fx::MIN), "-9223372036.854775808");
        // A full line refuses the value (and keeps what it had).
        let mut out = Expanded::new();
        while out.push(b'G').is_ok() {}
        assert!(!write_fx(&mut out, ONE));
        assert_eq!(out.len(), EXPANDED_MAX);
    }
}
