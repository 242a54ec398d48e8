//! Irrelevance strategy: sensors that move together carry the same information, so they are grouped by
//! complete-linkage hierarchical clustering on the distance 1 − |r| and only one per group is kept.

/// Groups of indices into the correlation matrix `r` (n × n, row major). Complete linkage cut at
/// 1 − `threshold` means every pair inside a group has |r| ≥ `threshold` — a group never chains two
/// unrelated sensors through a third. Groups are ordered by their first member; members ascending.
pub fn clusters(r: &[Vec<f64>], threshold: f64) -> Vec<Vec<usize>> {
    let cut = 1.0 - threshold;
    let mut groups: Vec<Vec<usize>> = (0..r.len()).map(|i| vec![i]).collect();
    let distance = |a: &[usize], b: &[usize]| {
        a.iter()
            .flat_map(|&i| b.iter().map(move |&j| 1.0 - r[i][j].abs()))
            .fold(0.0_f64, f64::max)
    };
    loop {
        let mut best: Option<(f64, usize, usize)> = None;
        for a in 0..groups.len() {
            for b in a + 1..groups.len() {
                let d = distance(&groups[a], &groups[b]);
                if d <= cut && best.is_none_or(|(bd, _, _)| d < bd) {
                    best = Some((d, a, b));
                }
            }
        }
        let Some((_, a, b)) = best else { break };
        let merged = groups.remove(b);
        groups[a].extend(merged);
        groups[a].sort_unstable();
    }
    groups.sort_by_key(|g| g[0]);
    groups
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn complete_linkage_does_not_chain_through_a_middle_sensor() {
        // 0–1 and 1–2 are close, 0–2 are not: single linkage would make one group of three.
        let r = vec![
            vec![1.0, 0.95, 0.5, 0.0],
            vec![0.95, 1.0, 0.93, 0.0],
            vec![0.5, 0.93, 1.0, 0.0],
            vec![0.0, 0.0, 0.0, 1.0],
        ];
        assert_eq!(clusters(&r, 0.9), vec![vec![0, 1], vec![2], vec![3]]);
        assert_eq!(clusters(&r, 0.4), vec![vec![0, 1, 2], vec![3]]);
    }

    #[test]
    fn anti_correlated_sensors_belong_together() {
        let r = vec![vec![1.0, -0.97], vec![-0.97, 1.0]];
        assert_eq!(clusters(&r, 0.9), vec![vec![0, 1]]);
    }
}
