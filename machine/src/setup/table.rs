//! The one table of setup settings: every key of the setup file with its section, unit, range
//! (in the core's integer units), grbl `$` number, getter ([`Key::value`]), setter ([`Key::set`]),
//! reference text and file comment. The setup file's reader and writer
//! (host-sender/src/setup_file.rs: two walks over the rows), [`super::Setup::validate`], the grbl
//! `$$` listing (machine/src/device/grbl/settings.rs) and docs/settings.md
//! (host-sender/src/settings_doc.rs) are all derived from it; docs/architecture.md, "How to add a
//! setting", walks through a new row.
//!
//! [`ROWS`] is what the board needs (ranges, grbl numbers); [`TEXT`] holds the names, doc text and
//! file comments, and [`Key::set`] writes a value: only host code reads or calls them, so the
//! firmware's linker drops them (scripts/fwsize.sh measures the same flash with and without).

use super::{AxisSetup, HomingAxis, Setup};
use crate::gcode::{Dialect, DwellUnits, RetractMode, Tool};

/// Where a row's key lives in the setup file, and how many times it repeats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Section {
    Top,
    /// `[axis.X]`: once per axis in use.
    Axis,
    Path,
    Program,
    /// `[[tool]]`: once per tool.
    Tool,
    Operator,
    Inputs,
    Homing,
    /// `[homing.axis.X]`: once per axis in use.
    HomingAxis,
    Jog,
    Spindle,
    /// `[[mcode]]`: once per list.
    Mcode,
    Link,
    Drivers,
    Grbl,
}

/// Sections in docs/settings.md order.
pub const SECTIONS: [Section; 15] = [
    Section::Top,
    Section::Axis,
    Section::Path,
    Section::Program,
    Section::Tool,
    Section::Operator,
    Section::Inputs,
    Section::Homing,
    Section::HomingAxis,
    Section::Jog,
    Section::Spindle,
    Section::Mcode,
    Section::Link,
    Section::Drivers,
    Section::Grbl,
];

impl Section {
    /// How many times the section's rows apply to `s` (axes in use, tools; 1 otherwise).
    pub fn count(self, s: &Setup) -> usize {
        match self {
            Section::Axis | Section::HomingAxis => {
                usize::from(s.axis_count).min(crate::units::MAX_AXES)
            }
            Section::Tool => s.program.tools.len(),
            Section::Mcode => s.outputs.mcode_lists.len(),
            _ => 1,
        }
    }
}

/// How a row's integer value reads in the setup file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    /// nm in the core, mm (degrees on A/B/C) in the file.
    Mm,
    /// nm/min, mm/min.
    MmPerMin,
    /// nm/s², mm/s².
    MmPerS2,
    /// nm/s³, mm/s³.
    MmPerS3,
    /// ns, µs.
    Us,
    /// ms, s.
    S,
    /// ms, ms.
    Ms,
    /// s, s.
    Seconds,
    /// millidegrees, degrees.
    Degrees,
    Percent,
    Rpm,
    /// A plain count (steps, ADC counts, timer counts, a priority, a mask).
    Count,
    Bool,
    /// An index into the row's [`RowText::choices`].
    Choice,
    /// A mask of axes in use, axis letters in the file (`["X", "Z"]`).
    AxisMask,
    /// A mask of input bits, input names in the file (`["x_min", "in30"]`).
    InputMask,
    /// Two axis indices (`a | b << 8`, 255: none), `["Y", "-"]` in the file.
    AxisPair,
    /// An input bit, its name in the file; [`super::OrientSetup::NONE`]: none, not written.
    Input,
    /// A user output (0-15), as in `set N`; [`super::OrientSetup::NONE`]: none, not written.
    Output,
    /// What the host reads with a codec of its own (the axes in use, M codes, positions, list
    /// commands, startup lines); no range here.
    Text,
}

impl Unit {
    /// Core units per file unit.
    pub const fn scale(self) -> i64 {
        match self {
            Unit::Mm | Unit::MmPerMin | Unit::MmPerS2 | Unit::MmPerS3 => 1_000_000,
            Unit::Us | Unit::S | Unit::Degrees => 1_000,
            _ => 1,
        }
    }

    /// Text after a value in messages and docs (lengths and speeds go without: the file's
    /// header says mm, mm/min, mm/s²).
    pub const fn suffix(self) -> &'static str {
        match self {
            Unit::Us => " µs",
            Unit::S | Unit::Seconds => " s",
            Unit::Degrees => " degrees",
            Unit::MmPerS3 => " mm/s³",
            Unit::Percent => " %",
            _ => "",
        }
    }
}

/// grbl number of a row without one.
pub(crate) const NO_GRBL: u16 = u16::MAX;

/// A setting as the board checks it (8 bytes: the range is two indices into [`BOUNDS`], which
/// keeps the table small in the firmware's flash).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Row {
    pub key: Key,
    pub section: Section,
    pub unit: Unit,
    lo: u8,
    hi: u8,
    /// grbl `$` number ([`NO_GRBL`]: none); per-axis rows of 100 and up are `$n+axis`.
    pub grbl: u16,
}

impl Row {
    /// Smallest allowed value, core units.
    pub fn min(&self) -> i64 {
        bound_at(self.lo)
    }

    /// Largest allowed value, core units.
    pub fn max(&self) -> i64 {
        bound_at(self.hi)
    }
}

/// Bound `i` of [`BOUNDS`]: one bounds check for both ends of every row.
#[inline(never)]
fn bound_at(i: u8) -> i64 {
    BOUNDS[usize::from(i)]
}

/// Every range bound of the table, core units.
const BOUNDS: [i64; 28] = [
    i64::MIN,
    i64::MAX,
    0,
    1,
    3,
    6,
    10,
    100,
    200,
    255,
    1_000,
    10_000,
    50_000,
    60_000,
    65_535,
    90_000,
    1_000_000,
    nm_of_mm(10),
    nm_of_mm(100),
    nm_of_mm(1000),
    -nm_of_mm(1000),
    nm_of_mm(10_000),
    nm_of_mm(100_000),
    -nm_of_mm(100_000),
    nm_of_mm(200_000),
    nm_of_mm(1_000_000),
    u32::MAX as i64,
    crate::units::MAX_AXES as i64,
];

/// The index of `v` in [`BOUNDS`] (a bound missing there fails the build).
const fn bound(v: i64) -> u8 {
    let mut i = 0;
    while i < BOUNDS.len() {
        if BOUNDS[i] == v {
            return i as u8;
        }
        i += 1;
    }
    panic!("a settings-table bound missing from BOUNDS")
}

/// The host's part of a row: its name in the file and its reference text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RowText {
    /// Name inside its section (`max_rate`, `travel[0]`).
    pub name: &'static str,
    /// Choices of a [`Unit::Choice`] row, by index.
    pub choices: &'static [&'static str],
    /// Range as docs/settings.md shows it; empty: from `min`/`max`.
    pub range: &'static str,
    /// Default as docs/settings.md shows it; empty: from [`Setup::default`].
    pub default: &'static str,
    pub doc: &'static str,
    /// What the setup file writer puts after the value on the key's line, spaces and `#`
    /// included (empty: nothing).
    pub note: &'static str,
}

const fn nm_of_mm(v: i64) -> i64 {
    v * 1_000_000
}

const ANY: (i64, i64) = (i64::MIN, i64::MAX);
const LENGTH: (i64, i64) = (-nm_of_mm(100_000), nm_of_mm(100_000));
const SPEED: (i64, i64) = (1_000, nm_of_mm(200_000));

macro_rules! table {
    ($($key:ident => $section:ident $name:literal $unit:ident $range:expr, $grbl:expr,
        |$s:ident, $i:ident| $get:expr, |$v:ident| $set:expr;
        [$($choice:literal),*] $rtext:literal $dtext:literal $doc:literal $note:literal,)*) => {
        /// Every setting, in table order ([`ROWS`], [`TEXT`]).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
        #[repr(u8)]
        pub enum Key {
            $($key,)*
        }

        /// The rows the board checks, indexed by [`Key`].
        pub const ROWS: &[Row] = &[
            $(Row {
                key: Key::$key,
                section: Section::$section,
                unit: Unit::$unit,
                lo: bound($range.0),
                hi: bound($range.1),
                grbl: $grbl,
            },)*
        ];

        /// Names and reference text, indexed by [`Key`] (host only).
        pub const TEXT: &[RowText] = &[
            $(RowText {
                name: $name,
                choices: &[$($choice),*],
                range: $rtext,
                default: $dtext,
                doc: $doc,
                note: $note,
            },)*
        ];

        impl Key {
            /// The row's value in `s` (`index`: axis or tool), widened to `i64`; 0 for text rows.
            pub fn value(self, s: &Setup, index: usize) -> i64 {
                match self {
                    $(Key::$key => {
                        let ($s, $i) = (s, index);
                        let _ = ($s, $i);
                        $get
                    })*
                }
            }

            /// Sets the row's value in `s` to `value` (core units, already checked with
            /// [`Key::check`]); text rows do nothing (the host's codecs set them). Only host code
            /// calls it (the setup file reader), so the firmware's linker drops it.
            // A text row's setter is `()`.
            #[allow(clippy::no_effect)]
            pub fn set(self, s: &mut Setup, index: usize, value: i64) {
                match self {
                    $(Key::$key => {
                        let ($s, $i, $v) = (s, index, value);
                        let _ = (&$i, &$v);
                        $set;
                    })*
                }
            }
        }
    };
}

table! {
    Axes => Top "axes" Text (1, crate::units::MAX_AXES as i64), NO_GRBL,
        |s, _i| i64::from(s.axis_count), |v| s.axis_count = v as u8;
        [] "1-6 letters, a prefix of X Y Z A B C" "`[\"X\",\"Y\",\"Z\"]`" "axes in use" "",
    Steps => Axis "steps_per[0]" Count (1, u32::MAX as i64), 100,
        |s, i| i64::from(axis(s, i).steps), |v| axis_mut(s, i).steps = v as u32;
        [] "" "" "exact ratio `[steps, distance]`: this many motor steps move the axis this far (the GIXA controller's \"Ratiometric Steps per Unit\"); long moves never drift. grbl `$100`+i writes steps per mm as an exact ratio" "   # motor steps : distance, an exact ratio",
    StepUnits => Axis "steps_per[1]" Mm (1, nm_of_mm(10_000)), NO_GRBL,
        |s, i| axis(s, i).units_nm, |v| axis_mut(s, i).units_nm = v;
        [] "" "" "" "",
    MaxRate => Axis "max_rate" MmPerMin (nm_of_mm(1), nm_of_mm(200_000)), 110,
        |s, i| axis(s, i).max_rate, |v| axis_mut(s, i).max_rate = v;
        [] "" "" "highest speed of the axis (rapid rate); its step rate must fit the drivers' timing (`[drivers]`)" "         # rapid rate",
    Accel => Axis "accel" MmPerS2 (nm_of_mm(1), nm_of_mm(100_000)), 120,
        |s, i| axis(s, i).accel, |v| axis_mut(s, i).accel = v;
        [] "" "" "acceleration" "",
    Jerk => Axis "jerk" MmPerS3 (0, nm_of_mm(1_000_000)), 800,
        |s, i| axis(s, i).jerk, |v| axis_mut(s, i).jerk = v;
        [] "" "`0` (off)" "jerk limit (rate of change of the acceleration): with every axis's set, the path's acceleration ramps at most this fast along the whole look-ahead, continuous across junctions, holds included (docs/motion.md, Jerk-limited motion); 0 on any axis in use = the trapezoid ramps (acceleration switched on and off at once). Firmware built without gantry-machine's `jerk` feature (the F411 boards', for flash; the F446's has it) refuses a nonzero value. grbl `$800`+i, grblHAL's number" "              # 0 = off (trapezoid)",
    StartSpeed => Axis "start_speed" MmPerMin (0, nm_of_mm(200_000)), NO_GRBL,
        |s, i| axis(s, i).start_speed, |v| axis_mut(s, i).start_speed = v;
        [] "0-`max_rate`" "" "speed the axis can reach instantly from rest (the GIXA controller's \"Starting Speed\")" "      # reachable instantly from rest",
    TravelMin => Axis "travel[0]" Mm LENGTH, NO_GRBL,
        |s, i| axis(s, i).travel_min, |v| axis_mut(s, i).travel_min = v;
        [] "±100000, min ≤ max" "" "soft-limit box `[min, max]` in machine coordinates; a block that would leave it never moves: error 900 when it is the job's first action (MDI), else the job stops on its path with alarm 2; jogs stop at it. grbl `$130`+i is max - min (writing it moves max)" "     # soft limits, machine coordinates",
    TravelMax => Axis "travel[1]" Mm LENGTH, 130,
        |s, i| axis(s, i).travel_max, |v| axis_mut(s, i).travel_max = v;
        [] "" "" "" "",
    InvertDir => Axis "invert_dir" Bool (0, 1), 3,
        |s, i| i64::from(axis(s, i).invert_dir), |v| axis_mut(s, i).invert_dir = v != 0;
        [] "" "" "reverse the direction output (grbl `$3`, a mask of all axes)" "",

    JunctionDeviation => Path "junction_deviation" Mm (0, nm_of_mm(10)), 11,
        |s, _i| s.path.junction_deviation, |v| s.path.junction_deviation = v;
        [] "" "" "grbl junction deviation: how far a corner may be rounded, which sets the corner speed" "",
    FeedShift => Path "feed_shift" MmPerMin (0, nm_of_mm(100_000)), NO_GRBL,
        |s, _i| s.path.feed_shift, |v| s.path.feed_shift = v;
        [] "" "" "instantaneous speed jump the steppers take at any junction (the GIXA controller's \"Feed Shift\"): a corner runs at the larger of junction deviation's speed and the speed whose direction change is this jump, so it only ever raises corner speeds (at the default 60 with the default limits, junction deviation's speed is the higher one except at near-reversals, turns of more than about 170°); 0 = junction deviation alone" "        # largest speed jump at a corner",
    ChordTolerance => Path "chord_tolerance" Mm (100, nm_of_mm(1)), 12,
        |s, _i| s.path.chord_tolerance, |v| s.path.chord_tolerance = v;
        [] "" "" "arcs are cut into straight segments deviating at most this much" "   # arcs are cut into lines within this error",
    ArcSegmentAngle => Path "arc_segment_angle" Degrees (0, 90_000), NO_GRBL,
        |s, _i| i64::from(s.path.arc_segment_angle_mdeg), |v| s.path.arc_segment_angle_mdeg = v as u32;
        [] "" "" "largest angle one arc segment may span (`gixa` \"Segment Angle\"); 0 = no limit" "   # degrees, 0 = no limit",
    ArcMaxSegments => Path "arc_max_segments" Count (0, u32::MAX as i64), NO_GRBL,
        |s, _i| i64::from(s.path.arc_max_segments), |v| s.path.arc_max_segments = v as u32;
        [] "≥ 0" "" "most segments per arc (`gixa` \"Max Segments per Arc\"), overrides both above; 0 = no limit" "    # 0 = no limit",
    BlendTolerance => Path "blend_tolerance" Mm (0, nm_of_mm(10)), NO_GRBL,
        |s, _i| s.path.blend_tolerance, |v| s.path.blend_tolerance = v;
        [] "" "" "path tolerance of `G64` without P (and of the power-up mode): short moves merged into chords and corners rounded by arcs within it, as `G64 P<blend_tolerance>` (below); 0 = off (junction deviation alone)" "   # G64 without P: path tolerance, 0 = off",

    Dialect => Program "dialect" Choice (0, 1), NO_GRBL,
        |s, _i| s.program.dialect as i64, |v| s.program.dialect = if v == 0 { Dialect::Rs274 } else { Dialect::Gixa };
        ["ngc", "gixa"] "" "" "G-code dialect: RS274NGC/Fanuc mill, or the GIXA controller's (docs in the README)" "",
    DwellUnits => Program "dwell_units" Choice (0, 1), NO_GRBL,
        |s, _i| s.program.dwell_units as i64, |v| s.program.dwell_units = if v == 0 { DwellUnits::Seconds } else { DwellUnits::FanucIntegerMillis };
        ["seconds", "milliseconds"] "" "" "how G4 P is read: seconds (RS274NGC) or integer milliseconds (classic Fanuc)" "",
    PeckClearance => Program "peck_clearance" Mm (0, nm_of_mm(100)), NO_GRBL,
        |s, _i| s.program.peck_clearance, |v| s.program.peck_clearance = v;
        [] "" "" "G73/G83 retract clearance" "",
    ChipBreakRetract => Program "chip_break_retract" Mm (0, nm_of_mm(100)), NO_GRBL,
        |s, _i| s.program.chip_break_retract, |v| s.program.chip_break_retract = v;
        [] "" "" "`gixa` G87 partial retract" "",
    DefaultRetract => Program "default_retract" Choice (0, 1), NO_GRBL,
        |s, _i| s.program.default_retract as i64, |v| s.program.default_retract = if v == 0 { RetractMode::InitialLevel } else { RetractMode::RPlane };
        ["g98", "g99"] "" "" "canned-cycle retract mode at program start and after M2/M30, for programs that set neither G98 nor G99: `\"g98\"` returns to the initial level between holes (the safer default), `\"g99\"` to the R plane (LinuxCNC's power-up mode); `gantry check` shows it in its summary" "",
    UserMcodes => Program "user_mcodes" Text ANY, NO_GRBL,
        |_s, _i| 0, |_v| ();
        [] "up to 16 codes, 10-999 except 30, 98, 99" "`[]`" "M codes the machine defines (they run the user M-code lists)" "",
    G28Home => Program "g28_home" Text ANY, NO_GRBL,
        |_s, _i| 0, |_v| ();
        [] "±100000 per axis" "all 0" "G28 position in machine coordinates (G28.1 sets it at run time)" "",
    G30Home => Program "g30_home" Text ANY, NO_GRBL,
        |_s, _i| 0, |_v| ();
        [] "±100000 per axis" "all 0" "G30 position in machine coordinates (G30.1 sets it at run time)" "",
    ToolChangePosition => Program "tool_change_position" Text ANY, NO_GRBL,
        |_s, _i| 0, |_v| ();
        [] "inside each axis's travel" "none" "where M6 moves before its stop, machine coordinates: an inline table of the axes to move, e.g. `{ X = 0.0, Y = 200.0, Z = 0.0 }`; Z first, then the others (docs/probing.md \"The tool-change position\")" "  # M6 moves there first (machine coordinates, Z first)",

    ToolNumber => Tool "number" Count (1, u32::MAX as i64), NO_GRBL,
        |s, i| i64::from(tool(s, i).number), |v| tool_mut(s, i).number = v as u32;
        [] "≥ 1, unique" "—" "T number" "",
    ToolLength => Tool "length" Mm (-nm_of_mm(1000), nm_of_mm(1000)), NO_GRBL,
        |s, i| tool(s, i).length, |v| tool_mut(s, i).length = v;
        [] "" "`0`" "tool length offset applied by G43 H" "",
    ToolDiameter => Tool "diameter" Mm (0, nm_of_mm(1000)), NO_GRBL,
        |s, i| tool(s, i).diameter, |v| tool_mut(s, i).diameter = v;
        [] "" "`0`" "diameter, used by cutter compensation (`G41 D<n>`, `G42 D<n>`; docs/gcode-compensation.md)" "",

    ResumeNeedsCycleStart => Operator "resume_needs_cycle_start" Bool (0, 1), NO_GRBL,
        |s, _i| i64::from(s.operator.resume_needs_cycle_start), |v| s.operator.resume_needs_cycle_start = v != 0;
        [] "" "" "after a feed hold is released: resume at once (the GIXA controller's behaviour) or wait for cycle start" "",
    TwoHandStart => Operator "two_hand_start" Bool (0, 1), NO_GRBL,
        |s, _i| i64::from(s.operator.two_hand_start), |v| s.operator.two_hand_start = v != 0;
        [] "" "" "cycle start needs both start inputs" "",
    FroLow => Operator "fro_range[0]" Percent (10, 200), NO_GRBL,
        |s, _i| i64::from(s.operator.fro_low), |v| s.operator.fro_low = v as u16;
        [] "10-200 %, low ≤ high" "" "feed-override potentiometer range `[low, high]`" "",
    FroHigh => Operator "fro_range[1]" Percent (10, 200), NO_GRBL,
        |s, _i| i64::from(s.operator.fro_high), |v| s.operator.fro_high = v as u16;
        [] "" "" "" "",
    DryRunFeed => Operator "dry_run_feed" MmPerMin (nm_of_mm(1), nm_of_mm(100_000)), NO_GRBL,
        |s, _i| s.operator.dry_run_feed, |v| s.operator.dry_run_feed = v;
        [] "" "" "feed used for every feed move during a dry run" "",

    ActiveLow => Inputs "active_low" InputMask (0, u32::MAX as i64), 5,
        |s, _i| i64::from(s.inputs.invert), |v| s.inputs.invert = v as u32;
        [] "input names" "`[]`" "inputs that are active while their switch is *open* (pin high): list the normally-closed switches (see input polarity above). Without it a closed switch is active. grbl `$5` sets or clears all limit inputs together" "   # active while the switch is open: the normally-closed switches",
    DebounceMs => Inputs "debounce_ms" Ms (1, 100), 26,
        |s, _i| i64::from(s.inputs.debounce_ms), |v| s.inputs.debounce_ms = v as u8;
        [] "" "" "consecutive equal 1 ms samples before an input level counts. Limit switches stop the step interrupt from the raw pin at once; debouncing only delays the alarm bookkeeping" "",
    LimitsMin => Inputs "limits_min" AxisMask (0, 255), NO_GRBL,
        |s, _i| i64::from(s.inputs.limit_min), |v| s.inputs.limit_min = v as u8;
        [] "axis letters in use" "`[]`" "axes with a min-side limit switch" "",
    LimitsMax => Inputs "limits_max" AxisMask (0, 255), NO_GRBL,
        |s, _i| i64::from(s.inputs.limit_max), |v| s.inputs.limit_max = v as u8;
        [] "axis letters in use" "`[]`" "axes with a max-side limit switch" "",
    HardLimits => Inputs "hard_limits" Bool (0, 1), 21,
        |s, _i| i64::from(s.inputs.hard_limits), |v| s.inputs.hard_limits = v != 0;
        [] "" "" "installed switches stop motion and raise alarm 1 (homing uses the switches either way)" "",
    FeedHold => Inputs "feed_hold" Bool (0, 1), NO_GRBL,
        |s, _i| i64::from(s.inputs.feed_hold), |v| s.inputs.feed_hold = v != 0;
        [] "" "" "feed-hold switch installed" "",
    Abort => Inputs "abort" Bool (0, 1), NO_GRBL,
        |s, _i| i64::from(s.inputs.abort), |v| s.inputs.abort = v != 0;
        [] "" "" "abort push button installed" "",
    FroPot => Inputs "fro_pot" Bool (0, 1), NO_GRBL,
        |s, _i| i64::from(s.inputs.fro_pot), |v| s.inputs.fro_pot = v != 0;
        [] "" "" "feed-override potentiometer installed (ADC range → `operator.fro_range`)" "",
    AdcMax => Inputs "adc_max" Count (255, 65_535), NO_GRBL,
        |s, _i| i64::from(s.inputs.adc_max), |v| s.inputs.adc_max = v as u16;
        [] "" "" "ADC full-scale reading (12-bit: 4095)" "",

    Required => Homing "required" Bool (0, 1), NO_GRBL,
        |s, _i| i64::from(s.homing.required), |v| s.homing.required = v != 0;
        [] "" "" "after power-up and after a hard limit, motion is refused (alarm 11, error 901) until the axes with a priority are homed. After a reset during motion (alarm 3) homing is required whenever an axis has a priority, whatever this says" "",
    BeforeSeek => Homing "before_seek" Text ANY, NO_GRBL,
        |_s, _i| 0, |_v| ();
        [] "≤ 8 list commands" "`[]`" "run before each axis's seek" "",
    BeforeRetract => Homing "before_retract" Text ANY, NO_GRBL,
        |_s, _i| 0, |_v| ();
        [] "≤ 8 list commands" "`[]`" "run when the switch has stopped the seek" "",
    AfterRetract => Homing "after_retract" Text ANY, NO_GRBL,
        |_s, _i| 0, |_v| ();
        [] "≤ 8 list commands" "`[]`" "run after the retract (and set home)" "",
    Priority => HomingAxis "priority" Count (0, 255), NO_GRBL,
        |s, i| i64::from(homing_axis(s, i).priority), |v| homing_axis_mut(s, i).priority = v as u8;
        [] "" "" "order of the seek, lower first, one axis at a time; 0 = the axis is not homed (grbl `$22` reads 1 when an axis has a priority)" "   # 0 = not homed",
    Seek => HomingAxis "seek" Choice (0, 1), 23,
        |s, i| i64::from(homing_axis(s, i).seek_low), |v| homing_axis_mut(s, i).seek_low = v != 0;
        ["high", "low"] "" "" "seek the min or the max switch (grbl `$23`, a mask of all axes)" "",
    SeekRate => HomingAxis "seek_rate" MmPerMin SPEED, 25,
        |s, i| homing_axis(s, i).seek_rate, |v| homing_axis_mut(s, i).seek_rate = v;
        [] "" "" "fast seek toward the switch, with the axis's acceleration; where it stops does not count, so it may be well above the start speed (grbl `$25` writes every axis)" "",
    LocateRate => HomingAxis "locate_rate" MmPerMin SPEED, 24,
        |s, i| homing_axis(s, i).locate_rate, |v| homing_axis_mut(s, i).locate_rate = v;
        [] "" "" "slow locate back onto the switch after the pull-off; it sets the position, so keep it at or below the axis `start_speed`: no ramp, the switch stops it on the exact step (grbl `$24` writes every axis)" "",
    Retract => HomingAxis "retract" Mm (0, nm_of_mm(1000)), 27,
        |s, i| homing_axis(s, i).retract, |v| homing_axis_mut(s, i).retract = v;
        [] "" "" "pull-off after the seek and back-off after the locate, at the rapid rate; must release the switch (else alarm 8); the locate searches twice this far (grbl `$27` writes every axis)" "",
    SetHome => HomingAxis "set_home" Bool (0, 1), NO_GRBL,
        |s, i| i64::from(homing_axis(s, i).set_home), |v| homing_axis_mut(s, i).set_home = v != 0;
        [] "" "" "after the retract, the axis position becomes `home_position`" "",
    HomePosition => HomingAxis "home_position" Mm LENGTH, NO_GRBL,
        |s, i| homing_axis(s, i).home_position, |v| homing_axis_mut(s, i).home_position = v;
        [] "" "" "machine position of the axis after the retract" "",

    Pair0 => Jog "pair0" AxisPair (0, 65_535), NO_GRBL,
        |s, _i| pair(s.jog.pairs[0]), |v| s.jog.pairs[0] = unpair(v);
        [] "axis letters or `\"-\"`" "`[\"Y\", \"X\"]`" "joystick axes with the pair selector off: `[S1 down / S4 up, S2 left / S3 right]`" "   # [down/up, left/right]",
    Pair1 => Jog "pair1" AxisPair (0, 65_535), NO_GRBL,
        |s, _i| pair(s.jog.pairs[1]), |v| s.jog.pairs[1] = unpair(v);
        [] "axis letters or `\"-\"`" "`[\"Z\", \"-\"]`" "the same with the pair selector on" "   # [down/up, left/right]",
    InstantSpeed => Jog "instant_speed" MmPerMin SPEED, NO_GRBL,
        |s, _i| s.jog.instant_speed, |v| s.jog.instant_speed = v;
        [] "" "" "Instantaneous mode speed (and nudge speed); at or below `start_speed` for no ramp" "",
    NudgeDistance => Jog "nudge_distance" Mm (1, nm_of_mm(100)), NO_GRBL,
        |s, _i| s.jog.nudge_distance, |v| s.jog.nudge_distance = v;
        [] "" "" "one nudge" "",
    NudgeIntervalMs => Jog "nudge_interval_ms" Ms (10, 10_000), NO_GRBL,
        |s, _i| i64::from(s.jog.nudge_interval_ms), |v| s.jog.nudge_interval_ms = v as u16;
        [] "" "" "time between nudges while a switch is held" "",
    AnalogAxes => Jog "analog_axes" AxisPair (0, 65_535), NO_GRBL,
        |s, _i| pair(s.jog.analog_axes), |v| s.jog.analog_axes = unpair(v);
        [] "axis letters or `\"-\"`" "`[\"X\", \"Y\"]`" "axes of analog stick channels 0 and 1" "",
    AnalogDeadband => Jog "analog_deadband" Count (0, 65_535), NO_GRBL,
        |s, _i| i64::from(s.jog.analog_deadband), |v| s.jog.analog_deadband = v as u16;
        [] "below `adc_max / 2`" "" "ADC counts around the centre that count as neutral" "",
    AnalogMaxSpeed => Jog "analog_max_speed" MmPerMin SPEED, NO_GRBL,
        |s, _i| s.jog.analog_max_speed, |v| s.jog.analog_max_speed = v;
        [] "" "" "speed at full deflection (8 steps); speed changes ramp at the axes' acceleration and direction changes bend the path without stopping (docs/controller.md, Jogging)" "",

    RpmMin => Spindle "rpm_range[0]" Rpm (0, 1_000_000), 31,
        |s, _i| i64::from(s.outputs.spindle_min_rpm), |v| s.outputs.spindle_min_rpm = v as u32;
        [] "low < high ≤ 1000000" "" "S values `[low, high]` mapped onto the PWM range (clamped at both ends; S0 or M5 = duty 0); grbl `$31`, `$30`" "",
    RpmMax => Spindle "rpm_range[1]" Rpm (1, 1_000_000), 30,
        |s, _i| i64::from(s.outputs.spindle_max_rpm), |v| s.outputs.spindle_max_rpm = v as u32;
        [] "" "" "" "",
    PwmMin => Spindle "pwm_range[0]" Count (0, 65_535), NO_GRBL,
        |s, _i| i64::from(s.outputs.pwm_min), |v| s.outputs.pwm_min = v as u16;
        [] "low ≤ high, high ≥ 1" "" "PWM duty (timer counts) at the low and high rpm" "",
    PwmMax => Spindle "pwm_range[1]" Count (1, 65_535), NO_GRBL,
        |s, _i| i64::from(s.outputs.pwm_max), |v| s.outputs.pwm_max = v as u16;
        [] "" "" "" "",
    Laser => Spindle "laser" Bool (0, 1), 32,
        |s, _i| i64::from(s.outputs.laser), |v| s.outputs.laser = v != 0;
        [] "" "" "laser mode (grbl `$32`, docs/laser-plasma.md): `S` changes between G1/G2/G3 moves never stop the motion (S travels with each move and sets the PWM duty at its first step); `M3` constant power, `M4` power scaled by the current speed ÷ the programmed feed at every segment; the beam is off in G0, at rest, in a hold, at M0/M6 stops, in an alarm and at program end, whatever S says. `false`: a milling spindle (every S change stops the motion until the spindle has it)" "   # laser mode: S travels with each move, M4 power follows the speed",
    OrientOutput => Spindle "orient_output" Output (0, 255), NO_GRBL,
        |s, _i| i64::from(s.outputs.orient.output), |v| s.outputs.orient.output = v as u8;
        [] "a user output 0-15 (as in `set N`)" "none" "the oriented spindle stop of G76 fine boring (docs/gcode-transforms.md, \"Fanuc cycles\"): this output is set at the hole's bottom (spindle stopped) and stays set until the spindle starts again. Without it G76 is refused (E411)" "   # G76's oriented stop",
    OrientDoneInput => Spindle "orient_done_input" Input (0, 255), NO_GRBL,
        |s, _i| i64::from(s.outputs.orient.done_input), |v| s.outputs.orient.done_input = v as u8;
        [] "an input name (`in20`, …)" "none" "reads high once the spindle is oriented: the shift off the wall waits for it. None: the orient takes `orient_dwell_ms`" "",
    OrientDwellMs => Spindle "orient_dwell_ms" Ms (0, 65_535), NO_GRBL,
        |s, _i| i64::from(s.outputs.orient.dwell_ms), |v| s.outputs.orient.dwell_ms = v as u16;
        [] "" "`0`" "without `orient_done_input`, how long the orient takes; with it, the longest wait for the input (then alarm 21, list input timeout; `0` = wait forever)" "",

    Torch => Spindle "torch" Bool (0, 1), 350,
        |s, _i| i64::from(s.outputs.torch.on), |v| s.outputs.torch.on = v != 0;
        [] "not with `laser`" "" "plasma torch mode (docs/laser-plasma.md \"Plasma\"): `M3` fires the torch on the spindle enable output and the motion waits for the `arc_ok` input (alarm 22 after `arc_ok_timeout_ms`); arc-OK lost while cutting holds the job on its path with the torch off; torch height control moves Z from the `thc_up`/`thc_down` inputs. grbl `$350` (grblHAL's plasma mode numbers): 0 off, 2 torch with up/down THC (`thc = true`), 3 torch with arc-OK only (`thc = false`); 1 (arc-voltage THC) is refused" "   # plasma: M3 waits for arc-OK, THC from the up/down inputs",
    ArcOkTimeoutMs => Spindle "arc_ok_timeout_ms" Ms (100, 60_000), 358,
        |s, _i| i64::from(s.outputs.torch.arc_ok_timeout_ms), |v| s.outputs.torch.arc_ok_timeout_ms = v as u16;
        [] "" "" "longest wait for arc-OK after `M3` (and after a cycle start that re-fires the torch): then alarm 22 \"no arc\", torch off, at rest (grbl `$358`, in seconds)" "",
    Thc => Spindle "thc" Bool (0, 1), NO_GRBL,
        |s, _i| i64::from(s.outputs.torch.thc), |v| s.outputs.torch.thc = v != 0;
        [] "" "" "torch height control: while the cut runs at cruise speed Z follows `thc_up`/`thc_down`; `M62 P2` (off) and `M63 P2` (on) switch it from the program (grbl `$350`: 2 with it, 3 without)" "",
    ThcRate => Spindle "thc_rate" MmPerMin (nm_of_mm(10), nm_of_mm(10_000)), 450,
        |s, _i| s.outputs.torch.thc_rate, |v| s.outputs.torch.thc_rate = v;
        [] "" "" "Z speed of the height control (grbl `$450`, a number of Gantry's own)" "",
    ThcTravel => Spindle "thc_travel" Mm (0, nm_of_mm(100)), 451,
        |s, _i| s.outputs.torch.thc_travel, |v| s.outputs.torch.thc_travel = v;
        [] "" "" "largest height correction up or down from the programmed Z (grbl `$451`, a number of Gantry's own)" "",
    ThcAntiDive => Spindle "thc_anti_dive" Percent (0, 100), 356,
        |s, _i| i64::from(s.outputs.torch.thc_anti_dive), |v| s.outputs.torch.thc_anti_dive = v as u8;
        [] "" "" "anti-dive: the height control holds while the speed is below this share of the programmed feed (and in every acceleration and corner slow-down; grbl `$356`)" "",
    ThcDelayMs => Spindle "thc_delay_ms" Ms (0, 10_000), 351,
        |s, _i| i64::from(s.outputs.torch.thc_delay_ms), |v| s.outputs.torch.thc_delay_ms = v as u16;
        [] "" "" "time after arc-OK before the height control acts (the pierce and its lead-in settle; grbl `$351`, in seconds)" "",

    McodeCode => Mcode "code" Count (0, 65_535), NO_GRBL,
        |s, i| i64::from(mcode(s, i).code), |v| mcode_mut(s, i).code = v as u16;
        [] "a code listed in `program.user_mcodes`" "—" "the M code" "",
    McodeDryRunDisabled => Mcode "dry_run_disabled" Bool (0, 1), NO_GRBL,
        |s, i| i64::from(mcode(s, i).dry_run_disabled), |v| mcode_mut(s, i).dry_run_disabled = v != 0;
        [] "" "`false`" "skip the list during a dry run (the GIXA controller's \"Disable these commands for Dry Run\")" "",
    McodeCommands => Mcode "commands" Text ANY, NO_GRBL,
        |_s, _i| 0, |_v| ();
        [] "≤ 6 list commands" "`[]`" "run at rest when the program reaches the M code; the program continues when the list ends. **Exactly one `set N` or `clear N`** (N 0-15): an on-the-fly M code instead: the motion does not stop, output N switches at the M code's exact place on the path (docs/controller.md, \"On-the-fly outputs\"). An empty list or a missing table stops the motion and does nothing else" "",

    HostLostStopS => Link "host_lost_stop_s" Seconds (0, 65_535), NO_GRBL,
        |s, _i| i64::from(s.link.host_lost_stop_s), |v| s.link.host_lost_stop_s = v as u16;
        [] "" "" "the board holds a running job when the host goes silent (1 s) and waits for it to come back and continue. A job that has stood still this long with the host gone — in a feed hold, or resumed locally and then waiting at rest for lines only the host could send — is ended (spindle, coolant and user outputs off, resume line remembered) with alarm 20. `0` = wait for the host forever. An M0/M1 stop is not ended (its outputs are off already)" "   # a job standing still with the host gone ends (alarm 20) after this; 0 = never",

    StepPulse => Drivers "step_pulse_us" Us (*super::DriverSetup::PULSE_NS.start() as i64, *super::DriverSetup::PULSE_NS.end() as i64), 0,
        |s, _i| i64::from(s.drivers.step_pulse_ns), |v| s.drivers.step_pulse_ns = v as u32;
        [] "" "" "width of every step pulse (grbl `$0`, whole µs)" "   # step pulse width (datasheet minimum: DM542 2.5, DRV8825 1.9)",
    DirSetup => Drivers "dir_setup_us" Us (*super::DriverSetup::DIR_SETUP_NS.start() as i64, *super::DriverSetup::DIR_SETUP_NS.end() as i64), NO_GRBL,
        |s, _i| i64::from(s.drivers.dir_setup_ns), |v| s.drivers.dir_setup_ns = v as u32;
        [] "" "" "least time from a direction change to the next step pulse" "   # direction change to next step pulse, at least (DM542 5)",

    StatusMask => Grbl "status_mask" Count (0, 3), 10,
        |s, _i| i64::from(s.grbl.status_mask), |v| s.grbl.status_mask = v as u8;
        [] "" "" "grbl `$10`: bit 0 `MPos` (set) or `WPos` in status reports, bit 1 the `Bf:` field" "   # $10: 1 machine position (0 work position), +2 buffer state",
    ReportInches => Grbl "report_inches" Bool (0, 1), 13,
        |s, _i| i64::from(s.grbl.inches), |v| s.grbl.inches = v != 0;
        [] "" "" "grbl `$13`: positions and feeds in reports in inches" "   # $13",
    StartupLines => Grbl "startup_lines" Text ANY, NO_GRBL,
        |_s, _i| 0, |_v| ();
        [] "2 lines, 64 characters each" "`[\"\", \"\"]`" "grbl `$N0`, `$N1`: G-code lines run after the banner (connect, soft reset, `$H`) unless the machine is in alarm" "   # $N0, $N1: run after the banner unless in alarm",
    DoorSpinUp => Grbl "door_spin_up_s" S (*super::GrblSetup::DOOR_SPIN_UP_MS.start() as i64, *super::GrblSetup::DOOR_SPIN_UP_MS.end() as i64), NO_GRBL,
        |s, _i| i64::from(s.grbl.door_spin_up_ms), |v| s.grbl.door_spin_up_ms = v as u16;
        [] "0-60 s, ms resolution" "" "after `~` closes the safety door (0x84) with the spindle on, spindle and coolant come back on at once and motion waits this long for the spindle to spin up (status `Door:3`), as grbl waits 4 s; 0 = no wait. No grbl `$` number (grbl has it built in)" "   # after ~ closes the safety door, the spindle spins up this long before motion; 0 = no wait",
    M6Stop => Grbl "m6_stop" Bool (0, 1), NO_GRBL,
        |s, _i| i64::from(s.grbl.m6_stop), |v| s.grbl.m6_stop = v != 0;
        [] "" "" "in grbl mode, `M6` stops for a manual tool change (`Hold:0`, `~` continues), which every sender shows as a hold with its resume button; `false`: grbl 1.1's `error:20`, for senders that handle the tool change themselves and expect grbl's answer (docs/grbl.md)" "   # M6 stops for a manual tool change; false: grbl's error:20",
}

/// Two axis indices as one [`Unit::AxisPair`] value.
fn pair(p: [u8; 2]) -> i64 {
    i64::from(p[0]) | i64::from(p[1]) << 8
}

/// A [`Unit::AxisPair`] value as its two axis indices.
fn unpair(v: i64) -> [u8; 2] {
    [v as u8, (v >> 8) as u8]
}

/// Axis `i` of `s` for the per-axis rows of [`Key::value`]: one bounds check for all of them
/// (indexing in each row gave each its own panic path, about 30 bytes of flash apiece).
#[inline(never)]
fn axis(s: &Setup, i: usize) -> &AxisSetup {
    &s.axes[i]
}

/// M-code list `i` of `s` (as [`axis`]).
#[inline(never)]
fn mcode(s: &Setup, i: usize) -> &super::McodeList {
    &s.outputs.mcode_lists[i]
}

/// M-code list `i` of `s` for [`Key::set`].
fn mcode_mut(s: &mut Setup, i: usize) -> &mut super::McodeList {
    &mut s.outputs.mcode_lists[i]
}

/// Axis `i` of `s` for [`Key::set`].
fn axis_mut(s: &mut Setup, i: usize) -> &mut AxisSetup {
    &mut s.axes[i]
}

/// Homing axis `i` of `s` for [`Key::set`].
fn homing_axis_mut(s: &mut Setup, i: usize) -> &mut HomingAxis {
    &mut s.homing.axes[i]
}

/// Tool `i` of `s` for [`Key::set`].
fn tool_mut(s: &mut Setup, i: usize) -> &mut Tool {
    &mut s.program.tools[i]
}

/// Homing axis `i` of `s` (as [`axis`]).
#[inline(never)]
fn homing_axis(s: &Setup, i: usize) -> &HomingAxis {
    &s.homing.axes[i]
}

/// Tool `i` of `s` (as [`axis`]).
#[inline(never)]
fn tool(s: &Setup, i: usize) -> &Tool {
    &s.program.tools[i]
}

impl Key {
    /// The key's row.
    pub fn row(self) -> &'static Row {
        &ROWS[self as usize]
    }

    /// The key's names and text (host only: keeps the text out of the firmware).
    pub fn text(self) -> &'static RowText {
        &TEXT[self as usize]
    }

    /// The key after this one in the table (the high half of a `[low, high]` pair).
    pub fn next(self) -> Key {
        ROWS.get(self as usize + 1).map_or(self, |r| r.key)
    }

    /// `value` (core units) against the row's range: the one range check of every path.
    pub fn check(self, index: usize, value: i64) -> Result<(), super::SetupError> {
        let r = self.row();
        if value < r.min() || value > r.max() {
            return Err(super::SetupError {
                key: self,
                index: index as u8,
                value,
                limit: 0,
                reason: super::Reason::OutOfRange,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    #[test]
    fn rows_and_texts_line_up_and_defaults_pass() {
        assert_eq!(ROWS.len(), TEXT.len());
        let s = Setup::default();
        for (i, r) in ROWS.iter().enumerate() {
            assert_eq!(r.key as usize, i);
            assert!(r.min() <= r.max(), "{:?}", r.key);
            let t = r.key.text();
            assert_eq!(t.choices.is_empty(), r.unit != Unit::Choice, "{}", t.name);
            for k in 0..r.section.count(&s) {
                assert_eq!(r.key.check(k, r.key.value(&s, k)), Ok(()), "{}", t.name);
            }
            // Pairs: `x[0]` is followed by `x[1]`.
            if let Some(base) = t.name.strip_suffix("[0]") {
                assert_eq!(r.key.next().text().name, std::format!("{base}[1]"));
            }
        }
    }

    #[test]
    fn each_setter_writes_what_its_getter_reads_at_both_ends_of_the_range() {
        for r in ROWS.iter().filter(|r| r.unit != Unit::Text) {
            let mut s = Setup::default();
            let _ = s.program.tools.push(Tool::default());
            for i in 0..r.section.count(&s) {
                for v in [r.min(), r.max()] {
                    let mut t = s.clone();
                    r.key.set(&mut t, i, v);
                    assert_eq!(r.key.value(&t, i), v, "{:?}[{i}] = {v}", r.key);
                    // Only the row's own value moved.
                    r.key.set(&mut t, i, r.key.value(&s, i));
                    assert_eq!(t, s, "{:?}[{i}]", r.key);
                }
            }
        }
    }
}
