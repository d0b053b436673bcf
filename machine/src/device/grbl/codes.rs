//! Gantry's error numbers as grbl 1.1 numbers (the table is in docs/grbl.md). Errors with no
//! grbl meaning keep their Gantry number (100 and up, docs/errors.md), which no grbl number uses.
//! Alarms keep their numbers: Gantry numbered them after grbl's (1 hard limit, 2 soft limit,
//! 3 reset during motion, 6, 8, 9 homing failures, 11 homing required as in grblHAL); 20 (host
//! lost) and 21 (command list timeout) have no grbl counterpart.

/// grbl: expected command letter.
pub(crate) const EXPECTED_LETTER: u16 = 1;
/// grbl: bad number format.
pub(crate) const BAD_NUMBER: u16 = 2;
/// grbl: `$` statement not recognised or not supported.
pub(crate) const INVALID_STATEMENT: u16 = 3;
/// grbl: negative value.
pub(crate) const NEGATIVE_VALUE: u16 = 4;
/// grbl: homing not enabled.
pub(crate) const HOMING_DISABLED: u16 = 5;
/// grbl: `$` command only valid when idle.
pub(crate) const IDLE_ONLY: u16 = 8;
/// grbl: G-code locked out during alarm or jog.
pub(crate) const LOCKED: u16 = 9;
/// grbl: line too long.
pub(crate) const LINE_TOO_LONG: u16 = 11;
/// grbl: jog target beyond the travel.
pub(crate) const JOG_TRAVEL: u16 = 15;
/// grbl: invalid jog command.
pub(crate) const JOG_INVALID: u16 = 16;
/// grbl: undefined feed rate.
pub(crate) const UNDEFINED_FEED: u16 = 22;
/// Unsupported or invalid G-code command.
pub(crate) const UNSUPPORTED: u16 = 20;

/// The grbl number for a Gantry error number.
pub(crate) fn error_number(gantry: u16) -> u16 {
    match gantry {
        101 | 103 | 106 => EXPECTED_LETTER,
        102 | 104 | 105 => BAD_NUMBER,
        201 => 25,       // repeated word
        202 | 203 => 21, // modal group violation
        204 | 205 | 212 | 504 | 506 | 608 => 20,
        207 => 23, // needs an integer
        209 => 24, // two G codes use the axis words
        210 => 31, // axis words without a command
        211 => 36, // unused words
        301 | 311 => UNDEFINED_FEED,
        302 => 35,             // arc without an in-plane offset
        305 | 306 | 308 => 33, // invalid arc target
        307 => 34,             // invalid arc radius
        309 => 32,             // arc without an in-plane axis word
        502 => 38,             // tool number
        520 => 33,             // a probe move that does not move: invalid target
        503 => 30,             // G53 needs G0/G1
        505 => 28,             // value word missing
        507 => 26,             // no axis words
        901 => LOCKED,         // homing required: grbl's alarm lock-out
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_map_to_grbl_numbers_where_one_matches() {
        assert_eq!(error_number(201), 25);
        assert_eq!(error_number(301), 22);
        assert_eq!(error_number(204), 20);
        assert_eq!(error_number(901), 9);
        assert_eq!(
            error_number(900),
            900,
            "soft limit: no grbl error, Gantry's number"
        );
        assert_eq!(error_number(701), 701);
    }
}
