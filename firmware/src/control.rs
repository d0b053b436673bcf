//! The main loop task: every millisecond, the core's `MainLoop::pass`
//! (machine/src/device/main_loop.rs), the very function the emulated board runs
//! (emulator/src/board.rs), and `MainLoop::host_bytes_pass` as soon as the USB receive task has
//! put the host's bytes into the pipe (a line is answered when it arrives, not at the next tick). This file is only its port onto the hardware: the step ISR's
//! kernel and queue (`step`), the input pins and limit arming (`inputs`), the ADC (`analog`), the
//! output pins, the USB pipes and DTR (`usb`), flash (`settings`), the motion marker
//! (`reset_marker`) and the watchdog. Nothing here decides anything.

use crate::inputs::{armed_limit, ARM, INVERT, PINS};
use crate::pin_table::Outputs;
use crate::settings::{self, Store};
use crate::step::{self, STOP};
use crate::usb::{LinkPipe, RxWake, DTR};
use crate::{analog, reset_marker, watchdog};
use core::sync::atomic::Ordering;
use embassy_futures::select::{select, Either};
use embassy_stm32::gpio::Level;
use embassy_time::{Duration, Instant, Ticker};
use gantry_machine::board::inputs::InputBits;
use gantry_machine::board::Board;
use gantry_machine::board::{AdcReadings, OutputLevels};
use gantry_machine::device::link::BoardLink;
use gantry_machine::device::main_loop::{BoardPort, HostPort, KernelSnapshot, MainLoop};
use gantry_machine::setup::Setup;
use gantry_machine::step::kernel::{Segment, StepTiming};
use gantry_machine::units::MAX_AXES;
use gantry_settings::SaveError;
use heapless::spsc::Producer;

/// Everything the main loop drives: the hardware side of its port.
pub struct Io {
    pub outputs: Outputs,
    pub segments: Producer<'static, Segment>,
    pub rx: &'static LinkPipe,
    /// Raised with each packet the receive task put into `rx`.
    pub rx_wake: &'static RxWake,
    pub tx: &'static LinkPipe,
    pub store: Store,
}

/// The port with what one task run needs besides `Io`.
struct Port {
    io: Io,
    /// A flash write stalled the CPU during this pass (the ticker restarts after it).
    saved: bool,
}

fn level(on: bool) -> Level {
    if on {
        Level::High
    } else {
        Level::Low
    }
}

impl BoardPort for Port {
    fn kernel(&mut self) -> KernelSnapshot {
        step::snapshot()
    }

    fn flush_kernel(&mut self) {
        step::flush();
    }

    /// With interrupts masked, so the input task cannot set `STOP` between the check and the
    /// clear.
    fn rearm_kernel(&mut self) {
        critical_section::with(|_| {
            STOP.store(armed_limit(PINS.load(Ordering::Relaxed)), Ordering::Relaxed);
        });
        step::rearm();
    }

    fn arm_limits(&mut self, arm: u32) {
        ARM.store(arm, Ordering::Relaxed);
        if armed_limit(PINS.load(Ordering::Relaxed)) {
            STOP.store(true, Ordering::Relaxed);
        }
    }

    fn raw_inputs(&mut self) -> u32 {
        PINS.load(Ordering::Relaxed)
    }

    fn arm_probe(&mut self, trips_at: Option<bool>) {
        step::arm_probe(trips_at);
    }

    fn probe_latched(&mut self) -> Option<[i64; gantry_machine::units::MAX_AXES]> {
        step::probe_latched()
    }

    fn adc(&mut self) -> AdcReadings {
        if analog::SAMPLED.load(Ordering::Relaxed) {
            let raw = |i: usize| analog::RAW[i].load(Ordering::Relaxed);
            AdcReadings {
                fro: Some(raw(0)),
                stick: Some([raw(1), raw(2)]),
            }
        } else {
            AdcReadings::default()
        }
    }

    fn queue_ready(&mut self) -> bool {
        self.io.segments.ready()
    }

    fn push_segment(&mut self, seg: Segment) {
        let _ = self.io.segments.enqueue(seg);
    }

    fn drop_newest(&mut self, max: usize) -> usize {
        step::drop_newest(max, &mut self.io.segments)
    }

    fn set_position(&mut self, steps: [i64; MAX_AXES]) {
        step::set_position(steps);
    }

    fn apply_setup(&mut self, invert: u32, timing: StepTiming) {
        INVERT.store(invert, Ordering::Relaxed);
        step::set_timing(timing);
    }

    fn exchange_user_outputs(&mut self, f: impl FnOnce(u16) -> Option<u16>) {
        step::sync_user_outputs(f);
    }

    /// The spindle duty counts `0..=pwm_max` (setup) and maps onto the PWM timer's own period.
    /// User outputs are driven by `step::sync_user_outputs` and the step ISR.
    fn drive_outputs(&mut self, l: &OutputLevels, pwm_max: u16, steppers_enabled: bool) {
        let o = &mut self.io.outputs;
        o.spindle_enable.set_level(level(l.spindle_enable));
        o.spindle_dir.set_level(level(l.spindle_ccw));
        if l.laser {
            // The step interrupt owns the compare register (`step.rs` `write_power`); the
            // period is `pwm_max` counts so a duty count is a compare count.
            crate::pin_table::spindle_pwm_period(pwm_max);
        } else {
            let max = u32::from(pwm_max.max(1));
            o.spindle_pwm
                .set_duty_cycle_fraction(u32::from(l.spindle_pwm).min(max), max);
        }
        o.coolant_flood.set_level(level(l.flood));
        o.coolant_mist.set_level(level(l.mist));
        // Active low.
        o.stepper_enable.set_level(level(!steppers_enabled));
    }

    /// `buf` is what the link can take now (the main loop sizes it): the rest stays in the pipe,
    /// and behind it in the endpoint (`usb::run_rx`).
    fn receive(&mut self, buf: &mut [u8]) -> usize {
        self.io.rx.try_read(buf).unwrap_or(0)
    }

    fn can_transmit(&mut self, len: usize) -> bool {
        self.io.tx.free_capacity() >= len
    }

    fn transmit(&mut self, frame: &[u8]) {
        let _ = self.io.tx.try_write(frame);
    }

    fn host_port(&mut self) -> HostPort {
        // A USB host that closes the port without dropping DTR is not visible here.
        if DTR.load(Ordering::Relaxed) {
            HostPort::Open
        } else {
            HostPort::Closed
        }
    }

    /// Stalls the CPU for up to ~2 s when a sector is erased (single-bank flash): the core calls
    /// it only with the controller idle and nothing moving.
    fn save_setup(&mut self, setup: &Setup) {
        watchdog::long();
        match settings::save(&mut self.io.store, setup) {
            Ok(()) => defmt::info!("setup saved to flash"),
            Err(SaveError::Encode) => defmt::error!("setup not saved: does not encode"),
            Err(SaveError::Flash) => defmt::error!("setup not saved: flash error"),
        }
        watchdog::normal();
        self.saved = true;
    }

    fn motion_marker(&mut self, moving: bool) {
        if moving {
            reset_marker::moving();
        } else {
            reset_marker::idle();
        }
    }

    fn limit_stopped(&mut self, levels: InputBits) {
        defmt::warn!("limit stop, pins {=u32:#010x}", levels.0);
    }

    fn host_closed(&mut self) {
        defmt::info!("host closed the port: host-loss policy");
    }
}

/// The board and its link live in statics (see `main`): built inside this task they would make
/// every poll of it reserve their ~48 KiB on the stack.
#[embassy_executor::task]
pub async fn run(io: Io, board: &'static mut Board, link: &'static mut BoardLink) -> ! {
    // The input task's limit check and the step ISR already run with the setup from flash; the
    // polarity is published here, before the first pass.
    INVERT.store(board.setup().inputs.invert, Ordering::Relaxed);
    let mut main = MainLoop::new(board.setup());
    let mut port = Port { io, saved: false };
    let mut ticker = Ticker::every(Duration::from_millis(1));
    let mut for_bytes = false;
    loop {
        watchdog::feed();
        let now = Instant::now().as_millis() as u32;
        if for_bytes {
            main.host_bytes_pass(now, board, link, &mut port);
        } else {
            main.pass(now, board, link, &mut port);
        }
        // A pass that read every byte has spent the wake (the emulated board does the same,
        // `emulator/src/board.rs` `main_loop`); bytes left by the link's flow control keep it.
        if port.io.rx.is_empty() {
            port.io.rx_wake.reset();
        }
        if core::mem::take(&mut port.saved) {
            ticker.reset();
        }
        // The tick first when both are ready, as the emulated board orders them.
        for_bytes = match select(ticker.next(), port.io.rx_wake.wait()).await {
            Either::First(()) => false,
            Either::Second(()) => true,
        };
    }
}
