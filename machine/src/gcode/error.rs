//! Interpreter errors: where (line, N word, columns of the bad word) and what ([`ErrorCode`]).
//!
//! The numeric codes are stable: they are documented in `docs/errors.md`, and hosts may match on
//! them. A block that produces an error produces no action at all.

/// An error of one block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GcodeError {
    /// 1-based line number in the program file.
    pub line: u32,
    /// The block's N word, if it had one.
    pub n_word: Option<u32>,
    /// Byte columns (0-based start, exclusive end) of the offending word, if one word is to blame.
    pub columns: Option<(u16, u16)>,
    /// What is wrong.
    pub code: ErrorCode,
}

impl GcodeError {
    /// The human-readable message of the error code.
    pub fn message(&self) -> &'static str {
        self.code.message()
    }
}

/// What went wrong, with a stable number (see [`ErrorCode::number`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum ErrorCode {
    // --- 1xx lexical ---
    /// A character that cannot start a word (digit without letter, `#`, `[`, unknown letter...).
    UnexpectedCharacter,
    /// A letter without a number after it.
    MissingNumber,
    /// `(` without a closing `)` on the same line.
    UnclosedComment,
    /// A number with too many digits, or outside the range of its word.
    NumberOutOfRange,
    /// The dialect requires a different word format (gixa: two-digit G words, `M00`/`M01`).
    BadWordFormat,
    /// A `(` inside a comment (`(a (b)`), which rs274 refuses.
    NestedComment,
    // --- 2xx block structure ---
    /// The same letter twice in one block (`X1 X2`, `N5 N6`).
    RepeatedWord,
    /// Two G codes of the same modal group in one block.
    ModalGroupConflict,
    /// Two M codes of the same group in one block.
    MCodeGroupConflict,
    /// A G code this interpreter does not know.
    UnknownGCode,
    /// An M code that is neither built in nor a user M code of the setup.
    UnknownMCode,
    /// A word value outside its allowed range (negative F or S, H or T too big...).
    ValueOutOfRange,
    /// A word that must be a whole number has a fraction.
    NotAnInteger,
    /// More M words in one block than allowed (5).
    TooManyMCodes,
    /// Two G codes in one block both want the axis words.
    AxisWordsConflict,
    /// Axis words but no motion mode to use them (G80 active or given).
    AxisWordsWithoutMotion,
    /// A word that no G or M code of the block uses (`Q` without G83...).
    UnusedWord,
    /// An axis letter for an axis the machine does not have.
    AxisNotConfigured,
    // --- 3xx motion ---
    /// Feed move with zero feed rate (no F programmed yet).
    ZeroFeedRate,
    /// G2/G3 without R or I/J/K.
    ArcCenterMissing,
    /// G2/G3 with both R and I/J/K.
    ArcMixedFormats,
    /// A centre word that does not belong to the active plane (K in G17...).
    ArcOffsetWrongPlane,
    /// R smaller than half the chord.
    ArcRadiusTooSmall,
    /// The end point is not on the circle through the start point (beyond LinuxCNC's tolerance).
    ArcRadiusMismatch,
    /// The centre is (almost) on the start or end point.
    ArcZeroRadius,
    /// R-format arc whose end point equals its start point.
    ArcEndEqualsStart,
    /// R-format arc without any end-point word of the plane.
    ArcEndPointMissing,
    /// P (turns) of an arc is not a positive whole number.
    ArcTurnsInvalid,
    /// G93 inverse time: a feed move without F.
    InverseTimeFeedMissing,
    /// A coordinate, offset or feed beyond the representable range (±100 m).
    CoordinateOverflow,
    /// A centre word is missing in absolute arc-centre mode (G90.1).
    ArcAbsoluteCenterMissing,
    /// G5 without P and Q (or without I and J when no G5 came before), G5.1 without I and J.
    SplineWordMissing,
    // --- 4xx canned cycles ---
    /// First block of a cycle without R.
    CycleRMissing,
    /// First block of a cycle without its depth word.
    CycleDepthMissing,
    /// R plane below the bottom of the hole.
    CycleRBelowBottom,
    /// G73/G83 (gixa G87) without Q, or Q not positive.
    CycleQInvalid,
    /// G82/G86/G89 without a dwell P.
    CycleDwellMissing,
    /// G84 needs the spindle turning clockwise (M3), G74 counter-clockwise (M4), G86/G87/G88
    /// need it on.
    CycleSpindleState,
    /// Canned cycle in G93 inverse-time mode.
    CycleInverseTime,
    /// Rotary axis word in a canned-cycle block.
    CycleRotaryAxis,
    /// K/L repeat count invalid (negative or fractional).
    CycleRepeatInvalid,
    /// gixa G87: Q not larger than the partial-retract distance.
    CyclePeckNotAboveRetract,
    /// A canned cycle this dialect does not support (gixa G73), or the board cannot run safely
    /// (G76 fine boring: no oriented spindle stop; G84.2/G84.3 rigid tapping: no synchronised
    /// spindle).
    CycleNotSupported,
    /// RS274NGC G87 without its I, J and K words in its first block.
    CycleBackBoreWordMissing,
    /// G76 fine boring with Q: its shift direction is a Fanuc machine parameter; Gantry shifts
    /// by the block's I/J only.
    CycleFineBoreQ,
    // --- 5xx offsets, tools, settings ---
    /// G10 with a missing or unsupported L, or P out of range (or a full tool table for L1).
    G10Invalid,
    /// G43 H (or tool number) not in the tool table.
    ToolNotInTable,
    /// G53 needs G0 or G1 and absolute mode.
    G53Invalid,
    /// Cutter radius compensation started by an arc (Fanuc: the entry move must be straight).
    CutterCompNotSupported,
    /// G4 without a P (or X) time.
    DwellTimeMissing,
    /// A feature this dialect does not support (G95, gixa parameters, polar coordinates...).
    NotSupported,
    /// G28/G30 or G92 need axis words / were given invalid words.
    MissingAxisWords,
    /// A G38.x probe move that does not move (its end is its start).
    ProbeZeroLength,
    /// A G38.x probe move in G93 inverse-time mode.
    ProbeInverseTime,
    // --- 6xx program flow ---
    /// M98 calls a program number that is not in the file.
    UnknownProgram,
    /// The same O number is defined twice in the file.
    DuplicateProgram,
    /// Subprogram calls nested deeper than the stack (16).
    NestingTooDeep,
    /// M98 without P.
    SubprogramPMissing,
    /// The file ended inside a subprogram (no M99).
    SubprogramWithoutM99,
    /// The program source could not jump to the requested line.
    SourceJumpFailed,
    /// Subprogram calls/returns or M99 restarts kept looping without producing any action.
    EndlessLoop,
    /// A subprogram call, return or O-word jump in a job whose sender streams lines in order
    /// only (grbl mode): only `gantry stream` serves the program's lines on request.
    JumpNotServed,
    // --- 7xx parameters, expressions, O-word control flow ---
    /// An expression, parameter reference or O-word line that does not parse.
    ExpressionSyntax,
    /// A result beyond ±9·10⁹ (the fixed-point range of parameters).
    ExpressionOverflow,
    /// Division (or MOD) by zero.
    DivisionByZero,
    /// A function argument outside its domain (SQRT of a negative, LN of 0, ASIN of 2...).
    FunctionDomain,
    /// A named parameter read before it was set.
    UndefinedParameter,
    /// A parameter number that does not exist or is read-only (#0, #5400 and up, fractions).
    ParameterNumberInvalid,
    /// More parameters or O-word blocks than the interpreter's fixed tables hold.
    ParameterTableFull,
    /// An O-word block that is not closed or closed by the wrong keyword (`endwhile` without
    /// `while`, end of file inside `if`, `break` outside a loop).
    UnbalancedBlock,
    /// `o<label> call` of a subroutine that is not in the file.
    UnknownSubroutine,
    /// `M72` (restore the modal state) where no `M70`/`M73` saved one at this call level.
    NoSavedModalState,
    // --- 8xx cutter radius compensation ---
    /// G41/G42 while compensation is already on.
    CompAlreadyOn,
    /// G41/G42 in the YZ plane (G19), or a plane change while compensation is on.
    CompPlane,
    /// Something compensation cannot be on for (offsets, G28/G30, G53, cycles, M6, G43/G49,
    /// coordinate system, path or retract mode changes).
    CompForbidden,
    /// The entry move is not longer than the tool radius.
    CompEntryTooShort,
    /// The tool radius is not less than the radius of an arc it runs inside.
    CompArcTooSmall,
    /// A concave corner the compensated tool cannot reach without gouging.
    CompGouge,
    /// The move right after G40 is an arc (it must be straight).
    CompArcAfterExit,
    /// More actions between two compensated moves than the look-ahead holds.
    CompLookAheadFull,
    /// G41.1/G42.1 without the D word (the diameter).
    CompDiameterMissing,
    // --- 9xx coordinate transforms (docs/gcode-transforms.md) ---
    /// G51, G51.1 or G68 twice without a cancel, or out of order (mirror, then scaling, then
    /// rotation; cancelled in the reverse order).
    TransformOrder,
    /// G17/G18/G19 changing the plane while G68 is on.
    TransformPlane,
    /// An arc while its two plane axes are scaled by different factors.
    TransformArcScaled,
    /// G92, G92.1-G92.3, G52 or G10 L20 while a mirror, scaling or rotation is on.
    TransformOffset,
    /// G51 with other codes or words than X Y Z I J K P in its block.
    TransformNotAlone,
    /// G51 without a factor, a factor not in (0, 999.999999], P beside I/J/K; G68 without R or
    /// beyond ±360°; G51.1 without an axis word.
    TransformValue,
}

impl ErrorCode {
    /// Every code, in numeric order (used by the documentation test).
    pub const ALL: &'static [ErrorCode] = &[
        ErrorCode::UnexpectedCharacter,
        ErrorCode::MissingNumber,
        ErrorCode::UnclosedComment,
        ErrorCode::NumberOutOfRange,
        ErrorCode::BadWordFormat,
        ErrorCode::NestedComment,
        ErrorCode::RepeatedWord,
        ErrorCode::ModalGroupConflict,
        ErrorCode::MCodeGroupConflict,
        ErrorCode::UnknownGCode,
        ErrorCode::UnknownMCode,
        ErrorCode::ValueOutOfRange,
        ErrorCode::NotAnInteger,
        ErrorCode::TooManyMCodes,
        ErrorCode::AxisWordsConflict,
        ErrorCode::AxisWordsWithoutMotion,
        ErrorCode::UnusedWord,
        ErrorCode::AxisNotConfigured,
        ErrorCode::ZeroFeedRate,
        ErrorCode::ArcCenterMissing,
        ErrorCode::ArcMixedFormats,
        ErrorCode::ArcOffsetWrongPlane,
        ErrorCode::ArcRadiusTooSmall,
        ErrorCode::ArcRadiusMismatch,
        ErrorCode::ArcZeroRadius,
        ErrorCode::ArcEndEqualsStart,
        ErrorCode::ArcEndPointMissing,
        ErrorCode::ArcTurnsInvalid,
        ErrorCode::InverseTimeFeedMissing,
        ErrorCode::CoordinateOverflow,
        ErrorCode::ArcAbsoluteCenterMissing,
        ErrorCode::SplineWordMissing,
        ErrorCode::CycleRMissing,
        ErrorCode::CycleDepthMissing,
        ErrorCode::CycleRBelowBottom,
        ErrorCode::CycleQInvalid,
        ErrorCode::CycleDwellMissing,
        ErrorCode::CycleSpindleState,
        ErrorCode::CycleInverseTime,
        ErrorCode::CycleRotaryAxis,
        ErrorCode::CycleRepeatInvalid,
        ErrorCode::CyclePeckNotAboveRetract,
        ErrorCode::CycleNotSupported,
        ErrorCode::CycleBackBoreWordMissing,
        ErrorCode::CycleFineBoreQ,
        ErrorCode::G10Invalid,
        ErrorCode::ToolNotInTable,
        ErrorCode::G53Invalid,
        ErrorCode::CutterCompNotSupported,
        ErrorCode::DwellTimeMissing,
        ErrorCode::NotSupported,
        ErrorCode::MissingAxisWords,
        ErrorCode::ProbeZeroLength,
        ErrorCode::ProbeInverseTime,
        ErrorCode::UnknownProgram,
        ErrorCode::DuplicateProgram,
        ErrorCode::NestingTooDeep,
        ErrorCode::SubprogramPMissing,
        ErrorCode::SubprogramWithoutM99,
        ErrorCode::SourceJumpFailed,
        ErrorCode::EndlessLoop,
        ErrorCode::ExpressionSyntax,
        ErrorCode::ExpressionOverflow,
        ErrorCode::DivisionByZero,
        ErrorCode::FunctionDomain,
        ErrorCode::UndefinedParameter,
        ErrorCode::ParameterNumberInvalid,
        ErrorCode::ParameterTableFull,
        ErrorCode::UnbalancedBlock,
        ErrorCode::UnknownSubroutine,
        ErrorCode::NoSavedModalState,
        ErrorCode::CompAlreadyOn,
        ErrorCode::CompPlane,
        ErrorCode::CompForbidden,
        ErrorCode::CompEntryTooShort,
        ErrorCode::CompArcTooSmall,
        ErrorCode::CompGouge,
        ErrorCode::CompArcAfterExit,
        ErrorCode::CompLookAheadFull,
        ErrorCode::CompDiameterMissing,
        ErrorCode::TransformOrder,
        ErrorCode::TransformPlane,
        ErrorCode::TransformArcScaled,
        ErrorCode::TransformOffset,
        ErrorCode::TransformNotAlone,
        ErrorCode::TransformValue,
    ];

    /// The stable number of the code (`E` + this number in messages).
    pub const fn number(self) -> u16 {
        use ErrorCode::*;
        match self {
            UnexpectedCharacter => 101,
            MissingNumber => 102,
            UnclosedComment => 103,
            NumberOutOfRange => 104,
            BadWordFormat => 105,
            NestedComment => 106,
            RepeatedWord => 201,
            ModalGroupConflict => 202,
            MCodeGroupConflict => 203,
            UnknownGCode => 204,
            UnknownMCode => 205,
            ValueOutOfRange => 206,
            NotAnInteger => 207,
            TooManyMCodes => 208,
            AxisWordsConflict => 209,
            AxisWordsWithoutMotion => 210,
            UnusedWord => 211,
            AxisNotConfigured => 212,
            ZeroFeedRate => 301,
            ArcCenterMissing => 302,
            ArcMixedFormats => 303,
            ArcOffsetWrongPlane => 304,
            ArcRadiusTooSmall => 305,
            ArcRadiusMismatch => 306,
            ArcZeroRadius => 307,
            ArcEndEqualsStart => 308,
            ArcEndPointMissing => 309,
            ArcTurnsInvalid => 310,
            InverseTimeFeedMissing => 311,
            CoordinateOverflow => 312,
            ArcAbsoluteCenterMissing => 313,
            SplineWordMissing => 314,
            CycleRMissing => 401,
            CycleDepthMissing => 402,
            CycleRBelowBottom => 403,
            CycleQInvalid => 404,
            CycleDwellMissing => 405,
            CycleSpindleState => 406,
            CycleInverseTime => 407,
            CycleRotaryAxis => 408,
            CycleRepeatInvalid => 409,
            CyclePeckNotAboveRetract => 410,
            CycleNotSupported => 411,
            CycleBackBoreWordMissing => 412,
            CycleFineBoreQ => 413,
            G10Invalid => 501,
            ToolNotInTable => 502,
            G53Invalid => 503,
            CutterCompNotSupported => 504,
            DwellTimeMissing => 505,
            NotSupported => 506,
            MissingAxisWords => 507,
            ProbeZeroLength => 520,
            ProbeInverseTime => 521,
            UnknownProgram => 601,
            DuplicateProgram => 602,
            NestingTooDeep => 603,
            SubprogramPMissing => 604,
            SubprogramWithoutM99 => 605,
            SourceJumpFailed => 606,
            EndlessLoop => 607,
            JumpNotServed => 608,
            ExpressionSyntax => 701,
            ExpressionOverflow => 702,
            DivisionByZero => 703,
            FunctionDomain => 704,
            UndefinedParameter => 705,
            ParameterNumberInvalid => 706,
            ParameterTableFull => 707,
            UnbalancedBlock => 708,
            UnknownSubroutine => 709,
            NoSavedModalState => 710,
            CompAlreadyOn => 801,
            CompPlane => 802,
            CompForbidden => 803,
            CompEntryTooShort => 804,
            CompArcTooSmall => 805,
            CompGouge => 806,
            CompArcAfterExit => 807,
            CompLookAheadFull => 808,
            CompDiameterMissing => 809,
            TransformOrder => 901,
            TransformPlane => 902,
            TransformArcScaled => 903,
            TransformOffset => 904,
            TransformNotAlone => 905,
            TransformValue => 906,
        }
    }

    /// A one-line explanation for the operator.
    pub const fn message(self) -> &'static str {
        use ErrorCode::*;
        match self {
            UnexpectedCharacter => "unexpected character (expected a word letter followed by a number)",
            MissingNumber => "a word letter must be followed by a number",
            UnclosedComment => "comment '(' is not closed on this line",
            NumberOutOfRange => "number too large for this word",
            BadWordFormat => "word format not allowed in this dialect (gixa: G needs two digits, M00/M01 need the leading zero)",
            NestedComment => "nested comment: '(' inside a comment",
            RepeatedWord => "the same word appears twice in one block",
            ModalGroupConflict => "two G codes of the same modal group in one block",
            MCodeGroupConflict => "two M codes of the same group in one block",
            UnknownGCode => "unknown or unsupported G code",
            UnknownMCode => "unknown M code (not built in and not a user M code of the setup)",
            ValueOutOfRange => "value out of range for this word",
            NotAnInteger => "this word needs a whole number",
            TooManyMCodes => "more than 5 M words in one block",
            AxisWordsConflict => "two G codes in this block both use the axis words",
            AxisWordsWithoutMotion => "axis words without a motion mode to use them (G80 is active)",
            UnusedWord => "word not used by any G or M code of this block",
            AxisNotConfigured => "axis word for an axis this machine does not have",
            ZeroFeedRate => "feed move with zero feed rate (program an F word)",
            ArcCenterMissing => "arc needs R or I/J/K words",
            ArcMixedFormats => "arc with both R and I/J/K words",
            ArcOffsetWrongPlane => "arc centre word of the axis off the plane (K on a G17 arc, J on G18, I on G19): it means nothing there, LinuxCNC refuses it; FreeCAD's grbl post writes K0 on every G17 arc: use its LinuxCNC post, or stream in grbl mode, which ignores the word",
            ArcRadiusTooSmall => "arc radius too small to reach the end point",
            ArcRadiusMismatch => "radius to the arc end point differs from radius to the start point",
            ArcZeroRadius => "zero-radius arc (centre on the start or end point)",
            ArcEndEqualsStart => "R-format arc with end point equal to the start point",
            ArcEndPointMissing => "R-format arc without end-point words in the selected plane",
            ArcTurnsInvalid => "arc P (turns) must be a positive whole number",
            InverseTimeFeedMissing => "G93 inverse time: every feed move needs an F word",
            CoordinateOverflow => "coordinate, offset or feed out of the representable range",
            ArcAbsoluteCenterMissing => "centre word missing for an arc in absolute centre mode (G90.1)",
            SplineWordMissing => "G5 needs P and Q (and I and J unless a G5 came before), G5.1 needs I and J",
            CycleRMissing => "canned cycle needs an R word in its first block",
            CycleDepthMissing => "canned cycle needs its depth word (Z in G17) in its first block",
            CycleRBelowBottom => "canned cycle R plane is below the bottom of the hole",
            CycleQInvalid => "peck cycle needs a positive Q (peck depth)",
            CycleDwellMissing => "canned cycle needs a dwell P in its first block",
            CycleSpindleState => "spindle state wrong for this cycle (G84 needs M3, G74 M4, G76/G86/G87/G88 need the spindle on)",
            CycleInverseTime => "canned cycles cannot run in G93 inverse-time mode",
            CycleRotaryAxis => "rotary axis words are not allowed in a canned-cycle block",
            CycleRepeatInvalid => "canned-cycle repeat count (K/L) must be a whole number >= 0",
            CyclePeckNotAboveRetract => "G87 peck Q must be larger than the partial-retract distance",
            CycleNotSupported => "canned cycle not supported in this dialect (gixa G73), or not on this board (G76 needs an oriented spindle stop, G84.2/G84.3 a synchronised spindle)",
            CycleBackBoreWordMissing => "G87 back boring needs I, J and K in its first block",
            CycleFineBoreQ => "G76 fine boring shifts by I and J: Q's direction is a machine parameter (write the shift as I/J)",
            G10Invalid => "G10 needs L1 (P tool), L2 or L20 (P0..P9)",
            ToolNotInTable => "tool not in the tool table",
            G53Invalid => "G53 needs G0 or G1 and absolute distance mode (G90)",
            CutterCompNotSupported => "cutter compensation must start with a straight move (G0/G1), not an arc",
            DwellTimeMissing => "G4 dwell needs a P time",
            NotSupported => "feature not supported by this interpreter or dialect",
            MissingAxisWords => "this G code needs axis words",
            ProbeZeroLength => "G38 probe move does not move (its end point is the start point)",
            ProbeInverseTime => "G38 probe moves cannot run in G93 inverse-time mode",
            UnknownProgram => "subprogram (O number) not found in the program",
            DuplicateProgram => "the same O number is defined twice in the program",
            NestingTooDeep => "subprogram calls nested too deeply",
            SubprogramPMissing => "M98 needs a P word (program number)",
            SubprogramWithoutM99 => "end of file inside a subprogram (missing M99)",
            SourceJumpFailed => "cannot jump to that line of the program",
            JumpNotServed => "subprograms and O-word jumps need a program server (gantry stream): this sender streams lines in order only",
            ExpressionSyntax => "bad expression, parameter reference or O-word line",
            ExpressionOverflow => "expression result out of range (beyond 9e9)",
            DivisionByZero => "division by zero",
            FunctionDomain => "function argument out of its domain (SQRT of a negative, LN of 0, ASIN/ACOS beyond 1)",
            UndefinedParameter => "named parameter used before it was set",
            ParameterNumberInvalid => "parameter number out of range or read-only",
            ParameterTableFull => "too many parameters, subroutines or nested O-word blocks for the interpreter's tables",
            UnbalancedBlock => "unbalanced O-word block (end without start, or a block left open)",
            UnknownSubroutine => "o-word call of a subroutine that is not in the program",
            NoSavedModalState => "M72 without a modal state saved by M70 or M73 at this call level",
            EndlessLoop => "endless loop: 10000 subprogram jumps or M99 restarts without any action",
            CompAlreadyOn => "cutter compensation is already on (G40 first)",
            CompPlane => "cutter compensation works only in the XY (G17) and XZ (G18) planes, and the plane cannot change while it is on",
            CompForbidden => "not allowed while cutter compensation is on (G40 first): offsets, G28/G30, G53, canned cycles, G38 probing, M6, G43/G49, G54-G59, G61/G64, G98/G99",
            CompEntryTooShort => "cutter compensation entry move is not longer than the tool radius",
            CompArcTooSmall => "tool radius is not less than the radius of the arc it runs inside",
            CompGouge => "concave corner the compensated tool cannot reach without gouging",
            CompArcAfterExit => "the move just after G40 must be straight, not an arc",
            CompLookAheadFull => "too many actions between two compensated moves (at most 5)",
            CompDiameterMissing => "G41.1/G42.1 need a D word (the tool diameter)",
            TransformOrder => "G51.1, G51, G68 given twice or out of order (mirror, scaling, rotation; cancel in reverse order)",
            TransformPlane => "plane change while G68 rotation is on (G69 first)",
            TransformArcScaled => "arc while its plane axes are scaled by different factors",
            TransformOffset => "G92, G52 or G10 L20 while mirror, scaling or rotation is on",
            TransformNotAlone => "G51 must stand alone in its block (X Y Z I J K P only)",
            TransformValue => "G51 needs a factor 0 < f <= 999.999999 (P or I/J/K, not both), G68 an R within 360 deg, G51.1 an axis",
        }
    }
}
