//! Reserved words of the block grammar. Matching is case-insensitive, as on the control.

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kw {
    If,
    Else,
    EndIf,
    While,
    EndWhile,
    For,
    EndFor,
    To,
    Repeat,
    Until,
    Loop,
    EndLoop,
    Case,
    Of,
    Default,
    /// GOTO, GOTOF, GOTOB, GOTOC: jumps with a target.
    Goto,
    /// GOTOS: back to the program start, no target.
    GotoS,
    Def,
    Redef,
    Proc,
    Extern,
    Define,
    As,
    /// Synchronized-action conditions: WHEN, WHENEVER, EVERY, FROM.
    Sync,
    Do,
    /// CALL, PCALL, MCALL, EXTCALL, ISOCALL.
    ProgCall,
    Block,
    Var,
    /// Data types: REAL INT BOOL CHAR STRING AXIS FRAME.
    Type,
    /// DEF storage/access attributes without a value.
    Attr,
    /// DEF attributes followed by a number.
    ValuedAttr,
    And,
    Or,
    Xor,
    /// NOT and B_NOT.
    Not,
    BAnd,
    BOr,
    BXor,
    Div,
    Mod,
}

const TABLE: &[(&str, Kw)] = &[
    ("IF", Kw::If),
    ("ELSE", Kw::Else),
    ("ENDIF", Kw::EndIf),
    ("WHILE", Kw::While),
    ("ENDWHILE", Kw::EndWhile),
    ("FOR", Kw::For),
    ("ENDFOR", Kw::EndFor),
    ("TO", Kw::To),
    ("REPEAT", Kw::Repeat),
    ("REPEATB", Kw::Repeat),
    ("UNTIL", Kw::Until),
    ("LOOP", Kw::Loop),
    ("ENDLOOP", Kw::EndLoop),
    ("CASE", Kw::Case),
    ("OF", Kw::Of),
    ("DEFAULT", Kw::Default),
    ("GOTO", Kw::Goto),
    ("GOTOF", Kw::Goto),
    ("GOTOB", Kw::Goto),
    ("GOTOC", Kw::Goto),
    ("GOTOS", Kw::GotoS),
    ("DEF", Kw::Def),
    ("REDEF", Kw::Redef),
    ("PROC", Kw::Proc),
    ("EXTERN", Kw::Extern),
    ("DEFINE", Kw::Define),
    ("AS", Kw::As),
    ("WHEN", Kw::Sync),
    ("WHENEVER", Kw::Sync),
    ("EVERY", Kw::Sync),
    ("FROM", Kw::Sync),
    ("DO", Kw::Do),
    ("CALL", Kw::ProgCall),
    ("PCALL", Kw::ProgCall),
    ("MCALL", Kw::ProgCall),
    ("EXTCALL", Kw::ProgCall),
    ("ISOCALL", Kw::ProgCall),
    ("BLOCK", Kw::Block),
    ("VAR", Kw::Var),
    ("REAL", Kw::Type),
    ("INT", Kw::Type),
    ("BOOL", Kw::Type),
    ("CHAR", Kw::Type),
    ("STRING", Kw::Type),
    ("AXIS", Kw::Type),
    ("FRAME", Kw::Type),
    ("NCK", Kw::Attr),
    ("CHAN", Kw::Attr),
    ("LUD", Kw::Attr),
    ("GUD", Kw::Attr),
    ("PRLOC", Kw::Attr),
    ("SYNR", Kw::Attr),
    ("SYNW", Kw::Attr),
    ("SYNRW", Kw::Attr),
    ("APR", Kw::ValuedAttr),
    ("APW", Kw::ValuedAttr),
    ("PHU", Kw::ValuedAttr),
    ("LLI", Kw::ValuedAttr),
    ("ULI", Kw::ValuedAttr),
    ("AND", Kw::And),
    ("OR", Kw::Or),
    ("XOR", Kw::Xor),
    ("NOT", Kw::Not),
    ("B_NOT", Kw::Not),
    ("B_AND", Kw::BAnd),
    ("B_OR", Kw::BOr),
    ("B_XOR", Kw::BXor),
    ("DIV", Kw::Div),
    ("MOD", Kw::Mod),
];

pub(crate) fn keyword(name: &[u8]) -> Option<Kw> {
    if name.len() > 8 {
        return None;
    }
    TABLE
        .iter()
        .find(|(text, _)| name.eq_ignore_ascii_case(text.as_bytes()))
        .map(|&(_, kw)| kw)
}

impl Kw {
    /// Words that can never be an operand (operators and the words that separate parts of a statement).
    pub(crate) fn is_reserved(self) -> bool {
        matches!(
            self,
            Kw::And
                | Kw::Or
                | Kw::Xor
                | Kw::Not
                | Kw::BAnd
                | Kw::BOr
                | Kw::BXor
                | Kw::Div
                | Kw::Mod
                | Kw::To
                | Kw::Of
                | Kw::Do
                | Kw::Goto
                | Kw::GotoS
        )
    }
}
