//! Why a board refuses a pushed setup: the code of the `Answer` to a `SetupCommit`
//! (docs/protocol.md "Answers"), written by the board (`machine/src/device/link.rs`) and read by
//! the host (`host-sender/src/session/setup.rs`). Code 0 is acceptance, as for every answer.

/// A refused `SetupCommit`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum SetupRefusal {
    /// The blob's length or CRC does not match the commit: chunks were lost or damaged.
    Damaged = 1,
    /// The blob decodes to no valid setup.
    Invalid = 2,
    /// The board is not idle: a setup changes only at rest.
    NotIdle = 3,
}

impl SetupRefusal {
    /// The answer's code.
    pub const fn code(self) -> u16 {
        self as u16
    }

    /// The refusal an answer's code names; `None` for 0 (accepted) and unknown codes.
    pub const fn from_code(code: u16) -> Option<Self> {
        match code {
            1 => Some(SetupRefusal::Damaged),
            2 => Some(SetupRefusal::Invalid),
            3 => Some(SetupRefusal::NotIdle),
            _ => None,
        }
    }

    /// What the refusal means, for an operator.
    pub const fn reason(self) -> &'static str {
        match self {
            SetupRefusal::Damaged => "the board received a damaged setup (length or CRC)",
            SetupRefusal::Invalid => "the board refused the setup as invalid",
            SetupRefusal::NotIdle => "the board is not idle: setups are changed only when idle",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_read_back_as_the_refusal_they_name() {
        for r in [
            SetupRefusal::Damaged,
            SetupRefusal::Invalid,
            SetupRefusal::NotIdle,
        ] {
            assert_eq!(SetupRefusal::from_code(r.code()), Some(r));
        }
        assert_eq!(SetupRefusal::from_code(0), None);
        assert_eq!(SetupRefusal::from_code(4), None);
    }
}
