//! Bring-up main loop (built without the `controller` feature): no `Board`, the USB port echoes
//! what it receives, the step ISR idles (its queue stays empty), every limit input stops it, the
//! outputs stay in their power-up state, and the watchdog is fed every millisecond.
//!
//! This is the firmware that fits the F411 size budget; the full controller (`--features
//! controller`) does not yet (see firmware/README.md).

use crate::board_def::Outputs;
use crate::inputs::{ARM, INVERT};
use crate::usb::LinkPipe;
use crate::watchdog;
use core::sync::atomic::Ordering;
use embassy_time::{Duration, Ticker};
use gantry_machine::board::LIMIT_BITS;
use gantry_machine::motion::kernel::Segment;
use heapless::spsc::Producer;

#[embassy_executor::task]
pub async fn run(
    _outputs: Outputs,
    _segments: Producer<'static, Segment>,
    rx: &'static LinkPipe,
    tx: &'static LinkPipe,
) -> ! {
    // Closed switch = 1 (see inputs.rs): any closed limit switch stops the kernel.
    INVERT.store(0, Ordering::Relaxed);
    ARM.store(LIMIT_BITS, Ordering::Relaxed);
    let mut ticker = Ticker::every(Duration::from_millis(1));
    let mut buf = [0u8; 64];
    loop {
        watchdog::feed();
        while tx.free_capacity() >= buf.len() {
            let Ok(n) = rx.try_read(&mut buf) else {
                break;
            };
            let _ = tx.try_write(&buf[..n]);
        }
        ticker.next().await;
    }
}
