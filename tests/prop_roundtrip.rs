//! Property: for "line soup" — random mixes of realistic Sinumerik fragments, arbitrary bytes, every line
//! ending, BOMs and missing final newlines — printing the parsed program gives the input back byte for byte,
//! the parser does not panic, and every diagnostic points inside the source.

use driftloop::{LineIndex, parse};
use proptest::prelude::*;

/// Pieces of real programs, chosen to reach every corner of the grammar, including broken ones.
const FRAGMENTS: &[&[u8]] = &[
    b"N10",
    b"N99999",
    b":100",
    b"/",
    b"/3",
    b"G0",
    b"G1",
    b"G90",
    b"G91",
    b"G17",
    b"G54",
    b"G500",
    b"G700",
    b"X10.5",
    b"Y-.5",
    b"Z=R1+5",
    b"X=IC(5)",
    b"Y=AC(2.5)",
    b"A=DC(90)",
    b"B=ACP(10)",
    b"C=ACN(10)",
    b"CR=5",
    b"I1 J2 K3",
    b"F1000",
    b"F=R7*2",
    b"S12000",
    b"S1=1000",
    b"M3",
    b"M3=5",
    b"M30",
    b"M17",
    b"M6",
    b"T1",
    b"T=\"FACE MILL 50\"",
    b"D1",
    b"H2",
    b"R1=5",
    b"R[2]=R1+1",
    b"R[R1+1]",
    b"$P_UIFR[1,Z,TR]=0.1",
    b"$AA_IM[X]",
    b"$AC_MEA[1]",
    b"$A_DBB[0]",
    b"DEF REAL VAL=1.5",
    b"DEF INT CNT[3]=SET(1,2,3)",
    b"DEF STRING[16] NAME=\"A\"",
    b"DEF AXIS AX1",
    b"DEF FRAME F1",
    b"PROC FOO(REAL A, VAR INT B) SAVE DISPLOF",
    b"EXTERN FOO(REAL, VAR INT)",
    b"DEFINE M_ON AS M3",
    b"IF R1>0",
    b"IF (R1==2) AND NOT (R2<>3)",
    b"ELSE",
    b"ENDIF",
    b"WHILE R1<10",
    b"ENDWHILE",
    b"FOR R1=1 TO 5",
    b"ENDFOR",
    b"REPEAT",
    b"UNTIL R1>=3",
    b"LOOP",
    b"ENDLOOP",
    b"CASE R1 OF 1 GOTOF L1 2 GOTOB L2 DEFAULT GOTOF L3",
    b"GOTOF LBL1",
    b"GOTOB START",
    b"GOTO N10",
    b"GOTOC \"L\"<<R1",
    b"GOTOS",
    b"LBL1:",
    b"START:",
    b"REPEAT LBL1 LBL2 P=3",
    b"MSG(\"hello \" << R1)",
    b"MSG()",
    b"CYCLE800(1,\"TC1\",,57,0,0,0)",
    b"SETAL(65000)",
    b"STOPRE",
    b"RET",
    b"L123 P3",
    b"CALL \"SUB\"",
    b"PCALL SUB(1)",
    b"MCALL CYCLE81(10,0,1)",
    b"MCALL",
    b"EXTCALL \"BIG\"",
    b"TRANS X10 Y5",
    b"ATRANS Z1",
    b"ROT Z45",
    b"AROT RPL=30",
    b"SCALE X2",
    b"MIRROR X0",
    b"ID=1 WHENEVER $AA_IM[X]>10 DO $R1=1",
    b"WHEN $A_IN[1]==1 DO M5",
    b"SIN(30)*COS(60)/TAN(1)",
    b"ATAN2(1,2)",
    b"SQRT(POT(3))",
    b"ROUND(TRUNC(2.5))",
    b"MINVAL(1,2) MAXVAL(3,4)",
    b"'H1F'",
    b"'B101'",
    b"R1 DIV 2 MOD 3",
    b"B_AND B_OR B_XOR B_NOT",
    b"XOR",
    b"OR",
    b"AND",
    b"NOT",
    b"<<",
    b"==",
    b"<>",
    b"<=",
    b">=",
    b"=",
    b"(",
    b")",
    b"[",
    b"]",
    b",",
    b"\"",
    b"\"unterminated",
    b"; comment",
    b"; \xC3\xBCmlaut",
    b"; latin1 \xFC",
    b"; gbk \xD6\xD0",
    b"(paren comment)",
    b"%_N_MAIN_MPF",
    b"%_N_SUB_SPF",
    b";$PATH=/_N_MPF_DIR",
    b"%",
    b"&",
    b"\t",
    b"\x00",
    b"\xFF\xFE",
    b"\xEF\xBB\xBF",
    b"\x1A",
    b"\x7F",
    b"X 10",
    b"N 20",
    b"G 1",
    b"Y -2.5",
    b"L 100 P 2",
    b"\xA3\xBB",
    b"\xA3\xBA",
    b"\xEF\xBC\x9B",
    b"\xE3\x80\x80",
    b"CASE R1 OF-1 GOTOF L1-2 GOTOF \"L\"<<R1",
    b"<<R1",
    b"WHEN R1>0 DO R2=1 ELSE R2=0",
    b"REPEATB L1 L2",
    b"ELSE IF R1>2",
    b"LBL1: X1",
];

const SEPARATORS: &[&[u8]] = &[b" ", b"", b"  ", b"\t", b"&", b" ; tail"];
const LINE_ENDINGS: &[&[u8]] = &[b"\n", b"\r\n", b"\r"];

fn fragment() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        6 => prop::sample::select(FRAGMENTS).prop_map(<[u8]>::to_vec),
        2 => (prop::sample::select(&b"XYZABCIJKFSRNGMTD"[..]), -99_999i32..99_999, 0u32..4)
            .prop_map(|(letter, value, scale)| {
                let v = f64::from(value) / 10f64.powi(scale as i32);
                format!("{}{v}", letter as char).into_bytes()
            }),
        1 => prop::collection::vec(any::<u8>(), 0..6),
    ]
}

fn line() -> impl Strategy<Value = Vec<u8>> {
    let separator = prop::sample::select(SEPARATORS);
    prop::collection::vec((fragment(), separator), 0..8).prop_map(|parts| {
        let mut line = Vec::new();
        for (fragment, separator) in parts {
            line.extend_from_slice(&fragment);
            line.extend_from_slice(separator);
        }
        line
    })
}

fn program() -> impl Strategy<Value = Vec<u8>> {
    let ending = prop::sample::select(LINE_ENDINGS);
    (
        any::<bool>(),
        prop::collection::vec((line(), ending), 0..24),
        any::<bool>(),
    )
        .prop_map(|(bom, lines, final_newline)| {
            let mut src = Vec::new();
            if bom {
                src.extend_from_slice(b"\xEF\xBB\xBF");
            }
            for (line, ending) in lines {
                src.extend_from_slice(&line);
                src.extend_from_slice(ending);
            }
            if !final_newline {
                while src.last().is_some_and(|b| matches!(b, b'\n' | b'\r')) {
                    src.pop();
                }
            }
            src
        })
}

fn check(src: &[u8]) -> Result<(), TestCaseError> {
    let program = parse(src);
    prop_assert_eq!(program.to_bytes(), src);
    let mut written = Vec::new();
    program.write_to(&mut written).unwrap();
    prop_assert_eq!(&written[..], src);

    let index = LineIndex::new(src);
    let mut last_start = 0;
    for d in program.diagnostics() {
        let (start, end) = (d.span.start, d.span.end);
        prop_assert!(
            start <= end && end <= src.len(),
            "span {start}..{end} outside {}: {d:?}",
            src.len()
        );
        prop_assert!(start >= last_start, "diagnostics not sorted: {d:?}");
        last_start = start;
        for (span, _) in &d.related {
            prop_assert!(
                span.start <= span.end && span.end <= src.len(),
                "related {span:?}: {d:?}"
            );
        }
        let (line, col) = index.line_col(start);
        prop_assert!(line >= 1 && col >= 1);
    }
    Ok(())
}

/// In a valid UTF-8 program no diagnostic may cut a character in two (a caret under half a character).
fn spans_on_char_boundaries(src: &[u8]) -> Result<(), TestCaseError> {
    let Ok(text) = std::str::from_utf8(src) else {
        return Ok(());
    };
    for d in parse(src).diagnostics() {
        let spans = std::iter::once(&d.span).chain(d.related.iter().map(|(span, _)| span));
        for span in spans {
            prop_assert!(
                text.is_char_boundary(span.start) && text.is_char_boundary(span.end),
                "{span:?} splits a character: {d:?}"
            );
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn line_soup_round_trips(src in program()) {
        check(&src)?;
    }

    #[test]
    fn line_soup_diagnostics_do_not_split_characters(src in program()) {
        spans_on_char_boundaries(&src)?;
    }

    #[test]
    fn arbitrary_bytes_round_trip(src in prop::collection::vec(any::<u8>(), 0..512)) {
        check(&src)?;
    }
}
