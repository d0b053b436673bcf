//! The board's main loop, once: the firmware (`firmware/src/control.rs`, every millisecond on
//! the board) and the emulated board (`emulator/src/board.rs`, every virtual millisecond)
//! both call [`MainLoop::pass`], and [`MainLoop::host_bytes_pass`] as soon as the host's bytes
//! arrive between two ticks, so a line is answered in the pass its bytes woke (a grbl counting
//! sender's rate is its `ok` round trip's, docs/laser-plasma.md "Raster speed"). Everything
//! that decides anything lives here; what differs between the two (the step kernel behind an
//! interrupt or on a virtual clock, pins, USB pipes or a byte buffer, flash, the motion marker)
//! sits behind [`BoardPort`].
//!
//! One pass, in this order (the order is part of the behaviour, see docs/architecture.md
//! "The main loop"):
//! 1. **Limit latch.** The kernel latched a stop (a limit switch): the queue and the running
//!    segment are dropped, [`Board::limit_stop`] is told where it stopped and which pins tripped,
//!    and the kernel stays stopped (no segment handed out, none dropped) while the board is in
//!    alarm; it is re-armed once the alarm is cleared (or at once when the stop was a homing
//!    seek's switch).
//! 2. **Inputs.** Raw pins debounced with the setup's polarity and debounce, the ADC readings:
//!    [`Board::on_inputs`]. At the ticks only: a pass the host's bytes woke keeps the last
//!    tick's levels.
//! 3. **Top-up.** In a plain run, the kernel's queue is filled from what is already planned
//!    before the link and the interpreter take their share of the pass.
//! 4. **Host link and controller.** Bytes from the host, at most [`RX_BYTES_PER_PASS`] and never more than the link can take ([`BoardLink::rx_room`]: the rest waits in the port, flow control); the host-loss rule (the host closed the
//!    port, DTR dropped: feed hold); the path speed ([`SpeedMeter`], a 20 ms window);
//!    [`BoardLink::service`]; a tripped probe latch to [`Board::probe_tripped`];
//!    [`Board::poll`] with the kernel's drained flag; a new home loaded
//!    into the kernel; queued segments taken back for a stop or a jog's speed change.
//! 5. **Segments** into the kernel's queue (the probe latch armed first, [`Board::probe_arm`]) (the motion marker set before the kernel can step
//!    them, cleared once drained), time lost to starvation counted ([`Starvation`]),
//!    the user output word exchanged with the kernel, the limit bits armed for the kernel.
//! 6. **Out.** The link again (events of this pass go out in it), frames to the host, output
//!    levels to the pins.
//! 7. **Setup change.** A setup the host pushed: new debouncer and step pulse timing now, saved
//!    once the board is idle and the kernel drained (a flash write stalls the CPU).
//! 8. **Underruns.** Whether the kernel running dry before the next pass would be a gap in the
//!    job's motion; the next pass counts it from the kernel's dry runs ([`Underruns`]).

use super::link::{BoardLink, KernelView};
use super::starvation::{Sample, Starvation};
use super::underruns::Underruns;
use crate::arith::isqrt_u64;
use crate::board::inputs::{Debouncer, InputBits};
use crate::board::Board;
use crate::board::{AdcReadings, OutputLevels, State};
use crate::motion::pipeline::MotionState;
use crate::setup::Setup;
use crate::step::kernel::{Segment, StepTiming};
use crate::units::{Pos, MAX_AXES};

pub use crate::step::KernelSnapshot;

/// Slots of the segment queue between the main loop and the step kernel. The firmware's queue is
/// a heapless SPSC queue of this many slots, which holds one less ([`SEGMENT_QUEUE_DEPTH`]).
pub const SEGMENT_QUEUE_SLOTS: usize = 16;
/// Segments the queue holds (about 2 ms each: 30 ms of motion ahead of the kernel). Segment prep
/// remembers at least as many, so a stop can take every queued segment back.
pub const SEGMENT_QUEUE_DEPTH: usize = SEGMENT_QUEUE_SLOTS - 1;

/// Bytes a pass takes from the host at most: a burst (a pty read of 4 KiB, the USB stack's
/// buffer after a busy moment) is taken over several passes, so one pass's link work cannot
/// outlast the kernel's queue (docs/architecture.md "One pass, in order"). 512 B a millisecond is
/// 1.8× what 8 k short lines a second need; the rest waits in the port's buffer.
pub(crate) const RX_BYTES_PER_PASS: usize = 512;

const _: () = assert!(
    SEGMENT_QUEUE_DEPTH <= crate::motion::history::SEGMENT_HISTORY,
    "every queued segment can be taken back"
);

/// What differs between the board and its emulation: the step kernel and its segment queue, the
/// pins, the link's bytes, the flash and the motion marker. Each method does one thing and
/// decides nothing; [`MainLoop::pass`] calls them in a fixed order.
pub trait BoardPort {
    /// The kernel now.
    fn kernel(&mut self) -> KernelSnapshot;
    /// After a latched stop: drop every queued segment and the running one (the position keeps
    /// the steps made). The kernel stays stopped.
    fn flush_kernel(&mut self);
    /// Clears the kernel's latched stop, re-evaluating the stop flag with the limit bits armed
    /// last ([`BoardPort::arm_limits`]): an armed switch still active stops it again.
    fn rearm_kernel(&mut self);
    /// The limit bits whose switch stops the kernel from now on ([`Board::limit_arm`]); an armed
    /// switch that is active already raises the kernel's stop flag.
    fn arm_limits(&mut self, arm: u32);
    /// Raw input pin levels (before the polarity setting).
    fn raw_inputs(&mut self) -> u32;
    /// The ADC readings of this pass.
    fn adc(&mut self) -> AdcReadings;
    /// The debounced levels of this pass (`changed`: bits that changed). Default: nothing.
    fn inputs_sampled(&mut self, _levels: InputBits, _changed: u32) {}
    /// The segment queue has room for one more.
    fn queue_ready(&mut self) -> bool;
    /// Queues a segment for the kernel (only after [`BoardPort::queue_ready`]).
    fn push_segment(&mut self, seg: Segment);
    /// Removes up to `max` of the newest queued segments the kernel has not started; returns how
    /// many it removed.
    fn drop_newest(&mut self, max: usize) -> usize;
    /// Loads a new step position into the kernel (at rest: homing set home).
    fn set_position(&mut self, steps: [i64; MAX_AXES]);
    /// New input polarity (the kernel's limit check applies it to the raw pins) and step pulse
    /// timing, from a new setup.
    fn apply_setup(&mut self, invert: u32, timing: StepTiming);
    /// Exchanges the user output word with the kernel: `f` gets the kernel's word and returns the
    /// word to load into the kernel and the pins, if any ([`Board::sync_user_outputs`]).
    fn exchange_user_outputs(&mut self, f: impl FnOnce(u16) -> Option<u16>);
    /// Drives spindle, coolant and stepper-enable pins.
    fn drive_outputs(&mut self, levels: &OutputLevels, pwm_max: u16, steppers_enabled: bool);
    /// Bytes from the host into `buf`; returns how many (0: none).
    fn receive(&mut self, buf: &mut [u8]) -> usize;
    /// Room to send a frame of `len` bytes now.
    fn can_transmit(&mut self, len: usize) -> bool;
    /// Sends a frame to the host.
    fn transmit(&mut self, frame: &[u8]);
    /// Whether a host holds the port open (USB CDC: DTR), and how it left it.
    fn host_port(&mut self) -> HostPort;
    /// Writes the setup to flash (called only with the board idle and the kernel drained).
    fn save_setup(&mut self, setup: &Setup);
    /// The motion marker: set (`true`) before a segment can reach the kernel, cleared once the
    /// kernel is drained and the position is known (`board::power_up`).
    fn motion_marker(&mut self, moving: bool);
    /// Right before each link service: a test harness may take the board's events here instead of
    /// the link. Default: nothing.
    fn before_link_service(&mut self, _board: &mut Board) {}
    /// A latched stop was handed to the board (`levels`: the logical pins it saw). For logs.
    fn limit_stopped(&mut self, _levels: InputBits) {}
    /// The host closed the port and the host-loss policy ran. For logs.
    fn host_closed(&mut self) {}
    /// Arms the kernel's probe latch for the raw probe pin level `trips_at`, or turns it off
    /// (`None`, which also forgets a latched position). Called every pass: an armed or tripped
    /// latch for the same level is left as it is. Default: no probe input.
    fn arm_probe(&mut self, _trips_at: Option<bool>) {}
    /// The step position the kernel's probe latch recorded, if it tripped. Default: never.
    fn probe_latched(&mut self) -> Option<[i64; MAX_AXES]> {
        None
    }
}

/// Path speed from the kernel's position, over a window of [`SpeedMeter::WINDOW_MS`]: what the
/// status reports as the feed and what `Hold { stopped }` is built from.
#[derive(Clone, Copy, Debug)]
pub struct SpeedMeter {
    since_ms: u32,
    from: Pos,
    um_min: u32,
}

impl SpeedMeter {
    /// Measuring window, ms: long enough to see a few steps at the slowest feeds.
    pub const WINDOW_MS: u32 = 20;

    pub const fn new() -> Self {
        SpeedMeter {
            since_ms: 0,
            from: [0; MAX_AXES],
            um_min: 0,
        }
    }

    /// The speed (µm/min) at `now_ms` with the machine at `at` (nm): a new figure once a window
    /// has passed, else the last one.
    pub fn update(&mut self, now_ms: u32, at: Pos) -> u32 {
        let dt = now_ms.wrapping_sub(self.since_ms);
        if dt >= Self::WINDOW_MS {
            let mut sum_sq: u64 = 0;
            for (a, b) in at.iter().zip(&self.from) {
                // Clamped to ±2^30 nm (1 m per window), far beyond any machine: no overflow.
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

    /// The kernel's position was redefined (homing set home): the window restarts from `at`.
    pub fn restart(&mut self, now_ms: u32, at: Pos) {
        self.since_ms = now_ms;
        self.from = at;
    }
}

impl Default for SpeedMeter {
    fn default() -> Self {
        Self::new()
    }
}

/// The kernel's limit latch as the main loop handles it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Latch {
    /// The kernel steps (or would, given segments).
    Armed,
    /// A latched stop was handed to the board; the kernel stays stopped while it is in alarm.
    Stopped,
}

/// The host's hold on the port, as the port sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HostPort {
    /// No host has the port open (USB CDC: DTR low; a host that closes the port drops DTR
    /// unless it cleared HUPCL).
    Closed,
    /// A host has the port open (USB CDC: DTR high).
    Open,
    /// The host closed the port and left DTR up (it cleared HUPCL, as `gantry`'s one-shot
    /// commands do: `host-sender/src/link.rs` `OnClose`). The USB board cannot tell this from
    /// [`HostPort::Open`]; the emulated board's pty can.
    ClosedDtrKept,
}

/// What started a pass: the millisecond tick, or the host's bytes arriving between two ticks
/// ([`MainLoop::host_bytes_pass`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Wake {
    Tick,
    HostBytes,
}

/// A setup applied from the host and not yet in flash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Save {
    Done,
    Pending,
}

/// The main loop's own state (small: the board and its link live with their owner, in statics on
/// the firmware).
pub struct MainLoop {
    debouncer: Debouncer,
    speed: SpeedMeter,
    latch: Latch,
    /// The host port as the last pass saw it (`None` before the first pass).
    host_port: Option<HostPort>,
    save: Save,
    /// Drivers stay disabled from power-up until the first segment goes to the kernel.
    steppers_enabled: bool,
    view: KernelView,
    underruns: Underruns,
    starvation: Starvation,
}

impl MainLoop {
    /// The main loop of a board powered up with `setup` (the port's kernel already has its step
    /// timing and polarity).
    pub fn new(setup: &Setup) -> Self {
        MainLoop {
            debouncer: Debouncer::new(setup.inputs.invert, setup.inputs.debounce_ms),
            speed: SpeedMeter::new(),
            latch: Latch::Armed,
            host_port: None,
            save: Save::Done,
            steppers_enabled: false,
            view: KernelView::default(),
            underruns: Underruns::new(),
            starvation: Starvation::new(),
        }
    }

    /// What the last pass's status reports saw of the kernel (position, inputs, speed).
    pub fn kernel_view(&self) -> KernelView {
        self.view
    }

    /// Times the step kernel ran dry in the middle of a job's motion (the planner starved it,
    /// [`Underruns`]).
    pub fn underruns(&self) -> u32 {
        self.underruns.gaps()
    }

    /// Milliseconds the current or last job lost to starvation: machine time beyond the planned
    /// time because the planner held too little of a program with more lines
    /// (machine/src/device/starvation.rs).
    pub fn starved_ms(&self) -> u32 {
        self.starvation.starved_ms()
    }

    /// The stepper drivers are enabled (the first segment has gone to the kernel).
    pub fn steppers_enabled(&self) -> bool {
        self.steppers_enabled
    }

    /// A latched kernel stop is being held until the alarm is cleared.
    pub fn kernel_latched(&self) -> bool {
        self.latch == Latch::Stopped
    }

    /// A setup from the host waits to be saved.
    pub fn save_pending(&self) -> bool {
        self.save == Save::Pending
    }

    /// Hands the kernel's queue the segments it has room for, the probe latch armed first;
    /// returns whether any went out.
    fn feed_kernel(&mut self, board: &mut Board, port: &mut impl BoardPort) -> bool {
        port.arm_probe(board.probe_arm());
        let mut handed_out = false;
        while port.queue_ready() {
            let Some(seg) = board.next_segment() else {
                break;
            };
            self.steppers_enabled = true;
            self.underruns.segment_handed_out();
            // Before the kernel can step it: a reset from here on is a reset during motion.
            port.motion_marker(true);
            handed_out = true;
            port.push_segment(seg);
        }
        handed_out
    }

    /// One pass of the main loop at `now_ms`, the millisecond tick's (see the module
    /// documentation for the order).
    pub fn pass(
        &mut self,
        now_ms: u32,
        board: &mut Board,
        link: &mut BoardLink,
        port: &mut impl BoardPort,
    ) {
        self.run(now_ms, board, link, port, Wake::Tick);
    }

    /// The pass the host's bytes wake between two ticks (the firmware's USB receive task,
    /// `firmware/src/control.rs`; the emulated board's `receive`): the same pass in the same
    /// order, so a line that arrives is taken, interpreted and answered now rather than at the
    /// next tick, with the inputs left to the ticks (the debounce counts samples a millisecond
    /// apart, `board::inputs::Debouncer`).
    pub fn host_bytes_pass(
        &mut self,
        now_ms: u32,
        board: &mut Board,
        link: &mut BoardLink,
        port: &mut impl BoardPort,
    ) {
        self.run(now_ms, board, link, port, Wake::HostBytes);
    }

    fn run(
        &mut self,
        now_ms: u32,
        board: &mut Board,
        link: &mut BoardLink,
        port: &mut impl BoardPort,
        wake: Wake,
    ) {
        // 1. A limit stopped the kernel: drop the queue, tell the board, re-arm unless alarmed.
        let k = port.kernel();
        self.underruns.kernel_seen(k.dry_runs);
        if k.stopped && self.latch == Latch::Armed {
            port.flush_kernel();
            let steps = port.kernel().steps;
            let levels = InputBits(port.raw_inputs() ^ board.setup().inputs.invert);
            board.limit_stop(levels, &steps);
            port.arm_limits(board.limit_arm());
            self.latch = Latch::Stopped;
            port.limit_stopped(levels);
        }
        if self.latch == Latch::Stopped && board.state() != State::Alarm {
            port.rearm_kernel();
            self.latch = Latch::Armed;
        }

        // 2. Inputs, debounced here (the kernel saw the raw limit pins already); at the ticks
        // only.
        let levels = if wake == Wake::Tick {
            let (levels, changed) = self.debouncer.sample(port.raw_inputs());
            port.inputs_sampled(levels, changed);
            let adc = port.adc();
            board.on_inputs(now_ms, levels, changed, adc);
            levels
        } else {
            self.debouncer.levels()
        };

        // 3. The kernel's queue topped up from what is already planned, before the host's
        // bytes and the interpreter take their share of the pass (at thousands of short lines a
        // second the queue holds little more than a pass of motion). Only in a job running on
        // its path: a hold, an abort or a speed change waits for `drop_queued` below, a limit
        // for its latch.
        let mut handed_out = false;
        if self.latch == Latch::Armed
            && board.job_running()
            && board.motion().drop_request().is_none()
        {
            handed_out = self.feed_kernel(board, port);
        }

        // 4. Host link and controller.
        let mut rx = [0u8; super::link::RX_PACKET];
        let mut budget = RX_BYTES_PER_PASS;
        while budget > 0 {
            // Only what the link can take (flow control): the rest stays in the port.
            let room = link.rx_room().min(rx.len());
            if room == 0 {
                break;
            }
            let n = port.receive(rx.get_mut(..room).unwrap_or_default());
            if n == 0 {
                break;
            }
            budget = budget.saturating_sub(n);
            // (`get`: a port never reports more than it was given; no panic path for it.)
            link.on_bytes(board, now_ms, rx.get(..n).unwrap_or_default());
        }
        let host_port = port.host_port();
        match (self.host_port, host_port) {
            (Some(HostPort::Open), now) if now != HostPort::Open => {
                // The sender closed the port: the host-loss policy now rather than after the
                // silence timeout (`BoardLink::port_closed`).
                link.port_closed(board, now == HostPort::Closed);
                port.host_closed();
            }
            // A host opened the port (not the state found at the first pass): it may be
            // greeted (`BoardLink::port_opened`).
            (Some(before), HostPort::Open) if before != HostPort::Open => link.port_opened(now_ms),
            _ => {}
        }
        self.host_port = Some(host_port);
        let measured = self.speed.update(now_ms, board.machine_position(&k.steps));
        // No job or jog and the kernel drained: at rest now, whatever the last window saw (the
        // status right after a job's end read 93.8 mm/min in Idle). A hold keeps the window:
        // a segment queue that ran dry mid-ramp is not rest.
        let idle = matches!(board.state(), State::Idle | State::Alarm);
        let speed_um_min = if k.drained && idle { 0 } else { measured };
        self.view = KernelView {
            steps: k.steps,
            inputs: levels.0,
            feed_um_min: speed_um_min,
            starved_ms: self.starvation.starved_ms(),
            laser_duty: k.laser_duty,
        };
        port.before_link_service(board);
        link.service(board, now_ms, &self.view);
        let drained = port.kernel().drained;
        // The probe latch tripped: the board stops the probe move on its path. Read after the
        // drained flag, so a trip on the move's last steps is never taken for no contact.
        if let Some(steps) = port.probe_latched() {
            board.probe_tripped(&steps);
        }
        board.poll(drained);
        if let Some(steps) = board.take_position_reset() {
            port.set_position(steps);
            self.speed.restart(now_ms, board.machine_position(&steps));
        }
        // A stop or a jog's speed change: the newest queued segments go, segment prep continues
        // from the end of the kernel's running segment. Nothing moves while latched.
        let latched = self.latch == Latch::Stopped;
        if !latched {
            board.drop_queued(|max| port.drop_newest(max));
        }

        // 5. Segments for the kernel (none while it is latched).
        if !latched {
            handed_out |= self.feed_kernel(board, port);
        } else {
            port.arm_probe(board.probe_arm());
        }
        if drained && !handed_out && !board.position_lost() {
            port.motion_marker(false);
        }
        let in_job = matches!(board.state(), State::Run | State::Hold | State::ToolChange);
        // µm/min → 1.024 µm/s (nm/s >> 10, the units of `Sample`): × 1000 / 60 / 1024.
        let speed = ((u64::from(measured) * 1067) >> 16) as u32;
        self.starvation
            .pass(now_ms, in_job, handed_out, speed, Sample::of(board));
        // User outputs: the board takes the levels the kernel's on-the-fly events left on the
        // pins, or (after a list at rest, an alarm) loads its own into the kernel and the pins.
        port.exchange_user_outputs(|word| board.sync_user_outputs(word));
        port.arm_limits(board.limit_arm());

        // 6. Events of this pass go out now; then the pins.
        port.before_link_service(board);
        link.service(board, now_ms, &self.view);
        let mut frame = [0u8; gantry_proto::MAX_FRAME_LEN];
        while port.can_transmit(frame.len()) {
            let Some(n) = link.poll_transmit(now_ms, &mut frame) else {
                break;
            };
            port.transmit(frame.get(..n).unwrap_or_default());
        }
        port.drive_outputs(
            &board.output_levels(),
            board.setup().outputs.pwm_max,
            self.steppers_enabled,
        );

        // 7. A new setup from the host (taken only while idle): its input polarity, debounce and
        // step pulse shape now; flash once idle with nothing moving.
        if link.take_setup_changed() {
            let s = board.setup();
            self.debouncer = Debouncer::new(s.inputs.invert, s.inputs.debounce_ms);
            port.apply_setup(s.inputs.invert, StepTiming::from_setup(&s.drivers));
            self.save = Save::Pending;
        }
        if board.take_offsets_changed() {
            self.save = Save::Pending;
        }
        if self.save == Save::Pending && board.state() == State::Idle && drained {
            // A failed write is not retried every millisecond; the next setup change tries again.
            self.save = Save::Done;
            port.save_setup(board.setup());
        }

        // 8. Whether the kernel running dry before the next pass would be an underrun: motion
        // still queued, or none with the program not at its end (lines not yet interpreted, or
        // not yet received).
        let motion_to_come = match board.motion().state() {
            MotionState::Running => true,
            MotionState::Idle => !board.interpreter().is_finished(),
            _ => false,
        };
        self.underruns
            .pass_done(board.job_running(), motion_to_come);
    }
}

#[cfg(test)]
mod tests {
    //! The pass's own rules on a port that records what it is asked (the scenario tests on the
    //! emulated board are in tests/tests/controller_main_loop.rs).
    use super::*;
    use crate::board::AlarmCode;
    use crate::units::NM_PER_MM;

    extern crate std;
    use std::vec::Vec;

    #[derive(Default)]
    struct FakePort {
        kernel: KernelSnapshot,
        flushed: u32,
        rearmed: u32,
        queued: u32,
        dtr: bool,
        saved: u32,
        /// Bytes waiting in the port (the firmware's USB receive pipe, then its endpoint).
        rx: Vec<u8>,
        /// Calls of `receive`, and the bytes they took.
        reads: u32,
        taken: usize,
        /// Everything the board sent.
        sent: Vec<u8>,
        /// Input samples taken (debounced levels handed over).
        samples: u32,
    }

    impl BoardPort for FakePort {
        fn kernel(&mut self) -> KernelSnapshot {
            self.kernel
        }
        fn flush_kernel(&mut self) {
            self.flushed += 1;
        }
        fn rearm_kernel(&mut self) {
            self.rearmed += 1;
            self.kernel.stopped = false;
        }
        fn arm_limits(&mut self, _arm: u32) {}
        fn raw_inputs(&mut self) -> u32 {
            0
        }
        fn adc(&mut self) -> AdcReadings {
            AdcReadings::default()
        }
        fn queue_ready(&mut self) -> bool {
            self.queued < SEGMENT_QUEUE_DEPTH as u32
        }
        fn push_segment(&mut self, _seg: Segment) {
            self.queued += 1;
            self.kernel.drained = false;
        }
        fn drop_newest(&mut self, _max: usize) -> usize {
            0
        }
        fn set_position(&mut self, _steps: [i64; MAX_AXES]) {}
        fn apply_setup(&mut self, _invert: u32, _timing: StepTiming) {}
        fn exchange_user_outputs(&mut self, f: impl FnOnce(u16) -> Option<u16>) {
            f(0);
        }
        fn drive_outputs(&mut self, _l: &OutputLevels, _pwm_max: u16, _enabled: bool) {}
        fn receive(&mut self, buf: &mut [u8]) -> usize {
            self.reads += 1;
            let n = buf.len().min(self.rx.len());
            buf[..n].copy_from_slice(&self.rx[..n]);
            self.rx.drain(..n);
            self.taken += n;
            n
        }
        fn can_transmit(&mut self, _len: usize) -> bool {
            self.dtr
        }
        fn transmit(&mut self, frame: &[u8]) {
            self.sent.extend_from_slice(frame);
        }
        fn host_port(&mut self) -> HostPort {
            if self.dtr {
                HostPort::Open
            } else {
                HostPort::Closed
            }
        }
        fn save_setup(&mut self, _setup: &Setup) {
            self.saved += 1;
        }
        fn motion_marker(&mut self, _moving: bool) {}
        fn inputs_sampled(&mut self, _levels: InputBits, _changed: u32) {
            self.samples += 1;
        }
    }

    fn parts() -> (MainLoop, Board, BoardLink, FakePort) {
        let setup = Setup::default();
        let port = FakePort {
            kernel: KernelSnapshot {
                drained: true,
                ..KernelSnapshot::default()
            },
            ..FakePort::default()
        };
        (
            MainLoop::new(&setup),
            Board::new(setup),
            BoardLink::new(1),
            port,
        )
    }

    #[test]
    fn the_speed_meter_measures_over_20_ms_windows() {
        let mut m = SpeedMeter::new();
        // 1 mm in 20 ms = 3000 mm/min, reported only when the window closes.
        assert_eq!(m.update(10, [NM_PER_MM / 2, 0, 0, 0, 0, 0]), 0);
        assert_eq!(m.update(20, [NM_PER_MM, 0, 0, 0, 0, 0]), 3_000_000);
        assert_eq!(m.update(39, [NM_PER_MM, 0, 0, 0, 0, 0]), 3_000_000);
        assert_eq!(m.update(40, [NM_PER_MM, 0, 0, 0, 0, 0]), 0);
    }

    #[test]
    fn a_latched_stop_holds_the_kernel_until_the_alarm_clears() {
        let (mut main, mut board, mut link, mut port) = parts();
        port.kernel.stopped = true;
        main.pass(0, &mut board, &mut link, &mut port);
        assert_eq!(board.alarm(), Some(AlarmCode::HardLimit));
        assert_eq!((port.flushed, port.rearmed), (1, 0));
        assert!(main.kernel_latched());
        for t in 1..100 {
            main.pass(t, &mut board, &mut link, &mut port);
        }
        // Flushed once, never re-armed, nothing queued while in the alarm.
        assert_eq!((port.flushed, port.rearmed, port.queued), (1, 0, 0));
        board.unlock();
        main.pass(100, &mut board, &mut link, &mut port);
        assert_eq!((port.flushed, port.rearmed), (1, 1));
        assert!(!main.kernel_latched());
    }

    #[test]
    fn a_kernel_that_runs_dry_mid_job_is_one_underrun_however_many_passes_it_stands() {
        let (mut main, mut board, mut link, mut port) = parts();
        main.pass(0, &mut board, &mut link, &mut port);
        assert!(board.start_job());
        assert!(board.push_line(0, 1, "G1 X10 F600"));
        for t in 1..5 {
            main.pass(t, &mut board, &mut link, &mut port);
        }
        // The queue is full (this port never empties it) and the move has a second to run.
        assert_eq!(port.queued, SEGMENT_QUEUE_DEPTH as u32);
        assert_eq!(board.motion().state(), MotionState::Running);
        // No dry run yet: nothing.
        assert_eq!(main.underruns(), 0);
        // The kernel ran dry once and stands for 20 passes: one underrun (the main loop used to
        // count every pass, the emulated board once: two figures for one gap).
        port.kernel.dry_runs = 1;
        for t in 5..25 {
            main.pass(t, &mut board, &mut link, &mut port);
        }
        assert_eq!(main.underruns(), 1);
        port.kernel.dry_runs = 2;
        main.pass(25, &mut board, &mut link, &mut port);
        assert_eq!(main.underruns(), 2);
    }

    /// The board's USB read path: the main loop takes bytes from the port (the firmware's
    /// receive pipe, `firmware/src/control.rs` `Port::receive`) only as the link has room. A
    /// grbl sender that writes far more than the receive buffer (a job, no counting) while the
    /// board cannot take lines (this port's kernel never runs a segment, so the planner fills):
    /// once the buffer is full the port is not read at all (the pipe fills, the USB task stops
    /// reading the endpoint and the host's NAKs hold the sender), no byte is dropped and no
    /// line is cut.
    #[test]
    fn a_full_receive_buffer_leaves_the_port_unread() {
        let (mut main, mut board, mut link, mut port) = parts();
        port.dtr = true;
        main.pass(0, &mut board, &mut link, &mut port);
        for i in 0..400 {
            let line = std::format!("G1 X{}.{:03} F100\n", i / 1000, i % 1000);
            port.rx.extend_from_slice(line.as_bytes());
        }
        let total = port.rx.len();
        let mut t = 1;
        while link.rx_room() > 0 || t < 10 {
            main.pass(t, &mut board, &mut link, &mut port);
            t += 1;
            assert!(t < 5_000, "the buffer never filled");
        }
        assert_eq!(link.protocol(), crate::device::link::LinkProtocol::Grbl);
        let (reads, taken) = (port.reads, port.taken);
        assert!(taken < total && taken > 128, "{taken} of {total} taken");
        for _ in 0..500 {
            main.pass(t, &mut board, &mut link, &mut port);
            t += 1;
        }
        assert_eq!(
            (port.reads, port.taken),
            (reads, taken),
            "a full buffer left the port unread"
        );
        assert_eq!(port.rx.len(), total - taken, "nothing dropped");
        let sent = std::string::String::from_utf8_lossy(&port.sent).into_owned();
        assert!(!sent.contains("error"), "{sent}");
        assert!(sent.contains("ok\r\n"), "{sent}");
    }

    /// A grbl line that arrives between two ticks is taken, interpreted and answered in the pass
    /// its bytes wake, not at the next tick; that pass leaves the inputs to the ticks.
    #[test]
    fn a_line_is_answered_in_the_pass_its_bytes_wake() {
        let (mut main, mut board, mut link, mut port) = parts();
        port.dtr = true;
        port.rx.extend_from_slice(b"\x18");
        for t in 0..5 {
            main.pass(t, &mut board, &mut link, &mut port);
        }
        let banner = std::string::String::from_utf8_lossy(&port.sent).into_owned();
        assert!(banner.contains(crate::device::grbl::BANNER), "{banner}");
        port.sent.clear();
        let samples = port.samples;
        for (i, line) in ["G1 X1 F600\n", "G1 X2\n", "G1 X3\n"].iter().enumerate() {
            port.rx.extend_from_slice(line.as_bytes());
            main.host_bytes_pass(5, &mut board, &mut link, &mut port);
            let sent = std::string::String::from_utf8_lossy(&port.sent).into_owned();
            assert_eq!(sent.matches("ok\r\n").count(), i + 1, "{sent}");
        }
        assert_eq!(port.samples, samples, "no input sample between the ticks");
        assert_eq!(board.lines_buffered(), 0);
        main.pass(6, &mut board, &mut link, &mut port);
        assert_eq!(port.samples, samples + 1);
    }

    #[test]
    fn the_host_closing_the_port_holds_a_job_and_opening_it_does_nothing() {
        let (mut main, mut board, mut link, mut port) = parts();
        main.pass(0, &mut board, &mut link, &mut port);
        assert!(board.start_job());
        assert!(board.push_line(0, 1, "G1 X10 F600"));
        port.dtr = true;
        main.pass(1, &mut board, &mut link, &mut port);
        main.pass(2, &mut board, &mut link, &mut port);
        assert_eq!(board.state(), State::Run);
        assert!(port.queued > 0);
        port.dtr = false;
        main.pass(3, &mut board, &mut link, &mut port);
        assert_eq!(board.state(), State::Hold);
        assert!(board.feed_held());
        port.dtr = true;
        main.pass(4, &mut board, &mut link, &mut port);
        assert_eq!(board.state(), State::Hold);
    }
}
