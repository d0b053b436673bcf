//! The emulated board: the very same [`Board`], [`BoardLink`], main loop and step interrupt
//! ([`StepIsr`]) the firmware runs, with the step timer on a virtual clock
//! ([`crate::step_clock`]) instead of TIM2.
//!
//! Virtual time counts kernel timer counts ([`KERNEL_TIMER_HZ`]). The main loop (link service,
//! interpretation, segment preparation) runs once per virtual millisecond and, as on the
//! firmware, as soon as the host's bytes arrive in between, the step interrupt at
//! the periods it sets (polling the queue every millisecond while idle, two kernel ticks ahead of
//! the pins), so the emulation runs as fast as the host can while keeping the board's timing.
//! Every step that reaches the pins is counted per axis, and an optional observer sees every
//! update that stepped or followed a change of the dir or output pins (for VCD traces).
//!
//! Inputs are virtual pins ([`EmulatedBoard::pins`], raw levels before the polarity setting) and
//! ADC readings, sampled and debounced once per main-loop pass exactly as the firmware does.
//! Limit switches can be modelled at fixed machine positions ([`EmulatedBoard::add_switch`]): the
//! switch pin follows the step pins' position after every step, and the kernel's limit flag is
//! set at that step when the switch is armed, so the interrupt's next kernel tick stops (the two
//! steps it has prepared still go out, as on the board; docs/controller.md "Safety rules as built").
//!
//! The firmware's motion marker (a RAM word that survives a reset, see
//! `gantry_machine::board::power_up`) is modelled too: [`EmulatedBoard::reset`] restarts the
//! board the way a watchdog, reset-pin or power-on reset would, with the machine standing where it
//! stopped.
//!
//! User outputs are virtual pins too: switched by the interrupt with the dir pins before the first
//! step of their segment (on-the-fly events), and loaded from the board when it switches outputs
//! itself ([`Board::sync_user_outputs`], once per main-loop pass, as the firmware).
//!
//! The main loop itself is the core's [`MainLoop::pass`], the very function the firmware calls
//! (`firmware/src/control.rs`): this file only models the hardware behind its [`BoardPort`]
//! (virtual time, the step timer, switches, gangs, pins and their traces, the host's bytes and
//! DTR, the flash).

use crate::cpu_model::{CpuMeter, CpuModel};
use crate::step_clock::{ClockEvent, StepClock};
use crate::torch_script::{TorchModel, TORCH_BITS};
use gantry_machine::board::inputs::{limit_bit, InputBits, Signal};
use gantry_machine::board::power_up::{PowerUp, ResetCause, MARKER_IDLE, MARKER_MOVING};
use gantry_machine::board::{AdcReadings, OutputLevels};
use gantry_machine::board::{Board, BoardEvent, LIMIT_BITS};
use gantry_machine::device::link::{BoardLink, KernelView};
use gantry_machine::device::main_loop::{
    BoardPort, HostPort, KernelSnapshot, MainLoop, SEGMENT_QUEUE_DEPTH,
};
use gantry_machine::motion::sim::SegmentFifo;
use gantry_machine::setup::Setup;
use gantry_machine::step::kernel::{Segment, StepTiming, KERNEL_TIMER_HZ};
use gantry_machine::step::{Run, StepIsr};
use gantry_machine::units::{Pos, MAX_AXES};
use std::collections::VecDeque;
use std::ops::{Deref, DerefMut};

/// Kernel timer counts per millisecond.
pub const COUNTS_PER_MS: u64 = KERNEL_TIMER_HZ as u64 / 1000;

/// The firmware's USB receive pipe (`firmware/src/usb.rs` `PIPE_LEN`): bytes a port in front of
/// the emulated board holds for it at most ([`Hardware::rx_room`]).
pub const RX_PIPE: usize = 512;

/// A change of the board's pins: a timer update that stepped, or the first after the interrupt
/// changed the dir pins or switched a user output, or a change of the input levels or of the user
/// outputs in the main loop (then `step` and `period` are 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PinEvent {
    /// Virtual time, kernel timer counts.
    pub time: u64,
    pub step: u8,
    pub dir: u8,
    /// Debounced input levels (`board::inputs::InputBits`).
    pub inputs: u32,
    /// User output pins (bit n = output n), switched before this event's steps.
    pub outputs: u16,
    /// Laser PWM duty (compare counts of `pwm_max`), switched before this event's steps.
    pub pwm: u16,
    /// Timer counts of the period this update starts (0: a main-loop event).
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

/// What the emulated touch probe touches (docs/probing.md "The emulated board"): the probe's
/// tip is a point at the machine position (X, Y, Z), all figures are machine nm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeTarget {
    /// A surface at `z`: touching at or below it, everywhere.
    Plane { z: i64 },
    /// A rectangular block `x[0]..=x[1]` by `y[0]..=y[1]` with its top at `top`: touching
    /// inside the rectangle at or below the top.
    Boss { x: [i64; 2], y: [i64; 2], top: i64 },
    /// A rectangular pocket `x[0]..=x[1]` by `y[0]..=y[1]` in a surface at `top`, with its floor
    /// at `bottom`: touching at or below the top outside the open rectangle, at or below the
    /// floor inside it.
    Hole {
        x: [i64; 2],
        y: [i64; 2],
        top: i64,
        bottom: i64,
    },
    /// A round tube centred on `c` (X, Y) with radii `r[0]..=r[1]` and its top at `top`:
    /// touching between the two circles at or below the top. Inside it is a bore of radius `r[0]`
    /// (open down to nothing), outside a boss of radius `r[1]`; `r[0]` = 0 is a round boss.
    Ring { c: [i64; 2], r: [i64; 2], top: i64 },
}

impl ProbeTarget {
    /// The tip at `p` (X, Y, Z in nm) touches it.
    pub fn touches(&self, p: [i64; 3]) -> bool {
        let inside = |x: &[i64; 2], y: &[i64; 2]| {
            (x[0]..=x[1]).contains(&p[0]) && (y[0]..=y[1]).contains(&p[1])
        };
        match *self {
            ProbeTarget::Plane { z } => p[2] <= z,
            ProbeTarget::Boss { x, y, top } => inside(&x, &y) && p[2] <= top,
            ProbeTarget::Hole { x, y, top, bottom } => {
                let open = x[0] < p[0] && p[0] < x[1] && y[0] < p[1] && p[1] < y[1];
                if open {
                    p[2] <= bottom
                } else {
                    p[2] <= top
                }
            }
            ProbeTarget::Ring { c, r, top } => {
                // Squares of nm: i128 holds them for any travel.
                let (dx, dy) = (i128::from(p[0] - c[0]), i128::from(p[1] - c[1]));
                let d2 = dx * dx + dy * dy;
                let sq = |v: i64| i128::from(v) * i128::from(v);
                p[2] <= top && sq(r[0]) <= d2 && d2 <= sq(r[1])
            }
        }
    }

    /// Parses `plane:Z`, `boss:X0,Y0,X1,Y1,TOP`, `hole:X0,Y0,X1,Y1,TOP,BOTTOM`,
    /// `ring:X,Y,D_INSIDE,D_OUTSIDE,TOP` or `cylinder:X,Y,D,TOP` (mm).
    pub fn parse(text: &str) -> anyhow::Result<ProbeTarget> {
        let (kind, rest) = text.split_once(':').unwrap_or((text, ""));
        let nums: Vec<i64> = rest
            .split(',')
            .map(|v| {
                let mm: f64 = v.trim().parse().map_err(|_| {
                    anyhow::anyhow!("probe target {text:?}: {v:?} is not a number (mm)")
                })?;
                anyhow::ensure!(mm.is_finite(), "probe target {text:?}: {v:?} is not finite");
                Ok((mm * 1e6).round() as i64)
            })
            .collect::<anyhow::Result<_>>()?;
        let sorted = |a: i64, b: i64| [a.min(b), a.max(b)];
        Ok(match (kind, nums.as_slice()) {
            ("plane", &[z]) => ProbeTarget::Plane { z },
            ("boss", &[x0, y0, x1, y1, top]) => ProbeTarget::Boss {
                x: sorted(x0, x1),
                y: sorted(y0, y1),
                top,
            },
            ("hole", &[x0, y0, x1, y1, top, bottom]) => ProbeTarget::Hole {
                x: sorted(x0, x1),
                y: sorted(y0, y1),
                top,
                bottom: bottom.min(top),
            },
            ("ring", &[x, y, d0, d1, top]) if 0 <= d0 && d0 < d1 => ProbeTarget::Ring {
                c: [x, y],
                r: [d0 / 2, d1 / 2],
                top,
            },
            ("cylinder", &[x, y, d, top]) if 0 < d => ProbeTarget::Ring {
                c: [x, y],
                r: [0, d / 2],
                top,
            },
            _ => anyhow::bail!(
                "probe target {text:?}: expected plane:Z, boss:X0,Y0,X1,Y1,TOP, hole:X0,Y0,X1,Y1,TOP,BOTTOM, \
                 ring:X,Y,D_INSIDE,D_OUTSIDE,TOP (0 <= inside < outside) or cylinder:X,Y,D,TOP (mm)"
            ),
        })
    }
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

/// Two motors on one step/dir channel (a ganged axis squared by homing, docs/controller.md "Homing"):
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

/// Converts physical steps to machine nm on X, Y, Z for the probe model.
#[derive(Clone, Copy, Debug)]
struct ProbeFrame {
    axes: [gantry_machine::motion::config::AxisConfig; 3],
    /// Physical step position of machine step 0 (homing moves the kernel's zero, not the part).
    origin: [i64; 3],
}

/// The emulated hardware: the step kernel on its virtual clock, its segment queue, pins,
/// switches, gangs and their traces, the host's bytes and DTR, the flash and the motion marker.
/// [`EmulatedBoard`] derefs to it, so its fields read as the board's.
pub struct Hardware {
    /// The step interrupt's state (the kernel, its segment queue, the prepared writes).
    pub isr: StepIsr<SegmentFifo<SEGMENT_QUEUE_DEPTH>>,
    /// The step timer and the pins the interrupt writes.
    pub clock: StepClock,
    /// Virtual time, kernel timer counts.
    now: u64,
    /// When the next tick's pass is due (the firmware's 1 ms ticker).
    next_main_loop: u64,
    /// When the pass running now ends (the CPU model's time; without it passes take none).
    cpu_free: u64,
    /// Bytes arrived that no pass has been woken for yet: the firmware's USB receive task wakes
    /// the main loop (`firmware/src/control.rs`), which runs a pass for them as soon as the one
    /// it may be in has ended ([`MainLoop::host_bytes_pass`]).
    woken: bool,
    /// Step position the step pins have made (the kernel's count less the steps it has
    /// prepared and not emitted yet).
    pin_steps: [i64; MAX_AXES],
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
    /// What the touch probe touches (nothing: the probe pin is the test's `pins` bit).
    probe_targets: Vec<ProbeTarget>,
    /// Physical steps of machine nm 0 on X, Y, Z and the step ratios, for the probe model.
    probe_frame: Option<ProbeFrame>,
    /// The probe pin's raw level, as the step interrupt reads it (follows every step).
    probe_raw: bool,
    /// Length of each tool (number, nm): the probe targets see the tool's tip, this far below
    /// the spindle (the machine Z), for the tool the board has in the spindle.
    pub tool_lengths: Vec<(u32, i64)>,
    /// The tool in the spindle (the board's, after each main-loop pass).
    tool: u32,
    /// User output pins at the last pin event.
    last_outputs: u16,
    /// Laser PWM duty at the last pin event.
    last_pwm: u16,
    /// Input polarity the hardware was given (the firmware's `INVERT`): from the setup at
    /// power-up and with every setup the host pushes.
    invert: u32,
    /// Physical position = pin steps + offset (homing redefines the kernel's zero).
    phys_offset: [i64; MAX_AXES],
    /// Limit bits armed for the kernel (from the board, once per main-loop pass).
    arm: u32,
    /// The switch model raised the kernel's limit flag.
    switch_stop: bool,
    /// Ticks that stopped the kernel on a limit, and the virtual time of the last one.
    pub limit_stops: u32,
    /// Dir pins at the last pin event.
    last_dir: u8,
    observer: Option<Box<dyn FnMut(PinEvent)>>,
    /// Bytes the board has sent and the host not yet read.
    outbox: Vec<u8>,
    /// Bytes from the host the main loop has not read yet.
    inbox: Vec<u8>,
    /// The host's hold on the port (the USB CDC DTR line; see [`EmulatedBoard::set_dtr`]).
    host_port: HostPort,
    /// Setups written to the emulated flash so far.
    pub setups_saved: u32,
    /// Where the machine stood at power-up in the frame of its travel and switches, nm
    /// (`gantry emulate --state`: from the state file; its step count starts at 0 there).
    pub stood_at: Pos,
    on_save: Option<SetupSaved>,
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
    /// Drivers enabled (the main loop's `steppers_enabled` at the last pass).
    pub steppers_enabled: bool,
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
    /// Virtual time of the last update that stepped (0: none yet).
    pub last_step_at: u64,
    /// Virtual time of the last interrupt run that found the kernel idle with nothing prepared:
    /// from then on the kernel is drained (until the main loop hands it a segment again); the
    /// first main-loop pass after it sees the machine at rest.
    pub kernel_idle_at: u64,
    /// The CPU model, when one is set ([`EmulatedBoard::set_cpu_model`]), and the segments the
    /// pass running now prepared, each reaching the kernel's queue when the pass has done the
    /// work before it.
    cpu: Option<CpuTime>,
    /// Times the step kernel ran dry in the middle of a job's motion ([`Starved`]).
    pub starved: Starved,
    /// A scripted plasma power source and height controller (`crate::torch_script`): when set,
    /// it drives the `arc_ok`, `thc_up` and `thc_down` pins from the torch output.
    pub torch: Option<TorchModel>,
}

/// The CPU model's state on the hardware.
struct CpuTime {
    meter: CpuMeter,
    /// Segments prepared by the pass running now, oldest first, with the virtual time each
    /// reaches the kernel's queue ([`AT_PASS_END`] until the pass's length is known).
    pending: VecDeque<(u64, Segment)>,
    /// When the pass running now started.
    pass_start: u64,
    /// The pass has not read the host's bytes yet: a segment it hands out now (the top-up at
    /// its start, `MainLoop::pass`) costs only its own preparation.
    before_intake: bool,
    /// Virtual time the top-up's segments took to prepare so far, in this pass.
    topped_up: u64,
}

/// Release time of a segment prepared after the pass's intake: when the pass ends.
const AT_PASS_END: u64 = u64::MAX;

/// Underruns as the machine feels them: the main loop's count
/// (`gantry_machine::device::underruns`), the firmware's own.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Starved {
    /// Times the step kernel ran dry in the middle of a job's motion so far.
    pub gaps: u64,
}

/// A board with its kernel on a virtual clock: the firmware's [`Board`], [`BoardLink`] and main
/// loop ([`MainLoop`]) on the emulated [`Hardware`].
pub struct EmulatedBoard {
    pub board: Board,
    pub link: BoardLink,
    /// The main loop's own state (speed meter, limit latch, debouncer, host port, save rule).
    main: MainLoop,
    hw: Hardware,
}

impl Deref for EmulatedBoard {
    type Target = Hardware;
    fn deref(&self) -> &Hardware {
        &self.hw
    }
}

impl DerefMut for EmulatedBoard {
    fn deref_mut(&mut self) -> &mut Hardware {
        &mut self.hw
    }
}

/// Called with every setup the board writes to its emulated flash.
type SetupSaved = Box<dyn FnMut(&Setup)>;

/// Boot id of the emulated board's first power-up.
const BOOT_ID: u32 = 0x6a17_0001;

impl EmulatedBoard {
    pub fn new(setup: Setup) -> Self {
        let timing = StepTiming::from_setup(&setup.drivers);
        let hw = Hardware {
            invert: setup.inputs.invert,
            isr: StepIsr::new(SegmentFifo::default(), timing),
            clock: StepClock::start(0, &timing),
            now: 0,
            next_main_loop: 0,
            cpu_free: 0,
            woken: false,
            pin_steps: [0; MAX_AXES],
            pulses: [0; MAX_AXES],
            inputs: 0,
            limit: false,
            pins: 0,
            adc: AdcReadings::default(),
            switches: Vec::new(),
            gang: None,
            probe_targets: Vec::new(),
            probe_frame: None,
            probe_raw: setup.inputs.invert >> Signal::Probe as u32 & 1 != 0,
            tool_lengths: Vec::new(),
            tool: 0,
            last_outputs: 0,
            last_pwm: 0,
            phys_offset: [0; MAX_AXES],
            arm: 0,
            switch_stop: false,
            limit_stops: 0,
            last_dir: 0,
            observer: None,
            outbox: Vec::new(),
            inbox: Vec::new(),
            host_port: HostPort::Open,
            stood_at: [0; MAX_AXES],
            setups_saved: 0,
            on_save: None,
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
            steppers_enabled: false,
            cpu: None,
            starved: Starved::default(),
            torch: None,
        };
        EmulatedBoard {
            main: MainLoop::new(&setup),
            board: Board::new(setup),
            link: BoardLink::new(BOOT_ID),
            hw,
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
        let timing = StepTiming::from_setup(&setup.drivers);
        self.isr = StepIsr::new(SegmentFifo::default(), timing);
        // The timer restarts with the MCU: dir and output pins low, no step prepared.
        let probe = self.clock.regs.probe;
        self.clock = StepClock::start(self.now, &timing);
        self.clock.regs.probe = probe;
        self.phys_offset = here;
        self.pin_steps = [0; MAX_AXES];
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
            let now = self.now;
            if let Some(log) = self.output_changes.as_mut() {
                log.push((now, OutputLevels::SAFE));
            }
        }
        self.main = MainLoop::new(&setup);
        self.invert = setup.inputs.invert;
        self.outbox.clear();
        self.inbox.clear();
        self.woken = false;
        self.cpu_free = self.now;
        how
    }

    /// Models a limit switch of `axis` at machine position `at_nm` (as the machine position is
    /// now): the min switch is active at or below it, the max switch at or above.
    pub fn add_switch(&mut self, axis: usize, max: bool, at_nm: i64) {
        let steps = self.board.motion_config().axes[axis].nm_to_steps(at_nm);
        let at = steps - self.isr.kernel.position()[axis] + self.physical()[axis];
        self.switches.push(LimitSwitch { axis, max, at });
    }

    /// Places a probe target in the frame of the travel and its switches: machine coordinates as
    /// they are now, plus [`EmulatedBoard::stood_at`] (where the machine stood at power-up, its
    /// step count 0 there; set it first). The part is fixed to the table, like the switches:
    /// after homing to the switches the target is where its figures say. From now on the probe
    /// pin follows the machine position after every step.
    pub fn add_probe_target(&mut self, target: ProbeTarget) {
        let cfg = self.board.motion_config();
        let k = self.isr.kernel.position();
        let phys = self.physical();
        let stood = cfg.to_steps(&self.stood_at);
        self.hw.probe_frame = Some(ProbeFrame {
            axes: [cfg.axes[0], cfg.axes[1], cfg.axes[2]],
            origin: [0, 1, 2].map(|i| phys[i] - k[i] - stood[i]),
        });
        self.hw.probe_targets.push(target);
        self.hw.probe_raw = self.hw.probe_level();
    }

    /// Models `axis` as two ganged motors, enabled by user outputs `enable`, with switches at
    /// machine positions `at_nm` (min side, or max side with `max`); both start where the axis is.
    pub fn add_gang(&mut self, axis: usize, max: bool, enable: [u8; 2], at_nm: [i64; 2]) {
        let a = self.board.motion_config().axes[axis];
        let here = self.physical()[axis];
        let k = self.isr.kernel.position()[axis];
        self.gang = Some(Gang {
            axis,
            max,
            enable,
            at: at_nm.map(|v| a.nm_to_steps(v) - k + here),
            motors: [here; 2],
        });
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

    /// Runs `ms` virtual milliseconds.
    pub fn run_ms(&mut self, ms: u64) {
        self.run_for(ms * COUNTS_PER_MS);
    }

    /// What a status report taken now sees of the kernel: its step position now, and the
    /// debounced inputs and path speed (20 ms window) of the last main-loop pass.
    pub fn kernel_view(&self) -> KernelView {
        KernelView {
            steps: self.hw.isr.kernel.position(),
            ..self.main.kernel_view()
        }
    }

    /// Runs the board for `counts` kernel timer counts of virtual time.
    pub fn run_for(&mut self, counts: u64) {
        let end = self.now + counts;
        while self.now < end {
            self.release_pass_segments();
            self.due_passes();
            while self.clock.next_event() <= self.now {
                self.clock_event();
            }
            // (Each candidate lies ahead: a pass due now has run or waits for `cpu_free`.)
            let mut next = end
                .min(self.clock.next_event())
                .min(self.next_main_loop.max(self.hw.cpu_free));
            if self.hw.woken {
                next = next.min(self.hw.cpu_free);
            }
            if let Some(&(at, _)) = self.cpu.as_ref().and_then(|c| c.pending.front()) {
                next = next.min(at);
            }
            self.now = next.max(self.now);
        }
    }

    /// Runs the passes due now without advancing the clock: the one bytes just given to
    /// [`Hardware::receive`] woke, as the firmware's main loop runs at once for them (`gantry
    /// emulate`, whose clock follows the wall clock, answers a line when it arrives).
    pub fn run_due(&mut self) {
        self.release_pass_segments();
        self.due_passes();
    }

    /// When the next tick's pass is due, virtual time.
    pub fn next_tick(&self) -> u64 {
        self.next_main_loop.max(self.hw.cpu_free)
    }

    /// The passes due now, once the CPU is free: the tick's (every millisecond), then the one
    /// the host's bytes woke.
    fn due_passes(&mut self) {
        if self.now < self.hw.cpu_free {
            return;
        }
        if self.now >= self.next_main_loop {
            let busy = self.main_loop(false);
            self.next_main_loop = self.now + busy.max(COUNTS_PER_MS);
            self.hw.cpu_free = self.now + busy;
        }
        if self.hw.woken && self.now >= self.hw.cpu_free {
            let busy = self.main_loop(true);
            self.hw.cpu_free = self.now + busy;
        }
    }

    // The hardware's own methods, also callable as `EmulatedBoard::…` (paths in other files).

    /// See [`Hardware::capture_events`].
    pub fn capture_events(&mut self) {
        self.hw.capture_events();
    }

    /// See [`Hardware::now`].
    pub fn now(&self) -> u64 {
        self.hw.now()
    }

    /// See [`Hardware::now_ms`].
    pub fn now_ms(&self) -> u32 {
        self.hw.now_ms()
    }

    /// See [`Hardware::receive`].
    pub fn receive(&mut self, bytes: &[u8]) {
        self.hw.receive(bytes);
    }

    /// The host left: bytes it sent that the main loop has not read go with it (the port's
    /// buffers belong to the connection).
    pub fn discard_input(&mut self) {
        self.hw.inbox.clear();
    }

    /// See [`Hardware::rx_room`].
    pub fn rx_room(&self) -> usize {
        self.hw.rx_room()
    }

    /// See [`Hardware::take_output`].
    pub fn take_output(&mut self) -> Vec<u8> {
        self.hw.take_output()
    }

    /// See [`Hardware::set_dtr`].
    pub fn set_dtr(&mut self, connected: bool) {
        self.hw.set_dtr(connected);
    }

    /// See [`Hardware::close_keeping_dtr`].
    pub fn close_keeping_dtr(&mut self) {
        self.hw.close_keeping_dtr();
    }

    /// See [`Hardware::kernel_drained`].
    pub fn kernel_drained(&self) -> bool {
        self.hw.kernel_drained()
    }

    /// The main loop holds a latched kernel stop (a limit tripped; the board is in alarm): no
    /// segment reaches the kernel until the alarm is cleared.
    pub fn kernel_latched(&self) -> bool {
        self.main.kernel_latched()
    }

    /// One pass of the board's main loop (the core's, as on the firmware), the tick's or the
    /// one the host's bytes woke (`for_bytes`), with this emulation as its port. Returns how
    /// long it keeps the CPU busy (kernel timer counts): 0 without a CPU model.
    fn main_loop(&mut self, for_bytes: bool) -> u64 {
        if let Some(cpu) = self.hw.cpu.as_mut() {
            cpu.pass_start = self.hw.now;
            cpu.before_intake = true;
            cpu.topped_up = 0;
        }
        let now = self.hw.now_ms();
        let (main, board, link, hw) = (
            &mut self.main,
            &mut self.board,
            &mut self.link,
            &mut self.hw,
        );
        if for_bytes {
            main.host_bytes_pass(now, board, link, hw);
        } else {
            main.pass(now, board, link, hw);
        }
        // The wake is spent with the pass that woke for it, and with any pass that read every
        // byte (the firmware resets its receive signal when the pipe is empty).
        if for_bytes || self.hw.inbox.is_empty() {
            self.hw.woken = false;
        }
        self.hw.starved.gaps = u64::from(self.main.underruns());
        self.hw.tool = self.board.outputs().tool;
        self.hw.steppers_enabled = self.main.steppers_enabled();
        self.cpu_pass_done()
    }

    /// Charges the CPU model (if any) for the pass that just ran; its segments reach the
    /// kernel's queue when it ends.
    fn cpu_pass_done(&mut self) -> u64 {
        let start = self.hw.now;
        let Some(cpu) = self.hw.cpu.as_mut() else {
            return 0;
        };
        let busy = cpu
            .meter
            .pass_done(&self.board, start, u64::from(KERNEL_TIMER_HZ));
        for (at, _) in cpu.pending.iter_mut() {
            if *at == AT_PASS_END {
                *at = start + busy;
            }
        }
        busy
    }

    /// Gives the emulated board a CPU model ([`crate::cpu_model`]): from now on each main-loop
    /// pass costs the instructions its work takes on that MCU. `None`: passes take no time.
    pub fn set_cpu_model(&mut self, model: Option<CpuModel>) {
        self.hw.cpu = model.map(|m| CpuTime {
            meter: CpuMeter::new(m),
            pending: VecDeque::new(),
            pass_start: 0,
            before_intake: false,
            topped_up: 0,
        });
    }

    /// The CPU model's meter, when one is set.
    pub fn cpu_meter(&self) -> Option<&CpuMeter> {
        self.hw.cpu.as_ref().map(|c| &c.meter)
    }
}

impl Hardware {
    /// The segments the pass has prepared by now go to the kernel's queue (CPU model only).
    fn release_pass_segments(&mut self) {
        let Some(cpu) = self.cpu.as_mut() else {
            return;
        };
        while let Some(&(at, seg)) = cpu.pending.front() {
            if at > self.now {
                break;
            }
            cpu.pending.pop_front();
            let _ = self.isr.source.0.push_back(seg);
        }
    }

    /// From now on the board's events (alarms, limit reports, errors, job ends) are collected in
    /// [`Hardware::events`], in order, instead of going out over the link: for scenario tests
    /// that drive the board without a host.
    pub fn capture_events(&mut self) {
        self.capture = true;
    }

    /// Physical step position (the steps the pins made + the offset homing introduced).
    pub fn physical(&self) -> [i64; MAX_AXES] {
        let mut p = self.pin_steps;
        for (v, o) in p.iter_mut().zip(self.phys_offset) {
            *v += o;
        }
        p
    }

    /// User output pins now (bit n = output n).
    pub fn user_outputs(&self) -> u16 {
        self.clock.regs.outputs
    }

    /// Laser PWM duty on the pin now (compare counts; laser mode).
    pub fn laser_pwm(&self) -> u16 {
        self.clock.regs.pwm
    }

    /// Logical levels of the modelled switches now, and the bits they own.
    fn switch_levels(&self) -> (u32, u32) {
        let p = self.physical();
        let user_outputs = self.user_outputs();
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

    /// Raw pin levels: the test's pins with the modelled switches', torch inputs' and probe's
    /// pins.
    pub fn raw_pins(&self) -> u32 {
        let (mut on, mut owned) = self.switch_levels();
        if let Some(t) = &self.torch {
            on |= t.levels(self.now_ms().into());
            owned |= TORCH_BITS;
        }
        let pins = (self.pins & !owned) | ((on ^ self.invert) & owned);
        if self.probe_targets.is_empty() {
            return pins;
        }
        let bit = 1 << Signal::Probe as u32;
        (pins & !bit) | if self.probe_raw { bit } else { 0 }
    }

    /// The probe pin's raw level from the probe targets at the machine position now.
    fn probe_level(&self) -> bool {
        let invert = self.invert >> Signal::Probe as u32 & 1 != 0;
        let Some(frame) = self.probe_frame else {
            return self.pins >> Signal::Probe as u32 & 1 != 0;
        };
        let phys = self.physical();
        let mut at = [0i64; 3];
        for i in 0..3 {
            at[i] = frame.axes[i].steps_to_nm(phys[i] - frame.origin[i]);
        }
        if let Some(&(_, length)) = self.tool_lengths.iter().find(|(t, _)| *t == self.tool) {
            at[2] -= length;
        }
        let touching = self.probe_targets.iter().any(|t| t.touches(at));
        touching ^ invert
    }

    /// The probe pin as the step interrupt reads it now.
    fn probe_pin(&self) -> bool {
        if self.probe_targets.is_empty() {
            self.pins >> Signal::Probe as u32 & 1 != 0
        } else {
            self.probe_raw
        }
    }

    /// Logical levels the step interrupt sees (raw pins, polarity applied, no debounce).
    fn logical_pins(&self) -> u32 {
        self.raw_pins() ^ self.invert
    }

    /// Sets or clears one raw pin.
    pub fn set_pin(&mut self, bit: u32, on: bool) {
        let mut b = InputBits(self.pins);
        b.set_bit(bit, on);
        self.pins = b.0;
    }

    /// The kernel has run every segment it was given and every step reached the pins.
    pub fn kernel_drained(&self) -> bool {
        self.isr.snapshot().drained
    }

    /// Virtual time the kernel's segment queue holds (not counting the running segment), ms.
    pub fn queued_ms(&self) -> f64 {
        let counts: u64 = self.isr.source.0.iter().map(|s| s.duration()).sum();
        counts as f64 / COUNTS_PER_MS as f64
    }

    /// Calls `f` for every pin event ([`PinEvent`]).
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

    /// Bytes the board's receive pipe takes now: what a port in front of the emulated board
    /// reads from its host at most (`gantry emulate`), so that bytes the board cannot take yet
    /// wait in the pty or socket as they wait behind the USB board's endpoint (the firmware's
    /// pipe, `firmware/src/usb.rs` `PIPE_LEN`, is read by the main loop only as the link has
    /// room: `BoardLink::rx_room`).
    pub fn rx_room(&self) -> usize {
        RX_PIPE.saturating_sub(self.inbox.len())
    }

    /// Bytes from the host: they wake the main loop, which reads them in a pass of their own as
    /// soon as the CPU is free ([`EmulatedBoard::run_for`], [`EmulatedBoard::run_due`]), as the
    /// firmware's USB receive task wakes its main loop. Tests may give any amount; a port honours
    /// [`Self::rx_room`].
    pub fn receive(&mut self, bytes: &[u8]) {
        if !bytes.is_empty() {
            self.last_received_ms = Some(self.now_ms());
            self.woken = true;
        }
        self.inbox.extend_from_slice(bytes);
    }

    /// A host holds the port open (`true`, the USB CDC DTR line raised) or has closed it. The
    /// board starts with a host attached; a drop during a job holds it (as the firmware does).
    pub fn set_dtr(&mut self, connected: bool) {
        self.host_port = if connected {
            HostPort::Open
        } else {
            HostPort::Closed
        };
    }

    /// The host closed the port and left DTR up (it cleared HUPCL): a pty shows this close, a
    /// USB port would not ([`HostPort::ClosedDtrKept`]).
    pub fn close_keeping_dtr(&mut self) {
        self.host_port = HostPort::ClosedDtrKept;
    }

    /// Calls `f` with every setup the board writes to its flash (a setup from the host, once the
    /// board is idle).
    pub fn on_setup_saved(&mut self, f: impl FnMut(&Setup) + 'static) {
        self.on_save = Some(Box::new(f));
    }

    /// Bytes for the host (everything sent since the last call).
    pub fn take_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.outbox)
    }

    /// The step clock's next event, due now.
    fn clock_event(&mut self) {
        let stop = self.limit || self.switch_stop;
        self.clock.regs.probe = self.probe_pin();
        let (queued, front) = (self.isr.source.0.len(), self.isr.source.0.front().copied());
        let was_idle = self.isr.idle;
        match self.clock.advance(self.now, &mut self.isr, stop) {
            ClockEvent::Update { step, period } => self.on_update(step, period),
            ClockEvent::Interrupt(Run::Scheduled) => {
                if let (Some(log), Some(seg)) = (self.started_segments.as_mut(), front) {
                    if self.isr.source.0.len() < queued {
                        log.push((self.now, seg));
                    }
                }
                if let Some(cpu) = self.cpu.as_mut() {
                    cpu.meter.on_tick(self.isr.after.step);
                }
                if self.isr.idle && !was_idle {
                    self.kernel_idle_at = self.now;
                }
            }
            ClockEvent::Interrupt(Run::Late) => {}
        }
    }

    /// An update of the step timer: the step pins of `step` rise (with the dir pins the
    /// interrupt wrote before), a period of `period` counts starts.
    fn on_update(&mut self, step: u8, period: u32) {
        let dir = self.clock.regs.dir_pins;
        let outputs = self.clock.regs.outputs;
        let pwm = self.clock.regs.pwm;
        if step != 0 {
            for (axis, (p, pulses)) in self.pin_steps.iter_mut().zip(&mut self.pulses).enumerate() {
                if step >> axis & 1 != 0 {
                    *pulses += 1;
                    *p += if dir >> axis & 1 != 0 { -1 } else { 1 };
                }
            }
            if let Some(g) = self.gang.as_mut() {
                if step & (1 << g.axis) != 0 {
                    let d = if dir & (1 << g.axis) != 0 { -1 } else { 1 };
                    for m in 0..2 {
                        if outputs & (1 << g.enable[m]) != 0 {
                            g.motors[m] += d;
                        }
                    }
                }
            }
            self.last_step_at = self.now;
            if !self.probe_targets.is_empty() {
                // The probe pin follows this step; the interrupt reads it on its next run.
                self.probe_raw = self.probe_level();
            }
            if !self.switches.is_empty() || self.gang.is_some() {
                // The switch pin follows this step; the kernel sees it on its next tick.
                self.switch_stop = self.logical_pins() & self.arm & LIMIT_BITS != 0;
            }
        }
        if step != 0 || dir != self.last_dir || outputs != self.last_outputs || pwm != self.last_pwm
        {
            if let Some(f) = self.observer.as_mut() {
                f(PinEvent {
                    time: self.now,
                    step,
                    dir,
                    inputs: self.inputs,
                    outputs,
                    pwm,
                    period,
                });
            }
            self.last_dir = dir;
            self.last_outputs = outputs;
            self.last_pwm = pwm;
        }
    }

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
                pwm: self.last_pwm,
                period: 0,
            });
        }
    }
}

/// The emulated hardware as the main loop's port.
impl BoardPort for Hardware {
    fn kernel(&mut self) -> KernelSnapshot {
        self.isr.snapshot()
    }

    fn flush_kernel(&mut self) {
        self.limit_stops += 1;
        self.isr.flush();
    }

    fn rearm_kernel(&mut self) {
        // As the firmware: the stop flag is re-evaluated from the pins with the current arming
        // (a forced `limit` is a one-off stop).
        self.limit = false;
        self.switch_stop = self.logical_pins() & self.arm & LIMIT_BITS != 0;
        self.isr.rearm();
    }

    fn arm_limits(&mut self, arm: u32) {
        self.arm = arm;
        // An armed switch that is already active stops the kernel's next tick.
        if self.logical_pins() & arm != 0 {
            self.switch_stop = true;
        }
    }

    fn raw_inputs(&mut self) -> u32 {
        self.raw_pins()
    }

    fn adc(&mut self) -> AdcReadings {
        self.adc
    }

    fn inputs_sampled(&mut self, levels: InputBits, changed: u32) {
        self.inputs = levels.0;
        if changed != 0 {
            if let Some(f) = self.observer.as_mut() {
                f(PinEvent {
                    time: self.now,
                    step: 0,
                    dir: self.last_dir,
                    inputs: levels.0,
                    outputs: self.last_outputs,
                    pwm: self.last_pwm,
                    period: 0,
                });
            }
        }
    }

    fn queue_ready(&mut self) -> bool {
        let pending = self.cpu.as_ref().map_or(0, |c| c.pending.len());
        self.isr.source.0.len() + pending < self.isr.source.0.capacity()
    }

    fn push_segment(&mut self, seg: Segment) {
        if let Some(cpu) = self.cpu.as_mut() {
            // Prepared by the pass running now: in the queue once prepared at its start (the
            // top-up before the intake), else when the pass ends.
            cpu.meter.segments += 1;
            let at = if cpu.before_intake {
                cpu.topped_up += cpu.meter.segment_counts(u64::from(KERNEL_TIMER_HZ));
                cpu.pass_start + cpu.topped_up
            } else {
                AT_PASS_END
            };
            cpu.pending.push_back((at, seg));
            return;
        }
        let _ = self.isr.source.0.push_back(seg);
    }

    fn drop_newest(&mut self, max: usize) -> usize {
        let fifo = &mut self.isr.source.0;
        let dropped = max.min(fifo.len());
        fifo.truncate(fifo.len() - dropped);
        // The kernel ticks at the interrupt after the next update, then once a period.
        let running_left = if self.isr.idle {
            0
        } else {
            self.clock.next_update().saturating_sub(self.now) + self.isr.kernel.remaining_counts()
        };
        self.last_drop = Some(QueueDrop {
            time: self.now,
            dropped,
            running_left,
        });
        dropped
    }

    fn set_position(&mut self, steps: [i64; MAX_AXES]) {
        for ((offset, pins), new) in self.phys_offset.iter_mut().zip(self.pin_steps).zip(steps) {
            *offset += pins - new;
        }
        self.pin_steps = steps;
        self.isr.kernel.set_position(steps);
    }

    fn apply_setup(&mut self, invert: u32, timing: StepTiming) {
        self.invert = invert;
        self.isr.timing = timing;
        self.clock.set_pulse(timing.pulse);
    }

    fn exchange_user_outputs(&mut self, f: impl FnOnce(u16) -> Option<u16>) {
        if let Some(word) = self.isr.exchange_outputs(f) {
            // The board switched outputs itself (a list at rest, the safe state).
            self.clock.regs.outputs = word;
            if word != self.last_outputs {
                self.drive_user_outputs(word);
            }
        }
    }

    fn drive_outputs(&mut self, levels: &OutputLevels, _pwm_max: u16, _steppers_enabled: bool) {
        if let Some(t) = self.torch.as_mut() {
            t.torch(levels.spindle_enable, self.now / COUNTS_PER_MS);
        }
        if *levels != self.driven {
            // Spindle, coolant and PWM follow the board once per pass (the user outputs are
            // the kernel's word, exchanged before).
            self.driven = *levels;
            if let Some(log) = self.output_changes.as_mut() {
                log.push((self.now, *levels));
            }
        }
    }

    fn receive(&mut self, buf: &mut [u8]) -> usize {
        if let Some(cpu) = self.cpu.as_mut() {
            cpu.before_intake = false;
        }
        let n = buf.len().min(self.inbox.len());
        buf[..n].copy_from_slice(&self.inbox[..n]);
        self.inbox.drain(..n);
        if let Some(cpu) = self.cpu.as_mut() {
            cpu.meter.on_received(&buf[..n]);
        }
        n
    }

    fn can_transmit(&mut self, _len: usize) -> bool {
        true
    }

    fn transmit(&mut self, frame: &[u8]) {
        self.outbox.extend_from_slice(frame);
    }

    fn host_port(&mut self) -> HostPort {
        self.host_port
    }

    fn save_setup(&mut self, setup: &Setup) {
        self.setups_saved += 1;
        if let Some(f) = self.on_save.as_mut() {
            f(setup);
        }
    }

    fn motion_marker(&mut self, moving: bool) {
        self.motion_marker = if moving { MARKER_MOVING } else { MARKER_IDLE };
    }

    fn arm_probe(&mut self, trips_at: Option<bool>) {
        self.isr.arm_probe(trips_at);
    }

    fn probe_latched(&mut self) -> Option<[i64; MAX_AXES]> {
        self.isr.probe_latched()
    }

    fn before_link_service(&mut self, board: &mut Board) {
        if self.capture {
            while let Some(e) = board.take_event() {
                self.events.push(e);
            }
        }
    }
}

/// The emulated board for `gantry home`: a limit switch sits at the travel end each homed axis
/// seeks, as on a real machine, so the homing cycle can be tried without hardware.
pub fn emulated_with_switches(setup: gantry_machine::setup::Setup) -> EmulatedBoard {
    let mut board = EmulatedBoard::new(setup.clone());
    for axis in 0..setup.axis_count as usize {
        let h = &setup.homing.axes[axis];
        if h.priority == 0 {
            continue;
        }
        let a = &setup.axes[axis];
        let at = if h.seek_low {
            a.travel_min
        } else {
            a.travel_max
        };
        board.add_switch(axis, !h.seek_low, at);
    }
    board
}

#[cfg(test)]
mod probe_target_tests {
    use super::ProbeTarget;

    #[test]
    fn a_ring_is_a_bore_inside_and_a_boss_outside() {
        let ring = ProbeTarget::parse("ring:100,50,30,60,0").unwrap();
        let mm = |v: f64| (v * 1e6) as i64;
        // On the bore's wall (radius 15) and the boss's (radius 30), on and off the X line.
        assert!(ring.touches([mm(115.0), mm(50.0), mm(-1.0)]));
        assert!(!ring.touches([mm(114.999), mm(50.0), mm(-1.0)]));
        assert!(ring.touches([mm(70.0), mm(50.0), mm(-1.0)]));
        assert!(!ring.touches([mm(69.999), mm(50.0), mm(-1.0)]));
        assert!(ring.touches([mm(100.0), mm(65.0), mm(0.0)]));
        assert!(!ring.touches([mm(100.0), mm(65.0), mm(0.001)]));
        let cyl = ProbeTarget::parse("cylinder:0,0,20,-3").unwrap();
        assert!(cyl.touches([0, 0, mm(-3.0)]) && !cyl.touches([mm(10.001), 0, mm(-5.0)]));
        assert!(ProbeTarget::parse("ring:0,0,60,30,0").is_err());
        assert!(ProbeTarget::parse("cylinder:0,0,0,0").is_err());
    }
}
