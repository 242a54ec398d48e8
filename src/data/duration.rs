//! Times on the command line, in one convention for every flag (`fit --until`, `diagnose --holdout-from`,
//! `--probe-every`, …): a number with its unit — `57600s`, `90min`, `24h` — or a bare number of minutes.

use std::str::FromStr;

/// A duration or a point on a data set's time axis, in minutes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Minutes(pub f64);

impl FromStr for Minutes {
    type Err = String;

    fn from_str(s: &str) -> Result<Minutes, String> {
        let text = s.trim();
        // The unit is the trailing run of letters, so an exponent (`1e6`, `2.5e3min`) stays in the number.
        let split = text
            .trim_end_matches(|c: char| c.is_ascii_alphabetic())
            .len();
        let (number, unit) = text.split_at(split);
        let per_unit = match unit.trim().to_ascii_lowercase().as_str() {
            "" | "min" | "m" => 1.0,
            "s" => 1.0 / 60.0,
            "h" => 60.0,
            "d" => 1440.0,
            other => {
                return Err(format!(
                    "`{s}`: unknown time unit `{other}` (use s, min or h, e.g. 57600s, 90min, 24h; a bare number is minutes)"
                ));
            }
        };
        let value: f64 = number.trim().parse().map_err(|_| {
            format!("`{s}` is not a time (a number with s, min or h, e.g. 24h; a bare number is minutes)")
        })?;
        if !value.is_finite() {
            return Err(format!("`{s}` is not a finite time"));
        }
        Ok(Minutes(value * per_unit))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_and_bare_minutes() {
        let m = |s: &str| s.parse::<Minutes>().map(|m| m.0);
        assert_eq!(m("24h"), Ok(1440.0));
        assert_eq!(m("90min"), Ok(90.0));
        assert_eq!(m("57600s"), Ok(960.0));
        assert_eq!(m("1.5 h"), Ok(90.0));
        assert_eq!(m("960"), Ok(960.0));
        assert_eq!(m("2d"), Ok(2880.0));
        assert!(
            m("16 hours")
                .unwrap_err()
                .contains("unknown time unit `hours`")
        );
        assert!(m("h").unwrap_err().contains("is not a time"));
        assert!(m("inf").is_err());
        assert_eq!(m("1e3"), Ok(1000.0));
        assert_eq!(m("1.5e2min"), Ok(150.0));
        assert_eq!(m("2e1 h"), Ok(1200.0));
    }
}
