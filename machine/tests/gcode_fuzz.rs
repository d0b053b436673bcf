//! Property test: arbitrary bytes and G-code-like token soup never panic the interpreter, every
//! action and error it gives names a line of the program, the same program gives the same items
//! twice, and its memory stays bounded (it is a fixed-size value; no heap exists in the crate).
//!
//! The default suite runs a few thousand executions. The long run is ignored by default:
//! `GCODE_FUZZ_EXECUTIONS=1000000 cargo test --release -p gantry-machine --test gcode_fuzz -- --ignored --nocapture`
#![allow(clippy::field_reassign_with_default, clippy::type_complexity)]

use std::time::Instant;

use gantry_machine::gcode::{InterpConfig, Interpreter, MemorySource};

/// xorshift64*: deterministic on every platform.
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

const LETTERS: &[u8] = b"GGGGMMXXYYZZIJKFFPQRSTHLNOABCD";
const G_CODES: &[&str] = &[
    "0", "1", "2", "3", "4", "10", "17", "18", "19", "20", "21", "28", "28.1", "30", "30.1", "40",
    "41", "43", "43.1", "49", "53", "54", "55", "59.3", "61", "64", "73", "80", "81", "82", "83",
    "84", "85", "86", "87", "88", "89", "90", "91", "90.1", "91.1", "92", "92.1", "92.2", "92.3",
    "93", "94", "98", "99", "01", "00",
];
const M_CODES: &[&str] = &[
    "0", "1", "2", "3", "4", "5", "6", "7", "8", "9", "30", "98", "99", "10", "100", "00", "01",
];

fn number(rng: &mut Rng, out: &mut Vec<u8>) {
    if rng.below(3) == 0 {
        out.push(if rng.below(2) == 0 { b'-' } else { b'+' });
    }
    let magnitude = match rng.below(6) {
        0 => rng.below(3),
        1 => rng.below(20),
        2 => rng.below(1000),
        3 => rng.below(100_000),
        4 => rng.below(10_000_000_000),
        _ => rng.next(),
    };
    let s = magnitude.to_string();
    match rng.below(4) {
        0 => out.extend_from_slice(s.as_bytes()),
        1 => {
            out.extend_from_slice(s.as_bytes());
            out.push(b'.');
        }
        2 => {
            out.push(b'.');
            out.extend_from_slice(s.as_bytes());
        }
        _ => {
            let cut = rng.below(s.len() as u64 + 1) as usize;
            out.extend_from_slice(&s.as_bytes()[..cut]);
            out.push(b'.');
            out.extend_from_slice(&s.as_bytes()[cut..]);
        }
    }
}

fn token_soup(rng: &mut Rng, out: &mut Vec<u8>) {
    let lines = rng.below(40) + 1;
    for _ in 0..lines {
        match rng.below(30) {
            0 => out.extend_from_slice(b"%"),
            1 => out.extend_from_slice(b"M30"),
            2 => {
                out.extend_from_slice(b"O");
                out.extend_from_slice(rng.below(4).to_string().as_bytes());
            }
            3 => {
                out.extend_from_slice(b"M98 P");
                out.extend_from_slice(rng.below(4).to_string().as_bytes());
                if rng.below(2) == 0 {
                    out.extend_from_slice(b" L3");
                }
            }
            4 => out.extend_from_slice(b"M99"),
            _ => {
                if rng.below(10) == 0 {
                    out.push(b'/');
                }
                let words = rng.below(7);
                for _ in 0..words {
                    let l = LETTERS[rng.below(LETTERS.len() as u64) as usize];
                    out.push(if rng.below(4) == 0 {
                        l.to_ascii_lowercase()
                    } else {
                        l
                    });
                    match l {
                        b'G' => out.extend_from_slice(
                            G_CODES[rng.below(G_CODES.len() as u64) as usize].as_bytes(),
                        ),
                        b'M' => out.extend_from_slice(
                            M_CODES[rng.below(M_CODES.len() as u64) as usize].as_bytes(),
                        ),
                        _ => number(rng, out),
                    }
                    match rng.below(12) {
                        0 => out.extend_from_slice(b"(c)"),
                        1 => out.extend_from_slice(b";x"),
                        2 => {}
                        _ => out.push(b' '),
                    }
                }
            }
        }
        out.push(if rng.below(8) == 0 { b'\r' } else { b'\n' });
        if rng.below(20) == 0 {
            out.push(b'\n');
        }
    }
}

fn random_bytes(rng: &mut Rng, out: &mut Vec<u8>) {
    let n = rng.below(200);
    for _ in 0..n {
        let b = match rng.below(4) {
            0 => rng.below(256) as u8,
            1 => b'\n',
            _ => b" 0123456789.-+GXYZMFPQRIJKLNO()%/;"[rng.below(34) as usize],
        };
        out.push(b);
    }
}

/// What one execution pulled: actions, errors, and a digest of the whole sequence.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Pulled {
    actions: usize,
    errors: usize,
    digest: u64,
}

/// Runs one execution. Every action and error must carry a line number of the program (at most
/// one past its last line break: the line an error at the end of the text is reported on).
fn execute(program: &[u8], cfg: &InterpConfig) -> Pulled {
    let lines = program
        .iter()
        .filter(|&&b| b == b'\n' || b == b'\r')
        .count() as u32
        + 1;
    let mut it = Interpreter::new(cfg);
    let mut src = MemorySource::new(program);
    let mut p = Pulled::default();
    let mut mix = |v: u64| p.digest = (p.digest ^ v).wrapping_mul(0x100_0000_01b3);
    let (mut actions, mut errors) = (0, 0);
    while let Some(item) = it.next(&mut src) {
        match item {
            Ok(c) => {
                assert!(
                    c.line <= lines,
                    "action on line {} of {lines}: {c:?}",
                    c.line
                );
                mix(u64::from(c.line));
                mix(format!("{:?}", c.action).len() as u64);
                actions += 1;
            }
            Err(e) => {
                assert!(
                    e.line <= lines,
                    "error on line {} of {lines}: {e:?}",
                    e.line
                );
                mix(u64::from(e.code.number()) << 32 | u64::from(e.line));
                errors += 1;
            }
        }
        // Endless M99 loops and huge repeat counts are legal: stop pulling, as a host would.
        if actions + errors >= 500 {
            break;
        }
    }
    p.actions = actions;
    p.errors = errors;
    p
}

/// Runs `executions` programs; the totals of what they pulled.
fn fuzz(executions: u64, seed: u64) -> Pulled {
    let mut rng = Rng(seed | 1);
    let mut configs = [InterpConfig::default(), InterpConfig::gixa()];
    configs[0].add_user_m_code(100);
    configs[0].set_tool(1, 10_000_000);
    configs[0].block_delete = true;
    let mut buf = Vec::with_capacity(4096);
    let mut total = Pulled::default();
    for i in 0..executions {
        buf.clear();
        if i % 4 == 0 {
            random_bytes(&mut rng, &mut buf);
        } else {
            token_soup(&mut rng, &mut buf);
        }
        if std::env::var("GCODE_FUZZ_TRACE").is_ok() {
            eprintln!("#{i} cfg{} {:?}", i % 2, String::from_utf8_lossy(&buf));
        }
        let cfg = &configs[(i % 2) as usize];
        let p = execute(&buf, cfg);
        if i % 16 == 0 {
            assert_eq!(execute(&buf, cfg), p, "program #{i} ran differently twice");
        }
        total.actions += p.actions;
        total.errors += p.errors;
        total.digest ^= p.digest;
    }
    total
}

#[test]
fn arbitrary_input_never_panics() {
    // 13 KiB: cutter compensation's look-ahead (machine/src/gcode/comp.rs) added 1,240 B, the
    // M70/M73 saved states (machine/src/gcode/interp/context.rs) 936 B.
    assert!(std::mem::size_of::<Interpreter>() <= 13 * 1024);
    let p = fuzz(1_000, 0x5eed_0001);
    // The generator reaches the interpreter's depths: many programs run actions, many fail.
    assert!(p.actions > 10_000, "{p:?}");
    assert!(p.errors > 10_000, "{p:?}");
}

#[test]
#[ignore = "long run: set GCODE_FUZZ_EXECUTIONS (default 1 000 000) and use --release"]
fn arbitrary_input_never_panics_long_run() {
    let executions = std::env::var("GCODE_FUZZ_EXECUTIONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1_000_000u64);
    let start = Instant::now();
    let p = fuzz(executions, 0xfeed_beef);
    let secs = start.elapsed().as_secs_f64();
    println!(
        "gcode fuzz: {executions} executions, {} actions, {} errors, {secs:.1} s",
        p.actions, p.errors
    );
}
