//! RS274NGC parameters, expressions and O-word control flow (LinuxCNC's dialect), with exact
//! positions: every expectation below is worked out by hand from the program.

mod gcode_support;

use gantry_machine::gcode::expr::{ParamRef, ONE};
use gantry_machine::gcode::ErrorCode;
use gcode_support::{first_error, moves, run, MM};

#[test]
fn numbered_and_named_parameters_and_expressions() {
    let m = moves(
        "#1 = 2\n#<depth> = -1.5\n#<_safe> = [#1 * 2.5]\nG0 X#1 Y[#1 + 3 * 2] Z#<_safe>\nG1 Z#<depth> F[100 / #1]\nG0 X-#1 Y[2 ** 3 MOD 5] Z[SQRT[16] + ABS[-1]]\n",
    );
    assert_eq!(
        m,
        [
            (4, [2 * MM, 8 * MM, 5 * MM]),
            (5, [2 * MM, 8 * MM, -1_500_000]),
            (6, [-2 * MM, 3 * MM, 5 * MM]),
        ]
    );
}

#[test]
fn assignments_take_effect_at_the_end_of_the_line() {
    // On line 2 X reads the old #1 (1) although the same line sets it to 5.
    let (_, it) = run("#1 = 1\n#1 = 5 G0 X#1\n#2 = #1 #1 = 7\n");
    assert_eq!(it.parameter(ParamRef::Numbered(1)), Ok(7 * ONE));
    assert_eq!(it.parameter(ParamRef::Numbered(2)), Ok(5 * ONE));
    assert_eq!(moves("#1 = 1\n#1 = 5 G0 X#1\n"), [(2, [MM, 0, 0])]);
}

#[test]
fn indirect_parameters_and_system_parameters() {
    // #[#1 + 1] is #11; #5420-#5422 are the current position in program units; #5221 the G54 X.
    let m = moves(
        "#1 = 10\n#[#1 + 1] = 4\nG0 X#11 Y1\nG10 L2 P1 X2\nG0 X[#5420 + #5221] Y[#5421 * 2]\n",
    );
    assert_eq!(m, [(3, [4 * MM, MM, 0]), (5, [6 * MM, 2 * MM, 0])]);
    // Writing #5221 moves the G54 X offset.
    assert_eq!(moves("#5221 = 3\nG0 X1\n"), [(2, [4 * MM, 0, 0])]);
    assert_eq!(
        first_error("#<nope> = #<missing>\n").code,
        ErrorCode::UndefinedParameter
    );
    assert_eq!(first_error("G0 X[1/0]\n").code, ErrorCode::DivisionByZero);
    assert_eq!(
        first_error("#0 = 1\n").code,
        ErrorCode::ParameterNumberInvalid
    );
    assert_eq!(
        first_error("G0 X[1 + ]\n").code,
        ErrorCode::ExpressionSyntax
    );
}

#[test]
fn while_loop_runs_and_ends() {
    let m =
        moves("#1 = 0\no101 while [#1 LT 3]\n  G0 X#1\n  #1 = [#1 + 1]\no101 endwhile\nG0 Y9\n");
    assert_eq!(
        m,
        [
            (3, [0, 0, 0]),
            (3, [MM, 0, 0]),
            (3, [2 * MM, 0, 0]),
            (6, [2 * MM, 9 * MM, 0])
        ]
    );
}

#[test]
fn do_while_repeat_break_continue() {
    let m = moves(
        "#1 = 0\no1 do\n  #1 = [#1 + 1]\n  o2 if [#1 EQ 2]\n    o1 continue\n  o2 endif\n  G0 X#1\no1 while [#1 LT 4]\no3 repeat [2]\n  G0 Y#1\n  #1 = [#1 + 1]\no3 endrepeat\no4 while [1]\n  #1 = [#1 + 1]\n  o5 if [#1 GE 8]\n    o4 break\n  o5 endif\n  G0 Z#1\no4 endwhile\nG0 Z1\n",
    );
    // do: #1 = 1 (X1), 2 (continue), 3 (X3), 4 (X4, then the while ends); repeat: Y4, Y5;
    // while: Z7, then #1 = 8 breaks.
    assert_eq!(
        m,
        [
            (7, [MM, 0, 0]),
            (7, [3 * MM, 0, 0]),
            (7, [4 * MM, 0, 0]),
            (10, [4 * MM, 4 * MM, 0]),
            (10, [4 * MM, 5 * MM, 0]),
            (18, [4 * MM, 5 * MM, 7 * MM]),
            (20, [4 * MM, 5 * MM, MM]),
        ]
    );
    // As LinuxCNC: break belongs to while/do, not to repeat.
    let e = first_error("o3 repeat [2]\no3 break\no3 endrepeat\n");
    assert_eq!((e.line, e.code), (2, ErrorCode::UnbalancedBlock));
}

#[test]
fn if_elseif_else() {
    let program = |v: i32| {
        format!("#1 = {v}\no5 if [#1 GT 10]\nG0 X1\no5 elseif [#1 GT 5]\nG0 X2\no5 else\nG0 X3\no5 endif\nG0 Y1\n")
    };
    assert_eq!(moves(&program(20))[0], (3, [MM, 0, 0]));
    assert_eq!(moves(&program(7))[0], (5, [2 * MM, 0, 0]));
    assert_eq!(moves(&program(1))[0], (7, [3 * MM, 0, 0]));
    assert_eq!(moves(&program(1)).len(), 2);
}

#[test]
fn subroutines_with_arguments_locals_and_forward_definitions() {
    // o200 is defined after its call; #1 of the caller comes back after the call.
    let m = moves(
        "o100 sub\n  #<x> = [#1 * 2]\n  G0 X#<x> Y#2\no100 endsub\n#1 = 9\no100 call [1] [2]\no100 call [3] [4]\no200 call [5]\nG0 Z#1\nM2\no200 sub\n  G0 X#1 Y0\n  o200 return\n  G0 X99\no200 endsub\n",
    );
    assert_eq!(
        m,
        [
            (3, [2 * MM, 2 * MM, 0]),
            (3, [6 * MM, 4 * MM, 0]),
            (12, [5 * MM, 0, 0]),
            (9, [5 * MM, 0, 9 * MM]),
        ]
    );
    // A local of the subroutine is not visible after it returns.
    let e = first_error("o1 sub\n#<v> = 1\no1 endsub\no1 call\nG0 X#<v>\n");
    assert_eq!((e.line, e.code), (5, ErrorCode::UndefinedParameter));
}

#[test]
fn unbalanced_blocks_and_unknown_labels_are_errors() {
    let e = first_error("G0 X1\no7 endwhile\n");
    assert_eq!((e.line, e.code), (2, ErrorCode::UnbalancedBlock));
    let e = first_error("o7 if [0]\nG0 X1\n");
    assert_eq!((e.line, e.code), (2, ErrorCode::UnbalancedBlock));
    let e = first_error("o9 call\nG0 X1\n");
    assert_eq!(e.code, ErrorCode::UnknownSubroutine);
    let e = first_error("o1 while [1]\no1 endwhile\n");
    assert_eq!(e.code, ErrorCode::EndlessLoop);
}

#[test]
fn comments_keep_their_hashes() {
    assert_eq!(
        moves("#1 = 2 (set #1)\nG0 X#1 (debug, #1)\n"),
        [(2, [2 * MM, 0, 0])]
    );
}

#[test]
fn fanuc_macro_b_while_do_end_if_then_goto() {
    // Hand-checked: the loop runs X0, X1, X2; #1 ends at 3 so THEN sets #2 = 7; IF [7 GT 5]
    // jumps over line 9 to N20; GOTO 40 skips N30.
    let m = moves(
        "#1 = 0\nWHILE [#1 LT 3] DO1\n  G0 X#1\n  #1 = [#1 + 1]\nEND1\nIF [#1 EQ 3] THEN #2 = 7\nG0 Y#2\nIF [#2 GT 5] GOTO 20\nG0 Z99\nN20 G0 Z1\nGOTO 40\nN30 G0 X99\nN40 G0 X5\n",
    );
    assert_eq!(
        m,
        [
            (3, [0, 0, 0]),
            (3, [MM, 0, 0]),
            (3, [2 * MM, 0, 0]),
            (7, [2 * MM, 7 * MM, 0]),
            (10, [2 * MM, 7 * MM, MM]),
            (13, [5 * MM, 7 * MM, MM]),
        ]
    );
    // Nested DO1/DO2 (2 × 2 turns), a false THEN that does nothing, a WHILE false from the start.
    let m = moves(
        "#1 = 0\nWHILE [#1 LT 2] DO1\n#2 = 0\nWHILE [#2 LT 2] DO2\nG0 X#1 Y#2\n#2 = [#2 + 1]\nEND2\n#1 = [#1 + 1]\nEND1\nIF [#1 EQ 0] THEN G0 Z9\nWHILE [0] DO3\nG0 Z8\nEND3\nG0 Z1\n",
    );
    assert_eq!(
        m,
        [
            (5, [0, 0, 0]),
            (5, [0, MM, 0]),
            (5, [MM, 0, 0]),
            (5, [MM, MM, 0]),
            (14, [MM, MM, MM]),
        ]
    );
    // GOTO to a block that does not exist.
    let e = first_error("G0 X1\nGOTO 77\n");
    assert_eq!((e.line, e.code), (2, ErrorCode::SourceJumpFailed));
    // END without WHILE.
    let e = first_error("END4\n");
    assert_eq!((e.line, e.code), (1, ErrorCode::UnbalancedBlock));
}

/// M70-M73 beyond what the rs274 goldens compare (tests/golden/rs274/140): the spindle and
/// coolant a restore switches back, and M73 restoring at the M99 of an M98 call.
#[test]
fn m73_restores_spindle_coolant_and_modes_at_m99_and_o_returns() {
    use gantry_machine::canon::{Action, Spindle};
    let program = "G21 G90 G17 F100\nM3 S1000\no1 sub\n  M73\n  M5 M8 G91\n  G1 X1\no1 endsub\n\
                   o1 call\nG1 X5\nM98 P7\nG1 X6\nM2\nO7\nM73\nM4 S200 G91\nG1 X1\nM99\n";
    let (out, _) = run(program);
    let actions: Vec<(u32, Action)> = out
        .into_iter()
        .map(|r| r.unwrap())
        .map(|c| (c.line, c.action))
        .collect();
    let spindle: Vec<(u32, Spindle, u32)> = actions
        .iter()
        .filter_map(|(l, a)| match a {
            Action::Spindle { state, rpm } => Some((*l, *state, *rpm)),
            _ => None,
        })
        .collect();
    // M3 (line 2), M5 in the sub (5), back on at its endsub (7); M4 S200 in O7 (15), and M3
    // S1000 again at its M99 (17).
    assert_eq!(
        spindle,
        [
            (2, Spindle::Cw, 1000),
            (5, Spindle::Off, 1000),
            (7, Spindle::Cw, 1000),
            (15, Spindle::Ccw, 200),
            (17, Spindle::Cw, 1000)
        ]
    );
    let coolant: Vec<(u32, bool, bool)> = actions
        .iter()
        .filter_map(|(l, a)| match a {
            Action::Coolant { mist, flood } => Some((*l, *mist, *flood)),
            _ => None,
        })
        .collect();
    assert_eq!(coolant, [(5, false, true), (7, false, false)]);
    // G91 in each subroutine, G90 again after it: X5 and X6 are absolute.
    let m = moves(program);
    assert_eq!(
        m,
        [
            (6, [MM, 0, 0]),
            (9, [5 * MM, 0, 0]),
            (16, [6 * MM, 0, 0]),
            (11, [6 * MM, 0, 0]),
        ]
    );
    // M72 at the top level without M70 is E710; M71 forgets.
    assert_eq!(first_error("M72\n").code, ErrorCode::NoSavedModalState);
    assert_eq!(
        first_error("M70\nM71\nM72\n").code,
        ErrorCode::NoSavedModalState
    );
}
