//! Blocks: the words of one line sorted by letter, G codes by modal group, M codes by group.
//!
//! This is where "same word twice", "two G codes of one modal group" and unknown codes are caught.
//! G codes are integers in tenths (`G28.1` = 281) so decimal codes need no floating point.

use super::codes::*;
use super::config::{Dialect, InterpConfig};
use super::error::ErrorCode;
use super::lexer::{Lexer, Word, MICRO};

/// Modal groups of G codes (RS274NGC numbering in the comments).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum GGroup {
    /// 0: G4 G10 G28 G28.1 G30 G30.1 G52 G53 G92 G92.1 G92.2 G92.3.
    NonModal = 0,
    /// 1: G0 G1 G2 G3 G38.2-G38.5 G73 G80-G89.
    Motion,
    /// 2: G17 G18 G19.
    Plane,
    /// 3: G90 G91.
    Distance,
    /// 4: G90.1 G91.1.
    ArcDistance,
    /// 5: G93 G94.
    FeedMode,
    /// 6: G20 G21.
    Units,
    /// 7: G40 G41 G42 G41.1 G42.1.
    CutterComp,
    /// 8: G43 G43.1 G49.
    ToolLength,
    /// 10: G98 G99.
    Return,
    /// 12: G54-G59.3.
    Coordinate,
    /// 13: G61 G61.1 G64.
    Path,
    /// Fanuc 11: G50 G51 (scaling).
    Scaling,
    /// Fanuc 16: G68 G69 (rotation).
    Rotation,
    /// Fanuc 17: G15 G16 (polar coordinates).
    Polar,
    /// Fanuc 18: G50.1 G51.1 (programmable mirror).
    Mirror,
}

/// Number of [`GGroup`]s.
pub(crate) const G_GROUPS: usize = 16;

/// The `g_set` bits of the transform groups (scaling, rotation, polar, mirror).
pub(crate) const TRANSFORM_GROUPS: u16 = 0xf << GGroup::Scaling as u16;

/// The group of a G code in tenths, or `None` if unknown.
pub(crate) fn g_group(code: u16) -> Option<GGroup> {
    G_TABLE.iter().find(|e| e.0 == code).map(|e| e.1)
}

/// Every known G code and its group, the common ones first: [`g_group`] scans it (a `match`
/// over the codes compiled to 500 B of comparisons in the firmware).
const G_TABLE: [(u16, GGroup); 79] = {
    use GGroup::*;
    [
        (G0, Motion),
        (G1, Motion),
        (G2, Motion),
        (G3, Motion),
        (G80, Motion),
        (G81, Motion),
        (G82, Motion),
        (G83, Motion),
        (G73, Motion),
        (G84, Motion),
        (G85, Motion),
        (G86, Motion),
        (G87, Motion),
        (G88, Motion),
        (G89, Motion),
        (G38_2, Motion),
        (G38_3, Motion),
        (G38_4, Motion),
        (G38_5, Motion),
        (G74, Motion),
        (G76, Motion),
        (G84_2, Motion),
        (G84_3, Motion),
        (G5, Motion),
        (G5_1, Motion),
        (G90, Distance),
        (G91, Distance),
        (G17, Plane),
        (G18, Plane),
        (G19, Plane),
        (G20, Units),
        (G21, Units),
        (G94, FeedMode),
        (G93, FeedMode),
        (G40, CutterComp),
        (G41, CutterComp),
        (G42, CutterComp),
        (G41_1, CutterComp),
        (G42_1, CutterComp),
        (G49, ToolLength),
        (G43, ToolLength),
        (G43_1, ToolLength),
        (G54, Coordinate),
        (G55, Coordinate),
        (G56, Coordinate),
        (G57, Coordinate),
        (G58, Coordinate),
        (G59, Coordinate),
        (G59_1, Coordinate),
        (G59_2, Coordinate),
        (G59_3, Coordinate),
        (G64, Path),
        (G61, Path),
        (G61_1, Path),
        (G98, Return),
        (G99, Return),
        (G4, NonModal),
        (G10, NonModal),
        (G28, NonModal),
        (G28_1, NonModal),
        (G30, NonModal),
        (G30_1, NonModal),
        (G52, NonModal),
        (G53, NonModal),
        (G65, NonModal),
        (G92, NonModal),
        (G92_1, NonModal),
        (G92_2, NonModal),
        (G92_3, NonModal),
        (G90_1, ArcDistance),
        (G91_1, ArcDistance),
        (G50, Scaling),
        (G51, Scaling),
        (G68, Rotation),
        (G69, Rotation),
        (G15, Polar),
        (G16, Polar),
        (G50_1, Mirror),
        (G51_1, Mirror),
    ]
};

/// Groups of M codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum MGroup {
    /// M0 M1 M2 M30 M98 M99: stops and program flow.
    Flow = 0,
    /// M6.
    ToolChange,
    /// M3 M4 M5.
    Spindle,
    /// M7 M8 M9 (M7 and M8 may share a block).
    Coolant,
    /// M48 M49 (accepted, no effect).
    Override,
    /// User M codes of the setup.
    User,
    /// M70 M71 M72 M73: save, invalidate, restore the modal state; save with restore at the
    /// subroutine's end (LinuxCNC; machine/src/gcode/interp/context.rs).
    Context,
    /// M62 M63 with P2: torch height control off and on with the next move (grblHAL's plasma
    /// port 2; docs/laser-plasma.md).
    Digital,
}

/// Number of [`MGroup`]s.
pub const M_GROUPS: usize = 8;

/// The group of an M code under `config`, or `None` if unknown.
pub(crate) fn m_group(code: u16, config: &InterpConfig) -> Option<MGroup> {
    use MGroup::*;
    Some(match code {
        0 | 1 | 2 | 30 | 98 | 99 => Flow,
        6 => ToolChange,
        3..=5 => Spindle,
        7..=9 => Coolant,
        48 | 49 => Override,
        c if config.is_user_m_code(c) => User,
        62 | 63 => Digital,
        70..=73 if config.dialect != super::config::Dialect::Gixa => Context,
        _ => return None,
    })
}

/// A G or M code with the columns it was written at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Code {
    pub code: u16,
    pub cols: (u16, u16),
}

/// Most M words in one block (as LinuxCNC).
pub(crate) const MAX_M_WORDS: usize = 5;

/// One parsed block.
#[derive(Clone, Debug)]
pub struct Block {
    /// N word.
    pub n: Option<u32>,
    /// O word (program number label).
    pub o: Option<Code>,
    /// The block started with `/`.
    pub block_delete: bool,
    /// Value words in the order written (each letter once; G, M and N are kept elsewhere).
    words: heapless::Vec<Word, WORD_SLOTS>,
    /// Where in `words` the word of each letter slot (`A`..`Z`, `@`, `^`) is, while its
    /// `present` bit is set. A new block only clears this and the mask, not 28 optional words
    /// (machine/src/gcode/interp/mod.rs makes one per line).
    index: [u8; WORD_SLOTS],
    /// Bit `slot` set while the block has the word of that slot (the unused-word check of every
    /// block reads it instead of scanning the 28 slots).
    present: u32,
    /// G codes by group (tenths), valid while the group's bit of `g_set` is set: a new block
    /// clears arrays of integers and a mask instead of writing twelve `Option<Code>`s through a
    /// copy (~250 Cortex-M4 instructions a line, target-tests/src/bin/bench_motion.rs).
    g: [u16; G_GROUPS],
    /// The columns of each group's G code (as `g`): start in the high half, end in the low.
    g_cols: [u32; G_GROUPS],
    /// Bit `group` set while the block has a G code of that group.
    g_set: u16,
    /// M codes in the order written.
    pub m: heapless::Vec<(MGroup, Code), MAX_M_WORDS>,
    /// True if the block has no words at all (blank or comment line).
    pub empty: bool,
    /// G80 was written next to G0-G3 (`G0 G80 X10`): the cycle is cancelled and the block's
    /// motion code applies, as rs274 and Fanuc read the usual safe-start lines.
    pub cancels_cycle: bool,
}

/// Value word slots: `A`..`Z`, then LinuxCNC's polar radius `@` and angle `^`.
const WORD_SLOTS: usize = 28;

/// The slot of a value word letter.
#[inline(always)]
const fn slot(l: u8) -> usize {
    match l {
        b'@' => 26,
        b'^' => 27,
        l => (l - b'A') as usize,
    }
}

/// The mask of `letters` for [`Block::has_any`] (for constants).
pub(crate) const fn letter_mask<const N: usize>(letters: &[u8; N]) -> u32 {
    let mut mask = 0;
    let mut i = 0;
    while i < N {
        mask |= 1 << slot(letters[i]);
        i += 1;
    }
    mask
}

/// A block error with the columns to blame.
pub(crate) type BlockError = (ErrorCode, Option<(u16, u16)>);

impl Default for Block {
    fn default() -> Self {
        Self::new()
    }
}

impl Block {
    /// A block with no words (what [`parse_block_into`] fills).
    pub fn new() -> Self {
        Block {
            n: None,
            o: None,
            block_delete: false,
            words: heapless::Vec::new(),
            index: [0; WORD_SLOTS],
            present: 0,
            g: [0; G_GROUPS],
            g_cols: [0; G_GROUPS],
            g_set: 0,
            m: heapless::Vec::new(),
            empty: true,
            cancels_cycle: false,
        }
    }

    /// The word with letter `l` (upper case).
    pub fn word(&self, l: u8) -> Option<Word> {
        let at = slot(l);
        if self.present & (1 << at) == 0 {
            return None;
        }
        self.words.get(self.index[at] as usize).copied()
    }

    /// The word of the first letter of `mask` ([`letter_mask`]) the block has, in the order of
    /// the letters' slots (`A`..`Z`, `@`, `^`).
    pub(crate) fn first_word(&self, mask: u32) -> Option<Word> {
        let bits = self.present & mask;
        if bits == 0 {
            return None;
        }
        let at = bits.trailing_zeros() as usize;
        self.index
            .get(at)
            .and_then(|&i| self.words.get(usize::from(i)))
            .copied()
    }

    /// True if the block has the word with letter `l`.
    #[inline(always)]
    pub fn has(&self, l: u8) -> bool {
        self.present & (1 << slot(l)) != 0
    }

    /// The block has a word of any letter of `mask` ([`letter_mask`]): one test where a loop of
    /// [`Self::has`] calls cost ~60 Cortex-M4 instructions a line.
    pub(crate) fn has_any(&self, mask: u32) -> bool {
        self.present & mask != 0
    }

    /// Removes a word (once an earlier step consumed it).
    pub fn take(&mut self, l: u8) -> Option<Word> {
        let w = self.word(l);
        self.present &= !(1 << slot(l));
        w
    }

    /// True if the block has no value word outside `mask` (see [`letter_mask`]).
    pub(crate) fn has_only(&self, mask: u32) -> bool {
        self.present & !mask == 0
    }

    /// Moves the word of letter `from` (if any) to the slot of letter `to`; false when `to` is
    /// taken (G16 hands X and Y on as LinuxCNC's polar words `@` and `^`).
    #[inline(always)]
    pub fn rename(&mut self, from: u8, to: u8) -> bool {
        let (f, t) = (slot(from), slot(to));
        if self.present & (1 << f) == 0 {
            return true;
        }
        if self.present & (1 << t) != 0 {
            return false;
        }
        self.index[t] = self.index[f];
        self.present = self.present & !(1 << f) | 1 << t;
        true
    }

    /// Adds the word of a letter slot not set yet.
    fn insert(&mut self, at: usize, w: Word) {
        self.index[at] = self.words.len() as u8;
        // Cannot overflow: one word per slot at most.
        let _ = self.words.push(w);
        self.present |= 1 << at;
    }

    /// The G code (with its columns) given for a group.
    #[inline(always)]
    pub fn g(&self, group: GGroup) -> Option<Code> {
        let at = group as usize;
        if self.g_set & (1 << at) == 0 {
            return None;
        }
        Some(Code {
            code: self.g[at],
            cols: ((self.g_cols[at] >> 16) as u16, self.g_cols[at] as u16),
        })
    }

    /// Writes the G code of a group (its bit of `g_set` is the caller's).
    #[inline(always)]
    fn set_g(&mut self, group: GGroup, c: Code) {
        self.g[group as usize] = c.code;
        self.g_cols[group as usize] = (c.cols.0 as u32) << 16 | c.cols.1 as u32;
    }

    /// True if the block has a G code of a group in `mask` (bits of [`GGroup`]).
    pub(crate) fn has_g_in(&self, mask: u16) -> bool {
        self.g_set & mask != 0
    }

    /// True if the block has a G code of any group other than `group`.
    pub(crate) fn has_g_besides(&self, group: GGroup) -> bool {
        self.g_set & !(1 << group as u16) != 0
    }

    /// The G code given for a group.
    #[inline(always)]
    pub(crate) fn g_of(&self, group: GGroup) -> Option<u16> {
        self.g(group).map(|c| c.code)
    }

    /// True if the block has this G code (tenths).
    pub fn has_g(&self, code: u16) -> bool {
        g_group(code).is_some_and(|grp| self.g_of(grp) == Some(code))
    }

    /// True if the block has this M code.
    pub(crate) fn has_m(&self, code: u16) -> bool {
        self.m.iter().any(|(_, c)| c.code == code)
    }

    /// The columns of a G code in the block.
    pub(crate) fn g_cols(&self, code: u16) -> Option<(u16, u16)> {
        g_group(code).and_then(|grp| self.g(grp).map(|c| c.cols))
    }

    /// Iterates over the letters of all value words present, in slot order (`A`..`Z`, `@`, `^`).
    pub fn letters(&self) -> impl Iterator<Item = u8> {
        let mut left = self.present;
        core::iter::from_fn(move || {
            if left == 0 {
                return None;
            }
            let i = left.trailing_zeros() as u8;
            left &= left - 1;
            Some(match i {
                26 => b'@',
                27 => b'^',
                i => b'A' + i,
            })
        })
    }
}

/// Parses the words of a line into a block. `Ok(None)` for `%`-framing and `E` lines are handled by
/// the caller through [`Lexer::start`].
pub fn parse_block(lexer: &mut Lexer<'_>, config: &InterpConfig) -> Result<Block, BlockError> {
    let mut b = Block::new();
    parse_block_into(lexer, config, &mut b)?;
    Ok(b)
}

/// [`parse_block`] into a new block the caller owns (`Block::new()`): the interpreter's per-line
/// path fills its block in place, since moving an 830-byte `Block` through return values costs
/// ~700 Cortex-M4 instructions a copy (target-tests/src/bin/bench_motion.rs, per-line figures).
pub(crate) fn parse_block_into(
    lexer: &mut Lexer<'_>,
    config: &InterpConfig,
    b: &mut Block,
) -> Result<(), BlockError> {
    b.block_delete = lexer.block_delete;
    let gixa = config.dialect == Dialect::Gixa;
    while let Some(w) = lexer.next_word().map_err(|(c, cols)| (c, Some(cols)))? {
        b.empty = false;
        let cols = Some(w.cols);
        match w.letter {
            b'G' => {
                if w.value < 0
                    || w.value >= 1000 * MICRO
                    || !(w.value as u32).is_multiple_of((MICRO / 10) as u32)
                {
                    return Err((ErrorCode::UnknownGCode, cols));
                }
                if gixa && w.int_digits < 2 {
                    return Err((ErrorCode::BadWordFormat, cols));
                }
                // 0 ≤ value < 10^9: a 32-bit division (no 64-bit divide on the Cortex-M4).
                let code = (w.value as u32 / (MICRO / 10) as u32) as u16;
                let group = g_group(code)
                    .filter(|_| !(gixa && code == G65))
                    .ok_or((ErrorCode::UnknownGCode, cols))?;
                let new = Code { code, cols: w.cols };
                match b.g(group) {
                    None => {
                        b.set_g(group, new);
                        b.g_set |= 1 << group as u16;
                    }
                    // G80 beside G0-G3 cancels the cycle; the straight or arc motion applies.
                    Some(old) if group == GGroup::Motion && !b.cancels_cycle => {
                        let straight_or_arc = |c: u16| matches!(c, G0 | G1 | G2 | G3);
                        if old.code == G80 && straight_or_arc(code) {
                            b.set_g(group, new);
                        } else if !(code == G80 && straight_or_arc(old.code)) {
                            return Err((ErrorCode::ModalGroupConflict, cols));
                        }
                        b.cancels_cycle = true;
                    }
                    Some(_) => return Err((ErrorCode::ModalGroupConflict, cols)),
                }
            }
            b'M' => {
                let v = w.integer().ok_or((ErrorCode::NotAnInteger, cols))?;
                if !(0..=9999).contains(&v) {
                    return Err((ErrorCode::UnknownMCode, cols));
                }
                let code = v as u16;
                if gixa && code <= 1 && w.int_digits < 2 {
                    return Err((ErrorCode::BadWordFormat, cols));
                }
                let group = m_group(code, config).ok_or((ErrorCode::UnknownMCode, cols))?;
                for (g, c) in b.m.iter() {
                    let coolant_pair =
                        group == MGroup::Coolant && matches!((c.code, code), (7, 8) | (8, 7));
                    if *g == group && group != MGroup::User && !coolant_pair {
                        return Err((ErrorCode::MCodeGroupConflict, cols));
                    }
                    if c.code == code {
                        return Err((ErrorCode::RepeatedWord, cols));
                    }
                }
                b.m.push((group, Code { code, cols: w.cols }))
                    .map_err(|_| (ErrorCode::TooManyMCodes, cols))?;
            }
            b'N' => {
                if b.n.is_some() {
                    return Err((ErrorCode::RepeatedWord, cols));
                }
                // RS274NGC allows a fraction (`N10.5`); only the whole part labels the block.
                let v = w.value / MICRO;
                if w.value < 0 || !(0..=99_999_999).contains(&v) {
                    return Err((ErrorCode::ValueOutOfRange, cols));
                }
                b.n = Some(v as u32);
            }
            b'O' => {
                if b.o.is_some() {
                    return Err((ErrorCode::RepeatedWord, cols));
                }
                let v = w.integer().ok_or((ErrorCode::NotAnInteger, cols))?;
                if !(0..=99_999_999).contains(&v) {
                    return Err((ErrorCode::ValueOutOfRange, cols));
                }
                b.o = Some(Code {
                    code: 0,
                    cols: w.cols,
                });
                // The O number itself is kept as a value word slot.
                b.insert(slot(b'O'), w);
            }
            // E, U, V and W are only Fanuc G65 arguments (#8, #21-#23), after the G65.
            b'E' | b'U' | b'V' | b'W' if b.g_of(GGroup::NonModal) != Some(G65) || gixa => {
                return Err((ErrorCode::UnexpectedCharacter, cols))
            }
            l => {
                if gixa && matches!(l, b'@' | b'^') {
                    return Err((ErrorCode::NotSupported, cols));
                }
                let at = slot(l);
                if b.present & (1 << at) != 0 {
                    return Err((ErrorCode::RepeatedWord, cols));
                }
                b.insert(at, w);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<Block, BlockError> {
        let cfg = InterpConfig::default();
        let mut lx = Lexer::new(s.as_bytes(), true);
        lx.start();
        parse_block(&mut lx, &cfg)
    }

    #[test]
    fn g80_beside_a_straight_or_arc_motion_cancels_the_cycle() {
        for line in [
            "G0 G80 X10",
            "G00 G17 G40 G49 G80 G90",
            "G0 G90 G40 G21 G17 G94 G80",
        ] {
            let b = parse(line).unwrap();
            assert_eq!(b.g_of(GGroup::Motion), Some(0), "{line}");
            assert!(b.cancels_cycle, "{line}");
        }
        assert_eq!(
            parse("G80 G2 X1 R1").unwrap().g_of(GGroup::Motion),
            Some(20)
        );
        assert!(!parse("G80").unwrap().cancels_cycle);
        for line in [
            "G0 G1 X1",
            "G81 G0 X1",
            "G0 G81 X1",
            "G80 G81 X1",
            "G0 G80 G80",
            "G80 G0 G1",
        ] {
            assert_eq!(
                parse(line).unwrap_err().0,
                ErrorCode::ModalGroupConflict,
                "{line}"
            );
        }
    }

    #[test]
    fn groups_and_conflicts() {
        let b = parse("N10 G01 G90 G28.1 M3 M8 X1").unwrap();
        assert_eq!(b.n, Some(10));
        assert_eq!(b.g_of(GGroup::Motion), Some(10));
        assert_eq!(b.g_of(GGroup::NonModal), Some(281));
        assert!(b.has_m(3) && b.has_m(8));
        assert_eq!(
            parse("G0 G1 X1").unwrap_err(),
            (ErrorCode::ModalGroupConflict, Some((3, 5)))
        );
        assert_eq!(parse("X1 X2").unwrap_err().0, ErrorCode::RepeatedWord);
        assert_eq!(parse("N10.5 G0").unwrap().n, Some(10));
        assert_eq!(parse("N5 N6 G0").unwrap_err().0, ErrorCode::RepeatedWord);
        assert_eq!(parse("M3 M4").unwrap_err().0, ErrorCode::MCodeGroupConflict);
        assert!(parse("M7 M8").is_ok());
        assert_eq!(parse("G12").unwrap_err().0, ErrorCode::UnknownGCode);
        assert_eq!(parse("G1.5").unwrap_err().0, ErrorCode::UnknownGCode);
        assert_eq!(parse("M77").unwrap_err().0, ErrorCode::UnknownMCode);
        assert_eq!(parse("M3.5").unwrap_err().0, ErrorCode::NotAnInteger);
        assert_eq!(
            parse("M3 M7 M48 M6 M0 M9").unwrap_err().0,
            ErrorCode::MCodeGroupConflict
        );
    }
}
