//! Spindle schedules for prediction: `"3000:60,0:30,5000:2h"` = 3000 rpm for 60 min, stop 30 min,
//! 5000 rpm for 2 h, starting from rest; a duration is a time as every flag takes it (a bare number is
//! minutes).

use std::str::FromStr;

use crate::data::{Dataset, SPINDLE, TimeUnit};

/// One constant-speed segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    pub rpm: f64,
    pub minutes: f64,
}

/// A sequence of constant-speed segments from rest.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    pub segments: Vec<Segment>,
}

impl FromStr for Schedule {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let segments = s
            .split(',')
            .enumerate()
            .map(|(i, item)| {
                let item = item.trim();
                let bad = |why: &str| format!("schedule item {} `{item}`: {why}", i + 1);
                let (rpm, min) = item
                    .split_once(':')
                    .ok_or_else(|| bad("expected RPM:DURATION, e.g. 3000:60 or 3000:1h"))?;
                let rpm: f64 = rpm
                    .trim()
                    .parse()
                    .map_err(|_| bad("speed is not a number"))?;
                let minutes = min
                    .parse::<crate::data::Minutes>()
                    .map_err(|why| bad(&format!("duration {why}")))?
                    .0;
                if !rpm.is_finite() {
                    return Err(bad("speed is not finite"));
                }
                if rpm.abs() > super::file::FASTEST_RPM {
                    return Err(bad(&format!(
                        "speed is faster than {} rpm",
                        super::file::FASTEST_RPM
                    )));
                }
                if !(minutes.is_finite() && minutes > 0.0) {
                    return Err(bad("duration must be a positive number of minutes"));
                }
                Ok(Segment { rpm, minutes })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Schedule { segments })
    }
}

impl Schedule {
    /// Total duration in minutes.
    pub fn minutes(&self) -> f64 {
        self.segments.iter().map(|s| s.minutes).sum()
    }

    /// Highest |speed| in the schedule.
    pub fn max_rpm(&self) -> f64 {
        self.segments.iter().fold(0.0, |a, s| a.max(s.rpm.abs()))
    }

    /// How many rows [`Schedule::to_dataset`] makes at `step_min` (as a float: it may be beyond any count).
    pub fn rows(&self, step_min: f64) -> f64 {
        self.segments
            .iter()
            .map(|s| (s.minutes / step_min).ceil().max(1.0))
            .sum::<f64>()
            + 1.0
    }

    /// The schedule as a one-run dataset with a `spindle_rpm` column: a row every `step_min` minutes and at
    /// every segment boundary, each row carrying the speed that holds from it on.
    pub fn to_dataset(&self, step_min: f64) -> Dataset {
        let mut t = Vec::new();
        let mut rpm = Vec::new();
        let mut start = 0.0;
        for seg in &self.segments {
            let n = (seg.minutes / step_min).ceil().max(1.0) as usize;
            for i in 0..n {
                let ti = start + i as f64 * step_min;
                if ti < start + seg.minutes {
                    t.push(ti);
                    rpm.push(seg.rpm);
                }
            }
            start += seg.minutes;
        }
        t.push(start);
        rpm.push(0.0);
        let mut ds = Dataset::new("schedule", TimeUnit::Min, t);
        ds.push_column(SPINDLE, rpm);
        ds
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_samples_boundaries() {
        let s: Schedule = "3000:60, 0:30,5000:2.5".parse().unwrap();
        assert_eq!(s.minutes(), 92.5);
        assert_eq!(s.max_rpm(), 5000.0);
        let ds = s.to_dataset(25.0);
        assert_eq!(ds.time_min, vec![0.0, 25.0, 50.0, 60.0, 85.0, 90.0, 92.5]);
        assert_eq!(
            ds.values(SPINDLE).unwrap(),
            &[3000.0, 3000.0, 3000.0, 0.0, 0.0, 5000.0, 0.0]
        );
    }

    #[test]
    fn durations_take_a_unit_as_every_time_flag_does() {
        let s: Schedule = "5000:1h,0:30min,3000:90s".parse().unwrap();
        assert_eq!(s.minutes(), 91.5);
        let err = "5000:1 hour".parse::<Schedule>().unwrap_err();
        assert!(err.contains("unknown time unit `hour`"), "{err}");
    }

    #[test]
    fn rejects_bad_items() {
        for bad in ["3000", "x:60", "3000:-5", "3000:0", "3000:60,,"] {
            let err = bad.parse::<Schedule>().unwrap_err();
            assert!(err.starts_with("schedule item"), "{bad}: {err}");
        }
    }
}
