//! `$J=` jog lines: the target in machine coordinates and the feed, from the jog's own words
//! (`G90`/`G91`, `G20`/`G21`, `G53`, axis words, `F`) over the interpreter's modal distance and
//! units, which the jog does not change (grbl's jogging rules).

use super::codes;
use super::text::parse_scaled;
use crate::gcode::state::ModalState;
use crate::units::{Pos, AXIS_LETTERS, NM_PER_MM};

/// A jog: where to and how fast (nm/min).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Jog {
    pub to: Pos,
    pub feed: i64,
}

/// The jog of `words` (upper case, no spaces) from machine position `from`; `Err` is the grbl
/// error number.
pub fn parse(words: &[u8], modal: &ModalState, from: &Pos, axes: usize) -> Result<Jog, u16> {
    let mut absolute = modal.absolute;
    let mut inch = modal.inch;
    let mut machine = false;
    let mut values: [Option<&[u8]>; 6] = [None; 6];
    let mut feed: Option<&[u8]> = None;
    let mut i = 0;
    while i < words.len() {
        let letter = words[i];
        let start = i + 1;
        let mut end = start;
        while end < words.len() && matches!(words[end], b'0'..=b'9' | b'.' | b'-' | b'+') {
            end += 1;
        }
        let num = words.get(start..end).unwrap_or_default();
        if num.is_empty() {
            return Err(codes::JOG_INVALID);
        }
        match letter {
            b'G' => match num {
                b"90" => absolute = true,
                b"91" => absolute = false,
                b"20" => inch = true,
                b"21" => inch = false,
                b"53" => machine = true,
                _ => return Err(codes::JOG_INVALID),
            },
            b'F' => feed = Some(num),
            _ => {
                let a = AXIS_LETTERS
                    .iter()
                    .position(|&c| c as u8 == letter)
                    .filter(|&a| a < axes)
                    .ok_or(codes::JOG_INVALID)?;
                if values[a].is_some() {
                    return Err(25);
                }
                values[a] = Some(num);
            }
        }
        i = end;
    }
    let per_unit = if inch { 25_400_000 } else { NM_PER_MM };
    let feed =
        parse_scaled(feed.ok_or(codes::UNDEFINED_FEED)?, per_unit).ok_or(codes::BAD_NUMBER)?;
    if feed <= 0 {
        return Err(codes::UNDEFINED_FEED);
    }
    if values.iter().all(Option::is_none) {
        return Err(26);
    }
    if machine && !absolute {
        return Err(codes::JOG_INVALID);
    }
    let mut to = *from;
    for ((to, v), offset) in to.iter_mut().zip(values).zip(modal.offset()) {
        let Some(v) = v else { continue };
        let v = parse_scaled(v, per_unit).ok_or(codes::BAD_NUMBER)?;
        *to = if machine {
            v
        } else if absolute {
            v + offset
        } else {
            *to + v
        };
    }
    Ok(Jog { to, feed })
}
