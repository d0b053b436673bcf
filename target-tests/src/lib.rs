//! Support for the target binaries: semihosting output, exit codes, panic and fault handlers.
//!
//! Every binary in `src/bin/` runs on QEMU `mps2-an386`; it prints over semihosting and ends with
//! [`exit`], whose status QEMU returns to `cargo run` (any panic or fault exits with failure).
#![no_std]

use core::fmt::Write;
use cortex_m_rt::{exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hio};

/// Writes formatted text to the host's stdout.
pub fn print(args: core::fmt::Arguments) {
    if let Ok(mut out) = hio::hstdout() {
        let _ = out.write_fmt(args);
    }
}

/// `println!` over semihosting.
#[macro_export]
macro_rules! println {
    ($($arg:tt)*) => {
        $crate::print(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// Ends the QEMU run with success (`true`) or failure.
pub fn exit(success: bool) -> ! {
    debug::exit(if success {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    loop {
        cortex_m::asm::bkpt();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    println!("PANIC {}", info);
    exit(false)
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    println!("HARD FAULT at pc {:#010x}", frame.pc());
    exit(false)
}
