//! Support for the target binaries: semihosting output, exit codes, panic and fault handlers.
//!
//! Every binary in `src/bin/` runs on QEMU `mps2-an386`; it prints over semihosting and ends with
//! [`exit`], whose status QEMU returns to `cargo run` (any panic or fault exits with failure).
#![no_std]

use core::fmt::Write;
use cortex_m_rt::{exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hio};

pub mod program;

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

/// The benchmarks' time base: SysTick counting the core clock down from [`clock::RELOAD`], its
/// wraps counted by the exception, read as one 64-bit count (`src/bin/bench_step.rs`,
/// `src/bin/bench_motion.rs`).
pub mod clock {
    use core::sync::atomic::{AtomicU32, Ordering};
    use cortex_m::peripheral::SYST;
    use cortex_m_rt::exception;

    /// The SysTick reload value the benchmarks set (the counter's full 24 bits).
    pub const RELOAD: u32 = 0x00FF_FFFF;
    static WRAPS: AtomicU32 = AtomicU32::new(0);

    #[exception]
    fn SysTick() {
        WRAPS.fetch_add(1, Ordering::Relaxed);
    }

    /// Starts SysTick on the core clock from [`RELOAD`], its wrap exception on, and returns once
    /// the counter has loaded (it starts at 0 and reloads on the first clock).
    pub fn start(syst: &mut SYST) {
        use cortex_m::peripheral::syst::SystClkSource;
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(RELOAD);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
        while SYST::get_current() == 0 {}
    }

    /// SysTick counts since start (wraps counted by the exception).
    pub fn now() -> u64 {
        loop {
            let w = WRAPS.load(Ordering::Relaxed);
            let c = SYST::get_current();
            if WRAPS.load(Ordering::Relaxed) == w {
                return w as u64 * (RELOAD as u64 + 1) + (RELOAD - c) as u64;
            }
        }
    }

    /// Counts × 1000 of an empty [`now`] pair: what each timed call's own two reads add
    /// (the benchmarks subtract it per timed call).
    pub fn timer_overhead() -> u64 {
        const N: u64 = 1000;
        let mut acc = 0u64;
        for _ in 0..N {
            let p0 = now();
            acc += core::hint::black_box(now()) - p0;
        }
        acc * 1000 / N
    }
}
