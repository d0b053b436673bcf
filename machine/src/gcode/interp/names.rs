//! LinuxCNC's predefined named parameters that read the modal state (`#<_x>`, `#<_feed>`,
//! `#<_motion_mode>`, …; docs/gcode-parameters.md "Predefined named parameters"): global and
//! read-only, each computed from the interpreter's state when it is read. Values follow
//! LinuxCNC's `rs274` (tests/golden/rs274/147-predefined-named-parameters).

use super::*;

/// What a predefined name reads.
#[derive(Clone, Copy)]
enum Reads {
    /// The numbered parameter that holds the same value (#5400 the tool, #5420-#5425 the
    /// position in program coordinates).
    Numbered(u16),
    /// The position of axis `i` in machine coordinates (G53), program units.
    Machine(usize),
    /// F as written, S.
    Feed,
    Rpm,
    /// The G code ×10 of the motion mode, the plane and the coordinate system.
    MotionMode,
    Plane,
    CoordSystem,
    /// A 0/1 flag of the modal state.
    Flag(fn(&ModalState) -> bool),
}

const fn name(text: &[u8], reads: Reads) -> (u32, Reads) {
    (expr::name_hash(text), reads)
}

/// The names (hashed as `#<name>` is) and what each reads.
const NAMES: [(u32, Reads); 29] = [
    name(b"_x", Reads::Numbered(5420)),
    name(b"_y", Reads::Numbered(5421)),
    name(b"_z", Reads::Numbered(5422)),
    name(b"_a", Reads::Numbered(5423)),
    name(b"_b", Reads::Numbered(5424)),
    name(b"_c", Reads::Numbered(5425)),
    name(b"_abs_x", Reads::Machine(0)),
    name(b"_abs_y", Reads::Machine(1)),
    name(b"_abs_z", Reads::Machine(2)),
    name(b"_abs_a", Reads::Machine(3)),
    name(b"_abs_b", Reads::Machine(4)),
    name(b"_abs_c", Reads::Machine(5)),
    name(b"_current_tool", Reads::Numbered(5400)),
    name(b"_feed", Reads::Feed),
    name(b"_rpm", Reads::Rpm),
    name(b"_motion_mode", Reads::MotionMode),
    name(b"_plane", Reads::Plane),
    name(b"_coord_system", Reads::CoordSystem),
    name(b"_metric", Reads::Flag(|s| !s.inch)),
    name(b"_imperial", Reads::Flag(|s| s.inch)),
    name(b"_absolute", Reads::Flag(|s| s.absolute)),
    name(b"_incremental", Reads::Flag(|s| !s.absolute)),
    name(b"_inverse_time", Reads::Flag(|s| s.inverse_time)),
    name(b"_units_per_minute", Reads::Flag(|s| !s.inverse_time)),
    name(b"_ijk_absolute_mode", Reads::Flag(|s| s.arc_absolute)),
    name(b"_spindle_on", Reads::Flag(|s| s.spindle != Spindle::Off)),
    name(b"_spindle_cw", Reads::Flag(|s| s.spindle == Spindle::Cw)),
    name(b"_mist", Reads::Flag(|s| s.mist)),
    name(b"_flood", Reads::Flag(|s| s.flood)),
];

/// What name `p` reads, if it is one of [`NAMES`].
fn reads(p: ParamRef) -> Option<Reads> {
    match p {
        ParamRef::Named { hash, global: true } => {
            NAMES.iter().find(|(h, _)| *h == hash).map(|&(_, r)| r)
        }
        _ => None,
    }
}

/// True for a predefined name (read-only).
pub(super) fn is_predefined(p: ParamRef) -> bool {
    reads(p).is_some()
}

/// The value of predefined name `p` in state `s` (`None`: not one); `numbered` reads a
/// numbered parameter.
pub(super) fn read(
    p: ParamRef,
    s: &ModalState,
    numbered: impl Fn(u16) -> Result<Fx, ErrorCode>,
) -> Option<Result<Fx, ErrorCode>> {
    let g = |code: u16| Ok(Fx::from(code) * ONE);
    Some(match reads(p)? {
        Reads::Numbered(n) => numbered(n),
        Reads::Machine(i) => Ok(super::super::params::nm_to_fx(
            s.position.get(i).copied().unwrap_or(0),
            s.inch,
        )),
        // F in program units ×10^6 → ×10^9.
        Reads::Feed => Ok(s.feed * 1000),
        Reads::Rpm => Ok(Fx::from(s.rpm) * ONE),
        Reads::MotionMode => g(match s.motion {
            MotionMode::Rapid => 0,
            MotionMode::Linear => 10,
            MotionMode::ArcCw => 20,
            MotionMode::ArcCcw => 30,
            MotionMode::None => 800,
            MotionMode::Cycle(c) | MotionMode::Probe(c) | MotionMode::Spline(c) => c,
        }),
        Reads::Plane => g(match s.plane {
            Plane::XY => 170,
            Plane::ZX => 180,
            Plane::YZ => 190,
        }),
        // G54-G59 are 540-590, G59.1-G59.3 591-593.
        Reads::CoordSystem => g(match s.work_system {
            w @ 0..=5 => 540 + 10 * u16::from(w),
            w => 585 + u16::from(w),
        }),
        Reads::Flag(f) => Ok(if f(s) { ONE } else { 0 }),
    })
}
