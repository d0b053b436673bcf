//! Every error code: a program that triggers it, the line/columns reported, no action from the
//! bad block, and an entry in docs/errors.md.
#![allow(clippy::field_reassign_with_default, clippy::type_complexity)]

use gantry_machine::canon::Canon;
use gantry_machine::gcode::{
    ErrorCode, GcodeError, InterpConfig, Interpreter, MemorySource, ProgramSource, SourceError,
};

fn run_src(src: &mut impl ProgramSource, cfg: &InterpConfig) -> Vec<Result<Canon, GcodeError>> {
    let mut it = Interpreter::new(cfg);
    let mut out = Vec::new();
    while let Some(x) = it.next(src) {
        let stop = x.is_err();
        out.push(x);
        if stop || out.len() > 10_000 {
            break;
        }
    }
    out
}

fn cfg_default() -> InterpConfig {
    let mut c = InterpConfig::default();
    for code in 100..=105 {
        c.add_user_m_code(code);
    }
    c
}

fn cfg_gixa() -> InterpConfig {
    InterpConfig::gixa()
}

/// A machine with an oriented spindle stop (G76 runs).
fn cfg_orient() -> InterpConfig {
    let mut c = InterpConfig::default();
    c.spindle_orient = true;
    c
}

fn cfg_3axis() -> InterpConfig {
    let mut c = InterpConfig::default();
    c.axis_count = 3;
    c
}

/// (program, setup, expected code, expected columns of the blamed word on the last line)
type Case = (
    &'static str,
    fn() -> InterpConfig,
    ErrorCode,
    Option<(u16, u16)>,
);

const CASES: &[Case] = &[
    (
        "G0 $1",
        cfg_default,
        ErrorCode::UnexpectedCharacter,
        Some((3, 4)),
    ),
    (
        "G0 X[1 + ]",
        cfg_default,
        ErrorCode::ExpressionSyntax,
        Some((9, 10)),
    ),
    (
        "G0 X[EXP[100]]",
        cfg_default,
        ErrorCode::ExpressionOverflow,
        Some((5, 6)),
    ),
    (
        "G0 X[1/0]",
        cfg_default,
        ErrorCode::DivisionByZero,
        Some((6, 7)),
    ),
    (
        "G0 X[SQRT[-1]]",
        cfg_default,
        ErrorCode::FunctionDomain,
        Some((5, 6)),
    ),
    (
        "G0 X#<nope>",
        cfg_default,
        ErrorCode::UndefinedParameter,
        Some((4, 5)),
    ),
    (
        "#0 = 1",
        cfg_default,
        ErrorCode::ParameterNumberInvalid,
        Some((0, 1)),
    ),
    (
        "o7 endwhile",
        cfg_default,
        ErrorCode::UnbalancedBlock,
        Some((0, 2)),
    ),
    ("o9 call", cfg_default, ErrorCode::UnknownSubroutine, None),
    (
        "M72",
        cfg_default,
        ErrorCode::NoSavedModalState,
        Some((0, 3)),
    ),
    ("G0 X", cfg_default, ErrorCode::MissingNumber, Some((3, 4))),
    (
        "G0 (a (b) X1",
        cfg_default,
        ErrorCode::NestedComment,
        Some((6, 7)),
    ),
    (
        "%\nG0 X1\n % vfd enable\nG0 X2\n%",
        cfg_default,
        ErrorCode::UnexpectedCharacter,
        Some((1, 2)),
    ),
    (
        "G0 (abc",
        cfg_default,
        ErrorCode::UnclosedComment,
        Some((3, 7)),
    ),
    (
        "G0 X9999999",
        cfg_default,
        ErrorCode::NumberOutOfRange,
        Some((3, 11)),
    ),
    (
        "G1 X1 F10",
        cfg_gixa,
        ErrorCode::BadWordFormat,
        Some((0, 2)),
    ),
    ("X1 X2", cfg_default, ErrorCode::RepeatedWord, Some((3, 5))),
    (
        "G0 G1 X1",
        cfg_default,
        ErrorCode::ModalGroupConflict,
        Some((3, 5)),
    ),
    (
        "M3 M4",
        cfg_default,
        ErrorCode::MCodeGroupConflict,
        Some((3, 5)),
    ),
    ("G12 X1", cfg_default, ErrorCode::UnknownGCode, Some((0, 3))),
    ("M77", cfg_default, ErrorCode::UnknownMCode, Some((0, 3))),
    ("F-1", cfg_default, ErrorCode::ValueOutOfRange, Some((0, 3))),
    ("T1.5", cfg_default, ErrorCode::NotAnInteger, Some((0, 4))),
    (
        "M100 M101 M102 M103 M104 M105",
        cfg_default,
        ErrorCode::TooManyMCodes,
        Some((25, 29)),
    ),
    (
        "G28 G1 X0",
        cfg_default,
        ErrorCode::AxisWordsConflict,
        Some((4, 6)),
    ),
    (
        "G80 X1",
        cfg_default,
        ErrorCode::AxisWordsWithoutMotion,
        Some((4, 6)),
    ),
    // The first axis word in X Y Z A B C @ ^ order is blamed, wherever it is written.
    (
        "G80 B1 Y2 A3",
        cfg_default,
        ErrorCode::AxisWordsWithoutMotion,
        Some((7, 9)),
    ),
    (
        "G80 ^1 C2 B3",
        cfg_default,
        ErrorCode::AxisWordsWithoutMotion,
        Some((10, 12)),
    ),
    ("G0 X1 Q2", cfg_default, ErrorCode::UnusedWord, Some((6, 8))),
    (
        "G0 A1",
        cfg_3axis,
        ErrorCode::AxisNotConfigured,
        Some((3, 5)),
    ),
    ("G1 X1", cfg_default, ErrorCode::ZeroFeedRate, None),
    ("G2 X1 F1", cfg_default, ErrorCode::ArcCenterMissing, None),
    (
        "G2 X1 R1 I1 F1",
        cfg_default,
        ErrorCode::ArcMixedFormats,
        Some((6, 8)),
    ),
    (
        "G2 X1 K1 F1",
        cfg_default,
        ErrorCode::ArcOffsetWrongPlane,
        Some((6, 8)),
    ),
    (
        "G2 X10 R4 F1",
        cfg_default,
        ErrorCode::ArcRadiusTooSmall,
        Some((7, 9)),
    ),
    (
        "G2 X10 I3 F1",
        cfg_default,
        ErrorCode::ArcRadiusMismatch,
        Some((7, 9)),
    ),
    (
        "G2 I0.0001 F1",
        cfg_default,
        ErrorCode::ArcZeroRadius,
        Some((3, 10)),
    ),
    (
        "G2 X0 R5 F1",
        cfg_default,
        ErrorCode::ArcEndEqualsStart,
        Some((6, 8)),
    ),
    (
        "G2 Z1 R5 F1",
        cfg_default,
        ErrorCode::ArcEndPointMissing,
        Some((6, 8)),
    ),
    (
        "G2 X10 I5 P0 F1",
        cfg_default,
        ErrorCode::ArcTurnsInvalid,
        Some((10, 12)),
    ),
    (
        "G93 G1 X1",
        cfg_default,
        ErrorCode::InverseTimeFeedMissing,
        None,
    ),
    (
        "G91 G0 X999999",
        cfg_default,
        ErrorCode::CoordinateOverflow,
        Some((7, 14)),
    ),
    (
        "G90.1 G2 X10 I5 F1",
        cfg_default,
        ErrorCode::ArcAbsoluteCenterMissing,
        None,
    ),
    (
        "G5 X1 Y1 I1 J0 F100",
        cfg_default,
        ErrorCode::SplineWordMissing,
        Some((0, 2)),
    ),
    (
        "G81 X1 Z-1 F1",
        cfg_default,
        ErrorCode::CycleRMissing,
        Some((0, 3)),
    ),
    (
        "G81 X1 R1 F1",
        cfg_default,
        ErrorCode::CycleDepthMissing,
        Some((0, 3)),
    ),
    (
        "G81 X1 R-2 Z-1 F1",
        cfg_default,
        ErrorCode::CycleRBelowBottom,
        Some((7, 10)),
    ),
    (
        "G83 X1 R1 Z-1 F1",
        cfg_default,
        ErrorCode::CycleQInvalid,
        Some((0, 3)),
    ),
    (
        "G82 X1 R1 Z-1 F1",
        cfg_default,
        ErrorCode::CycleDwellMissing,
        Some((0, 3)),
    ),
    (
        "G84 X1 R1 Z-1 F1",
        cfg_default,
        ErrorCode::CycleSpindleState,
        Some((0, 3)),
    ),
    (
        "G93 G81 X1 R1 Z-1 F1",
        cfg_default,
        ErrorCode::CycleInverseTime,
        Some((4, 7)),
    ),
    (
        "G81 X1 A1 R1 Z-1 F1",
        cfg_default,
        ErrorCode::CycleRotaryAxis,
        Some((7, 9)),
    ),
    (
        "G81 X1 R1 Z-1 K1.5 F1",
        cfg_default,
        ErrorCode::CycleRepeatInvalid,
        Some((14, 18)),
    ),
    (
        "G87 X1 R1 Z-1 Q0.1 F1",
        cfg_gixa,
        ErrorCode::CyclePeckNotAboveRetract,
        Some((14, 18)),
    ),
    (
        "G73 X1 R1 Z-1 Q1 F1",
        cfg_gixa,
        ErrorCode::CycleNotSupported,
        Some((0, 3)),
    ),
    (
        "M3 S100 G87 X1 R1 Z-1 I0.1 J0 F1",
        cfg_default,
        ErrorCode::CycleBackBoreWordMissing,
        Some((8, 11)),
    ),
    (
        "M3 S100 G76 X1 R1 Z-1 I0.1 F1",
        cfg_default,
        ErrorCode::CycleNotSupported,
        Some((8, 11)),
    ),
    (
        "M3 S100 G76 X1 R1 Z-1 Q0.1 F1",
        cfg_orient,
        ErrorCode::CycleFineBoreQ,
        Some((22, 26)),
    ),
    (
        "G10 L3 P1 X1",
        cfg_default,
        ErrorCode::G10Invalid,
        Some((4, 6)),
    ),
    (
        "G43 H7",
        cfg_default,
        ErrorCode::ToolNotInTable,
        Some((4, 6)),
    ),
    (
        "G91 G53 G0 X1",
        cfg_default,
        ErrorCode::G53Invalid,
        Some((4, 7)),
    ),
    (
        "G41.1 D1 G2 X1 Y1 R1 F1",
        cfg_default,
        ErrorCode::CutterCompNotSupported,
        None,
    ),
    (
        "G41.1 D1\nG42.1 D1",
        cfg_default,
        ErrorCode::CompAlreadyOn,
        Some((0, 5)),
    ),
    (
        "G41.1 D1\nG18",
        cfg_default,
        ErrorCode::CompPlane,
        Some((0, 3)),
    ),
    (
        "G41.1 D1\nG92 X0",
        cfg_default,
        ErrorCode::CompForbidden,
        Some((0, 3)),
    ),
    (
        "G41.1 D2 G1 X0.5 F1",
        cfg_default,
        ErrorCode::CompEntryTooShort,
        None,
    ),
    (
        "G41.1 D2 G1 X10 F1\nG3 X11 Y1 I0 J1",
        cfg_default,
        ErrorCode::CompArcTooSmall,
        None,
    ),
    (
        "G41.1 D2 G1 X10 F1\nX20\nY0.5\nX0",
        cfg_default,
        ErrorCode::CompGouge,
        None,
    ),
    (
        "G41.1 D2 G1 X10 F1\nX20\nG40 G2 X30 R5",
        cfg_default,
        ErrorCode::CompArcAfterExit,
        None,
    ),
    (
        "G41.1 D2 G1 X10 F1\nM3 S1\nM4\nM5\nM7\nM8\nM9",
        cfg_default,
        ErrorCode::CompLookAheadFull,
        None,
    ),
    (
        "G41.1 G1 X10 F1",
        cfg_default,
        ErrorCode::CompDiameterMissing,
        Some((0, 5)),
    ),
    (
        "G68 R30\nG68 R10",
        cfg_default,
        ErrorCode::TransformOrder,
        Some((0, 3)),
    ),
    (
        "G68 R30\nG18",
        cfg_default,
        ErrorCode::TransformPlane,
        Some((0, 3)),
    ),
    (
        "G51 I.5 J2\nG2 X1 I.5 F1",
        cfg_default,
        ErrorCode::TransformArcScaled,
        None,
    ),
    (
        "G51.1 X5\nG92 X0",
        cfg_default,
        ErrorCode::TransformOffset,
        Some((0, 3)),
    ),
    (
        "G51 P2 F100",
        cfg_default,
        ErrorCode::TransformNotAlone,
        Some((0, 3)),
    ),
    (
        "G51 X0",
        cfg_default,
        ErrorCode::TransformValue,
        Some((0, 3)),
    ),
    ("G4", cfg_default, ErrorCode::DwellTimeMissing, Some((0, 2))),
    (
        "G10 L2 P1 R5",
        cfg_default,
        ErrorCode::NotSupported,
        Some((10, 12)),
    ),
    (
        "G92",
        cfg_default,
        ErrorCode::MissingAxisWords,
        Some((0, 3)),
    ),
    (
        "G38.2 Z0 F100",
        cfg_default,
        ErrorCode::ProbeZeroLength,
        Some((0, 5)),
    ),
    (
        "G93 G38.3 Z-1 F100",
        cfg_default,
        ErrorCode::ProbeInverseTime,
        Some((4, 9)),
    ),
    (
        "M98 P9",
        cfg_default,
        ErrorCode::UnknownProgram,
        Some((4, 6)),
    ),
    (
        "M98 P5\nM30\nO5\nM99\nO0005\nM99",
        cfg_default,
        ErrorCode::DuplicateProgram,
        Some((4, 6)),
    ),
    (
        "M98 P1\nM30\nO1\nM98 P1",
        cfg_default,
        ErrorCode::NestingTooDeep,
        Some((0, 3)),
    ),
    (
        "M98",
        cfg_default,
        ErrorCode::SubprogramPMissing,
        Some((0, 3)),
    ),
    (
        "M98 P1\nM30\nO1\nG0 X1",
        cfg_default,
        ErrorCode::SubprogramWithoutM99,
        None,
    ),
    (
        "M98 P1 L20000\nM30\nO1\nM99",
        cfg_default,
        ErrorCode::EndlessLoop,
        Some((0, 3)),
    ),
];

#[test]
fn every_error_code_is_reachable_and_blames_the_right_word() {
    let mut seen = Vec::new();
    for &(program, cfg, code, cols) in CASES {
        let text = format!("G00 X0\n{program}\n");
        let out = run_src(&mut MemorySource::new(text.as_bytes()), &cfg());
        let e = out
            .iter()
            .find_map(|r| r.as_ref().err())
            .unwrap_or_else(|| panic!("no error for {program:?}: {out:?}"));
        assert_eq!(e.code, code, "program {program:?}");
        if !matches!(
            code,
            ErrorCode::SubprogramWithoutM99
                | ErrorCode::DuplicateProgram
                | ErrorCode::UnknownSubroutine
        ) {
            assert_eq!(e.columns, cols, "columns for {program:?}");
        }
        // The bad block produced no action (end of file inside a subprogram is not a block error).
        if !matches!(
            code,
            ErrorCode::SubprogramWithoutM99 | ErrorCode::UnknownSubroutine
        ) {
            assert!(
                out.iter()
                    .filter_map(|r| r.as_ref().ok())
                    .all(|c| c.line != e.line),
                "action from the bad block of {program:?}: {out:?}"
            );
        }
        seen.push(code);
    }
    // The jump failure needs a source that cannot jump.
    struct NoJump<'a>(MemorySource<'a>);
    impl ProgramSource for NoJump<'_> {
        fn next_line(&mut self) -> Option<(u32, &[u8])> {
            self.0.next_line()
        }
        fn jump_to_program(&mut self, p: u32) -> Result<u32, SourceError> {
            self.0.jump_to_program(p)
        }
        fn jump_to_sequence(&mut self, n: u32) -> Result<u32, SourceError> {
            self.0.jump_to_sequence(n)
        }
        fn jump_to_line(&mut self, _: u32) -> Result<(), SourceError> {
            Err(SourceError::NoSuchLine)
        }
    }
    let out = run_src(
        &mut NoJump(MemorySource::new(b"G0 X1\nM99\n")),
        &cfg_default(),
    );
    let e = out.last().unwrap().as_ref().unwrap_err();
    assert_eq!(
        (e.code, e.line, e.columns),
        (ErrorCode::SourceJumpFailed, 2, Some((0, 3)))
    );
    seen.push(e.code);
    // The parameter table holds 96 numbered parameters: the 97th is refused on its line.
    let program: String = (1..=97).map(|n| format!("#{n} = 1\n")).collect();
    let out = run_src(&mut MemorySource::new(program.as_bytes()), &cfg_default());
    let e = out.last().unwrap().as_ref().unwrap_err();
    assert_eq!((e.code, e.line), (ErrorCode::ParameterTableFull, 97));
    seen.push(e.code);
    for code in ErrorCode::ALL {
        assert!(seen.contains(code), "no test case for {code:?}");
    }
}

#[test]
fn codes_are_unique_and_documented() {
    let doc = include_str!("../../docs/errors.md");
    let mut numbers: Vec<u16> = ErrorCode::ALL.iter().map(|c| c.number()).collect();
    for code in ErrorCode::ALL {
        let row = format!("| E{} |", code.number());
        assert!(doc.contains(&row), "docs/errors.md lacks {row}");
        assert!(
            doc.contains(code.message()),
            "docs/errors.md lacks the message of {code:?}"
        );
    }
    numbers.sort();
    numbers.dedup();
    assert_eq!(numbers.len(), ErrorCode::ALL.len());
}

#[test]
fn n_word_is_reported_even_for_lexical_errors() {
    let out = run_src(&mut MemorySource::new(b"N70 G0 X\n"), &cfg_default());
    let e = out[0].as_ref().unwrap_err();
    assert_eq!(
        (e.line, e.n_word, e.code),
        (1, Some(70), ErrorCode::MissingNumber)
    );
}
