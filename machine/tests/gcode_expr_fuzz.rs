//! Fuzzing the expression parser: random expressions from the RS274NGC grammar and random bytes
//! never panic, and generated arithmetic agrees with a double-precision evaluation of the same
//! expression (the test's own oracle) to within the fixed-point rounding.
//!
//! The default run is short; the long one is ignored:
//! `GCODE_EXPR_FUZZ=1000000 cargo test --release -p gantry-machine --test gcode_expr_fuzz -- --ignored --nocapture`

use gantry_machine::gcode::expr::{eval, Cursor, Fx, ParamRead, ParamRef, ONE};
use gantry_machine::gcode::ErrorCode;

/// xorshift64*: deterministic everywhere.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

/// #n reads n / 4; named parameters are undefined.
struct Params;

impl ParamRead for Params {
    fn read(&self, p: ParamRef) -> Result<Fx, ErrorCode> {
        match p {
            ParamRef::Numbered(n) => Ok(n as Fx * ONE / 4),
            ParamRef::Named { .. } => Err(ErrorCode::UndefinedParameter),
        }
    }
    fn exists(&self, _: ParamRef) -> bool {
        false
    }
}

/// Rounding of one fixed-point operation (half a unit of the ninth decimal, with margin).
const ULP: f64 = 1.0e-9;

/// An arithmetic expression, its double-precision value and a bound on the fixed-point error
/// (forward error analysis: each operation adds one rounding and propagates its inputs' errors).
/// None: a division by zero, or by a value the accumulated error could make zero.
fn arithmetic(rng: &mut Rng, depth: u32, out: &mut String) -> Option<(f64, f64)> {
    if depth == 0 || rng.below(3) == 0 {
        return if rng.below(4) == 0 {
            let n = 1 + rng.below(40);
            out.push_str(&format!("#{n}"));
            Some((n as f64 / 4.0, 0.0))
        } else {
            let v = rng.below(20_000) as f64 / 100.0 - 100.0;
            out.push_str(&format!("{v:.2}"));
            Some((v, 0.0))
        };
    }
    out.push('[');
    let a = arithmetic(rng, depth - 1, out);
    let op = ["+", "-", "*", "/"][rng.below(4) as usize];
    out.push_str(&format!(" {op} "));
    let b = arithmetic(rng, depth - 1, out);
    out.push(']');
    let ((a, ea), (b, eb)) = (a?, b?);
    match op {
        "+" => Some((a + b, ea + eb + ULP)),
        "-" => Some((a - b, ea + eb + ULP)),
        "*" => Some((a * b, a.abs() * eb + b.abs() * ea + ea * eb + ULP)),
        _ if b.abs() <= 2.0 * eb + ULP => None,
        _ => Some((
            a / b,
            (a.abs() * eb + b.abs() * ea) / (b.abs() * (b.abs() - eb)) + ULP,
        )),
    }
}

const TOKENS: &[&str] = &[
    "[",
    "]",
    "[",
    "]",
    "#",
    "#<a>",
    "#[",
    "1",
    "2.5",
    ".5",
    "-",
    "+",
    "*",
    "**",
    "/",
    " MOD ",
    " EQ ",
    " NE ",
    " GT ",
    " GE ",
    " LT ",
    " LE ",
    " AND ",
    " OR ",
    " XOR ",
    "SIN",
    "COS",
    "TAN",
    "ASIN",
    "ACOS",
    "ATAN",
    "SQRT",
    "EXP",
    "LN",
    "ABS",
    "FIX",
    "FUP",
    "ROUND",
    "EXISTS",
    "999999999",
    "0",
    " ",
];

/// (executions, arithmetic results checked against the oracle, token soups that evaluated).
fn fuzz(executions: u64, seed: u64) -> (u64, u64, u64) {
    let mut rng = Rng(seed);
    let mut checked = 0;
    let mut soup_ok = 0;
    let mut text = String::new();
    for i in 0..executions {
        text.clear();
        match i % 3 {
            0 => {
                let want = arithmetic(&mut rng, 4, &mut text);
                let got = eval(&mut Cursor::new(text.as_bytes(), 0), &Params);
                match (want, got) {
                    (None, _) => {}
                    (Some((w, bound)), Ok(v)) => {
                        let v = v as f64 / ONE as f64;
                        // The bound, plus double precision's own rounding of large values.
                        let tol = bound + 1e-12 * w.abs() + 1e-12;
                        assert!((v - w).abs() <= tol, "{text}: {v} vs {w} (bound {bound})");
                        checked += 1;
                    }
                    (Some((w, _)), Err((code, _))) => {
                        // Only a result beyond the fixed-point range may fail.
                        assert!(
                            code == ErrorCode::ExpressionOverflow || w.abs() > 9.0e9 || w.is_nan(),
                            "{text}: {code:?} for {w}"
                        );
                    }
                }
            }
            1 => {
                for _ in 0..1 + rng.below(24) {
                    text.push_str(TOKENS[rng.below(TOKENS.len() as u64) as usize]);
                }
                if eval(&mut Cursor::new(text.as_bytes(), 0), &Params).is_ok() {
                    soup_ok += 1;
                }
            }
            _ => {
                let bytes: Vec<u8> = (0..rng.below(40)).map(|_| rng.next() as u8).collect();
                let _ = eval(&mut Cursor::new(&bytes, 0), &Params);
            }
        }
    }
    (executions, checked, soup_ok)
}

#[test]
fn expressions_never_panic_and_match_double_precision() {
    let (n, checked, soup_ok) = fuzz(30_000, 0x5eed_e4e4);
    assert_eq!(n, 30_000);
    assert!(checked > 8_000, "too few arithmetic checks: {checked}");
    assert!(soup_ok > 100, "token soup never evaluated: {soup_ok}");
}

#[test]
#[ignore]
fn expressions_fuzz_long_run() {
    let n: u64 = std::env::var("GCODE_EXPR_FUZZ")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1_000_000);
    let t = std::time::Instant::now();
    let (n, checked, soup_ok) = fuzz(n, 0xfeed_0002);
    eprintln!(
        "{n} executions, {checked} checked against f64, {soup_ok} soups evaluated, {:.1} s",
        t.elapsed().as_secs_f64()
    );
    assert!(n >= 1_000_000);
}
