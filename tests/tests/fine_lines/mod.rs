//! Programs of very short moves for the CPU-model and starvation tests (`cpu_model.rs`,
//! `stream_starvation.rs`): `lines` moves of `step_um` µm along X from `from_x_mm`, Y and Z
//! drifting 0.02 µm a line, at `feed_mm_min`.

// Each test binary uses the wording it needs.
#![allow(dead_code)]

/// A parameter (0) of a long name that a [`Wording::Wordy`] line adds to its X.
const NAME: &str =
    "_a_parameter_whose_long_name_makes_each_line_of_this_program_take_more_bytes_on_the_wire";

/// How each move is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wording {
    /// `X-249.980 Y0.00002 Z-0.00002`: 30 bytes a line.
    Short,
    /// X as a sum with [`NAME`]: 143 bytes a line, so the link, not the board's CPU, is what
    /// cannot keep up (the board takes at most `RX_BYTES_PER_PASS`, 512 B, a millisecond:
    /// ~3,500 such lines a second).
    Wordy,
}

/// The program (see the module documentation), ending in M30.
pub fn fine_lines(
    from_x_mm: i64,
    lines: i64,
    step_um: i64,
    feed_mm_min: u32,
    wording: Wording,
) -> String {
    let mut p = String::from("G21 G90\n");
    if wording == Wording::Wordy {
        p.push_str(&format!("#<{NAME}>=0\n"));
    }
    p.push_str(&format!("G0 X{from_x_mm} Y0 Z0\nG1 F{feed_mm_min}\n"));
    for i in 1..=lines {
        // µm: X `step_um` per line, Y and Z 0.02 (written to 5 decimals of a mm).
        let (x, yz) = (from_x_mm * 1000 + i * step_um, i * 2);
        let sign = if x < 0 { "-" } else { "" };
        let x = format!("{sign}{}.{:03}", x.abs() / 1000, x.abs() % 1000);
        let x = match wording {
            Wording::Short => x,
            Wording::Wordy => format!("[{x}+#<{NAME}>]"),
        };
        p.push_str(&format!("X{x} Y0.{yz:05} Z-0.{yz:05}\n"));
    }
    p.push_str("M30\n");
    p
}
