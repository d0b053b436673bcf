//! Analog task: reads the feed-override pot and the joystick stick on ADC1 every 20 ms.
//!
//! Raw 12-bit readings go to atomics; scaling (override percent, jog speed, dead band) belongs to
//! the core's controller.

use crate::pin_table::Analog;
use core::sync::atomic::{AtomicBool, AtomicU16, Ordering};
use embassy_stm32::adc::{Adc, SampleTime};
use embassy_stm32::peripherals::ADC1;
use embassy_stm32::Peri;
use embassy_time::{Duration, Ticker};

/// Latest raw readings: feed-override pot, joystick X, joystick Y.
pub static RAW: [AtomicU16; 3] = [AtomicU16::new(0), AtomicU16::new(0), AtomicU16::new(0)];
/// Set once `RAW` holds a first reading.
pub static SAMPLED: AtomicBool = AtomicBool::new(false);

#[embassy_executor::task]
pub async fn run(adc1: Peri<'static, ADC1>, mut analog: Analog) {
    let mut adc = Adc::new(adc1);
    let mut ticker = Ticker::every(Duration::from_millis(20));
    loop {
        let [jx, jy] = &mut analog.joystick;
        for (slot, ch) in RAW.iter().zip([&mut analog.fro_pot, jx, jy]) {
            slot.store(
                adc.blocking_read(ch, SampleTime::CYCLES144),
                Ordering::Relaxed,
            );
        }
        SAMPLED.store(true, Ordering::Relaxed);
        ticker.next().await;
    }
}
