//! O-word control lines (`o100 sub`, `o<loop> while [#1 LT 3]`, ...) recognised before the block
//! parser: the label, the keyword and where the rest of the line (an expression, arguments)
//! starts. A line `O1234` without a keyword is a Fanuc program label and is not an O-word line.

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
        return None;
    }
    let start = c.pos;
    c.pos += 1;
    let mut end = c.pos;
    let label = if c.peek() == Some(b'<') {
        let open = c.pos;
        let close = line[open..].iter().position(|&b| b == b'>')? + open;
        c.pos = close + 1;
        end = c.pos;
        (1u64 << 32) | name_hash(&line[open + 1..close]) as u64
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
    }
}
