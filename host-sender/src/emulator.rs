//! The emulated board: the very same [`Board`] and [`BoardLink`] the firmware runs, with the step
//! kernel ticked on a virtual clock instead of a timer interrupt.
//!
//! Virtual time counts kernel timer counts ([`KERNEL_TIMER_HZ`]). The main loop (link service,
//! interpretation, segment preparation) runs once per virtual millisecond, the kernel at the
//! periods it asks for, so the emulation runs as fast as the host can while keeping the board's
//! timing. Every step is counted per axis, and an optional observer sees every tick that stepped
//! (for VCD traces).
//!
//! Inputs are virtual pins ([`EmulatedBoard::pins`], raw levels before the polarity setting) and
//! ADC readings, sampled and debounced once per main-loop pass exactly as the firmware does.
//! Limit switches can be modelled at fixed machine positions ([`EmulatedBoard::add_switch`]): the
//! switch pin follows the kernel's step position after every tick, and the kernel's limit flag is
//! set in that same tick when the switch is armed, so the next tick stops (DESIGN §6).
//!
//! The firmware's motion marker (a RAM word that survives a reset, see
//! `gantry_machine::controller::power_up`) is modelled too: [`EmulatedBoard::reset`] restarts the
//! board the way a watchdog, reset-pin or power-on reset would, with the machine standing where it
//! stopped.
//!
//! User outputs are virtual pins too: the kernel's output word ([`StepKernel::outputs`]), switched
//! by on-the-fly events on the tick that starts their segment, and loaded from the board when it
//! switches outputs itself ([`Board::sync_user_outputs`], once per main-loop pass, as the firmware).

use gantry_machine::board::link::{BoardLink, KernelView};
use gantry_machine::board::{Board, BoardEvent, LIMIT_BITS};
use gantry_machine::controller::inputs::{limit_bit, Debouncer, InputBits};
use gantry_machine::controller::power_up::{PowerUp, ResetCause, MARKER_IDLE, MARKER_MOVING};
use gantry_machine::controller::{AdcReadings, OutputLevels, State};
use gantry_machine::motion::kernel::{Segment, StepKernel, StepTiming, KERNEL_TIMER_HZ};
use gantry_machine::motion::pipeline::MotionState;
use gantry_machine::motion::sim::{SegmentFifo, SEGMENT_QUEUE};
use gantry_machine::setup::Setup;
use gantry_machine::units::MAX_AXES;

/// Kernel timer counts per millisecond.
pub const COUNTS_PER_MS: u64 = KERNEL_TIMER_HZ as u64 / 1000;

/// A change of the board's pins: a kernel tick that stepped, changed direction or switched a user
/// output, or a change of the input levels or of the user outputs in the main loop (then `step`
/// is 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PinEvent {
    /// Virtual time, kernel timer counts.
    pub time: u64,
    pub step: u8,
    pub dir: u8,
    /// Debounced input levels (`controller::inputs::InputBits`).
    pub inputs: u32,
    /// User output pins (bit n = output n), switched before this event's steps.
    pub outputs: u16,
    /// Timer counts to the kernel's next tick (0: idle, or a main-loop event).
    pub period: u32,
}

/// Queued segments the board took back for a stop or a speed change ([`Board::drop_queued`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct QueueDrop {
    /// Virtual time, kernel timer counts.
    pub time: u64,
    /// Segments removed from the kernel's queue.
    pub dropped: usize,
    /// Counts until the kernel's running segment ends (0: the kernel was idle): the new plan
    /// starts then.
    pub running_left: u64,
}

/// A limit switch at a fixed place of the machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LimitSwitch {
    pub axis: usize,
    /// The max-side switch (active at or beyond `at`); else the min-side one (at or below).
    pub max: bool,
    /// Physical position in steps (the kernel's step count at power-up; homing moves the
    /// kernel's zero, not the switch).
    pub at: i64,
}

impl LimitSwitch {
    fn bit(&self) -> u32 {
        1 << limit_bit(self.axis, self.max)
    }
}

/// Two motors on one step/dir channel (a ganged axis, seed 003 "Squaring Parallel Drives"):
/// each motor moves only while its enable output is on, and its limit switch is gated by the same
/// output; both switches share the axis's limit input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Gang {
    pub axis: usize,
    /// The switches are on the max side (else the min side).
    pub max: bool,
    /// User output bits enabling motor 0 and motor 1.
    pub enable: [u8; 2],
    /// Switch position of each motor, physical steps.
    pub at: [i64; 2],
    /// Position of each motor, physical steps.
    pub motors: [i64; 2],
}

impl Gang {
    fn bit(&self) -> u32 {
        1 << limit_bit(self.axis, self.max)
    }

    fn on_switch(&self, m: usize) -> bool {
        if self.max {
            self.motors[m] >= self.at[m]
        } else {
            self.motors[m] <= self.at[m]
        }
    }
}

/// A board with its kernel on a virtual clock.
pub struct EmulatedBoard {
    pub board: Board,
    pub link: BoardLink,
    pub kernel: StepKernel,
    fifo: SegmentFifo<SEGMENT_QUEUE>,
    /// Virtual time, kernel timer counts.
    now: u64,
    next_main_loop: u64,
    /// When the kernel ticks next (`None`: idle until the main loop hands it a segment).
    next_tick: Option<u64>,
    /// Step pulses per axis since power-up (direction-independent).
    pub pulses: [u64; MAX_AXES],
    /// Debounced input levels the controller sees.
    pub inputs: u32,
    /// Forces the kernel's limit flag (the switch model sets it by itself).
    pub limit: bool,
    /// Raw input pin levels set by the test or user (modelled switches override their bits).
    pub pins: u32,
    /// ADC readings sampled with the inputs.
    pub adc: AdcReadings,
    /// Modelled limit switches.
    pub switches: Vec<LimitSwitch>,
    /// A modelled ganged axis.
    pub gang: Option<Gang>,
    /// User output pins at the last pin event.
    last_outputs: u16,
    /// Polarity and debounce the debouncer was built with.
    debounce_setup: (u32, u8),
    /// Physical position = kernel steps + offset (homing redefines the kernel's zero).
    phys_offset: [i64; MAX_AXES],
    debouncer: Debouncer,
    /// Limit bits armed for the kernel (from the board, once per main-loop pass).
    arm: u32,
    /// The switch model raised the kernel's limit flag.
    switch_stop: bool,
    /// Ticks that stopped the kernel on a limit, and the virtual time of the last one.
    pub limit_stops: u32,
    last_dir: u8,
    /// Pulses at the previous main-loop pass, and the path speed measured from them.
    pulses_at_last_loop: [u64; MAX_AXES],
    measured_um_min: u32,
    observer: Option<Box<dyn FnMut(PinEvent)>>,
    /// Main-loop passes that found the kernel idle with motion still to run and nothing prepared
    /// (the planner starved the kernel).
    pub underruns: u64,
    /// Bytes the board has sent and the host not yet read.
    outbox: Vec<u8>,
    /// The firmware's motion marker word (survives [`EmulatedBoard::reset`]): set before a
    /// segment goes to the kernel, cleared when the kernel is drained and the board's position is
    /// not lost (`Board::position_lost`).
    pub motion_marker: u32,
    /// Resets so far (each power-up gets its own boot id).
    resets: u32,
    /// Virtual time (ms) bytes from the host last arrived.
    pub last_received_ms: Option<u32>,
    /// Board events taken by the test instead of the link (see [`EmulatedBoard::capture_events`]).
    pub events: Vec<BoardEvent>,
    capture: bool,
    /// The last time the board took back queued segments.
    pub last_drop: Option<QueueDrop>,
    /// When `Some`, every segment the kernel starts, with the virtual time it starts.
    pub started_segments: Option<Vec<(u64, Segment)>>,
    /// When `Some`, every change of the output levels the main loop drives (spindle, coolant,
    /// user outputs: [`Board::output_levels`], step 9 of the firmware's main loop), with the
    /// virtual time of the pass that drove it.
    pub output_changes: Option<Vec<(u64, OutputLevels)>>,
    /// Output levels the last main-loop pass drove.
    driven: OutputLevels,
    /// Virtual time of the last kernel tick that stepped (0: none yet).
    pub last_step_at: u64,
    /// Virtual time of the last tick that found no segment and stopped the kernel's timer: from
    /// then on the kernel is drained (until the main loop hands it a segment again); the first
    /// main-loop pass after it sees the machine at rest.
    pub kernel_idle_at: u64,
}

/// Boot id of the emulated board's first power-up.
const BOOT_ID: u32 = 0x6a17_0001;

impl EmulatedBoard {
    pub fn new(setup: Setup) -> Self {
        let debouncer = Debouncer::new(setup.inputs.invert, setup.inputs.debounce_ms);
        EmulatedBoard {
            debounce_setup: (setup.inputs.invert, setup.inputs.debounce_ms),
            board: Board::new(setup),
            link: BoardLink::new(BOOT_ID),
            kernel: StepKernel::new(),
            fifo: SegmentFifo::default(),
            now: 0,
            next_main_loop: 0,
            next_tick: None,
            pulses: [0; MAX_AXES],
            inputs: 0,
            limit: false,
            pins: 0,
            adc: AdcReadings::default(),
            switches: Vec::new(),
            gang: None,
            last_outputs: 0,
            phys_offset: [0; MAX_AXES],
            debouncer,
            arm: 0,
            switch_stop: false,
            limit_stops: 0,
            last_dir: 0,
            pulses_at_last_loop: [0; MAX_AXES],
            measured_um_min: 0,
            observer: None,
            underruns: 0,
            outbox: Vec::new(),
            motion_marker: MARKER_IDLE,
            resets: 0,
            last_received_ms: None,
            events: Vec::new(),
            capture: false,
            last_drop: None,
            started_segments: None,
            output_changes: None,
            driven: OutputLevels::SAFE,
            last_step_at: 0,
            kernel_idle_at: 0,
        }
    }

    /// From now on the board's events (alarms, limit reports, errors, job ends) are collected in
    /// [`EmulatedBoard::events`], in order, instead of going out over the link: for scenario
    /// tests that drive the board without a host.
    pub fn capture_events(&mut self) {
        self.capture = true;
    }

    fn take_events(&mut self) {
        if self.capture {
            while let Some(e) = self.board.take_event() {
                self.events.push(e);
            }
        }
    }

    /// Resets the board now, as the MCU would for `cause`: the step kernel, the controller and
    /// the link start afresh (kernel position 0, a new boot id, bytes in flight lost) with the
    /// setup it had (flash), while the machine stays where it physically stopped. The new board
    /// powers up as the firmware's would from the motion marker: in alarm 3 when the steppers were
    /// moving and the cause keeps RAM. Returns what it decided.
    pub fn reset(&mut self, cause: ResetCause) -> PowerUp {
        // A power-on reset leaves the RAM undefined.
        let marker = if cause == ResetCause::PowerOn {
            0
        } else {
            self.motion_marker
        };
        let how = PowerUp::after_reset(marker, cause);
        let setup = self.board.setup().clone();
        let here = self.physical();
        self.resets += 1;
        self.board = Board::power_up(setup.clone(), how);
        self.link = BoardLink::new(BOOT_ID.wrapping_add(self.resets));
        self.kernel = StepKernel::new();
        self.phys_offset = here;
        self.fifo = SegmentFifo::default();
        self.next_tick = None;
        self.limit = false;
        self.switch_stop = false;
        self.arm = 0;
        if self.last_outputs != 0 {
            // The reset leaves every output pin low (the new kernel's word is 0).
            self.drive_user_outputs(0);
        }
        if self.driven != OutputLevels::SAFE {
            // Spindle and coolant pins drop with the reset too.
            self.driven = OutputLevels::SAFE;
            if let Some(log) = self.output_changes.as_mut() {
                log.push((self.now, OutputLevels::SAFE));
            }
        }
        self.debounce_setup = (setup.inputs.invert, setup.inputs.debounce_ms);
        self.debouncer = Debouncer::new(setup.inputs.invert, setup.inputs.debounce_ms);
        self.outbox.clear();
        how
    }

    /// Models a limit switch of `axis` at machine position `at_nm` (as the machine position is
    /// now): the min switch is active at or below it, the max switch at or above.
    pub fn add_switch(&mut self, axis: usize, max: bool, at_nm: i64) {
        let steps = self.board.motion_config().axes[axis].nm_to_steps(at_nm);
        let at = steps - self.kernel.position()[axis] + self.physical()[axis];
        self.switches.push(LimitSwitch { axis, max, at });
    }

    /// Models `axis` as two ganged motors, enabled by user outputs `enable`, with switches at
    /// machine positions `at_nm` (min side, or max side with `max`); both start where the axis is.
    pub fn add_gang(&mut self, axis: usize, max: bool, enable: [u8; 2], at_nm: [i64; 2]) {
        let a = self.board.motion_config().axes[axis];
        let here = self.physical()[axis];
        let k = self.kernel.position()[axis];
        self.gang = Some(Gang {
            axis,
            max,
            enable,
            at: at_nm.map(|v| a.nm_to_steps(v) - k + here),
            motors: [here; 2],
        });
    }

    /// Physical step position (kernel position + the offset homing introduced).
    pub fn physical(&self) -> [i64; MAX_AXES] {
        let mut p = self.kernel.position();
        for (v, o) in p.iter_mut().zip(self.phys_offset) {
            *v += o;
        }
        p
    }

    /// User output pins now (bit n = output n).
    pub fn user_outputs(&self) -> u16 {
        self.kernel.outputs()
    }

    /// Logical levels of the modelled switches now, and the bits they own.
    fn switch_levels(&self) -> (u32, u32) {
        let p = self.physical();
        let user_outputs = self.kernel.outputs();
        let (mut on, mut owned) = (0, 0);
        if let Some(g) = &self.gang {
            owned |= g.bit();
            for m in 0..2 {
                if user_outputs & (1 << g.enable[m]) != 0 && g.on_switch(m) {
                    on |= g.bit();
                }
            }
        }
        for s in &self.switches {
            owned |= s.bit();
            let active = if s.max {
                p[s.axis] >= s.at
            } else {
                p[s.axis] <= s.at
            };
            if active {
                on |= s.bit();
            }
        }
        (on, owned)
    }

    /// Raw pin levels: the test's pins with the modelled switches' pins.
    pub fn raw_pins(&self) -> u32 {
        let invert = self.board.setup().inputs.invert;
        let (on, owned) = self.switch_levels();
        (self.pins & !owned) | ((on ^ invert) & owned)
    }

    /// Logical levels the step interrupt sees (raw pins, polarity applied, no debounce).
    fn logical_pins(&self) -> u32 {
        self.raw_pins() ^ self.board.setup().inputs.invert
    }

    /// Sets or clears one raw pin.
    pub fn set_pin(&mut self, bit: u32, on: bool) {
        let mut b = InputBits(self.pins);
        b.set_bit(bit, on);
        self.pins = b.0;
    }

    /// Runs until `done` holds (checked every virtual millisecond) or `max_ms` have passed;
    /// true if `done` held.
    pub fn run_until(&mut self, max_ms: u64, mut done: impl FnMut(&EmulatedBoard) -> bool) -> bool {
        for _ in 0..max_ms {
            if done(self) {
                return true;
            }
            self.run_for(COUNTS_PER_MS);
        }
        done(self)
    }

    /// The kernel has run every segment it was given (queue empty, no tick due).
    pub fn kernel_drained(&self) -> bool {
        self.fifo.0.is_empty() && self.next_tick.is_none()
    }

    /// Virtual time the kernel's segment queue holds (not counting the running segment), ms.
    pub fn queued_ms(&self) -> f64 {
        let counts: u64 = self.fifo.0.iter().map(|s| s.duration()).sum();
        counts as f64 / COUNTS_PER_MS as f64
    }

    /// Runs `ms` virtual milliseconds.
    pub fn run_ms(&mut self, ms: u64) {
        self.run_for(ms * COUNTS_PER_MS);
    }

    /// Calls `f` for every kernel tick that stepped or changed direction.
    pub fn observe(&mut self, f: impl FnMut(PinEvent) + 'static) {
        self.observer = Some(Box::new(f));
    }

    /// Virtual time in kernel timer counts.
    pub fn now(&self) -> u64 {
        self.now
    }

    /// Virtual time in milliseconds (the link's clock).
    pub fn now_ms(&self) -> u32 {
        (self.now / COUNTS_PER_MS) as u32
    }

    /// Virtual time in seconds.
    pub fn seconds(&self) -> f64 {
        self.now as f64 / KERNEL_TIMER_HZ as f64
    }

    /// STUB (serial helper, issue 13; replace with the emulator rework's own): the host's DTR line, a drop holds a running job as `firmware/src/control.rs` does.
    pub fn set_dtr(&mut self, on: bool) {
        if !on {
            self.board.feed_hold()
        }
    }

    /// Bytes from the host.
    pub fn receive(&mut self, bytes: &[u8]) {
        let now = self.now_ms();
        if !bytes.is_empty() {
            self.last_received_ms = Some(now);
        }
        self.link.on_bytes(now, bytes);
    }

    /// Bytes for the host (everything sent since the last call).
    pub fn take_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.outbox)
    }

    /// What the status reports see of the kernel.
    pub fn kernel_view(&self) -> KernelView {
        KernelView {
            steps: self.kernel.position(),
            inputs: self.inputs,
            feed_um_min: self.measured_um_min,
        }
    }

    /// Runs the board for `counts` kernel timer counts of virtual time.
    pub fn run_for(&mut self, counts: u64) {
        let end = self.now + counts;
        while self.now < end {
            if self.now >= self.next_main_loop {
                self.main_loop();
                self.next_main_loop = self.now + COUNTS_PER_MS;
            }
            if self.next_tick.is_some_and(|t| t <= self.now) {
                self.tick();
            }
            let mut next = self.next_main_loop.min(end);
            if let Some(t) = self.next_tick {
                next = next.min(t);
            }
            self.now = next.max(self.now);
        }
    }

    fn tick(&mut self) {
        let (queued, front) = (self.fifo.0.len(), self.fifo.0.front().copied());
        let out = self
            .kernel
            .tick(&mut self.fifo, self.limit || self.switch_stop);
        let user_outputs = self.kernel.outputs();
        if let (Some(log), Some(seg)) = (self.started_segments.as_mut(), front) {
            if self.fifo.0.len() < queued {
                log.push((self.now, seg));
            }
        }
        if let Some(g) = self.gang.as_mut() {
            if out.step & (1 << g.axis) != 0 {
                let d = if out.dir & (1 << g.axis) != 0 { -1 } else { 1 };
                for m in 0..2 {
                    if user_outputs & (1 << g.enable[m]) != 0 {
                        g.motors[m] += d;
                    }
                }
            }
        }
        if out.step != 0 {
            self.last_step_at = self.now;
        }
        if out.step != 0 && (!self.switches.is_empty() || self.gang.is_some()) {
            // The switch pin follows this tick's step; the interrupt sees it on the next tick.
            self.switch_stop = self.logical_pins() & self.arm & LIMIT_BITS != 0;
        }
        if out.step != 0 || out.dir != self.last_dir || user_outputs != self.last_outputs {
            for (axis, p) in self.pulses.iter_mut().enumerate() {
                *p += u64::from(out.step >> axis & 1);
            }
            if let Some(f) = self.observer.as_mut() {
                f(PinEvent {
                    time: self.now,
                    step: out.step,
                    dir: out.dir,
                    inputs: self.inputs,
                    outputs: user_outputs,
                    period: out.period,
                });
            }
            self.last_dir = out.dir;
            self.last_outputs = user_outputs;
        }
        // As the step interrupt: a period too short for the setup's pulse and dir set-up is
        // stretched to the shortest one that fits.
        let timing = StepTiming::from_setup(&self.board.setup().drivers);
        self.next_tick =
            (out.period != 0).then(|| self.now + u64::from(timing.stretch(out.period)));
        if out.period == 0 {
            self.kernel_idle_at = self.now;
        }
    }

    /// Path speed over the last main-loop interval (1 ms), from the pulses the axes made.
    fn measure_speed(&mut self) {
        let cfg = self.board.motion_config();
        let mut sum_sq = 0.0f64;
        for axis in 0..cfg.axis_count as usize {
            let n = self.pulses[axis] - self.pulses_at_last_loop[axis];
            let a = &cfg.axes[axis];
            let nm = n as f64 * a.units as f64 / a.steps as f64;
            sum_sq += nm * nm;
        }
        self.pulses_at_last_loop = self.pulses;
        // nm per ms → µm per min.
        self.measured_um_min = (sum_sq.sqrt() * 60.0).round() as u32;
    }

    /// One pass of the firmware's main loop: link, controller, segment preparation.
    /// The user output pins take `word` now (the board switched them, or a reset dropped them).
    fn drive_user_outputs(&mut self, word: u16) {
        self.last_outputs = word;
        if let Some(f) = self.observer.as_mut() {
            f(PinEvent {
                time: self.now,
                step: 0,
                dir: self.last_dir,
                inputs: self.inputs,
                outputs: word,
                period: 0,
            });
        }
    }

    fn main_loop(&mut self) {
        self.measure_speed();
        let now = self.now_ms();
        if self.kernel.is_stopped() {
            // The kernel latched a limit stop: drop the queue, tell the board, re-arm.
            self.limit_stops += 1;
            self.fifo.0.clear();
            self.kernel.flush();
            self.next_tick = None;
            let levels = InputBits(self.logical_pins());
            let steps = self.kernel.position();
            self.board.limit_stop(levels, &steps);
            self.kernel.clear_stop();
            self.switch_stop = false;
            self.limit = false;
        }
        let inputs = self.board.setup().inputs;
        if (inputs.invert, inputs.debounce_ms) != self.debounce_setup {
            // A new setup arrived over the link: sample with its polarity and debounce.
            self.debounce_setup = (inputs.invert, inputs.debounce_ms);
            self.debouncer = Debouncer::new(inputs.invert, inputs.debounce_ms);
        }
        let (levels, changed) = self.debouncer.sample(self.raw_pins());
        self.inputs = levels.0;
        if changed != 0 {
            if let Some(f) = self.observer.as_mut() {
                f(PinEvent {
                    time: self.now,
                    step: 0,
                    dir: self.last_dir,
                    inputs: levels.0,
                    outputs: self.last_outputs,
                    period: 0,
                });
            }
        }
        self.board.on_inputs(now, levels, changed, self.adc);
        let view = self.kernel_view();
        self.take_events();
        self.link.service(&mut self.board, now, &view);
        let drained = self.fifo.0.is_empty() && self.next_tick.is_none();
        self.board.poll(drained);
        if let Some(steps) = self.board.take_position_reset() {
            let old = self.kernel.position();
            for i in 0..MAX_AXES {
                self.phys_offset[i] += old[i] - steps[i];
            }
            self.kernel.set_position(steps);
        }
        // A stop or a speed change: the newest queued segments go, prep continues from the end
        // of the kernel's running segment.
        let fifo = &mut self.fifo.0;
        let mut dropped = None;
        self.board.drop_queued(|max| {
            let n = max.min(fifo.len());
            fifo.truncate(fifo.len() - n);
            dropped = Some(n);
            n
        });
        if let Some(dropped) = dropped {
            let running_left = match self.next_tick {
                Some(t) => t.saturating_sub(self.now) + self.kernel.remaining_counts(),
                None => 0,
            };
            self.last_drop = Some(QueueDrop {
                time: self.now,
                dropped,
                running_left,
            });
        }
        let mut handed_out = false;
        while !self.fifo.0.is_full() {
            match self.board.next_segment() {
                Some(s) => {
                    // As the firmware: the marker is set before the kernel can step.
                    self.motion_marker = MARKER_MOVING;
                    handed_out = true;
                    let _ = self.fifo.0.push_back(s);
                }
                None => break,
            }
        }
        if drained && !handed_out && !self.board.position_lost() {
            self.motion_marker = MARKER_IDLE;
        }
        if self.next_tick.is_none() {
            if !self.fifo.0.is_empty() {
                self.next_tick = Some(self.now);
            } else if drained
                && self.board.motion().state() == MotionState::Running
                && self.board.state() == State::Run
            {
                self.underruns += 1;
            }
        }
        if let Some(word) = self.board.sync_user_outputs(self.kernel.outputs()) {
            // The board switched outputs itself (a list at rest, the safe state).
            self.kernel.set_outputs(word);
            if word != self.last_outputs {
                self.drive_user_outputs(word);
            }
        }
        let levels = self.board.output_levels();
        if levels != self.driven {
            // Spindle, coolant and PWM follow the board once per pass (the user outputs are
            // the kernel's word, exchanged above).
            self.driven = levels;
            if let Some(log) = self.output_changes.as_mut() {
                log.push((self.now, levels));
            }
        }
        self.arm = self.board.limit_arm();
        // An armed switch that is already active stops the kernel's next tick.
        self.switch_stop = self.logical_pins() & self.arm != 0;
        // Events raised by this poll go out in the same pass.
        self.take_events();
        self.link.service(&mut self.board, now, &view);
        let mut frame = [0u8; gantry_proto::MAX_FRAME_LEN];
        while let Some(n) = self.link.poll_transmit(now, &mut frame) {
            self.outbox.extend_from_slice(&frame[..n]);
        }
    }
}
