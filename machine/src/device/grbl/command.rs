//! The `$` system commands of a grbl line, parsed (upper-cased, spaces removed) into one value.

use super::codes;

/// What `$$RST=` restores.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Restore {
    /// `$RST=$`: the numbered settings to their defaults.
    Settings,
    /// `$RST=#`: work offsets and G28/G30 positions to zero.
    Offsets,
    /// `$RST=*`: both.
    All,
}

/// A system command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Command<'a> {
    /// `$`: the help line.
    Help,
    /// `$$`: every numbered setting.
    Settings,
    /// `$n=value`.
    Set { number: u16, value: &'a [u8] },
    /// `$#`: coordinate parameters.
    Params,
    /// `$G`: the modal state.
    Modes,
    /// `$I`: build info.
    Info,
    /// `$N`: startup lines.
    StartupLines,
    /// `$Nn=line`: store startup line `index` (0 or 1).
    SetStartupLine { index: u8, line: &'a [u8] },
    /// `$C`: check mode on or off.
    Check,
    /// `$X`: unlock.
    Unlock,
    /// `$H` (every axis with a homing priority) or `$HX`… (bit mask of one axis).
    Home(u8),
    /// `$J=…`: a jog, its words.
    Jog(&'a [u8]),
    /// `$RST=…`.
    Restore(Restore),
    /// `$SLP`.
    Sleep,
    /// `$I=text`: grbl's build info text (accepted, not stored).
    SetInfo,
}

/// Parses a `$` line (upper case, no spaces, starting with `$`).
pub fn parse(line: &[u8]) -> Result<Command<'_>, u16> {
    let rest = line.split_first().map_or(&[][..], |(_, rest)| rest);
    Ok(match rest {
        b"" => Command::Help,
        b"$" => Command::Settings,
        b"#" => Command::Params,
        b"G" => Command::Modes,
        b"I" => Command::Info,
        b"N" => Command::StartupLines,
        b"C" => Command::Check,
        b"X" => Command::Unlock,
        b"H" => Command::Home(0),
        b"SLP" => Command::Sleep,
        b"RST=$" => Command::Restore(Restore::Settings),
        b"RST=#" => Command::Restore(Restore::Offsets),
        b"RST=*" => Command::Restore(Restore::All),
        [b'H', axis] => {
            let i = crate::units::AXIS_LETTERS
                .iter()
                .position(|&c| c as u8 == *axis)
                .ok_or(codes::INVALID_STATEMENT)?;
            Command::Home(1 << i)
        }
        [b'J', b'=', words @ ..] => Command::Jog(words),
        [b'I', b'=', ..] => Command::SetInfo,
        [b'N', n @ (b'0' | b'1'), b'=', line @ ..] => Command::SetStartupLine {
            index: n - b'0',
            line,
        },
        _ => {
            let eq = rest
                .iter()
                .position(|&c| c == b'=')
                .ok_or(codes::INVALID_STATEMENT)?;
            let (Some(num), Some(value)) = (rest.get(..eq), rest.get(eq + 1..)) else {
                return Err(codes::INVALID_STATEMENT);
            };
            if num.is_empty() || num.len() > 3 || !num.iter().all(u8::is_ascii_digit) {
                return Err(codes::INVALID_STATEMENT);
            }
            let number = num.iter().fold(0u16, |n, &d| n * 10 + u16::from(d - b'0'));
            Command::Set { number, value }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn system_commands_parse() {
        assert_eq!(parse(b"$"), Ok(Command::Help));
        assert_eq!(parse(b"$$"), Ok(Command::Settings));
        assert_eq!(parse(b"$HY"), Ok(Command::Home(2)));
        assert_eq!(parse(b"$J=G91X1F100"), Ok(Command::Jog(b"G91X1F100")));
        assert_eq!(
            parse(b"$110=500.5"),
            Ok(Command::Set {
                number: 110,
                value: b"500.5"
            })
        );
        assert_eq!(parse(b"$Q"), Err(codes::INVALID_STATEMENT));
        assert_eq!(parse(b"$1234=1"), Err(codes::INVALID_STATEMENT));
        assert_eq!(parse(b"$RST=*"), Ok(Command::Restore(Restore::All)));
        assert_eq!(
            parse(b"$N1=G21G90"),
            Ok(Command::SetStartupLine {
                index: 1,
                line: b"G21G90"
            })
        );
    }
}
