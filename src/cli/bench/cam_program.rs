//! A synthetic CAM-style program for throughput measurements: a short set-up, then N-numbered linear moves
//! (`N… G1 X… Y… Z…` with a feed word whenever the feed changes), as post-processors emit for 3-axis
//! finishing. Only the RS-274 subset both parsers under comparison understand, and fully deterministic for a
//! given seed so numbers from different runs measure the same bytes.

use std::fmt::Write;

use crate::model::synth::Rng;

/// Uniform in `-span..span` with three decimals, the resolution CAM output uses for millimetres.
fn step(rng: &mut Rng, span: i64) -> i64 {
    (rng.next_u64() % (2 * span as u64 + 1)) as i64 - span
}

/// Appends `value / 1000` with exactly three decimals (integer maths: no float formatting cost or rounding).
fn push_mm(out: &mut String, letter: char, value: i64) {
    let sign = if value < 0 { "-" } else { "" };
    let abs = value.unsigned_abs();
    let _ = write!(out, " {letter}{sign}{}.{:03}", abs / 1000, abs % 1000);
}

/// Generates at least `target_bytes` bytes (it finishes the line and adds the program end); LF line endings.
pub fn generate(target_bytes: usize, seed: u64) -> Vec<u8> {
    let mut rng = Rng::new(seed);
    let mut out = String::with_capacity(target_bytes + 64);
    out.push_str("N1 G90 G17 G54 G71\nN2 T1 M6\nN3 S12000 M3\nN4 G0 X0.000 Y0.000 Z50.000\n");
    let (mut x, mut y, mut z) = (0i64, 0i64, 5_000i64);
    let mut feed = 0u32;
    let mut n = 5u64;
    while out.len() < target_bytes {
        x = (x + step(&mut rng, 2_000)).clamp(-250_000, 250_000);
        y = (y + step(&mut rng, 2_000)).clamp(-250_000, 250_000);
        z = (z + step(&mut rng, 200)).clamp(-40_000, 5_000);
        let _ = write!(out, "N{n} G1");
        push_mm(&mut out, 'X', x);
        push_mm(&mut out, 'Y', y);
        push_mm(&mut out, 'Z', z);
        if feed == 0 || rng.next_u64() % 8 == 0 {
            feed = 500 + (rng.next_u64() % 40) as u32 * 100;
            let _ = write!(out, " F{feed}");
        }
        out.push('\n');
        n += 1;
    }
    let _ = writeln!(out, "N{n} M30");
    out.into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_bytes_and_size_reached() {
        let a = generate(10_000, 7);
        assert_eq!(a, generate(10_000, 7));
        assert_ne!(a, generate(10_000, 8));
        assert!(a.len() >= 10_000 && a.len() < 10_100, "{}", a.len());
        assert!(a.ends_with(b" M30\n"));
    }

    #[test]
    fn every_move_line_is_numbered_and_well_formed() {
        let text = String::from_utf8(generate(5_000, 1)).unwrap();
        let mut last_n = 0;
        for line in text.lines() {
            let (n, rest) = line.split_once(' ').unwrap();
            let n: u64 = n.strip_prefix('N').unwrap().parse().unwrap();
            assert_eq!(n, last_n + 1, "{line}");
            last_n = n;
            if let Some(words) = rest.strip_prefix("G1 ") {
                let letters: Vec<char> = words
                    .split(' ')
                    .map(|w| w.chars().next().unwrap())
                    .collect();
                assert!(letters.starts_with(&['X', 'Y', 'Z']), "{line}");
                for word in words.split(' ') {
                    word[1..].parse::<f64>().unwrap();
                }
            }
        }
    }
}
