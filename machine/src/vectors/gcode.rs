//! Cross-target vectors: embedded programs interpreted and every action (and error) digested.
//!
//! The host test in `vectors/mod.rs` and the QEMU Cortex-M4 harness run the same functions; equal
//! digests prove the interpreter bit-identical on both instruction sets.

use super::{Digest, Vector};
use crate::canon::{Action, ArcDir, Plane, Spindle, StopKind};
use crate::gcode::config::{DwellUnits, InterpConfig};
use crate::gcode::Interpreter;
use crate::gcode::MemorySource;

/// Interprets `program` with `config` and digests every action and error.
pub fn digest_program(program: &[u8], config: &InterpConfig) -> u32 {
    let mut interp = Interpreter::new(config);
    let mut src = MemorySource::new(program);
    let mut d = Digest::new();
    let mut count: u64 = 0;
    while let Some(item) = interp.next(&mut src) {
        count += 1;
        match item {
            Ok(c) => {
                d.u64(c.line as u64);
                digest_action(&mut d, &c.action);
            }
            Err(e) => {
                d.bytes(b"E");
                d.u64(e.line as u64);
                d.u64(e.code.number() as u64);
                let (a, b) = e.columns.unwrap_or((0, 0));
                d.u64(((a as u64) << 16) | b as u64);
            }
        }
        if count > 100_000 {
            break;
        }
    }
    d.u64(count);
    for v in interp.state().position {
        d.i64(v);
    }
    d.finish()
}

fn digest_action(d: &mut Digest, a: &Action) {
    match *a {
        Action::Rapid { to } => {
            d.bytes(b"r");
            to.iter().for_each(|&v| d.i64(v));
        }
        Action::Feed { to, feed } => {
            d.bytes(b"f");
            to.iter().for_each(|&v| d.i64(v));
            d.i64(feed);
        }
        Action::Arc {
            to,
            center,
            plane,
            dir,
            turns,
            feed,
        } => {
            d.bytes(b"a");
            to.iter().for_each(|&v| d.i64(v));
            center.iter().for_each(|&v| d.i64(v));
            d.bytes(&[
                match plane {
                    Plane::XY => 0,
                    Plane::ZX => 1,
                    Plane::YZ => 2,
                },
                match dir {
                    ArcDir::Cw => 0,
                    ArcDir::Ccw => 1,
                },
            ]);
            d.u64(turns as u64);
            d.i64(feed);
        }
        Action::Probe { to, feed, mode } => {
            d.bytes(&[b'P', mode.toward as u8, mode.must_trip as u8]);
            for v in to {
                d.i64(v);
            }
            d.i64(feed);
        }
        Action::Dwell { micros } => {
            d.bytes(b"d");
            d.u64(micros);
        }
        Action::Spindle { state, rpm } => {
            d.bytes(b"s");
            d.bytes(&[match state {
                Spindle::Off => 0,
                Spindle::Cw => 1,
                Spindle::Ccw => 2,
            }]);
            d.u64(rpm as u64);
        }
        Action::SpindleOrient => d.bytes(b"o"),
        Action::Coolant { mist, flood } => d.bytes(&[b'c', mist as u8, flood as u8]),
        Action::ToolChange { tool } => {
            d.bytes(b"t");
            d.u64(tool as u64);
        }
        Action::UserMCode { code, .. } => {
            d.bytes(b"m");
            d.u64(code as u64);
        }
        Action::PathMode(mode) => {
            d.bytes(b"p");
            match mode {
                crate::canon::PathMode::ExactStop => d.i64(-1),
                crate::canon::PathMode::Blend { tolerance } => d.i64(tolerance),
            }
        }
        Action::Stop(kind) => d.bytes(&[
            b'S',
            match kind {
                StopKind::Pause => 0,
                StopKind::OptionalPause => 1,
                StopKind::End => 2,
                StopKind::EndRewind => 3,
            },
        ]),
    }
}

const ARCS: &[u8] =
    b"G21 G90 G17\nG0 X10 Y0 Z0\nG3 X0 Y10 I-10 J0 F600\nX-10 Y0 I0 J-10\nG2 X10 Y0 R-10\n\
G2 X20 Y0 R5.000001\nG3 X20 Y0 Z-5 I-10 P2\nG18 G0 X10 Y0 Z0\nG2 X0 Z10 I-10 K0\nG19 G0 Y10 Z0\n\
G3 Y0 Z10 J-10 K0\nG17 G0 X0 Y0 Z0\nG2 X3.3333 Y-7.7777 R9.1\nG93 G3 X5 Y5 R7 F3\n\
G94 G2 X7 Y7 I1 J1 F123.456\nG2 X10 Y10 I3 F10\nM30\n";

const CYCLES: &[u8] = b"G21 G90 G17 G0 X0 Y0 Z10\nM3 S1200\nG91 G99 G81 X10 Z-5 R-8 K3 F100\nG90 G98 G83 X1 Y2 Z-10 R1 Q4\n\
X3\nG73 X4 Z-3.3 R0.5 Q0.7\nG82 X5 Z-2 R1 P0.25\nG84 X6 Z-4 R2 F80\nG85 X7 Z-1 R1\nG86 X8 Z-1 R1 P0\n\
G89 X9 Z-1 R1 P1.5\nG18 G81 X1 Z1 Y-2 R1\nG80\nG0 X0 Y0\nG81 X1 Z-1\nM30\n";

const INCH_OFFSETS: &[u8] = b"G20 G90\nG10 L2 P1 X1 Y2 Z-0.5\nG10 L2 P2 X-3.25\nG0 X0 Y0 Z0\nG55 G0 X0.0001\nG92 X0 Y0\n\
G1 X1.23456 Y-0.00001 F12.5\nG92.2\nG0 X0\nG92.3\nG0 X0\nG43 H2\nG0 Z0\nG91 G28 Z0\nG90 G53 G0 X-1\n\
G10 L20 P3 X5\nG56 G0 X0\nG21 G54 G0 X1\nG4 P0.5\nG64 P0.01\nG61\nM30\n";

const SUBPROGRAMS: &[u8] =
    b"%\nO1000 (main)\nG90 G0 X0 Y0\nM98 P2001 L3\nM98 P32002\nM6 T1\nM7 M8\nM101\nM1\nM9\n\
/G0 X99\nM30\nO2001\nG91 G1 X1 F200\nM98 P2002\nG90\nM99\nO2002\nG91 G0 Y0.5\nG90\nM99\n%\n";

const ERRORS_AND_GIXA: &[u8] =
    b"G0 X1\nG1 X2\nG2 X10 R4 F10\nG1 X1 X2\nM98 P77\nG81 X1 Z-1\nG41 G1 X1\n\
G0 X0 Y0\nG2 X10 I3 F10\nG0 X$\nG0 (\nM30\n";

const GIXA: &[u8] =
    b"G00 Z5\nG04 P25\nN200 G81 X1.5 Y2.0 R.5 Z2 F20 M03 G99 G91\nN201 X1 G98\nN202 G80\n\
G90 G87 X0 Y0 R0 Z-2 Q1 F50\nG80\nG18\nG02 X0 Z10 I-10 J0 F100\nG17\nG88 X1 Y1\nX2\nG80\n\
M98 P900 L2\nM30\nN900 G91 G00 X1 ; sub\nM99\n";

const PARAMETRIC: &[u8] = b"G21 G90 G17\n#1 = 0\n#<_r> = 12.5\no100 sub\n  G1 X[#<_r> * COS[#1]] Y[#<_r> * SIN[#1]] Z#2 F[#3 ** 2]\n\
o100 endsub\no1 while [#1 LT 360]\n  o100 call [#1] [-[#1 / 360]] [ROUND[SQRT[90000]]]\n  #1 = [#1 + 37.5]\no1 endwhile\n\
o2 do\n  #1 = [#1 - 100]\n  o3 if [#1 MOD 2 EQ 0 AND #1 GT 100]\n    o2 continue\n  o3 elseif [#1 LT 0]\n    o2 break\n\
  o3 endif\n  G0 X[ATAN[#1]/[7]] Y[EXP[#1 / 200]] Z[LN[#1 + 1]]\no2 while [1]\no4 repeat [3]\n\
  G2 X[#5420 + 1] Y#5421 I0.5 J0\no4 endrepeat\nG0 X[ASIN[0.3]] Y[ACOS[-0.7]] Z[TAN[-33.3]]\n\
G0 X[FIX[-2.5] + FUP[2.1]] Y[ABS[-3] XOR 0] Z[#<_r> LE 12.5]\nG0 X[1/0]\nM30\n";

/// Every expression function over a sweep of inputs, digested (errors as their code).
fn functions() -> u32 {
    use crate::gcode::expr::{self, ONE};
    let mut d = Digest::new();
    let mut put = |r: Result<i64, crate::gcode::ErrorCode>| match r {
        Ok(v) => d.i64(v),
        Err(e) => d.u64(e.number() as u64),
    };
    let mut x: i64 = -725 * ONE;
    while x <= 725 * ONE {
        let (c, s) = expr::sin_cos_deg(x);
        put(Ok(c));
        put(Ok(s));
        put(Ok(expr::atan_deg(x, 3 * ONE)));
        put(expr::sqrt(x));
        put(expr::exp(x / 40));
        put(expr::ln(x));
        put(expr::asin_deg(x / 725));
        put(expr::acos_deg(x / 700));
        put(expr::pow(x / 100, 3 * ONE / 2));
        put(expr::div(ONE, x));
        x += 3_141_592_653;
    }
    d.finish()
}

fn parametric() -> u32 {
    digest_program(PARAMETRIC, &InterpConfig::default())
}

fn arcs() -> u32 {
    digest_program(ARCS, &InterpConfig::default())
}

fn cycles() -> u32 {
    let cfg = InterpConfig {
        peck_clearance: 500_000,
        ..InterpConfig::default()
    };
    digest_program(CYCLES, &cfg)
}

fn inch_offsets() -> u32 {
    let mut cfg = InterpConfig::default();
    cfg.set_tool(2, 12_345_678);
    cfg.g28_position = [1, 2, 3, 0, 0, 0];
    cfg.work_offsets[0] = [100_000_000, -50_000_000, 0, 0, 0, 0];
    cfg.dwell_units = DwellUnits::FanucIntegerMillis;
    digest_program(INCH_OFFSETS, &cfg)
}

fn subprograms() -> u32 {
    let mut cfg = InterpConfig::default();
    cfg.add_user_m_code(101);
    cfg.optional_stop = true;
    cfg.block_delete = true;
    digest_program(SUBPROGRAMS, &cfg)
}

fn errors() -> u32 {
    digest_program(ERRORS_AND_GIXA, &InterpConfig::default())
}

/// Cutter compensation: entry, convex arcs, concave trims (line-line, line-arc, arc-line,
/// arc-arc), Z moves held back, G18, exit, and polar coordinates in a G91 bolt circle.
const CUTTER_COMP: &[u8] = b"G21 G90 G17\nG0 X10 Y-10\nG41.1 D5.08 G1 X10 Y0 F200\nX50\n\
G3 X50 Y30 R15\nG1 X35\nG2 X25 Y30 R5\nG1 X10\nG3 X10 Y0 R15\nG1 Z-1\nG40 G1 X10 Y-10\n\
G42.1 D3 X0 Y0\nY40\nX40\nY0\nX0\nG40 X-10 Y-10\nG18\nG42.1 D4 G1 X10 Z0\nZ-10\n\
G2 X15 Z-15 I5 K0\nG1 X20 Z-20\nG40 G0 X30\nG17 G0 X38.1 Y0\nG91 G81 R1 Z-3 ^60 L6\nG90 G80 G0 @10 ^45\nM2\n";

fn cutter_comp() -> u32 {
    digest_program(CUTTER_COMP, &InterpConfig::default())
}

fn gixa() -> u32 {
    digest_program(GIXA, &InterpConfig::gixa())
}

/// The transform pipeline (docs/gcode-transforms.md): an arc mirrored about X5, doubled and
/// turned 90 deg (tests/golden/transforms/07-pipeline-arc), an incremental arc under it, a
/// rotation by -33.3 deg about 1,2 with a G16 polar end point, a scaled cycle.
const TRANSFORMED: &[u8] = b"G21 G90 G17\nG0 X0 Y0 Z0\nG51.1 X5.\nG51 X0 Y0 P2.\nG68 X0 Y0 R90.\n\
G1 X10. Y0 F600\nG3 X0 Y10. R10.\nG91 G2 X-3.3 Y1.7 R2.5\nG90 G69\nG50\nG50.1\nG68 X1. Y2. R-33.3\n\
G16 G1 X12.5 Y40.\nG15 G69\nG51 X1 Y1 I1.5 J1.5 K.5\nG98 G81 X3 Y-2 Z-1 R1 F300\nG80 G50\nG0 X0 Y0 Z0\nM2\n";

/// [`TRANSFORMED`] interpreted (every action digested) and its moves stepped by the motion
/// core (every step event digested): the board computes the same steps as the host.
fn transformed_arc() -> u32 {
    use crate::motion::config::MotionConfig;
    use crate::motion::sim::{Feeder, Sim, SimEvent};
    let mut interp = Interpreter::new(&InterpConfig::default());
    let mut src = MemorySource::new(TRANSFORMED);
    let mut d = Digest::new();
    let mut moves = [None; 24];
    let mut n = 0;
    while let Some(item) = interp.next(&mut src) {
        match item {
            Ok(c) => {
                d.u64(c.line as u64);
                digest_action(&mut d, &c.action);
                if matches!(
                    c.action,
                    Action::Rapid { .. } | Action::Feed { .. } | Action::Arc { .. }
                ) && n < moves.len()
                {
                    moves[n] = Some(c);
                    n += 1;
                }
            }
            Err(e) => d.u64(e.code.number() as u64),
        }
    }
    let mut sim: Sim<48> = Sim::new(MotionConfig::default());
    let mut feeder = Feeder::new(moves.into_iter().flatten());
    let mut on = |e: SimEvent| {
        if let SimEvent::Step(s) = e {
            d.u64(s.time);
            d.bytes(&[s.step, s.dir]);
        }
    };
    let mut idle = 0;
    while idle < 4 {
        let _ = feeder.feed(&mut sim);
        if sim.tick(&mut on).period == 0 && feeder.exhausted() {
            idle += 1;
        } else {
            idle = 0;
        }
    }
    for p in sim.kernel.position() {
        d.i64(p);
    }
    d.u64(n as u64);
    d.finish()
}

/// Cross-target vectors of the interpreter (see [`crate::vectors`]).
/// LinuxCNC's own idioms (tests/golden/rs274/133-143, tests/golden/g5): polar words with
/// expressions, a computed O-word call, a return value, M73 auto-restore, the DEBUG switch, a
/// G5 cubic and a G5.1 quadratic spline (integer biarcs), a 178° compensated turn into an arc.
const LINUXCNC_IDIOMS: &[u8] =
    b"G21 G90 G17 F100\n#5599 = 0\no20 sub\n  M73\n  G91 F300\n  G1 X1\n\
o20 endsub [#1 * 2]\n#1 = 2\no[#1 * 10] call [3]\nG1 X[#<_value>] Y[#<_value_returned>]\n\
G0 X0 Y0\nG1 @10 ^[360/6]\nG0 X0 Y0\nG5 I0 J10 P0 Q-10 X20 Y0\nG5 P0 Q10 X40 Y0\n\
G5.1 I5 J5 X50 Y0\nG0 X-30 Y-110\nG42.1 D0.5\nG1 X-39.500873 Y-104.657107\n\
G1 X-54.500873 Y-94.657107\nG2 I-1.575966 J-2.552711 X-57.872219 Y-99.613276\nG40\n\
G1 X-62.872219 Y-114.613276\nM2\n";

fn linuxcnc_idioms() -> u32 {
    digest_program(LINUXCNC_IDIOMS, &InterpConfig::default())
}

pub(crate) const VECTORS: &[Vector] = &[
    Vector {
        name: "gcode/arcs",
        run: arcs,
        expected: 0xb571_ee93,
    },
    Vector {
        name: "gcode/canned-cycles",
        run: cycles,
        expected: 0x6949_e643,
    },
    Vector {
        name: "gcode/inch-offsets",
        run: inch_offsets,
        expected: 0xa6c1_6add,
    },
    Vector {
        name: "gcode/subprograms",
        run: subprograms,
        expected: 0x7b53_7bf7,
    },
    Vector {
        name: "gcode/cutter-comp",
        run: cutter_comp,
        expected: 0x2b33_6dda,
    },
    Vector {
        name: "gcode/errors",
        run: errors,
        expected: 0x4d78_00f3,
    },
    Vector {
        name: "gcode/gixa",
        run: gixa,
        expected: 0xc2c4_e45d,
    },
    Vector {
        name: "gcode/expr-functions",
        run: functions,
        expected: 0xf691_6103,
    },
    Vector {
        name: "gcode/parametric",
        run: parametric,
        expected: 0xeebc_aa62,
    },
    Vector {
        name: "gcode/transformed-arc",
        run: transformed_arc,
        expected: 0xb6d9_ee01,
    },
    Vector {
        name: "gcode/linuxcnc-idioms",
        run: linuxcnc_idioms,
        expected: 0x3e73_e377,
    },
];
