//! Internal T numbers of tools the program names (`T="EM_D20"`, `GETT("EM_D20", 2)`). On a control with
//! tool management each tool (name and duplo number) gets its T number when it is created in the tool
//! table; the dry run has no tool table, so it derives one from the name and duplo number alone: the same
//! in every run and every program, so an original and its transformed program read the same numbers.

/// Where derived numbers start: above the T numbers programs write themselves (T1 … T999 and more).
const FIRST: u32 = 10_000;
/// How many derived numbers there are; T numbers on the control go up to 32 000.
const SPAN: u32 = 20_000;

/// The T number of tool `name` (any case) with duplo number `duplo`.
pub fn internal_number(name: &str, duplo: u32) -> f64 {
    // FNV-1a: a fixed hash, unlike the standard library's, which may change between releases.
    let mut h: u32 = 0x811c_9dc5;
    for b in name
        .to_ascii_uppercase()
        .bytes()
        .chain([0])
        .chain(duplo.to_le_bytes())
    {
        h = (h ^ u32::from(b)).wrapping_mul(0x0100_0193);
    }
    f64::from(FIRST + h % SPAN)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_stable_and_tell_sisters_apart() {
        let first = internal_number("EM_D10_FIN", 1);
        assert_eq!(
            first,
            internal_number("em_d10_fin", 1),
            "names are not case-sensitive"
        );
        assert_ne!(
            first,
            internal_number("EM_D10_FIN", 2),
            "a sister tool is a tool of its own"
        );
        assert_ne!(first, internal_number("EM_D20_ROUGH", 1));
        assert!((10_000.0..30_000.0).contains(&first) && first.fract() == 0.0);
        // Pinned: a change of the derivation changes what stored runs and snapshots read.
        assert_eq!(internal_number("EM_D10_FIN", 2), NUMBER_OF_EM_D10_FIN_2);
    }

    const NUMBER_OF_EM_D10_FIN_2: f64 = 20_815.0;
}
