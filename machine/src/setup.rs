//! The machine setup: every user setting, as stored in flash and sent over the link.
//!
//! This is the one persistent description of a machine. The host reads it from a commented TOML
//! file (`gantry setup`), the board keeps it in flash, and the interpreter, planner and controller
//! each take their part of it. All values are integers in machine units (nm, nm/min, nm/s², µs),
//! so the same setup means bit-identical behaviour on every target.

use crate::gcode::config::WORK_SYSTEMS;
pub use crate::step::timing::DriverSetup;
use crate::step::timing::{StepTiming, KERNEL_TIMER_HZ};
use crate::units::{FeedNmPerMin, Nm, Pos, MAX_AXES, NM_PER_MM};
use heapless::Vec;
use serde::{Deserialize, Serialize};

mod blob;
pub mod table;
mod validate;

pub use table::Key;
pub use validate::{file_value, section_name, KeyName, Reason, SetupError};

/// Number of user M-code lists.
pub const MAX_USER_MCODES: usize = 16;
/// Commands a user M-code list may hold.
pub const MAX_LIST_COMMANDS: usize = 8;

/// The dialect, the G4 P units and the tool-table entry are the interpreter's own types (one set
/// for the setup, the flash blob and the interpreter); the board keeps [`MAX_TOOLS`] tools, as
/// many as the interpreter's table holds.
pub use crate::gcode::{Dialect, DwellUnits, Tool, ToolChangePosition, MAX_TOOLS};

/// Per-axis setup.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct AxisSetup {
    /// Exact ratio: `steps` motor steps move the axis `units_nm` nanometres (the GIXA controller's "Ratiometric Steps per Unit").
    pub steps: u32,
    pub units_nm: Nm,
    /// Highest speed of this axis (rapid rate) in nm/min.
    pub max_rate: FeedNmPerMin,
    /// Acceleration in nm/s².
    pub accel: i64,
    /// Jerk limit in nm/s³; 0 = none (trapezoid ramps).
    pub jerk: i64,
    /// Speed reachable instantly from rest (the GIXA controller's "Starting Speed"), nm/min.
    pub start_speed: FeedNmPerMin,
    /// Soft-limit box in machine coordinates, nm (min ≤ max).
    pub travel_min: Nm,
    pub travel_max: Nm,
    /// Reverse the direction output.
    pub invert_dir: bool,
}

/// Path-planning settings shared by all axes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PathSetup {
    /// grbl junction deviation, nm.
    pub junction_deviation: Nm,
    /// Speed jump the steppers take at any junction (the GIXA controller's "Feed Shift"), nm/min; it only raises
    /// junction deviation's corner speed (docs/settings.md).
    pub feed_shift: FeedNmPerMin,
    /// Largest chord error when arcs are cut into lines, nm.
    pub chord_tolerance: Nm,
    /// Largest angle of one arc segment, millidegrees (0 = no limit).
    pub arc_segment_angle_mdeg: u32,
    /// Most segments one arc may be cut into (0 = no limit).
    pub arc_max_segments: u32,
    /// Path tolerance `G64` without P blends with (chords and rounded corners), nm; 0 = off.
    pub blend_tolerance: Nm,
}

/// Interpreter settings.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ProgramSetup {
    pub dialect: Dialect,
    pub dwell_units: DwellUnits,
    /// Retract clearance of G73/G83 pecks, nm (default 0.254 mm).
    pub peck_clearance: Nm,
    /// Partial retract of the `gixa` G87 chip-break cycle, nm.
    pub chip_break_retract: Nm,
    /// Canned-cycle retract mode when a program sets neither G98 nor G99 (default G98).
    pub default_retract: crate::gcode::RetractMode,
    pub tools: Vec<Tool, MAX_TOOLS>,
    /// G54..G59.3 offsets, nm (the interpreter's [`WORK_SYSTEMS`] systems).
    pub work_offsets: [Pos; WORK_SYSTEMS],
    /// G28 / G30 home positions in machine coordinates.
    pub g28_home: Pos,
    pub g30_home: Pos,
    /// M codes the user has defined; each reaches the controller as a user M-code action.
    pub user_mcodes: Vec<u16, MAX_USER_MCODES>,
    /// Where `M6` moves (machine coordinates, Z first) before it stops for the tool change;
    /// no axis set by default (docs/probing.md "Tool change").
    pub tool_change_position: ToolChangePosition,
}

/// Operator-input behaviour.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct OperatorSetup {
    /// After a feed hold is released: resume at once (the GIXA controller's behaviour) or wait for cycle start.
    pub resume_needs_cycle_start: bool,
    /// Cycle start needs both start inputs (two-hand start).
    pub two_hand_start: bool,
    /// Feed-override potentiometer range, percent (ADC low → `fro_low`, high → `fro_high`).
    pub fro_low: u16,
    pub fro_high: u16,
    /// Feed used for every feed move during a dry run, nm/min.
    pub dry_run_feed: FeedNmPerMin,
}

/// Commands a homing list (before seek, before retract, after retract) may hold.
pub(crate) const MAX_HOMING_COMMANDS: usize = 8;
/// User M codes that may carry a command list.
pub const MAX_MCODE_LISTS: usize = 8;
/// Commands one M-code list may hold.
pub(crate) const MAX_MCODE_COMMANDS: usize = 6;
/// User outputs (bit numbers 0..16 of [`crate::board::OutputLevels::user`]).
pub const USER_OUTPUTS: u8 = 16;

/// One entry of a command list (homing lists, user M-code lists), the GIXA controller's command lists reduced to
/// output actions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ListCommand {
    /// Switch user output `n` on.
    Set(u8),
    /// Switch user output `n` off.
    Clear(u8),
    /// Wait this many milliseconds.
    DwellMs(u16),
    /// Wait until input bit `bit` (an [`crate::board::inputs::InputBits`] bit) reads `level`;
    /// after `timeout_ms` the controller alarms (0 = wait forever).
    WaitInput {
        bit: u8,
        level: bool,
        timeout_ms: u16,
    },
    /// The GIXA controller's `#disable_limit_report`, only as the first entry of a list: the switch hits this
    /// list's `seek` commands cause (squaring) are not reported to the host. Unexpected switches
    /// still stop the machine and raise alarm 1 with their report.
    DisableLimitReport,
    /// In a homing list: seek the homed axis's switch again at the seek rate and continue when it
    /// stops the motion (squaring a ganged axis: enable one side, seek, enable the other, seek).
    /// Ignored in M-code lists.
    Seek,
}

/// Input wiring: polarity, debounce and which switches are installed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct InputSetup {
    /// Active-low pins: bit i set = input bit i reads active when its pin is low.
    pub invert: u32,
    /// Consecutive equal 1 ms samples before an input level is accepted (1 = no debounce).
    /// Limit switches stop the step kernel from the raw pin regardless (docs/controller.md, "Safety rules as built").
    pub debounce_ms: u8,
    /// Installed limit switches: bit i = axis i (X = bit 0).
    pub limit_min: u8,
    pub limit_max: u8,
    /// Hard limits enabled: an installed switch stops motion and raises the alarm.
    pub hard_limits: bool,
    /// Feed-hold and abort switches installed (docs/controller.md, "Operator inputs").
    pub feed_hold: bool,
    pub abort: bool,
    /// Feed-rate override potentiometer installed (docs/controller.md, "Operator inputs").
    pub fro_pot: bool,
    /// ADC full-scale reading (a 12-bit ADC: 4095).
    pub adc_max: u16,
}

/// Limit-switch seek (homing) of one axis (docs/controller.md, "Homing").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct HomingAxis {
    /// Order in the seek: lower goes first, one axis at a time; 0 = the axis is not homed.
    pub priority: u8,
    /// Seek the min switch (else the max switch).
    pub seek_low: bool,
    /// Fast seek speed toward the switch, nm/min (grbl `$25`).
    pub seek_rate: FeedNmPerMin,
    /// Slow locate speed back onto the switch after the pull-off, nm/min (grbl `$24`); at or
    /// below the axis start speed the locate has no ramp and stops on the exact step.
    pub locate_rate: FeedNmPerMin,
    /// Pull-off between seek and locate, and back-off from the switch at the end, at the rapid
    /// rate, nm (grbl `$27`).
    pub retract: Nm,
    /// After the retract, set the axis position to `home_position` (the GIXA controller's "Set Home After Retract").
    pub set_home: bool,
    /// Machine position (nm) the axis gets after the retract.
    pub home_position: Nm,
}

/// Homing: per-axis seek settings and the three command lists.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct HomingSetup {
    pub axes: [HomingAxis; MAX_AXES],
    /// Motion is refused after power-up and after a hard limit until the axes are homed.
    pub required: bool,
    pub before_seek: Vec<ListCommand, MAX_HOMING_COMMANDS>,
    pub before_retract: Vec<ListCommand, MAX_HOMING_COMMANDS>,
    pub after_retract: Vec<ListCommand, MAX_HOMING_COMMANDS>,
}

/// Joystick jog (docs/controller.md, "Jogging").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct JogSetup {
    /// Axis pairs by stage-pair selector position: `[down/up (S1/S4) axis, left/right (S2/S3) axis]`;
    /// 255 = no axis.
    pub pairs: [[u8; 2]; 2],
    /// Constant speed of Instantaneous mode, nm/min (at or below the start speed: no ramp).
    pub instant_speed: FeedNmPerMin,
    /// Distance of one nudge, nm.
    pub nudge_distance: Nm,
    /// Time between nudges while a switch is held, ms (seed: 500).
    pub nudge_interval_ms: u16,
    /// Analog stick: axes driven by ADC channels 0 and 1 (255 = none).
    pub analog_axes: [u8; 2],
    /// ADC reading around the centre that counts as neutral (±).
    pub analog_deadband: u16,
    /// Speed at full deflection, nm/min.
    pub analog_max_speed: FeedNmPerMin,
}

/// Spindle output mapping and user M-code command lists.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct OutputSetup {
    /// S range mapped linearly onto the PWM duty (S ≤ min → duty at min, S ≥ max → full duty).
    pub spindle_min_rpm: u32,
    pub spindle_max_rpm: u32,
    /// PWM duty at `spindle_max_rpm` (the timer's period count).
    pub pwm_max: u16,
    /// PWM duty at `spindle_min_rpm` (0 is allowed).
    pub pwm_min: u16,
    /// Laser mode (grbl `$32`, docs/laser-plasma.md): S travels with each move and sets the
    /// beam's power at the move's first step, M4 scales it with the speed, and the beam is on
    /// only while a G1/G2/G3 runs.
    pub laser: bool,
    /// Plasma torch mode (docs/laser-plasma.md "Plasma"); never with `laser`.
    pub torch: TorchSetup,
    /// Command lists of user M codes.
    pub mcode_lists: Vec<McodeList, MAX_MCODE_LISTS>,
    /// The oriented spindle stop of G76 fine boring.
    pub orient: OrientSetup,
}

/// The oriented spindle stop (`[spindle] orient_*`, docs/settings.md): a user output that tells
/// the drive to orient and an input that says it has, or a fixed time. Without an output G76
/// is refused (E411): the bar would shift away from the wall at an unknown angle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct OrientSetup {
    /// User output (0-15) that commands the orient; [`OrientSetup::NONE`]: no orient.
    pub output: u8,
    /// Input bit (an [`crate::board::inputs::InputBits`] bit) that reads high once the
    /// spindle is oriented; [`OrientSetup::NONE`]: wait `dwell_ms` instead.
    pub done_input: u8,
    /// Without a done input, how long the orient takes; with one, the longest wait for it
    /// (then alarm `ListInputTimeout`; 0 = wait forever).
    pub dwell_ms: u16,
}

impl OrientSetup {
    /// No output (or no done input).
    pub const NONE: u8 = u8::MAX;
    /// No orient: G76 is refused.
    pub(crate) const OFF: OrientSetup = OrientSetup {
        output: Self::NONE,
        done_input: Self::NONE,
        dwell_ms: 0,
    };

    /// True when the machine can orient its spindle.
    pub fn present(&self) -> bool {
        self.output < USER_OUTPUTS
    }

    /// The orient as a command list run at rest: set the output, then wait for the done input
    /// or the dwell. The output stays set until the spindle starts again (`board/outputs/mod.rs`).
    pub(crate) fn commands(&self) -> [ListCommand; 2] {
        [
            ListCommand::Set(self.output),
            if self.done_input == Self::NONE {
                ListCommand::DwellMs(self.dwell_ms)
            } else {
                ListCommand::WaitInput {
                    bit: self.done_input,
                    level: true,
                    timeout_ms: self.dwell_ms,
                }
            },
        ]
    }
}

/// A plasma torch on the spindle enable output (docs/laser-plasma.md "Plasma"): M3 fires it and
/// the motion waits for the arc-OK input; torch height control (THC) moves Z from the up/down
/// inputs while the cut runs at cruise speed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TorchSetup {
    /// Torch mode on.
    pub on: bool,
    /// Longest wait for arc-OK after M3 (or a resume after an arc loss), ms: then alarm 22.
    pub arc_ok_timeout_ms: u16,
    /// Torch height control from the `thc_up`/`thc_down` inputs.
    pub thc: bool,
    /// Z speed of the height control, nm/min.
    pub thc_rate: FeedNmPerMin,
    /// Largest height correction either way, nm.
    pub thc_travel: Nm,
    /// Anti-dive: the correction holds below this percentage of the programmed feed.
    pub thc_anti_dive: u8,
    /// Time after arc-OK before the height control acts (the pierce settles), ms.
    pub thc_delay_ms: u16,
}

impl TorchSetup {
    /// No torch; 3 s arc-OK wait, THC on at 1200 mm/min within ±5 mm, anti-dive 90 %, 500 ms
    /// after the pierce.
    pub const DEFAULT: TorchSetup = TorchSetup {
        on: false,
        arc_ok_timeout_ms: 3000,
        thc: true,
        thc_rate: 1200 * NM_PER_MM,
        thc_travel: 5 * NM_PER_MM,
        thc_anti_dive: 90,
        thc_delay_ms: 500,
    };
}

/// The command list of one user M code.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct McodeList {
    pub code: u16,
    /// The GIXA controller's "Disable these commands for Dry Run".
    pub dry_run_disabled: bool,
    pub commands: Vec<ListCommand, MAX_MCODE_COMMANDS>,
}

/// What the board does when the host link goes quiet (docs/protocol.md §7).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LinkSetup {
    /// A job held because the host went away is ended (program-stop sequence, alarm 20) once the
    /// host has stayed away this many seconds; 0 = hold and wait for the host forever.
    pub host_lost_stop_s: u16,
}

impl McodeList {
    /// The output this list switches on the fly (docs/controller.md, "On-the-fly outputs"): a list of
    /// exactly one `set n` or `clear n` (n < 16) does not stop the motion, its output switches at
    /// the M code's exact place on the path. `None` for any other list (no entry, several, a
    /// dwell or a wait): the motion stops and the list runs at rest.
    pub fn on_the_fly(&self) -> Option<crate::step::output_event::OutputEvent> {
        use crate::step::output_event::OutputEvent;
        match self.commands.as_slice() {
            [ListCommand::Set(n)] => OutputEvent::new(*n, true),
            [ListCommand::Clear(n)] => OutputEvent::new(*n, false),
            _ => None,
        }
    }
}

/// Characters a grbl startup line (`$N0=`, `$N1=`) holds, at most (grbl stores 79; docs/grbl.md).
pub const STARTUP_LINE_LEN: usize = 64;

/// The grbl front end's own stored settings (`machine/src/device/grbl/`, docs/grbl.md): the status
/// report mask `$10`, inch reports `$13` and the two startup lines `$N0`/`$N1`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct GrblSetup {
    /// `$10`: bit 0 machine position (else work position), bit 1 buffer state.
    pub status_mask: u8,
    /// `$13`: report positions and feeds in inches.
    pub inches: bool,
    /// `$N0`, `$N1`: G-code lines run after the banner (power-up, connect, soft reset) when the
    /// machine is not in alarm; empty = none.
    pub startup: [heapless::String<STARTUP_LINE_LEN>; 2],
    /// After `~` closes the safety door with the spindle on, motion waits this long for the
    /// spindle to spin up (`Door:3`, machine/src/device/grbl/door.rs), ms; 0 = no wait
    /// ([`Self::DOOR_SPIN_UP_MS`]).
    pub door_spin_up_ms: u16,
    /// `M6` stops for a manual tool change (`Hold:0`, `~` continues: Gantry's stop), or, when
    /// false, answers grbl 1.1's `error:20` and changes nothing (docs/grbl.md).
    pub m6_stop: bool,
}

impl GrblSetup {
    /// grbl's defaults: machine position in reports, mm, no startup lines, a 4 s spindle spin-up
    /// after the safety door.
    pub const DEFAULT: GrblSetup = GrblSetup {
        status_mask: 1,
        inches: false,
        startup: [heapless::String::new(), heapless::String::new()],
        door_spin_up_ms: 4_000,
        m6_stop: true,
    };

    /// Accepted spin-up waits after the safety door, ms: up to a minute (grbl waits 4 s).
    pub(crate) const DOOR_SPIN_UP_MS: core::ops::RangeInclusive<u16> = 0..=60_000;
}

/// The whole machine setup.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Setup {
    /// Axes in use (X, Y, Z, A, B, C in that order), 1..=6.
    pub axis_count: u8,
    pub axes: [AxisSetup; MAX_AXES],
    pub path: PathSetup,
    pub program: ProgramSetup,
    pub operator: OperatorSetup,
    pub inputs: InputSetup,
    pub homing: HomingSetup,
    pub jog: JogSetup,
    pub outputs: OutputSetup,
    pub link: LinkSetup,
    pub drivers: DriverSetup,
    pub grbl: GrblSetup,
}

const fn nm_of_mm(v: i64) -> Nm {
    v * NM_PER_MM
}

impl AxisSetup {
    /// A typical router axis: 3200 steps per 5 mm lead screw, 3000 mm/min, 200 mm/s², travel
    /// ±`travel_mm` around the power-up position (which is machine zero until the axis is homed).
    pub(crate) const fn default_linear(travel_mm: i64) -> Self {
        AxisSetup {
            steps: 3200,
            units_nm: nm_of_mm(5),
            max_rate: nm_of_mm(3000),
            accel: nm_of_mm(200),
            jerk: 0,
            start_speed: nm_of_mm(60),
            travel_min: -nm_of_mm(travel_mm),
            travel_max: nm_of_mm(travel_mm),
            invert_dir: false,
        }
    }
}

impl Default for Setup {
    fn default() -> Self {
        let mut axes = [AxisSetup::default_linear(300); MAX_AXES];
        axes[1] = AxisSetup::default_linear(200);
        axes[2] = AxisSetup::default_linear(100);
        Setup {
            axis_count: 3,
            axes,
            path: PathSetup {
                junction_deviation: 10_000,
                feed_shift: nm_of_mm(60),
                chord_tolerance: 2_000,
                arc_segment_angle_mdeg: 0,
                arc_max_segments: 0,
                blend_tolerance: 0,
            },
            program: ProgramSetup {
                dialect: Dialect::Rs274,
                dwell_units: DwellUnits::Seconds,
                peck_clearance: 254_000,
                chip_break_retract: 254_000,
                default_retract: crate::gcode::RetractMode::InitialLevel,
                tools: Vec::new(),
                work_offsets: [[0; MAX_AXES]; WORK_SYSTEMS],
                g28_home: [0; MAX_AXES],
                g30_home: [0; MAX_AXES],
                user_mcodes: Vec::new(),
                tool_change_position: ToolChangePosition::default(),
            },
            operator: OperatorSetup {
                resume_needs_cycle_start: false,
                two_hand_start: false,
                fro_low: 10,
                fro_high: 200,
                dry_run_feed: nm_of_mm(2000),
            },
            inputs: InputSetup {
                invert: 0,
                debounce_ms: 5,
                limit_min: 0,
                limit_max: 0,
                hard_limits: true,
                feed_hold: true,
                abort: true,
                fro_pot: false,
                adc_max: 4095,
            },
            homing: HomingSetup {
                axes: [HomingAxis {
                    priority: 0,
                    seek_low: true,
                    seek_rate: nm_of_mm(2000),
                    locate_rate: nm_of_mm(60),
                    retract: nm_of_mm(2),
                    set_home: true,
                    home_position: 0,
                }; MAX_AXES],
                required: false,
                before_seek: Vec::new(),
                before_retract: Vec::new(),
                after_retract: Vec::new(),
            },
            jog: JogSetup {
                pairs: [[1, 0], [2, 255]],
                instant_speed: nm_of_mm(60),
                nudge_distance: 10_000,
                nudge_interval_ms: 500,
                analog_axes: [0, 1],
                analog_deadband: 100,
                analog_max_speed: nm_of_mm(1000),
            },
            outputs: OutputSetup {
                spindle_min_rpm: 0,
                spindle_max_rpm: 24_000,
                pwm_max: 1000,
                pwm_min: 0,
                laser: false,
                torch: TorchSetup::DEFAULT,
                mcode_lists: Vec::new(),
                orient: OrientSetup::OFF,
            },
            link: LinkSetup {
                host_lost_stop_s: 60,
            },
            drivers: DriverSetup::DEFAULT,
            grbl: GrblSetup::DEFAULT,
        }
    }
}

impl Setup {
    /// The interpreter's part of the setup.
    pub fn interp_config(&self) -> crate::gcode::InterpConfig {
        let p = &self.program;
        let mut c = match p.dialect {
            Dialect::Rs274 => crate::gcode::InterpConfig::default(),
            Dialect::Gixa => crate::gcode::InterpConfig::gixa(),
        };
        c.axis_count = self.axis_count;
        c.dwell_units = p.dwell_units;
        c.peck_clearance = p.peck_clearance;
        c.gixa.partial_retract = p.chip_break_retract;
        c.default_retract = p.default_retract;
        c.work_offsets = p.work_offsets;
        c.g28_position = p.g28_home;
        c.g30_position = p.g30_home;
        c.tool_change_position = p.tool_change_position;
        c.spindle_orient = self.outputs.orient.present();
        for (slot, tool) in c.tools.iter_mut().zip(&p.tools) {
            *slot = *tool;
        }
        for &code in &p.user_mcodes {
            c.add_user_m_code(code);
        }
        c
    }
}

/// Largest encoded setup (bytes): the flash record and the link transfer are sized for it.
pub const SETUP_BLOB_MAX: usize = 2048;

impl Setup {
    /// Encodes the setup for flash and the link ([`blob`]); `None` if it does not fit `out`.
    pub fn to_blob<'a>(&self, out: &'a mut [u8]) -> Option<&'a mut [u8]> {
        let len = blob::encode(self, out, 0, false)?;
        out.get_mut(..len)
    }

    /// Encodes bytes `from .. from + out.len()` of the blob into `out` (a chunk for the link,
    /// without a buffer for the whole blob); returns how many it wrote (fewer at the end).
    pub fn blob_window(&self, from: usize, out: &mut [u8]) -> usize {
        let room = out.len();
        blob::encode(self, out, from, true)
            .unwrap_or(0)
            .saturating_sub(from)
            .min(room)
    }

    /// Decodes and checks a setup blob; `None` when it is not a valid setup (another format
    /// byte included: a setup stored by older firmware).
    pub fn from_blob(bytes: &[u8]) -> Option<Setup> {
        blob::decode(bytes).filter(Setup::is_valid)
    }

    /// [`Self::validate`] passes: the invariants every part of the core relies on (the board's
    /// last line of defence against a corrupt or foreign blob; the host and grbl `$x=` refuse
    /// with the same check's [`SetupError`]).
    pub fn is_valid(&self) -> bool {
        self.validate().is_ok()
    }

    /// Axis `a` (one of [`Self::axes`]) at its max rate leaves every step period long enough for the step pulse of
    /// [`Self::drivers`], the pin low as long again and the step interrupt's writes
    /// ([`StepTiming::min_period`]); else the step interrupt would stretch the periods and the
    /// machine would run slower than planned. The dir set-up is not part of it: only the period
    /// before a direction change holds it ([`StepTiming::period`]), a few µs per reversal.
    /// Exact: `max_rate · steps / (units · 60)` steps/s times the period in timer counts must not
    /// exceed the timer's counts per second (compared multiplied out, no rounding).
    pub(crate) fn step_rate_fits(&self, a: &AxisSetup) -> bool {
        let period = StepTiming::from_setup(&self.drivers).min_period;
        let need = a.max_rate.max(0) as u128 * u128::from(a.steps) * u128::from(period);
        let have = a.units_nm.max(1) as u128 * 60 * u128::from(KERNEL_TIMER_HZ);
        need <= have
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    #[test]
    fn a_full_setup_fits_the_blob_and_round_trips() {
        let mut s = Setup {
            axis_count: 6,
            ..Default::default()
        };
        for i in 0..MAX_TOOLS {
            s.program
                .tools
                .push(Tool {
                    number: 1000 + i as u32,
                    length: -123_456_789,
                    diameter: 25_400_000,
                })
                .unwrap();
        }
        for i in 0..MAX_USER_MCODES {
            s.program.user_mcodes.push(100 + i as u16).unwrap();
        }
        s.program.work_offsets = [[-1_000_000_000; MAX_AXES]; WORK_SYSTEMS];
        s.program.tool_change_position = ToolChangePosition {
            axes: 0b11_1111,
            at: [-1_000_000_000, 2, -3, 4, i64::MAX, i64::MIN],
        };
        let wait = ListCommand::WaitInput {
            bit: 31,
            level: true,
            timeout_ms: 60_000,
        };
        for _ in 0..MAX_HOMING_COMMANDS {
            s.homing.before_seek.push(wait).unwrap();
            s.homing.before_retract.push(wait).unwrap();
            s.homing.after_retract.push(wait).unwrap();
        }
        for i in 0..MAX_MCODE_LISTS {
            let mut l = McodeList {
                code: 100 + i as u16,
                dry_run_disabled: true,
                commands: Vec::new(),
            };
            for _ in 0..MAX_MCODE_COMMANDS {
                l.commands.push(wait).unwrap();
            }
            s.outputs.mcode_lists.push(l).unwrap();
        }
        s.drivers = DriverSetup {
            step_pulse_ns: 1_900,
            dir_setup_ns: 650,
        };
        s.jog.pairs = [[255, 255], [255, 255]];
        s.inputs.invert = u32::MAX;
        s.grbl.status_mask = 3;
        s.grbl.inches = true;
        for line in &mut s.grbl.startup {
            while line.push('G').is_ok() {}
        }
        let mut buf = [0u8; SETUP_BLOB_MAX];
        let blob = s.to_blob(&mut buf).expect("fits");
        // Room to spare for settings still to come (1,548 B with both grbl startup lines full).
        assert!(blob.len() < SETUP_BLOB_MAX * 4 / 5, "{} bytes", blob.len());
        assert_eq!(Setup::from_blob(blob), Some(s.clone()));
        // Every list command kind survives.
        let kinds = [
            ListCommand::Set(15),
            ListCommand::Clear(3),
            ListCommand::DwellMs(65_535),
            ListCommand::WaitInput {
                bit: 7,
                level: false,
                timeout_ms: 0,
            },
            ListCommand::DisableLimitReport,
            ListCommand::Seek,
        ];
        s.outputs.mcode_lists[0].commands = Vec::from_slice(&kinds).unwrap();
        let blob = s.to_blob(&mut buf).expect("fits");
        assert_eq!(Setup::from_blob(blob), Some(s));
    }

    #[test]
    fn the_interpreter_gets_the_setup_tools_as_stored() {
        let mut s = Setup::default();
        let t = Tool {
            number: 7,
            length: -1_500_000,
            diameter: 6_000_000,
        };
        s.program.tools.push(t).unwrap();
        let c = s.interp_config();
        assert_eq!(c.tool(7), Some(t));
        assert_eq!(c.tools[1], Tool::default());
        // The blob's tool bytes: number, length, diameter as postcard varints (zigzag for the
        // signed ones), as the setup's own `Tool` stored them before it became the interpreter's.
        let mut buf = [0u8; 16];
        let bytes = postcard::to_slice(&t, &mut buf).unwrap();
        assert_eq!(
            bytes,
            [0x07, 0xbf, 0x8d, 0xb7, 0x01, 0x80, 0xb6, 0xdc, 0x05]
        );
    }

    #[test]
    fn windows_of_the_blob_put_together_are_the_blob() {
        let mut s = Setup::default();
        s.program.user_mcodes.push(1234).unwrap();
        let mut buf = [0u8; SETUP_BLOB_MAX];
        let blob = s.to_blob(&mut buf).unwrap().to_vec();
        for size in [1, 7, 64, blob.len() + 5] {
            let mut joined = std::vec::Vec::new();
            let mut chunk = std::vec![0u8; size];
            while joined.len() < blob.len() {
                let n = s.blob_window(joined.len(), &mut chunk);
                assert!(n > 0 && n <= size);
                joined.extend_from_slice(&chunk[..n]);
            }
            assert_eq!(joined, blob, "chunks of {size}");
            assert_eq!(s.blob_window(blob.len(), &mut chunk), 0);
        }
    }

    #[test]
    fn damaged_blobs_are_refused() {
        let mut buf = [0u8; SETUP_BLOB_MAX];
        let len = Setup::default().to_blob(&mut buf).unwrap().len();
        let blob = &buf[..len];
        assert_eq!(Setup::from_blob(blob), Some(Setup::default()));
        // Every truncation, and a trailing byte.
        for n in 0..len {
            assert_eq!(Setup::from_blob(&blob[..n]), None, "{n} bytes");
        }
        let mut longer = blob.to_vec();
        longer.push(0);
        assert_eq!(Setup::from_blob(&longer), None);
        // Another format version.
        let mut other = blob.to_vec();
        other[0] = blob::FORMAT + 1;
        assert_eq!(Setup::from_blob(&other), None);
        // An unknown enum variant: the one byte where the Ngc and Gixa dialects differ.
        let mut gixa = Setup::default();
        gixa.program.dialect = Dialect::Gixa;
        let mut other_buf = [0u8; SETUP_BLOB_MAX];
        let gixa_blob = gixa.to_blob(&mut other_buf).unwrap();
        let diff: std::vec::Vec<usize> = (0..len).filter(|&i| blob[i] != gixa_blob[i]).collect();
        assert_eq!(diff.len(), 1);
        let mut unknown = blob.to_vec();
        unknown[diff[0]] = 2;
        assert_eq!(Setup::from_blob(&unknown), None);
        // A value beyond its field: a bool as 2 (`axes[0].invert_dir`, the byte before axis 1's
        // `steps`, 3200 = varint 0x80 0x19; axis 0 starts with the same bytes at offset 2).
        let axis1 = (3..len)
            .find(|&i| blob[i..].starts_with(&[0x80, 0x19]))
            .unwrap();
        assert_eq!(blob[axis1 - 1], 0, "invert_dir false");
        let mut wide = blob.to_vec();
        wide[axis1 - 1] = 2;
        assert_eq!(Setup::from_blob(&wide), None);
        wide[axis1 - 1] = 1;
        assert!(Setup::from_blob(&wide).unwrap().axes[0].invert_dir);
        // An encoder given too little room says so.
        assert!(Setup::default().to_blob(&mut buf[..len - 1]).is_none());
    }

    #[test]
    fn driver_timing_is_checked_against_every_axis_max_rate() {
        let mut s = Setup::default();
        assert!(s.is_valid());
        s.drivers.step_pulse_ns = 999;
        assert!(!s.is_valid());
        s.drivers.step_pulse_ns = 50_001;
        assert!(!s.is_valid());
        s.drivers = DriverSetup {
            step_pulse_ns: 50_000,
            dir_setup_ns: 50_001,
        };
        assert!(!s.is_valid());
        // 3200 steps per 5 mm at 3000 mm/min: 32 000 steps/s, a 375-count (31.25 µs) period.
        // Pulse and low time of 188 counts each: 376; the dir set-up does not count.
        s.drivers = DriverSetup {
            step_pulse_ns: 15_584,
            dir_setup_ns: 50_000,
        };
        assert_eq!(StepTiming::from_setup(&s.drivers).min_period, 376);
        assert!(!s.step_rate_fits(&s.axes[0]));
        assert!(!s.is_valid());
        s.drivers.step_pulse_ns = 15_583; // 187 counts: a 374-count period fits
        assert!(s.step_rate_fits(&s.axes[0]));
        assert!(s.is_valid());
        // Axes beyond axis_count do not count.
        s.axes[5].max_rate *= 10;
        assert!(s.is_valid());
        s.axis_count = 6;
        assert!(!s.is_valid());
    }

    #[test]
    fn invalid_blobs_are_refused() {
        let mut buf = [0u8; SETUP_BLOB_MAX];
        let mut s = Setup::default();
        s.axes[0].steps = 0;
        let blob = s.to_blob(&mut buf).unwrap();
        assert_eq!(Setup::from_blob(blob), None);
        assert_eq!(Setup::from_blob(&[1, 2, 3]), None);
    }
}
