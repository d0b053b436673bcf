//! Runs every cross-target vector of the core (`gantry_machine::vectors::all()`) on the Cortex-M4.
//!
//! Prints `ok NAME` or `FAIL NAME got X expected Y` per vector, then `N passed, M failed`, and exits
//! non-zero if any failed. With the `wrong-vector` feature one extra vector expects a wrong value,
//! so that build must fail: the test script checks the harness can fail.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use gantry_machine::vectors::{all, Vector};
use gantry_target_tests::{exit, println};

#[cfg(feature = "wrong-vector")]
fn deliberately_wrong() -> u32 {
    use gantry_machine::vectors::Digest;
    let mut d = Digest::new();
    d.bytes(b"gantry");
    d.finish()
}

/// Vectors added by this harness (only the deliberately wrong one, when enabled).
#[cfg(feature = "wrong-vector")]
const EXTRA: &[Vector] = &[Vector {
    name: "harness/deliberately-wrong-expectation",
    run: deliberately_wrong,
    expected: 0,
}];
#[cfg(not(feature = "wrong-vector"))]
const EXTRA: &[Vector] = &[];

#[entry]
fn main() -> ! {
    let (mut passed, mut failed) = (0u32, 0u32);
    for v in all().chain(EXTRA) {
        let got = (v.run)();
        if got == v.expected {
            println!("ok {}", v.name);
            passed += 1;
        } else {
            println!(
                "FAIL {} got {:#010x} expected {:#010x}",
                v.name, got, v.expected
            );
            failed += 1;
        }
    }
    println!("{} passed, {} failed", passed, failed);
    exit(failed == 0)
}
