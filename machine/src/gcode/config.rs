//! Interpreter setup: dialect, tool table, offsets at start, home positions, switches, user M codes.
//!
//! Everything is fixed size (no heap) so the setup can live in flash on the board and be sent by the
//! host as one message.

use crate::canon::Plane;
use crate::units::{Nm, Pos, MAX_AXES};
use serde::{Deserialize, Serialize};

/// Which G-code dialect to interpret (also the setup's `program.dialect`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Dialect {
    /// RS274NGC / Fanuc mill programs as CAM posts emit them (LinuxCNC is the oracle).
    Rs274,
    /// Ability Systems "G Code Controller" (GIXA) programs (docs/controller.md).
    Gixa,
}

/// How a G4 P (or canned-cycle P) number is read (also the setup's `program.dwell_units`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum DwellUnits {
    /// P is seconds, with or without a decimal point (LinuxCNC).
    Seconds,
    /// Fanuc: an integer P is milliseconds, a P with a decimal point is seconds.
    FanucIntegerMillis,
}

/// Where a canned cycle retracts between holes when the program sets neither G98 nor G99.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum RetractMode {
    /// G98: back to the initial level (the level before the first cycle block), or R if higher.
    InitialLevel,
    /// G99: to the R plane (LinuxCNC's power-up mode).
    RPlane,
}

/// How gixa reads I/J arc centres (Job › Arc Translation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArcCenterMode {
    /// Relative to the arc start (recommended by GIXA, and the default).
    Incremental,
    /// Absolute program coordinates.
    Absolute,
    /// Follows G90/G91.
    FollowsDistanceMode,
}

/// One tool-table entry: the interpreter's table and the setup's `program.tools` (stored in flash
/// as postcard, fields in this order) are this one type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Tool {
    /// Tool number (T and H words). 0 marks an unused slot.
    pub number: u32,
    /// Tool length offset along Z in nm (added to Z by G43).
    pub length: Nm,
    /// Cutter diameter in nm (for cutter compensation and the tool-table parameters).
    pub diameter: Nm,
}

/// Where `M6` takes the tool before it stops for the change (docs/probing.md "Tool change"):
/// the axes whose bit is set in `axes` (bit i = axis i, X = bit 0) go to `at` in machine
/// coordinates at rapid, Z first. `axes == 0` (the default): `M6` stops where it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct ToolChangePosition {
    pub axes: u8,
    pub at: Pos,
}

/// Tool-table size.
pub const MAX_TOOLS: usize = 32;
/// User M-code list size.
pub(crate) const MAX_USER_M_CODES: usize = 32;
/// Number of work coordinate systems: G54..G59, G59.1..G59.3.
pub(crate) const WORK_SYSTEMS: usize = 9;

/// Gixa-only setup fields (Job setup).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GixaSetup {
    /// I/J centre interpretation.
    pub arc_centers: ArcCenterMode,
    /// G87 chip-break partial retract distance in nm.
    pub partial_retract: Nm,
    /// Plane at job start.
    pub plane: Plane,
    /// Distance mode at job start: `true` = G90.
    pub absolute: bool,
    /// Default F (Job Vector Speed) in nm/min, restored by M30.
    pub default_feed: i64,
}

impl Default for GixaSetup {
    fn default() -> Self {
        GixaSetup {
            arc_centers: ArcCenterMode::Incremental,
            partial_retract: 254_000,
            plane: Plane::XY,
            absolute: true,
            default_feed: 0,
        }
    }
}

/// What an arc's centre offset word for the axis normal to its plane (`K` on a G17 arc, `J` on
/// G18, `I` on G19) does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OffPlaneOffset {
    /// Refused (E304), as LinuxCNC refuses it: the word means nothing on that plane.
    #[default]
    Refused,
    /// Ignored, as grbl ignores it (its parser clears I, J and K once it has read the plane's
    /// two): FreeCAD's grbl post writes `K0.000` on every G17 arc. The grbl front end's jobs.
    Ignored,
}

/// The interpreter's setup.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InterpConfig {
    pub dialect: Dialect,
    /// Axes present (3 = XYZ, up to 6 = XYZABC). Words for absent axes are errors.
    pub axis_count: u8,
    /// Tool table (unused slots have number 0).
    pub tools: [Tool; MAX_TOOLS],
    /// Work offsets G54..G59.3 in machine nm at program start.
    pub work_offsets: [Pos; WORK_SYSTEMS],
    /// G28 and G30 positions (machine coordinates).
    pub g28_position: Pos,
    pub g30_position: Pos,
    /// Where `M6` moves before the tool change (none by default).
    pub tool_change_position: ToolChangePosition,
    /// Reading of G4 P.
    pub dwell_units: DwellUnits,
    /// G73/G83 retract clearance in nm (LinuxCNC's G83 "rapid delta"); default 0.254 mm.
    pub peck_clearance: Nm,
    /// Block delete switch: `/` blocks are skipped when on.
    pub block_delete: bool,
    /// Optional stop switch: M1 stops when on.
    pub optional_stop: bool,
    /// User M codes (0 = unused slot); each becomes [`crate::canon::Action::UserMCode`].
    pub user_m_codes: [u16; MAX_USER_M_CODES],
    /// Start in inch mode (G20).
    pub start_inch: bool,
    /// Retract mode at program start and after M2/M30 (G98 unless the setup says G99).
    pub default_retract: RetractMode,
    /// Gixa job setup (ignored by the RS274 dialect).
    pub gixa: GixaSetup,
    /// An arc's off-plane centre word (RS274 dialect).
    pub off_plane_offset: OffPlaneOffset,
    /// The machine has an oriented spindle stop (the setup's `spindle.orient_output`): G76
    /// fine boring runs; without it G76 is E411.
    pub spindle_orient: bool,
}

impl Default for InterpConfig {
    fn default() -> Self {
        InterpConfig {
            dialect: Dialect::Rs274,
            axis_count: MAX_AXES as u8,
            tools: [Tool::default(); MAX_TOOLS],
            work_offsets: [[0; MAX_AXES]; WORK_SYSTEMS],
            g28_position: [0; MAX_AXES],
            g30_position: [0; MAX_AXES],
            tool_change_position: ToolChangePosition::default(),
            dwell_units: DwellUnits::Seconds,
            peck_clearance: 254_000,
            block_delete: false,
            optional_stop: false,
            user_m_codes: [0; MAX_USER_M_CODES],
            start_inch: false,
            default_retract: RetractMode::InitialLevel,
            gixa: GixaSetup::default(),
            off_plane_offset: OffPlaneOffset::Refused,
            spindle_orient: false,
        }
    }
}

impl InterpConfig {
    /// The default setup of the gixa dialect (M10 punch list registered as a user M code).
    pub fn gixa() -> Self {
        let mut c = InterpConfig {
            dialect: Dialect::Gixa,
            ..InterpConfig::default()
        };
        c.user_m_codes[0] = 10;
        c
    }

    /// True if `code` is one of the setup's user M codes.
    pub(crate) fn is_user_m_code(&self, code: u16) -> bool {
        code != 0 && self.user_m_codes.contains(&code)
    }

    /// Adds a user M code; false if the list is full.
    pub fn add_user_m_code(&mut self, code: u16) -> bool {
        if self.is_user_m_code(code) {
            return true;
        }
        match self.user_m_codes.iter_mut().find(|c| **c == 0) {
            Some(slot) => {
                *slot = code;
                true
            }
            None => false,
        }
    }

    /// Adds a tool or sets the length of one already in the table (its diameter stays; a new tool
    /// has diameter 0); false if the table is full.
    pub fn set_tool(&mut self, number: u32, length: Nm) -> bool {
        if number == 0 {
            return false;
        }
        if let Some(t) = self.tools.iter_mut().find(|t| t.number == number) {
            t.length = length;
            return true;
        }
        match self.tools.iter_mut().find(|t| t.number == 0) {
            Some(t) => {
                *t = Tool {
                    number,
                    length,
                    diameter: 0,
                };
                true
            }
            None => false,
        }
    }

    /// Looks a tool up.
    pub fn tool(&self, number: u32) -> Option<Tool> {
        self.tools
            .iter()
            .copied()
            .find(|t| t.number == number && number != 0)
    }
}
