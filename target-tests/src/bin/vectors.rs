//! Runs every cross-target vector of the core (`gantry_machine::vectors::all()`) on the Cortex-M4.
//!
//! Prints `ok NAME` or `FAIL NAME got X expected Y` per vector, then `N passed, M failed`, and exits
//! non-zero if any failed. With the `wrong-vector` feature the first core vector runs once more with
//! an expected digest one bit off, so that build must fail: the test script checks the harness can
//! fail on a real vector.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use gantry_machine::vectors::{all, Vector};
use gantry_target_tests::{exit, println};

/// With `wrong-vector`: the first real core vector again, its expected digest off by one bit, so
/// the build must report it failed (the test script checks that the harness can fail).
#[cfg(feature = "wrong-vector")]
fn extra() -> Option<Vector> {
    all().next().map(|v| Vector {
        name: "harness/deliberately-wrong-expectation",
        run: v.run,
        expected: v.expected ^ 1,
    })
}

#[cfg(not(feature = "wrong-vector"))]
fn extra() -> Option<Vector> {
    None
}

#[entry]
fn main() -> ! {
    let (mut passed, mut failed) = (0u32, 0u32);
    let mut check = |v: &Vector| {
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
    };
    all().for_each(&mut check);
    if let Some(v) = extra() {
        check(&v);
    }
    println!("{} passed, {} failed", passed, failed);
    exit(failed == 0)
}
