//! What the parser keeps of each block besides its bytes: its control-flow role ([`BlockKind`]) and its
//! [`flag`]s.

use serde::Serialize;

/// The control-flow role of a block, kept per block so the structure pass never re-parses plain blocks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
#[repr(u8)]
pub enum BlockKind {
    /// No control keyword (words, assignments, calls, comments, empty lines, one-line jumps).
    Plain,
    /// `%…` archive or transfer header: starts a new program unit.
    Header,
    If,
    Else,
    EndIf,
    While,
    EndWhile,
    For,
    EndFor,
    /// `REPEAT` opening a REPEAT … UNTIL loop (not the `REPEAT label` section repeat).
    Repeat,
    Until,
    Loop,
    EndLoop,
}

impl BlockKind {
    /// The control keyword of the role (`IF`, `ENDWHILE` …; "a header" for a header, empty for a plain block).
    pub fn keyword(self) -> &'static str {
        match self {
            BlockKind::If => "IF",
            BlockKind::Else => "ELSE",
            BlockKind::EndIf => "ENDIF",
            BlockKind::While => "WHILE",
            BlockKind::EndWhile => "ENDWHILE",
            BlockKind::For => "FOR",
            BlockKind::EndFor => "ENDFOR",
            BlockKind::Repeat => "REPEAT",
            BlockKind::Until => "UNTIL",
            BlockKind::Loop => "LOOP",
            BlockKind::EndLoop => "ENDLOOP",
            BlockKind::Header => "a header",
            BlockKind::Plain => "",
        }
    }
}

/// Per-block flags, as bits (see [`Program::block_flags`](super::Program::block_flags)).
pub mod flag {
    pub const LABEL: u8 = 1;
    pub const JUMP: u8 = 2;
    pub const ERROR: u8 = 4;
    /// Inside an archive section that holds text, not NC code (`%_N_…_COM`): kept as opaque text.
    pub const TEXT: u8 = 8;
}
