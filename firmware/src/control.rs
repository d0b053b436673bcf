//! The main loop: one task that owns the `Board` (controller, interpreter, motion pipeline) and
//! its `BoardLink`, and runs every millisecond in the shape of the emulated board's main loop
//! (host-sender/src/emulator.rs):
//!
//! 1. kernel stopped by a limit → drop the queue, `Board::limit_stop`, re-arm unless in alarm;
//! 2. debounced inputs and ADC readings → `Board::on_inputs`;
//! 3. bytes from USB → `BoardLink::on_bytes`, `service`, `Board::poll(kernel_drained)`;
//!    `Board::drop_queued` takes back queued segments for a stop or a jog's speed change;
//! 4. segments from `Board::next_segment` into the step ISR's queue, with the motion marker set
//!    before the ISR can run them and cleared once the kernel is drained (alarm 3 after a reset);
//!    the user output word exchanged with the kernel (`Board::sync_user_outputs`);
//! 5. `service` again, frames into the USB transmit pipe, output levels to the pins;
//! 6. a setup the host pushed is saved to flash once the board is idle;
//! 7. the watchdog is fed.
//!
//! Host loss: `BoardLink` holds a running job when the host goes silent (and ends it with alarm 20
//! after `link.host_lost_stop_s`); a DTR drop (the sender closed the port) holds it at once.

use crate::board_def::Outputs;
use crate::inputs::{armed_limit, ARM, INVERT, PINS};
use crate::settings::{self, Store};
use crate::step::{self, STOP};
use crate::usb::{LinkPipe, DTR};
use crate::{analog, reset_marker, watchdog};
use core::sync::atomic::Ordering;
use embassy_stm32::gpio::Level;
use embassy_time::{Duration, Instant, Ticker};
use gantry_machine::board::link::{BoardLink, KernelView};
use gantry_machine::board::Board;
use gantry_machine::controller::inputs::{Debouncer, InputBits};
use gantry_machine::controller::{AdcReadings, OutputLevels, State};
use gantry_machine::motion::kernel::{Segment, StepTiming};
use gantry_machine::motion::trig::isqrt_u64;
use gantry_machine::setup::Setup;
use gantry_machine::units::{Pos, MAX_AXES};
use gantry_settings::{SaveError, SavePolicy};
use heapless::spsc::Producer;

/// Everything the main loop drives.
pub struct Io {
    pub outputs: Outputs,
    pub segments: Producer<'static, Segment>,
    pub rx: &'static LinkPipe,
    pub tx: &'static LinkPipe,
    pub store: Store,
}

/// Path speed from the kernel's position, measured over about 20 ms.
struct SpeedMeter {
    since_ms: u32,
    from: Pos,
    um_min: u32,
}

impl SpeedMeter {
    const WINDOW_MS: u32 = 20;

    fn update(&mut self, now_ms: u32, at: Pos) -> u32 {
        let dt = now_ms.wrapping_sub(self.since_ms);
        if dt >= Self::WINDOW_MS {
            let mut sum_sq: u64 = 0;
            for (a, b) in at.iter().zip(&self.from) {
                // Clamped to ±2^30 nm (1 m per window), far beyond any machine: no overflow.
                // max/min, not `clamp`: its panic message would link core::fmt (flash).
                #[allow(clippy::manual_clamp)]
                let d = (a - b).max(-(1 << 30)).min(1 << 30).unsigned_abs();
                sum_sq = sum_sq.saturating_add(d * d);
            }
            // nm per ms × 60 = µm per min.
            self.um_min = (isqrt_u64(sum_sq) * 60 / u64::from(dt)).min(u64::from(u32::MAX)) as u32;
            self.since_ms = now_ms;
            self.from = at;
        }
        self.um_min
    }
}

fn level(on: bool) -> Level {
    if on {
        Level::High
    } else {
        Level::Low
    }
}

/// Output levels to pins. The spindle duty counts `0..=pwm_max` (setup) and maps onto the PWM
/// timer's own period. User outputs are not driven here but in `step::sync_user_outputs`.
fn drive(o: &mut Outputs, l: &OutputLevels, pwm_max: u16, steppers_enabled: bool) {
    o.spindle_enable.set_level(level(l.spindle_enable));
    o.spindle_dir.set_level(level(l.spindle_ccw));
    let max = u32::from(pwm_max.max(1));
    o.spindle_pwm
        .set_duty_cycle_fraction(u32::from(l.spindle_pwm).min(max), max);
    o.coolant_flood.set_level(level(l.flood));
    o.coolant_mist.set_level(level(l.mist));
    // Active low.
    o.stepper_enable.set_level(level(!steppers_enabled));
}

fn debouncer(setup: &Setup) -> Debouncer {
    INVERT.store(setup.inputs.invert, Ordering::Relaxed);
    Debouncer::new(setup.inputs.invert, setup.inputs.debounce_ms)
}

/// Re-evaluates the stop flag with the board's current arming and re-arms the kernel: with
/// interrupts masked, so the input task cannot set `STOP` between the check and the clear.
fn rearm_kernel() {
    critical_section::with(|_| {
        STOP.store(armed_limit(PINS.load(Ordering::Relaxed)), Ordering::Relaxed);
    });
    step::rearm();
}

/// The board and its link live in statics (see `main`): built inside this task they would make
/// every poll of it reserve their ~48 KiB on the stack.
#[embassy_executor::task]
pub async fn run(mut io: Io, board: &'static mut Board, link: &'static mut BoardLink) -> ! {
    let mut debounce = debouncer(board.setup());
    let mut policy = SavePolicy::new();
    let mut speed = SpeedMeter {
        since_ms: 0,
        from: [0; MAX_AXES],
        um_min: 0,
    };
    // A latched kernel stop the board has been told about; the kernel stays stopped while the
    // board is in alarm.
    let mut stop_handled = false;
    let mut steppers_enabled = false;
    let mut dtr_was = false;
    let mut rx = [0u8; 64];
    let mut frame = [0u8; gantry_proto::MAX_FRAME_LEN];
    let mut ticker = Ticker::every(Duration::from_millis(1));
    loop {
        watchdog::feed();
        let now = Instant::now().as_millis() as u32;

        // 1. A limit stopped the kernel: drop the queue, tell the board, re-arm unless alarmed.
        let k = step::snapshot();
        if k.stopped && !stop_handled {
            step::flush();
            let steps = step::snapshot().steps;
            let levels = InputBits(PINS.load(Ordering::Relaxed) ^ board.setup().inputs.invert);
            board.limit_stop(levels, &steps);
            ARM.store(board.limit_arm(), Ordering::Relaxed);
            stop_handled = true;
            defmt::warn!("limit stop, pins {=u32:#010x}", levels.0);
        }
        if stop_handled && board.state() != State::Alarm {
            rearm_kernel();
            stop_handled = false;
        }

        // 2. Inputs (debounced here; the kernel saw the raw limit pins already).
        let (levels, changed) = debounce.sample(PINS.load(Ordering::Relaxed));
        let adc = if analog::SAMPLED.load(Ordering::Relaxed) {
            let raw = |i: usize| analog::RAW[i].load(Ordering::Relaxed);
            AdcReadings {
                fro: Some(raw(0)),
                stick: Some([raw(1), raw(2)]),
            }
        } else {
            AdcReadings::default()
        };
        board.on_inputs(now, levels, changed, adc);

        // 3. Host link and controller.
        while let Ok(n) = io.rx.try_read(&mut rx) {
            link.on_bytes(now, &rx[..n]);
        }
        let dtr = DTR.load(Ordering::Relaxed);
        if dtr_was && !dtr {
            // The sender closed the port: hold now rather than after the silence timeout.
            defmt::info!("host closed the port: feed hold");
            board.feed_hold();
        }
        dtr_was = dtr;
        let speed_um_min = speed.update(now, board.machine_position(&k.steps));
        let view = KernelView {
            steps: k.steps,
            inputs: levels.0,
            feed_um_min: speed_um_min,
        };
        link.service(board, now, &view);
        let drained = step::snapshot().drained;
        board.poll(drained);
        if let Some(steps) = board.take_position_reset() {
            step::set_position(steps);
        }
        // A stop or a jog's speed change: the newest queued segments go, segment prep continues
        // from the end of the kernel's running segment.
        if !stop_handled {
            board.drop_queued(|max| step::drop_newest(max, &mut io.segments));
        }

        // 4. Segments for the step ISR (none while it is stopped).
        let mut handed_out = false;
        if !stop_handled {
            while io.segments.ready() {
                let Some(seg) = board.next_segment() else {
                    break;
                };
                // Power-up: drivers stay disabled until the first motion (DESIGN §6).
                steppers_enabled = true;
                // Before the ISR can step it: a reset from here on is a reset during motion.
                reset_marker::moving();
                handed_out = true;
                let _ = io.segments.enqueue(seg);
            }
        }
        if drained && !handed_out && !board.position_lost() {
            reset_marker::idle();
        }
        // User outputs: the board takes the levels the kernel's on-the-fly events left on the
        // pins, or (after a list at rest, an alarm) loads its own into the kernel and the pins.
        step::sync_user_outputs(|word| board.sync_user_outputs(word));
        ARM.store(board.limit_arm(), Ordering::Relaxed);
        if armed_limit(PINS.load(Ordering::Relaxed)) {
            STOP.store(true, Ordering::Relaxed);
        }

        // 5. Events of this pass go out now; then the pins.
        link.service(board, now, &view);
        while io.tx.free_capacity() >= frame.len() {
            let Some(n) = link.poll_transmit(now, &mut frame) else {
                break;
            };
            let _ = io.tx.try_write(&frame[..n]);
        }
        drive(
            &mut io.outputs,
            &board.output_levels(),
            board.setup().outputs.pwm_max,
            steppers_enabled,
        );

        // 6. A new setup from the host: new input polarity and step pulse shape now (the board
        // is idle: setups are only taken then), flash once idle.
        let changed = link.take_setup_changed();
        if changed {
            debounce = debouncer(board.setup());
            step::set_timing(StepTiming::from_setup(&board.setup().drivers));
        }
        policy.changed(changed);
        if policy.due(board.state(), drained) {
            // Stalls the CPU for up to ~2 s when a sector is erased (single-bank flash): only
            // here, with the controller idle and nothing moving.
            watchdog::long();
            match settings::save(&mut io.store, board.setup()) {
                Ok(()) => defmt::info!("setup saved to flash"),
                Err(SaveError::Encode) => defmt::error!("setup not saved: does not encode"),
                Err(SaveError::Flash) => defmt::error!("setup not saved: flash error"),
            }
            watchdog::normal();
            policy.done();
            ticker.reset();
        }

        ticker.next().await;
    }
}
