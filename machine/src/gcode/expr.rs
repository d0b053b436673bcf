//! RS274NGC expressions in fixed point: `[1 + #2 * SIN[30]]`, parameter references and functions.
//!
//! Every value is an [`Fx`]: an `i64` holding the number times 10⁹ (nine decimals, range ±9.2·10⁹),
//! so arithmetic is exact integer arithmetic and bit-identical on the host and the Cortex-M4.
//! Products and quotients go through `i128` and round half away from zero. Angles are degrees as
//! in LinuxCNC; SIN/COS/ATAN use the CORDIC of `machine/src/arith.rs`, SQRT the integer
//! square root there, EXP/LN short series on 10¹⁸-scaled `i128` values.
//!
//! Precedence (LinuxCNC): `**` > `* / MOD` > `+ -` > `EQ NE GT GE LT LE` > `AND OR XOR`, each left
//! associative. Comparisons and logic give 1 or 0; AND/OR/XOR treat any non-zero value as true.

use super::error::ErrorCode;
use crate::arith;

/// A fixed-point value: the number times [`ONE`].
pub type Fx = i64;
/// 1.0 as an [`Fx`].
pub const ONE: Fx = 1_000_000_000;
/// Deepest bracket nesting of one expression (bounds the recursion on the board's stack).
pub(crate) const MAX_DEPTH: u8 = 16;

/// A parameter named in a program.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamRef {
    /// `#123`.
    Numbered(u16),
    /// `#<name>`: FNV-1a hash of the lower-case name without blanks; `global` for `#<_name>`.
    Named { hash: u32, global: bool },
}

/// What an expression may read.
pub trait ParamRead {
    /// The value of a parameter (an unset numbered one is 0; an unset named one is an error).
    fn read(&self, p: ParamRef) -> Result<Fx, ErrorCode>;
    /// True if a named parameter is defined (`EXISTS[#<name>]`).
    fn exists(&self, p: ParamRef) -> bool;
}

/// An expression error: code and the byte offset where it was found.
pub(crate) type ExprError = (ErrorCode, usize);

/// A cursor over one line, skipping blanks (RS274NGC allows spaces anywhere).
pub struct Cursor<'a> {
    pub line: &'a [u8],
    pub pos: usize,
}

impl<'a> Cursor<'a> {
    pub fn new(line: &'a [u8], pos: usize) -> Self {
        Cursor { line, pos }
    }

    /// The next non-blank byte (upper-cased), without consuming it.
    pub fn peek(&mut self) -> Option<u8> {
        while self.pos < self.line.len() && matches!(self.line[self.pos], b' ' | b'\t' | b'\r') {
            self.pos += 1;
        }
        self.line.get(self.pos).map(|c| c.to_ascii_uppercase())
    }

    fn eat(&mut self, c: u8) -> bool {
        if self.peek() == Some(c) {
            self.pos += 1;
            true
        } else {
            false
        }
    }

    fn expect(&mut self, c: u8) -> Result<(), ExprError> {
        if self.eat(c) {
            Ok(())
        } else {
            Err((ErrorCode::ExpressionSyntax, self.pos))
        }
    }

    /// Consumes a keyword (letters, blanks allowed between them) if it comes next.
    pub fn keyword(&mut self, word: &[u8]) -> bool {
        let save = self.pos;
        for &w in word {
            if self.peek() != Some(w) {
                self.pos = save;
                return false;
            }
            self.pos += 1;
        }
        true
    }
}

fn syntax<T>(at: usize) -> Result<T, ExprError> {
    Err((ErrorCode::ExpressionSyntax, at))
}

/// FNV-1a of a parameter or label name: lower case, blanks removed.
pub(crate) const fn name_hash(name: &[u8]) -> u32 {
    let mut h: u32 = 0x811c_9dc5;
    let mut i = 0;
    while i < name.len() {
        let c = name[i];
        i += 1;
        if matches!(c, b' ' | b'\t') {
            continue;
        }
        h ^= c.to_ascii_lowercase() as u32;
        h = h.wrapping_mul(0x0100_0193);
    }
    h
}

/// Reads `<name>` (the cursor is on `<`): returns (hash, global).
pub(crate) fn read_name(c: &mut Cursor<'_>) -> Result<(u32, bool), ExprError> {
    c.expect(b'<')?;
    let start = c.pos;
    // `get` rather than slicing: no bounds-check panic paths (`start` is within the line).
    let rest = c.line.get(start..).unwrap_or_default();
    let len = rest
        .iter()
        .position(|&b| b == b'>')
        .ok_or((ErrorCode::ExpressionSyntax, start))?;
    let name = rest.get(..len).unwrap_or_default();
    let end = start + len;
    let first = name.iter().find(|b| !b.is_ascii_whitespace());
    if first.is_none() {
        return syntax(start);
    }
    c.pos = end + 1;
    Ok((name_hash(name), first == Some(&b'_')))
}

/// Reads a parameter reference after `#`: `#12`, `#<name>`, `#[expr]`, `##1`.
pub(crate) fn read_param_ref(
    c: &mut Cursor<'_>,
    params: &dyn ParamRead,
    depth: u8,
) -> Result<ParamRef, ExprError> {
    let at = c.pos;
    if c.peek() == Some(b'<') {
        let (hash, global) = read_name(c)?;
        return Ok(ParamRef::Named { hash, global });
    }
    let v = real_value(c, params, depth)?;
    if v % ONE != 0 || !(0..=99_999 * ONE).contains(&v) {
        return Err((ErrorCode::ParameterNumberInvalid, at));
    }
    Ok(ParamRef::Numbered((v / ONE) as u16))
}

/// Evaluates a bracketed expression; the cursor is on `[`.
pub(crate) fn bracketed(
    c: &mut Cursor<'_>,
    params: &dyn ParamRead,
    depth: u8,
) -> Result<Fx, ExprError> {
    if depth >= MAX_DEPTH {
        return Err((ErrorCode::ExpressionSyntax, c.pos));
    }
    c.expect(b'[')?;
    let v = expression(c, params, depth + 1, 0)?;
    c.expect(b']')?;
    Ok(or_zero(v))
}

/// Fanuc's "vacant" value (#0, and an unset local inside a G65 macro): only a bare `#n` carries
/// it (`#2 = #0` leaves #2 vacant, `X#0` is no X word); EQ and NE tell it from 0, every other
/// operator, function and bracket counts it as 0 (docs/gcode-parameters.md).
pub(crate) const VACANT: Fx = i64::MIN;

/// A value with vacant counted as 0.
pub(crate) fn or_zero(v: Fx) -> Fx {
    if v == VACANT {
        0
    } else {
        v
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Op {
    Pow,
    Mul,
    Div,
    Mod,
    Add,
    Sub,
    Eq,
    Ne,
    Gt,
    Ge,
    Lt,
    Le,
    And,
    Or,
    Xor,
}

impl Op {
    fn precedence(self) -> u8 {
        match self {
            Op::Pow => 5,
            Op::Mul | Op::Div | Op::Mod => 4,
            Op::Add | Op::Sub => 3,
            Op::Eq | Op::Ne | Op::Gt | Op::Ge | Op::Lt | Op::Le => 2,
            Op::And | Op::Or | Op::Xor => 1,
        }
    }
}

fn peek_op(c: &mut Cursor<'_>) -> Option<(Op, usize)> {
    let save = c.pos;
    let op = match c.peek()? {
        b'*' => {
            c.pos += 1;
            if c.eat(b'*') {
                Op::Pow
            } else {
                Op::Mul
            }
        }
        b'/' => {
            c.pos += 1;
            Op::Div
        }
        b'+' => {
            c.pos += 1;
            Op::Add
        }
        b'-' => {
            c.pos += 1;
            Op::Sub
        }
        _ => {
            const WORDS: [(&[u8], Op); 10] = [
                (b"MOD", Op::Mod),
                (b"EQ", Op::Eq),
                (b"NE", Op::Ne),
                (b"GT", Op::Gt),
                (b"GE", Op::Ge),
                (b"LT", Op::Lt),
                (b"LE", Op::Le),
                (b"AND", Op::And),
                (b"OR", Op::Or),
                (b"XOR", Op::Xor),
            ];
            WORDS
                .iter()
                .find(|(w, _)| c.keyword(w))
                .map(|&(_, op)| op)?
        }
    };
    let len = c.pos - save;
    c.pos = save;
    Some((op, len))
}

/// Precedence climbing over binary operators of at least `min` precedence.
fn expression(
    c: &mut Cursor<'_>,
    params: &dyn ParamRead,
    depth: u8,
    min: u8,
) -> Result<Fx, ExprError> {
    let mut lhs = real_value(c, params, depth)?;
    while let Some((op, len)) = peek_op(c) {
        let prec = op.precedence();
        if prec < min {
            break;
        }
        let at = c.pos;
        c.pos += len;
        let rhs = expression(c, params, depth, prec + 1)?;
        lhs = apply(op, lhs, rhs).map_err(|code| (code, at))?;
    }
    Ok(lhs)
}

fn truth(v: bool) -> Fx {
    if v {
        ONE
    } else {
        0
    }
}

fn checked(v: i128) -> Result<Fx, ErrorCode> {
    i64::try_from(v).map_err(|_| ErrorCode::ExpressionOverflow)
}

/// `a × b / ONE` rounded half away from zero.
pub(crate) fn mul(a: Fx, b: Fx) -> Result<Fx, ErrorCode> {
    checked(round_div(
        arith::mul_i128(a as i128, b as i128),
        ONE as i128,
    ))
}

/// `a × ONE / b` rounded half away from zero.
pub(crate) fn div(a: Fx, b: Fx) -> Result<Fx, ErrorCode> {
    if b == 0 {
        return Err(ErrorCode::DivisionByZero);
    }
    checked(round_div(a as i128 * ONE as i128, b as i128))
}

fn round_div(n: i128, d: i128) -> i128 {
    let (n, d) = if d < 0 { (-n, -d) } else { (n, d) };
    let q = arith::div_i128(n.abs() + d / 2, d);
    if n < 0 {
        -q
    } else {
        q
    }
}

fn apply(op: Op, a: Fx, b: Fx) -> Result<Fx, ErrorCode> {
    // EQ/NE compare vacant as its own value; everything else counts it as 0.
    match op {
        Op::Eq => return Ok(truth(a == b)),
        Op::Ne => return Ok(truth(a != b)),
        _ => {}
    }
    let (a, b) = (or_zero(a), or_zero(b));
    Ok(match op {
        Op::Pow => pow(a, b)?,
        Op::Mul => mul(a, b)?,
        Op::Div => div(a, b)?,
        Op::Mod => {
            if b == 0 {
                return Err(ErrorCode::DivisionByZero);
            }
            // LinuxCNC: the result has the sign of the divisor's absolute value (fmod, then +|b|).
            let r = a % b;
            if r < 0 {
                r + b.abs()
            } else {
                r
            }
        }
        Op::Add => a.checked_add(b).ok_or(ErrorCode::ExpressionOverflow)?,
        Op::Sub => a.checked_sub(b).ok_or(ErrorCode::ExpressionOverflow)?,
        Op::Eq => truth(a == b),
        Op::Ne => truth(a != b),
        Op::Gt => truth(a > b),
        Op::Ge => truth(a >= b),
        Op::Lt => truth(a < b),
        Op::Le => truth(a <= b),
        Op::And => truth(a != 0 && b != 0),
        Op::Or => truth(a != 0 || b != 0),
        Op::Xor => truth((a != 0) != (b != 0)),
    })
}

/// A number literal: digits with an optional point (up to 9 decimals kept, the 10th rounds).
fn number(c: &mut Cursor<'_>) -> Result<Fx, ExprError> {
    let at = c.pos;
    let mut int: i64 = 0;
    let mut frac: i64 = 0;
    let mut frac_digits = 0u32;
    let mut point = false;
    let mut any = false;
    let mut round = false;
    while let Some(ch) = c.peek() {
        match ch {
            b'0'..=b'9' => {
                any = true;
                let d = (ch - b'0') as i64;
                if point {
                    if frac_digits < 9 {
                        frac = frac * 10 + d;
                        frac_digits += 1;
                    } else if frac_digits == 9 {
                        round = d >= 5;
                        frac_digits += 1;
                    }
                } else {
                    int = int
                        .checked_mul(10)
                        .and_then(|v| v.checked_add(d))
                        .filter(|&v| v < 9_000_000_000)
                        .ok_or((ErrorCode::NumberOutOfRange, at))?;
                }
            }
            b'.' if !point => point = true,
            _ => break,
        }
        c.pos += 1;
    }
    if !any {
        return syntax(at);
    }
    while frac_digits < 9 {
        frac *= 10;
        frac_digits += 1;
    }
    Ok(int * ONE + frac + i64::from(round))
}

/// A real value: number, parameter, `[expr]`, unary minus/plus, or a function.
pub(crate) fn real_value(
    c: &mut Cursor<'_>,
    params: &dyn ParamRead,
    depth: u8,
) -> Result<Fx, ExprError> {
    if depth >= MAX_DEPTH {
        return syntax(c.pos);
    }
    let next = c.peek();
    let at = c.pos;
    match next {
        Some(b'[') => bracketed(c, params, depth),
        Some(b'-') => {
            c.pos += 1;
            Ok(-or_zero(real_value(c, params, depth + 1)?))
        }
        Some(b'+') => {
            c.pos += 1;
            Ok(or_zero(real_value(c, params, depth + 1)?))
        }
        Some(b'#') => {
            c.pos += 1;
            let r = read_param_ref(c, params, depth + 1)?;
            params.read(r).map_err(|code| (code, at))
        }
        Some(b'0'..=b'9' | b'.') => number(c),
        Some(b'A'..=b'Z') => function(c, params, depth),
        _ => syntax(at),
    }
}

fn function(c: &mut Cursor<'_>, params: &dyn ParamRead, depth: u8) -> Result<Fx, ExprError> {
    let at = c.pos;
    if c.keyword(b"EXISTS") {
        c.expect(b'[')?;
        c.expect(b'#')?;
        let r = read_param_ref(c, params, depth + 1)?;
        c.expect(b']')?;
        return Ok(truth(params.exists(r)));
    }
    if c.keyword(b"ATAN") {
        let y = bracketed(c, params, depth)?;
        c.expect(b'/')?;
        let x = bracketed(c, params, depth)?;
        return Ok(atan_deg(y, x));
    }
    const UNARY: [&[u8]; 13] = [
        b"ABS", b"ACOS", b"ASIN", b"COS", b"EXP", b"FIX", b"FUP", b"ROUND", b"LN", b"SIN", b"SQRT",
        b"TAN", b"ATAN",
    ];
    // Longest names first where one is a prefix of another (none here but ACOS/ASIN vs ABS).
    let Some(i) = UNARY.iter().position(|w| c.keyword(w)) else {
        return Err((ErrorCode::ExpressionSyntax, at));
    };
    let v = bracketed(c, params, depth)?;
    let r = match i {
        0 => Ok(v.abs()),
        1 => acos_deg(v),
        2 => asin_deg(v),
        3 => Ok(sin_cos_deg(v).0),
        4 => exp(v),
        5 => Ok(v.div_euclid(ONE) * ONE),
        6 => Ok(-((-v).div_euclid(ONE)) * ONE),
        7 => Ok(round_div(v as i128, ONE as i128) as i64 * ONE),
        8 => ln(v),
        9 => Ok(sin_cos_deg(v).1),
        10 => sqrt(v),
        11 => {
            let (cos, sin) = sin_cos_deg(v);
            div(sin, cos)
        }
        _ => Err(ErrorCode::ExpressionSyntax),
    };
    r.map_err(|code| (code, at))
}

/// 360° in binary-angle units per ONE degree: degrees × TURN / 360 / ONE.
fn deg_to_binary(deg: Fx) -> i64 {
    let full = 360 * ONE as i128;
    let turns = deg as i128 - arith::div_i128(deg as i128, full) * full;
    arith::div_i128(turns * arith::TURN as i128, 360 * ONE as i128) as i64
}

fn binary_to_deg(angle: i64) -> Fx {
    round_div(angle as i128 * 360 * ONE as i128, arith::TURN as i128) as i64
}

/// (cos, sin) of an angle in degrees.
pub(crate) fn sin_cos_deg(deg: Fx) -> (Fx, Fx) {
    let (c, s) = arith::polar(ONE, deg_to_binary(deg));
    (c, s)
}

/// ATAN[y]/[x] in degrees, in (−180, 180].
pub(crate) fn atan_deg(y: Fx, x: Fx) -> Fx {
    binary_to_deg(arith::atan2(y, x))
}

/// √v (v ≥ 0).
pub(crate) fn sqrt(v: Fx) -> Result<Fx, ErrorCode> {
    if v < 0 {
        return Err(ErrorCode::FunctionDomain);
    }
    let scaled = v as u128 * ONE as u128;
    let r = arith::isqrt_u128(scaled);
    // Round to nearest: r or r + 1.
    let r = if (r * r + r) < scaled { r + 1 } else { r };
    Ok(r as i64)
}

fn one_minus_square_root(v: Fx) -> Result<Fx, ErrorCode> {
    if !(-ONE..=ONE).contains(&v) {
        return Err(ErrorCode::FunctionDomain);
    }
    sqrt(ONE - mul(v, v)?)
}

/// ASIN in degrees.
pub(crate) fn asin_deg(v: Fx) -> Result<Fx, ErrorCode> {
    Ok(atan_deg(v, one_minus_square_root(v)?))
}

/// ACOS in degrees.
pub(crate) fn acos_deg(v: Fx) -> Result<Fx, ErrorCode> {
    Ok(atan_deg(one_minus_square_root(v)?, v))
}

/// 10¹⁸: the internal scale of EXP and LN.
const E18: i128 = 1_000_000_000_000_000_000;
/// ln 2 × 10¹⁸.
const LN2_E18: i128 = 693_147_180_559_945_309;

/// Natural logarithm (v > 0): v = m·2^k with m in [1, 2), ln m = 2·atanh((m−1)/(m+1)).
pub(crate) fn ln(v: Fx) -> Result<Fx, ErrorCode> {
    if v <= 0 {
        return Err(ErrorCode::FunctionDomain);
    }
    let mut m = v as i128 * ONE as i128; // 10¹⁸ scale
    let mut k: i128 = 0;
    while m >= 2 * E18 {
        m = (m + 1) / 2;
        k += 1;
    }
    while m < E18 {
        m *= 2;
        k -= 1;
    }
    let z = arith::div_i128((m - E18) * E18, m + E18);
    // i128 `/` is expanded inline on the Cortex-M4 (~1 KiB each): the shared division instead.
    let z2 = arith::div_i128(arith::mul_i128(z, z), E18);
    let mut term = z;
    let mut sum = 0i128;
    let mut n = 1i128;
    while term != 0 {
        sum += arith::div_i128(term, n);
        term = arith::div_i128(arith::mul_i128(term, z2), E18);
        n += 2;
    }
    let r = 2 * sum + k * LN2_E18;
    Ok(round_div(r, ONE as i128) as i64)
}

/// e^v: v = k·ln 2 + r with |r| ≤ ln 2 / 2, e^r by its Taylor series.
pub(crate) fn exp(v: Fx) -> Result<Fx, ErrorCode> {
    let x = v as i128 * ONE as i128;
    let k = round_div(x, LN2_E18);
    if k > 34 {
        return Err(ErrorCode::ExpressionOverflow);
    }
    if k < -70 {
        return Ok(0);
    }
    let r = x - k * LN2_E18;
    let mut term = E18;
    let mut sum = 0i128;
    let mut n = 1i128;
    while term != 0 {
        sum += term;
        term = arith::div_i128(arith::div_i128(arith::mul_i128(term, r), E18), n);
        n += 1;
    }
    let scaled = if k >= 0 { sum << k } else { sum >> (-k) };
    checked(round_div(scaled, ONE as i128))
}

/// a ** b: exact repeated multiplication for whole exponents, e^(b·ln a) otherwise.
pub(crate) fn pow(a: Fx, b: Fx) -> Result<Fx, ErrorCode> {
    if b % ONE == 0 && (b / ONE).abs() <= 64 {
        let n = b / ONE;
        let mut r = ONE;
        for _ in 0..n.abs() {
            r = mul(r, a)?;
        }
        return if n < 0 { div(ONE, r) } else { Ok(r) };
    }
    if a < 0 {
        return Err(ErrorCode::FunctionDomain);
    }
    if a == 0 {
        return Ok(0);
    }
    exp(mul(b, ln(a)?)?)
}

/// Evaluates a whole expression starting at the cursor (for tests and the fuzzer).
pub fn eval(c: &mut Cursor<'_>, params: &dyn ParamRead) -> Result<Fx, ExprError> {
    expression(c, params, 0, 0).map(or_zero)
}

#[cfg(test)]
mod tests {
    use super::*;

    struct NoParams;
    impl ParamRead for NoParams {
        fn read(&self, p: ParamRef) -> Result<Fx, ErrorCode> {
            match p {
                ParamRef::Numbered(n) => Ok(n as Fx * ONE),
                ParamRef::Named { .. } => Err(ErrorCode::UndefinedParameter),
            }
        }
        fn exists(&self, _: ParamRef) -> bool {
            false
        }
    }

    fn ev(s: &str) -> Result<Fx, ErrorCode> {
        let mut c = Cursor::new(s.as_bytes(), 0);
        let v = eval(&mut c, &NoParams).map_err(|e| e.0)?;
        if c.peek().is_some() {
            return Err(ErrorCode::ExpressionSyntax);
        }
        Ok(v)
    }

    #[test]
    fn precedence_and_operators() {
        assert_eq!(ev("[1 + 2 * 3]"), Ok(7 * ONE));
        assert_eq!(ev("[2 ** 3 ** 2]"), Ok(64 * ONE)); // left associative, as LinuxCNC
        assert_eq!(ev("[1 + 2 EQ 3]"), Ok(ONE));
        assert_eq!(ev("[1 LT 2 AND 3 GT 4]"), Ok(0));
        assert_eq!(ev("[1 XOR 0 OR 0]"), Ok(ONE));
        assert_eq!(ev("[-7 MOD 3]"), Ok(2 * ONE));
        assert_eq!(ev("[7 MOD -3]"), Ok(ONE));
        assert_eq!(ev("[1/3]"), Ok(333_333_333));
        assert_eq!(ev("[-[2]]"), Ok(-2 * ONE));
        assert_eq!(ev("[#7 / 2]"), Ok(3_500_000_000));
        assert_eq!(ev("[1/0]"), Err(ErrorCode::DivisionByZero));
        assert_eq!(ev("[1 +]"), Err(ErrorCode::ExpressionSyntax));
        assert_eq!(ev("[#<nope>]"), Err(ErrorCode::UndefinedParameter));
    }

    #[test]
    fn functions() {
        assert_eq!(ev("SQRT[2]"), Ok(1_414_213_562));
        assert_eq!(ev("SQRT[-1]"), Err(ErrorCode::FunctionDomain));
        assert_eq!(ev("ABS[-1.5]"), Ok(1_500_000_000));
        assert_eq!(ev("FIX[-1.5]"), Ok(-2 * ONE));
        assert_eq!(ev("FUP[-1.5]"), Ok(-ONE));
        assert_eq!(ev("FUP[1.2]"), Ok(2 * ONE));
        assert_eq!(ev("ROUND[2.5]"), Ok(3 * ONE));
        assert_eq!(ev("ROUND[-2.5]"), Ok(-3 * ONE));
        let near = |v: Result<Fx, ErrorCode>, want: Fx| {
            let v = v.unwrap();
            assert!((v - want).abs() <= 20, "{v} vs {want}");
        };
        near(ev("SIN[30]"), 500_000_000);
        near(ev("COS[60]"), 500_000_000);
        near(ev("COS[180]"), -ONE);
        near(ev("TAN[45]"), ONE);
        near(ev("ATAN[1]/[1]"), 45 * ONE);
        near(ev("ATAN[1]/[-1]"), 135 * ONE);
        near(ev("ASIN[0.5]"), 30 * ONE);
        near(ev("ACOS[0.5]"), 60 * ONE);
        near(ev("EXP[1]"), 2_718_281_828);
        near(ev("LN[10]"), 2_302_585_093);
        near(ev("EXP[LN[7.25]]"), 7_250_000_000);
        near(ev("[2 ** 0.5]"), 1_414_213_562);
        assert_eq!(ev("LN[0]"), Err(ErrorCode::FunctionDomain));
        assert_eq!(ev("EXP[100]"), Err(ErrorCode::ExpressionOverflow));
        assert_eq!(ev("ACOS[2]"), Err(ErrorCode::FunctionDomain));
    }
}
