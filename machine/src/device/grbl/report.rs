//! grbl's reports: the status report `<…>` (with the `$10` mask), `[GC:…]` (`$G`), the
//! coordinate parameters (`$#`) and the build info (`$I`).

use super::settings::Prefs;
use super::text::Out;
use super::RX_SIZE;
use crate::board::inputs::{InputBits, Signal};
use crate::board::State;
use crate::board::{Board, PLANNER_BLOCKS};
use crate::canon::{Plane, Spindle};
use crate::device::kernel_view::KernelView;
use crate::gcode::state::MotionMode;
use crate::units::{Pos, NM_PER_MM};

/// nm per inch.
const NM_PER_INCH: i64 = 25_400_000;

/// Writes a position (mm with 3 decimals, or inches with 4).
fn position(out: &mut Out, p: &Pos, axes: usize, prefs: &Prefs) {
    for (i, v) in p.iter().take(axes).enumerate() {
        if i > 0 {
            out.byte(b',');
        }
        length(out, *v, prefs);
    }
}

fn length(out: &mut Out, nm: i64, prefs: &Prefs) {
    if prefs.inches {
        out.fixed(nm, NM_PER_INCH, 4);
    } else {
        out.fixed(nm, NM_PER_MM, 3);
    }
}

/// A feed (nm/min) in mm/min or in/min, as grbl shows it.
fn feed(out: &mut Out, nm_min: i64, prefs: &Prefs) {
    if prefs.inches {
        out.fixed(nm_min, NM_PER_INCH, 1);
    } else {
        out.fixed(nm_min, NM_PER_MM, 0);
    }
}

/// The state name grbl senders know. A job standing at rest waiting for lines is `Idle` to them
/// (the front end ends it in the same pass).
pub fn state_name(board: &Board, view: &KernelView, check_mode: bool) -> &'static str {
    match board.state() {
        State::Idle if check_mode => "Check",
        State::Idle => "Idle",
        State::Run if board.waiting_for_lines() => "Idle",
        State::Run => "Run",
        // The board's M6 stop: at rest, waiting for cycle start (`~`), as grbl's Hold:0.
        State::ToolChange => "Hold:0",
        State::Hold if view.feed_um_min == 0 => "Hold:0",
        State::Hold => "Hold:1",
        State::Alarm => "Alarm",
        State::Homing => "Home",
        State::Jog => "Jog",
        State::Check => "Check",
    }
}

/// What changes rarely and is shown only every few reports (grbl: WCO and Ov).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sparse {
    count: u8,
    wco: Option<Pos>,
    /// Feed, rapid and spindle overrides and the `A:` letters (a toggle shows at once, as in grbl).
    ov: Option<(u16, u16, u16, [bool; 4])>,
}

impl Sparse {
    pub const fn new() -> Self {
        Sparse {
            count: 0,
            wco: None,
            ov: None,
        }
    }
}

/// Longest status report, bytes (6 axes of MPos and WCO, every field).
pub(crate) const STATUS_MAX: usize = 260;

/// One status report line.
pub fn status(
    out: &mut Out,
    board: &Board,
    view: &KernelView,
    prefs: &Prefs,
    state: &str,
    rx_free: usize,
    sparse: &mut Sparse,
) {
    let axes = usize::from(board.setup().axis_count);
    // (A plasma torch's height correction left out of Z, as in the native status.)
    let machine = board.reported_position(&view.steps);
    // WCO: the offsets of the move being executed (`board/executing.rs`), as grbl's.
    let modes = board.executing_modes();
    out.byte(b'<');
    out.str(state);
    if prefs.status_mask & 1 != 0 {
        out.str("|MPos:");
        position(out, &machine, axes, prefs);
    } else {
        out.str("|WPos:");
        position(out, &modes.work_position(&machine), axes, prefs);
    }
    if prefs.status_mask & 2 != 0 {
        let planner = board.motion().planner().len();
        out.str("|Bf:");
        out.uint(PLANNER_BLOCKS.saturating_sub(planner) as u64);
        out.byte(b',');
        out.uint(rx_free as u64);
    }
    if matches!(board.state(), State::Run | State::Hold) && board.line() > 0 {
        out.str("|Ln:");
        out.uint(u64::from(board.line()));
    }
    out.str("|FS:");
    feed(out, i64::from(view.feed_um_min) * 1000, prefs);
    out.byte(b',');
    out.uint(u64::from(spindle_now(board, view)));
    pins(out, InputBits(view.inputs), board);
    // WCO and Ov: when they change, and every 10th report.
    sparse.count = (sparse.count + 1) % 10;
    let o = board.outputs();
    let acc = [
        (o.spindle == Spindle::Cw, 'S'),
        (o.spindle == Spindle::Ccw, 'C'),
        (o.flood, 'F'),
        (o.mist, 'M'),
    ];
    let ov = (
        board.feed_override(),
        board.motion().planner().rapid_override(),
        board.spindle_override(),
        acc.map(|(on, _)| on),
    );
    let wco = modes.offset;
    if sparse.count == 0 || sparse.wco != Some(wco) {
        sparse.wco = Some(wco);
        out.str("|WCO:");
        position(out, &wco, axes, prefs);
    }
    if sparse.count == 5 || sparse.ov != Some(ov) {
        sparse.ov = Some(ov);
        out.str("|Ov:");
        out.uint(u64::from(ov.0));
        out.byte(b',');
        out.uint(u64::from(ov.1));
        out.byte(b',');
        out.uint(u64::from(ov.2));
        if acc.iter().any(|(on, _)| *on) {
            out.str("|A:");
            for (on, c) in acc {
                if on {
                    out.byte(c as u8);
                }
            }
        }
    }
    out.byte(b'>');
    out.eol();
}

/// `FS:`'s spindle value: the programmed S, or in laser mode the S the beam fires at now (the
/// PWM duty mapped back onto the S range: S × speed ÷ F under M4, 0 while the beam is off in G0,
/// at rest or in a hold; docs/laser-plasma.md).
fn spindle_now(board: &Board, view: &KernelView) -> u32 {
    let o = &board.setup().outputs;
    if !o.laser {
        return board.outputs().rpm;
    }
    if view.laser_duty == 0 {
        return 0;
    }
    let duty = u64::from(view.laser_duty.max(o.pwm_min) - o.pwm_min);
    let span = u64::from(o.pwm_max.saturating_sub(o.pwm_min)).max(1);
    let rpm = u64::from(o.spindle_max_rpm.saturating_sub(o.spindle_min_rpm));
    (u64::from(o.spindle_min_rpm) + (duty * rpm + span / 2) / span) as u32
}

/// `Pn:` from the debounced inputs: limit switches by axis, H feed hold, R abort, S cycle start.
fn pins(out: &mut Out, levels: InputBits, board: &Board) {
    let axes = usize::from(board.setup().axis_count);
    let limits = levels.limits_min() | levels.limits_max();
    let inputs = &board.setup().inputs;
    let mut any = false;
    let mut put = |out: &mut Out, c: u8| {
        if !any {
            out.str("|Pn:");
            any = true;
        }
        out.byte(c);
    };
    for (i, c) in crate::units::AXIS_LETTERS.iter().enumerate().take(axes) {
        if limits & (1 << i) != 0 {
            put(out, *c as u8);
        }
    }
    if inputs.feed_hold && levels.get(Signal::FeedHold) {
        put(out, b'H');
    }
    if inputs.abort && levels.get(Signal::Abort) {
        put(out, b'R');
    }
    if levels.get(Signal::Probe) {
        put(out, b'P');
    }
    if levels.get(Signal::CycleStart1) || levels.get(Signal::CycleStart2) {
        put(out, b'S');
    }
}

/// `[GC:…]`: the interpreter's modal state.
pub(crate) fn gcode_modes(out: &mut Out, board: &Board, prefs: &Prefs) {
    let s = board.interpreter().state();
    out.str("[GC:");
    match s.motion {
        MotionMode::Rapid => out.str("G0"),
        MotionMode::Linear => out.str("G1"),
        MotionMode::ArcCw => out.str("G2"),
        MotionMode::ArcCcw => out.str("G3"),
        MotionMode::Cycle(c) => {
            out.byte(b'G');
            out.uint(u64::from(c / 10));
        }
        _ => out.str("G80"),
    }
    match s.work_system {
        w @ 0..=5 => {
            out.str(" G");
            out.uint(54 + u64::from(w));
        }
        w => {
            out.str(" G59.");
            out.uint(u64::from(w) - 5);
        }
    }
    out.str(match s.plane {
        Plane::XY => " G17",
        Plane::ZX => " G18",
        Plane::YZ => " G19",
    });
    out.str(if s.inch { " G20" } else { " G21" });
    out.str(if s.absolute { " G90" } else { " G91" });
    out.str(if s.inverse_time { " G93" } else { " G94" });
    out.str(match s.spindle {
        Spindle::Cw => " M3",
        Spindle::Ccw => " M4",
        Spindle::Off => " M5",
    });
    match (s.mist, s.flood) {
        (false, false) => out.str(" M9"),
        (m, f) => {
            if m {
                out.str(" M7");
            }
            if f {
                out.str(" M8");
            }
        }
    }
    out.str(" T");
    out.uint(u64::from(s.tool_selected));
    out.str(" F");
    let inches = Prefs {
        inches: s.inch,
        ..*prefs
    };
    feed(out, s.feed, &inches);
    out.str(" S");
    out.uint(u64::from(s.rpm));
    out.byte(b']');
    out.eol();
}

/// `$#`: work systems, G28/G30, G92, tool length offset and the last probe.
pub(crate) fn parameters(out: &mut Out, board: &Board, prefs: &Prefs) {
    let s = board.interpreter().state();
    let axes = usize::from(board.setup().axis_count);
    for (i, w) in s.work_offsets.iter().enumerate().take(6) {
        out.str("[G");
        out.uint(54 + i as u64);
        out.byte(b':');
        position(out, w, axes, prefs);
        out.byte(b']');
        out.eol();
    }
    for (name, p) in [("[G28:", &s.g28), ("[G30:", &s.g30), ("[G92:", &s.g92)] {
        out.str(name);
        position(out, p, axes, prefs);
        out.byte(b']');
        out.eol();
    }
    out.str("[TLO:");
    length(out, s.tool_offset[2], prefs);
    out.byte(b']');
    out.eol();
    probe(out, board, prefs);
}

/// `[PRB:x,y,z:1]`: the last probe move's trip (or end) position in machine coordinates, and
/// whether it tripped (docs/probing.md); zeros and 0 before the first probe move. In `$#` and
/// sent by itself when a probe move ends.
pub fn probe(out: &mut Out, board: &Board, prefs: &Prefs) {
    let axes = usize::from(board.setup().axis_count);
    let probe = board.probe_result();
    out.str("[PRB:");
    position(
        out,
        &probe.map_or([0; crate::units::MAX_AXES], |p| p.position),
        axes,
        prefs,
    );
    out.str(if probe.is_some_and(|p| p.success) {
        ":1]"
    } else {
        ":0]"
    });
    out.eol();
}

/// `$I`: version and options (`V` variable spindle; planner blocks; RX buffer bytes).
pub(crate) fn build_info(out: &mut Out) {
    out.line("[VER:1.1h.20190830:Gantry]");
    out.str("[OPT:V,");
    out.uint(PLANNER_BLOCKS as u64);
    out.byte(b',');
    out.uint(RX_SIZE as u64);
    out.byte(b']');
    out.eol();
}
