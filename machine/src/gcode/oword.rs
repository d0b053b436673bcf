//! O-word control lines (`o100 sub`, `o<loop> while [#1 LT 3]`, ...) recognised before the block
//! parser: the label, the keyword and where the rest of the line (an expression, arguments)
//! starts. A line `O1234` without a keyword is a Fanuc program label and is not an O-word line.
//!
//! Fanuc Macro B's control lines are read here too, in the same `ngc` dialect (none of them is
//! valid RS274NGC, so nothing clashes): `WHILE [c] DOn` and `ENDn` are a while loop labelled
//! [`FANUC_LOOP`]` | n`, `GOTO n` and `IF [c] GOTO n` jump to the block `Nn`, `IF [c] THEN …`
//! runs the rest of the line when c is true.

use super::expr::{name_hash, Cursor};

/// A label: `o100` (number) or `o<name>` (hash of the name), never equal to each other.
pub type Label = u64;

/// The keyword of an O-word line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Keyword {
    Sub,
    EndSub,
    Call,
    Return,
    If,
    ElseIf,
    Else,
    EndIf,
    While,
    EndWhile,
    Do,
    Repeat,
    EndRepeat,
    Break,
    Continue,
    /// Fanuc `GOTO n` (the label is n).
    Goto,
    /// Fanuc `IF [c] GOTO n`: `rest` is the condition, the label n.
    IfGoto,
    /// Fanuc `IF [c] THEN …`: `rest` is the condition, the label where the statement starts.
    IfThen,
}

/// Label bit of Fanuc `WHILE … DOn` / `ENDn` loops (never equal to an `o` label).
pub(crate) const FANUC_LOOP: Label = 2 << 32;

/// Reads an unsigned integer at the cursor (blanks skipped), if any.
fn digits(c: &mut Cursor<'_>) -> Option<u64> {
    let mut n: u64 = 0;
    let mut any = false;
    while let Some(d @ b'0'..=b'9') = c.peek() {
        n = (n * 10 + (d - b'0') as u64).min(u32::MAX as u64);
        any = true;
        c.pos += 1;
    }
    any.then_some(n)
}

/// Skips a bracketed expression (the cursor is on `[`); false if it is not closed.
fn skip_brackets(c: &mut Cursor<'_>) -> bool {
    let mut depth = 0u32;
    while c.pos < c.line.len() {
        match c.line[c.pos] {
            b'[' => depth += 1,
            b']' => {
                depth = depth.saturating_sub(1);
                if depth == 0 {
                    c.pos += 1;
                    return true;
                }
            }
            _ => {}
        }
        c.pos += 1;
    }
    false
}

/// A Fanuc Macro B control line starting at the cursor.
fn fanuc(c: &mut Cursor<'_>) -> Option<OLine> {
    let start = c.pos;
    let cols = |end: usize| (start as u16, end as u16);
    if c.keyword(b"GOTO") {
        let n = digits(c)?;
        return Some(OLine {
            label: n,
            keyword: Keyword::Goto,
            rest: c.pos,
            cols: cols(c.pos),
            computed: None,
        });
    }
    if c.keyword(b"END") {
        let n = digits(c)?;
        return Some(OLine {
            label: FANUC_LOOP | n,
            keyword: Keyword::EndWhile,
            rest: c.pos,
            cols: cols(c.pos),
            computed: None,
        });
    }
    let while_ = c.keyword(b"WHILE");
    if !while_ && !c.keyword(b"IF") {
        return None;
    }
    if c.peek() != Some(b'[') {
        return None;
    }
    let cond = c.pos;
    if !skip_brackets(c) {
        return None;
    }
    let (label, keyword) = if while_ {
        if !c.keyword(b"DO") {
            return None;
        }
        (FANUC_LOOP | digits(c)?, Keyword::While)
    } else if c.keyword(b"GOTO") {
        (digits(c)?, Keyword::IfGoto)
    } else if c.keyword(b"THEN") {
        c.peek();
        (c.pos as u64, Keyword::IfThen)
    } else {
        return None;
    };
    Some(OLine {
        label,
        keyword,
        rest: cond,
        cols: cols(cond),
        computed: None,
    })
}

/// A parsed O-word line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OLine {
    pub label: Label,
    pub keyword: Keyword,
    /// Byte offset of what follows the keyword.
    pub rest: usize,
    /// Byte columns of the O word.
    pub cols: (u16, u16),
    /// Where the `[expression]` of a computed number `o[…]` starts (`label` is 0 until the
    /// interpreter has evaluated it).
    pub computed: Option<u16>,
}

const KEYWORDS: [(&[u8], Keyword); 15] = [
    (b"ENDSUB", Keyword::EndSub),
    (b"ENDIF", Keyword::EndIf),
    (b"ENDWHILE", Keyword::EndWhile),
    (b"ENDREPEAT", Keyword::EndRepeat),
    (b"ELSEIF", Keyword::ElseIf),
    (b"ELSE", Keyword::Else),
    (b"SUB", Keyword::Sub),
    (b"CALL", Keyword::Call),
    (b"RETURN", Keyword::Return),
    (b"IF", Keyword::If),
    (b"WHILE", Keyword::While),
    (b"DO", Keyword::Do),
    (b"REPEAT", Keyword::Repeat),
    (b"BREAK", Keyword::Break),
    (b"CONTINUE", Keyword::Continue),
];

/// The O-word line in `line`, if it is one (a leading `/` or N word is skipped).
pub fn parse(line: &[u8]) -> Option<OLine> {
    let mut c = Cursor::new(line, 0);
    if c.peek() == Some(b'/') {
        c.pos += 1;
    }
    if c.peek() == Some(b'N') {
        c.pos += 1;
        while matches!(c.peek(), Some(b'0'..=b'9' | b'.')) {
            c.pos += 1;
        }
    }
    if c.peek() != Some(b'O') {
        return fanuc(&mut c);
    }
    let start = c.pos;
    c.pos += 1;
    let mut end = c.pos;
    let mut computed = None;
    let label = if c.peek() == Some(b'[') {
        // LinuxCNC's computed number `o[#1 * 10]`: the interpreter evaluates it
        // (`OLine::computed`).
        computed = Some(c.pos as u16);
        if !skip_brackets(&mut c) {
            return None;
        }
        end = c.pos;
        0
    } else if c.peek() == Some(b'<') {
        let open = c.pos;
        // `get` rather than slicing: no bounds-check panic paths.
        let rest = line.get(open..)?;
        let len = rest.iter().position(|&b| b == b'>')?;
        c.pos = open + len + 1;
        end = c.pos;
        (1u64 << 32) | name_hash(rest.get(1..len)?) as u64
    } else {
        let mut n: u64 = 0;
        let mut any = false;
        while let Some(d @ b'0'..=b'9') = c.peek() {
            n = (n * 10 + (d - b'0') as u64).min(u32::MAX as u64);
            any = true;
            c.pos += 1;
            end = c.pos;
        }
        if !any {
            return None;
        }
        n
    };
    let keyword = KEYWORDS.iter().find_map(|&(w, k)| {
        let save = c.pos;
        if c.keyword(w) && !matches!(c.line.get(c.pos), Some(b'a'..=b'z' | b'A'..=b'Z')) {
            Some(k)
        } else {
            c.pos = save;
            None
        }
    })?;
    Some(OLine {
        label,
        keyword,
        rest: c.pos,
        cols: (start as u16, end as u16),
        computed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_and_keywords() {
        let l = parse(b"o100 sub").unwrap();
        assert_eq!((l.label, l.keyword), (100, Keyword::Sub));
        let l = parse(b"  O<My Loop> WHILE [#1 LT 3]").unwrap();
        assert_eq!(l.keyword, Keyword::While);
        assert_eq!(l.label, parse(b"o<myloop> endwhile").unwrap().label);
        assert_eq!(&b"  O<My Loop> WHILE [#1 LT 3]"[l.rest..], b" [#1 LT 3]");
        assert_eq!(parse(b"o10 else").unwrap().keyword, Keyword::Else);
        assert_eq!(parse(b"o10 elseif [1]").unwrap().keyword, Keyword::ElseIf);
        assert_eq!(parse(b"N5 o10 do").unwrap().keyword, Keyword::Do);
        assert_eq!(parse(b"O1234"), None);
        assert_eq!(parse(b"O1234 (name)"), None);
        assert_eq!(parse(b"G0 X1"), None);
        assert_eq!(parse(b"o1 dot"), None);
        let l = parse(b"N10 WHILE [#1 LT 3] DO2").unwrap();
        assert_eq!((l.label, l.keyword), (FANUC_LOOP | 2, Keyword::While));
        assert_eq!(parse(b"END2").unwrap().label, FANUC_LOOP | 2);
        assert_eq!(parse(b"GOTO 30").unwrap().keyword, Keyword::Goto);
        let l = parse(b"IF [#1 EQ [2]] GOTO30").unwrap();
        assert_eq!((l.label, l.keyword), (30, Keyword::IfGoto));
        let l = parse(b"IF [#1 EQ 1] THEN #2 = 5").unwrap();
        assert_eq!((l.label, l.keyword), (18, Keyword::IfThen));
        assert_eq!(parse(b"G0 X1"), None);
        let l = parse(b"O[#1 * 10] call [2]").unwrap();
        assert_eq!(
            (l.keyword, l.computed, l.cols),
            (Keyword::Call, Some(1), (0, 10))
        );
        assert_eq!(parse(b"O[#1 call"), None);
    }
}
