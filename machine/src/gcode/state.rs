//! Modal state: everything a block leaves behind for the next one (modes, offsets, position).
//!
//! The state is `Copy`, so the interpreter can snapshot it before a block and restore it when the
//! block fails: a bad block leaves no trace. Positions are machine nanometres; the program
//! (work) coordinate of an axis is `machine - work offset - G92 offset - tool offset`.

use super::config::{InterpConfig, WORK_SYSTEMS};
use super::transform::Transform;
use crate::canon::{PathMode, Plane, Spindle};
use crate::units::{Nm, Pos, MAX_AXES};

/// Motion mode (G-code group 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MotionMode {
    /// G0.
    Rapid,
    /// G1.
    Linear,
    /// G2.
    ArcCw,
    /// G3.
    ArcCcw,
    /// G80: no motion mode.
    None,
    /// G73, G81..G89 (the code in tenths, e.g. 810).
    Cycle(u16),
    /// G38.2..G38.5 (the code in tenths, e.g. 382).
    Probe(u16),
    /// G5 cubic / G5.1 quadratic spline (the code in tenths: 50, 51).
    Spline(u16),
}

/// Data a canned cycle remembers between blocks (cleared by G80 and motion codes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct CycleMemory {
    /// R as programmed (absolute program value, or increment in G91), nm.
    pub r: Option<Nm>,
    /// Depth word as programmed, nm.
    pub depth: Option<Nm>,
    /// Q peck, nm.
    pub q: Option<Nm>,
    /// Dwell in microseconds (P).
    pub dwell_us: Option<u64>,
    /// Initial level (program coordinate on the drilling axis), latched by the first cycle block.
    pub initial_level: Option<Nm>,
    /// G87 I, J, K as programmed, indexed by axis (X, Y, Z), nm.
    pub back_bore: Option<[Nm; 3]>,
}

/// The modal state of the interpreter: its [`Modes`] (read and written through `Deref`, so
/// `state.feed` names `state.modes.feed`) and the offset tables.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ModalState {
    /// Every field but the offset tables, in one struct so that a block's undo record
    /// ([`Rollback::Modes`]) is one copy (field-by-field it cost ~165 Cortex-M4 instructions a
    /// line, target-tests/src/bin/bench_motion.rs).
    pub modes: Modes,
    /// Work offsets G54..G59.3, machine nm.
    pub work_offsets: [Pos; WORK_SYSTEMS],
    /// G92 offset in force, and the saved value G92.3 restores.
    pub g92: Pos,
    pub g92_saved: Pos,
    /// Tool length offset (G43 H / G43.1).
    pub tool_offset: Pos,
    pub g28: Pos,
    pub g30: Pos,
    /// Mirror, scaling, rotation and polar mode (docs/gcode-transforms.md).
    pub xf: Transform,
}

/// Every field of [`ModalState`] but the offset tables (work offsets, G92 and its saved value,
/// tool offset, G28/G30 positions).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Modes {
    pub motion: MotionMode,
    /// Motion mode before the current cycle (gixa G80 restores it).
    pub motion_before_cycle: MotionMode,
    pub plane: Plane,
    /// G90 (true) / G91.
    pub absolute: bool,
    /// G90.1 (true) / G91.1: I/J/K absolute.
    pub arc_absolute: bool,
    /// G93 (true) / G94.
    pub inverse_time: bool,
    /// G20 (true) / G21.
    pub inch: bool,
    /// Active work system 0..8 = G54..G59.3.
    pub work_system: u8,
    pub path: PathMode,
    /// G99 (true) / G98.
    pub retract_to_r: bool,
    /// Feed in nm/min (or 1e-6 deg/min for rotary-only moves); in G93 the inverse-time value ×10^6.
    pub feed: i64,
    /// F in program units ×10^6 as last written (rotary-only moves use it directly).
    pub feed_raw: i64,
    pub spindle: Spindle,
    pub rpm: u32,
    pub mist: bool,
    pub flood: bool,
    /// Selected tool (T) and tool in the spindle (after M6).
    pub tool_selected: u32,
    pub tool_loaded: u32,
    /// Current machine position, nm.
    pub position: Pos,
    pub cycle: CycleMemory,
    /// gixa: dwell stored by G04 P, microseconds.
    pub stored_dwell_us: u64,
    /// Under a transform: the program point (X, Y, Z before the transforms) of the position,
    /// valid while the position's work point is still `xf_at` (docs/gcode-transforms.md).
    pub xf_prog: [Nm; 3],
    pub xf_at: [Nm; 3],
}

impl core::ops::Deref for ModalState {
    type Target = Modes;
    #[inline(always)]
    fn deref(&self) -> &Modes {
        &self.modes
    }
}

impl core::ops::DerefMut for ModalState {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut Modes {
        &mut self.modes
    }
}

/// What a failing block must give back (machine/src/gcode/interp/mod.rs, `Interpreter::next`): the
/// whole state, or only its modes and position when the block cannot touch the offset tables.
/// Copying the 904-byte state before every line was the largest single cost of a short line
/// (target-tests/src/bin/bench_motion.rs). It lives on the stack for one block (no heap to box
/// the large variant into; only the variant in use is written).
#[allow(clippy::large_enum_variant)]
pub(crate) enum Rollback {
    Whole(ModalState),
    Modes(Modes),
}

impl Rollback {
    /// The undo record for a block: `tables` is true when the block has a code that can write
    /// the work offsets, G92, G28/G30 positions or the tool offset (a non-modal G code such as
    /// G10, G28.1, G30.1, G92.x or G65; G43/G49; or an M code, M2/M30 clearing G92).
    pub fn of(state: &ModalState, tables: bool) -> Self {
        if tables {
            Rollback::Whole(*state)
        } else {
            Rollback::Modes(state.modes)
        }
    }

    /// Puts the saved fields back.
    pub fn restore(&self, state: &mut ModalState) {
        match self {
            Rollback::Whole(saved) => *state = *saved,
            Rollback::Modes(modes) => state.modes = *modes,
        }
    }
}

impl ModalState {
    /// The power-up state for a setup.
    pub fn new(config: &InterpConfig) -> Self {
        let gixa = config.dialect == super::config::Dialect::Gixa;
        ModalState {
            modes: Modes {
                motion: MotionMode::Rapid,
                motion_before_cycle: MotionMode::Rapid,
                plane: if gixa { config.gixa.plane } else { Plane::XY },
                absolute: if gixa { config.gixa.absolute } else { true },
                arc_absolute: false,
                inverse_time: false,
                inch: config.start_inch,
                work_system: 0,
                path: PathMode::Blend { tolerance: 0 },
                retract_to_r: config.default_retract == super::config::RetractMode::RPlane,
                feed: if gixa { config.gixa.default_feed } else { 0 },
                feed_raw: 0,
                spindle: Spindle::Off,
                rpm: 0,
                mist: false,
                flood: false,
                tool_selected: 0,
                tool_loaded: 0,
                position: [0; MAX_AXES],
                cycle: CycleMemory::default(),
                stored_dwell_us: 0,
                xf_prog: [0; 3],
                xf_at: [0; 3],
            },
            work_offsets: config.work_offsets,
            g92: [0; MAX_AXES],
            g92_saved: [0; MAX_AXES],
            tool_offset: [0; MAX_AXES],
            g28: config.g28_position,
            g30: config.g30_position,
            xf: Transform::OFF,
        }
    }

    /// Total offset from program to machine coordinates on every axis.
    pub fn offset(&self) -> Pos {
        core::array::from_fn(|i| self.axis_offset(i))
    }

    /// Total offset from program to machine coordinates on axis `axis` (a line's move needs
    /// only its written axes: building the whole [`ModalState::offset`] cost ~250 Cortex-M4
    /// instructions a line, target-tests/src/bin/bench_motion.rs).
    #[inline]
    pub(crate) fn axis_offset(&self, axis: usize) -> Nm {
        self.work_offsets[self.work_system as usize][axis] + self.g92[axis] + self.tool_offset[axis]
    }

    /// The current position in program (work) coordinates.
    pub fn program_position(&self) -> Pos {
        let o = self.offset();
        let mut p = self.position;
        for (v, off) in p.iter_mut().zip(o) {
            *v -= off;
        }
        p
    }

    /// The program point of the current position: the work point before the transforms (X, Y,
    /// Z), the work point itself on the other axes and when no transform is in force.
    pub(crate) fn program_point(&self) -> Pos {
        let mut p = self.program_position();
        if self.xf.active() {
            let w = [p[0], p[1], p[2]];
            let q = if w == self.xf_at {
                self.xf_prog
            } else {
                self.xf.inverse(w)
            };
            p[..3].copy_from_slice(&q);
        }
        p
    }

    /// Program coordinates to machine coordinates.
    pub fn to_machine(&self, program: Pos) -> Pos {
        let o = self.offset();
        let mut p = program;
        for (v, off) in p.iter_mut().zip(o) {
            *v += off;
        }
        p
    }

    /// Resets what M2/M30 reset (Fanuc/LinuxCNC): G54, G17, G90, G94, G80 → G0, the setup's
    /// retract mode (G98 by default), M5, M9, G50.1 G50 G69 G15, G92
    /// offsets off (saved values kept). Units, tool offset and path mode survive.
    pub(crate) fn reset_at_program_end(&mut self, config: &InterpConfig) {
        let fresh = ModalState::new(config);
        self.motion = MotionMode::Rapid;
        self.motion_before_cycle = MotionMode::Rapid;
        self.plane = fresh.plane;
        self.absolute = fresh.absolute;
        self.arc_absolute = false;
        self.inverse_time = false;
        self.work_system = 0;
        self.retract_to_r = fresh.retract_to_r;
        self.spindle = Spindle::Off;
        self.mist = false;
        self.flood = false;
        self.g92 = [0; MAX_AXES];
        self.xf = Transform::OFF;
        self.cycle = CycleMemory::default();
        if config.dialect == super::config::Dialect::Gixa {
            self.feed = config.gixa.default_feed;
        }
    }
}
