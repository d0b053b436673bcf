//! Fanuc Macro B G65 macro calls (ngc dialect): argument specification I, a new level of locals
//! #1-#33 per call, M99 return, L repeats and nesting, with hand-checked positions.
#![allow(clippy::field_reassign_with_default)]
mod gcode_support;

use gantry_machine::gcode::{Dialect, ErrorCode, InterpConfig, Interpreter, MemorySource};
use gcode_support::{first_error, moves, MM};

#[test]
fn g65_arguments_follow_fanuc_specification_one() {
    // A→#1 B→#2 C→#3 I→#4 J→#5 K→#6 D→#7 E→#8 F→#9 H→#11 Q→#17 R→#18 S→#19 T→#20 U→#21 V→#22
    // W→#23 X→#24 Y→#25 Z→#26.
    let p = "G21 G90 G17\n\
             G65 P9010 A1 B2 C3 I4 J5 K6 D7 E8 F9 H11 Q17 R18 S19 T20 U21 V22 W23 X24 Y25 Z26\n\
             M30\n\
             O9010\n\
             G0 X#1 Y#2 Z#3\n\
             G0 X#4 Y#5 Z#6\n\
             G0 X#7 Y#8 Z#9\n\
             G0 X#11 Y#17 Z#18\n\
             G0 X#19 Y#20 Z#21\n\
             G0 X#22 Y#23 Z#24\n\
             G0 X#25 Y#26 Z[#10 + #12]\n\
             M99\n";
    let e = moves(p);
    let want: Vec<(u32, [i64; 3])> = vec![
        (5, [MM, 2 * MM, 3 * MM]),
        (6, [4 * MM, 5 * MM, 6 * MM]),
        (7, [7 * MM, 8 * MM, 9 * MM]),
        (8, [11 * MM, 17 * MM, 18 * MM]),
        (9, [19 * MM, 20 * MM, 21 * MM]),
        (10, [22 * MM, 23 * MM, 24 * MM]),
        // #10 and #12 have no argument letter: unset, 0.
        (11, [25 * MM, 26 * MM, 0]),
    ];
    assert_eq!(e, want);
}

#[test]
fn g65_gives_the_caller_its_locals_back_and_leaves_globals() {
    let p = "G21 G90\n\
             #1 = 7\n\
             #2 = 8\n\
             #100 = 0\n\
             G65 P20 A1.5 X-2.25\n\
             G0 X#1 Y#2 Z#100\n\
             M30\n\
             O20\n\
             G0 X#1 Y#24 Z#2\n\
             #100 = [#1 * 2]\n\
             #2 = 99\n\
             M99\n";
    assert_eq!(
        moves(p),
        vec![
            // In the macro: A1.5, X-2.25, #2 unset (0).
            (9, [1_500_000, -2_250_000, 0]),
            // Back: the caller's #1 and #2, the common #100 the macro set.
            (6, [7 * MM, 8 * MM, 3 * MM]),
        ]
    );
}

#[test]
fn g65_repeats_with_l_and_nests() {
    let p = "G21 G91\n\
             G65 P30 L3 X1\n\
             G90 G0 Z5\n\
             M30\n\
             O30\n\
             G0 X#24\n\
             G65 P31 Y[#24 * 10]\n\
             G0 Z#24\n\
             M99\n\
             O31\n\
             G0 Y#25 Z#24\n\
             M99\n";
    // Each of the 3 repeats: X+1; the nested macro Y+10 (its own #24 unset: Z+0); back, Z+1.
    let mut want = Vec::new();
    for i in 1..=3 {
        want.push((6, [i * MM, 10 * (i - 1) * MM, (i - 1) * MM]));
        want.push((11, [i * MM, 10 * i * MM, (i - 1) * MM]));
        want.push((8, [i * MM, 10 * i * MM, i * MM]));
    }
    want.push((3, [3 * MM, 30 * MM, 5 * MM]));
    assert_eq!(moves(p), want);
}

#[test]
fn g65_errors() {
    let e = first_error("G65 A1\nM30\n");
    assert_eq!((e.line, e.code), (1, ErrorCode::SubprogramPMissing));
    let e = first_error("G65 P77 A1\nM30\n");
    assert_eq!((e.line, e.code), (1, ErrorCode::UnknownProgram));
    // Other G or M codes cannot share the block with G65.
    let e = first_error("G65 G0 P1 A1\nM30\nO1\nM99\n");
    assert_eq!((e.line, e.code), (1, ErrorCode::NotSupported));
    // Fanuc allows 4 nested macro levels.
    let mut p = String::from("G65 P1\nM30\n");
    for i in 1..=5 {
        p.push_str(&format!("O{i}\nG65 P{}\nM99\n", i + 1));
    }
    p.push_str("O6\nM99\n");
    let e = first_error(&p);
    assert_eq!(e.code, ErrorCode::NestingTooDeep);
    // U/V/W/E stay errors outside G65, and G65 is not a gixa code.
    let e = first_error("G0 U1\nM30\n");
    assert_eq!((e.line, e.code), (1, ErrorCode::UnexpectedCharacter));
    let mut cfg = InterpConfig::default();
    cfg.dialect = Dialect::Gixa;
    let mut it = Interpreter::new(&cfg);
    let mut src = MemorySource::new(b"G65 P1\nM30\n");
    let e = it.next(&mut src).unwrap().unwrap_err();
    assert_eq!(e.code, ErrorCode::UnknownGCode);
}

#[test]
fn vacant_number_zero_follows_fanuc_rules() {
    let p = "G21 G90\n\
             G0 X1 Y2 Z3\n\
             G0 X#0 Y5\n\
             #1 = [#0 + 1]\n\
             #3 = 7\n\
             #3 = #0\n\
             G0 X#1 Y#3 Z[#0 EQ 0]\n\
             G0 Z[#0 EQ #0]\n\
             G0 Z[[#0 GT -1] + [#0 LT 1] * 2 + [#0 NE 0] * 4]\n\
             G0 X[ABS[#0] + #0 * 3 - 2]\n\
             M30\n";
    assert_eq!(
        moves(p),
        vec![
            (2, [MM, 2 * MM, 3 * MM]),
            // X#0: no X word.
            (3, [MM, 5 * MM, 3 * MM]),
            // #0 + 1 = 1; #3 = #0 unset it (0 outside a macro); vacant EQ 0 is false.
            (7, [MM, 0, 0]),
            (8, [MM, 0, MM]),
            // GT and LT count vacant as 0 (1 + 2), NE tells it from 0 (+4).
            (9, [MM, 0, 7 * MM]),
            (10, [-2 * MM, 0, 7 * MM]),
        ]
    );
    let e = first_error("#0 = 5\nM30\n");
    assert_eq!((e.line, e.code), (1, ErrorCode::ParameterNumberInvalid));
}

#[test]
fn unset_locals_are_vacant_inside_a_g65_macro_only() {
    let p = "G21 G90\n\
             G65 P40 A2\n\
             G0 X[#2 EQ #0] Y[#2 EQ 0] Z9\n\
             M30\n\
             O40\n\
             G0 X[#1 EQ #0] Y[#2 EQ #0] Z[#2 NE 0]\n\
             G0 X#2 Y#1\n\
             #5 = 6\n\
             #5 = #0\n\
             G0 Z[#5 + 4] X#5\n\
             M99\n";
    assert_eq!(
        moves(p),
        vec![
            // In the macro: #1 = 2 is set, #2 (no B argument) is vacant.
            (6, [0, MM, MM]),
            // X#2 omitted.
            (7, [0, 2 * MM, MM]),
            // #5 = #0 makes it vacant again: Z4, X omitted.
            (10, [0, 2 * MM, 4 * MM]),
            // Main level (LinuxCNC's rule): unset #2 reads 0, which is not vacant.
            (3, [0, MM, 9 * MM]),
        ]
    );
}
