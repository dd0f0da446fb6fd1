//! Summary statistics of a batch of trials.

use formica::{Outcome, RunResult};
use serde::Serialize;

/// Wilson score interval for `k` successes in `n` trials at 95 %.
pub fn wilson95(k: usize, n: usize) -> [f64; 2] {
    if n == 0 {
        return [0.0, 1.0];
    }
    let z = 1.959_963_984_540_054_f64;
    let n_f = n as f64;
    let p = k as f64 / n_f;
    let denom = 1.0 + z * z / n_f;
    let centre = (p + z * z / (2.0 * n_f)) / denom;
    let half = z * (p * (1.0 - p) / n_f + z * z / (4.0 * n_f * n_f)).sqrt() / denom;
    // At k = 0 (k = n) the bound is 0 (1) exactly; rounding left 5.6e-17.
    let lo = if k == 0 {
        0.0
    } else {
        (centre - half).max(0.0)
    };
    let hi = if k >= n {
        1.0
    } else {
        (centre + half).min(1.0)
    };
    [lo, hi]
}

/// Mean of `f` over the results that have it (`None` if none has).
pub fn mean_of(results: &[RunResult], f: impl Fn(&RunResult) -> Option<f64>) -> Option<f64> {
    let xs: Vec<f64> = results.iter().filter_map(f).collect();
    (!xs.is_empty()).then(|| xs.iter().sum::<f64>() / xs.len() as f64)
}

/// Median completion time with failures censored at +infinity: the time by which half of all
/// trials had succeeded, or `None` unless more than half did (with exactly half, the middle of
/// the sample is a failure).
pub fn censored_median(results: &[RunResult]) -> Option<f64> {
    let mut times: Vec<f64> = results
        .iter()
        .filter(|r| r.outcome == Outcome::Success)
        .map(|r| r.sim_time_s)
        .collect();
    times.sort_by(f64::total_cmp);
    let n = results.len();
    if n == 0 || times.len() * 2 < n {
        return None;
    }
    // Median of the full sample with failures at +inf.
    if n % 2 == 1 {
        times.get(n / 2).copied()
    } else {
        match (times.get(n / 2 - 1), times.get(n / 2)) {
            (Some(a), Some(b)) => Some((a + b) / 2.0),
            _ => None,
        }
    }
}

/// The summary line of `formica run --seeds`.
#[derive(Debug, Serialize)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// Number of trials.
    pub trials: usize,
    /// Successes / trials (null for a scenario with no success rule: static filling).
    pub success_rate: Option<f64>,
    /// Wilson 95 % interval of the success rate (null as `success_rate`).
    pub success_ci95: Option<[f64; 2]>,
    /// Median completion time, failures censored (null unless more than half succeeded, or no
    /// success rule).
    pub median_time_s: Option<f64>,
    /// Mean path efficiency of the successful trials, as reports give it (null as
    /// `success_rate`, or if none succeeded: a failed trial's efficiency measures a path that
    /// never reached the goal).
    pub mean_path_efficiency: Option<f64>,
    /// Counts of each outcome.
    pub outcomes: std::collections::BTreeMap<String, usize>,
}

/// Summarises a batch; `judged`: whether the scenario has a success rule (without one, the
/// success figures are null rather than a 0 % that means nothing).
pub fn summarize(scenario: &str, results: &[RunResult], judged: bool) -> Summary {
    let n = results.len();
    let k = results
        .iter()
        .filter(|r| r.outcome == Outcome::Success)
        .count();
    let mut outcomes = std::collections::BTreeMap::new();
    for r in results {
        *outcomes.entry(r.outcome.name().to_string()).or_insert(0) += 1;
    }
    Summary {
        scenario: scenario.to_string(),
        trials: n,
        success_rate: judged.then_some(if n > 0 { k as f64 / n as f64 } else { 0.0 }),
        success_ci95: judged.then(|| wilson95(k, n)),
        median_time_s: censored_median(results).filter(|_| judged),
        mean_path_efficiency: mean_of(results, |r| {
            (r.outcome == Outcome::Success)
                .then_some(r.path_efficiency)
                .flatten()
        })
        .filter(|_| judged),
        outcomes,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_matches_known_values() {
        // 43/45 (Chen et al.): about [0.852, 0.988].
        let [lo, hi] = wilson95(43, 45);
        assert!((lo - 0.8519).abs() < 1e-3, "{lo}");
        assert!((hi - 0.9877).abs() < 1e-3, "{hi}");
        assert_eq!(wilson95(0, 0), [0.0, 1.0]);
        // No success: the lower bound is exactly 0 (it read 5.55e-17), the upper z^2 / (n + z^2).
        let [lo, hi] = wilson95(0, 10);
        assert_eq!(lo, 0.0);
        assert!((hi - 0.2775).abs() < 1e-4, "{hi}");
        assert_eq!(wilson95(10, 10)[1], 1.0);
    }

    #[test]
    fn path_efficiency_is_the_mean_of_the_successes() {
        let r = |outcome, path_efficiency| RunResult {
            outcome,
            path_efficiency,
            ..RunResult::default()
        };
        // A box that never moved still has a small efficiency from its jitter.
        let rs = [
            r(Outcome::Success, Some(0.9)),
            r(Outcome::Timeout, Some(0.1)),
            r(Outcome::Success, Some(0.7)),
        ];
        let eff = summarize("s", &rs, true).mean_path_efficiency.unwrap();
        assert!((eff - 0.8).abs() < 1e-12, "{eff}");
        assert_eq!(summarize("s", &rs[1..2], true).mean_path_efficiency, None);
        assert_eq!(summarize("s", &rs, false).mean_path_efficiency, None);
    }

    #[test]
    fn mean_of_counts_only_the_results_that_have_the_field() {
        let r = |x: Option<usize>| RunResult {
            cavity_robots: x,
            ..RunResult::default()
        };
        let rs = [r(Some(1)), r(None), r(Some(4))];
        assert_eq!(
            mean_of(&rs, |r| r.cavity_robots.map(|n| n as f64)),
            Some(2.5)
        );
        assert_eq!(
            mean_of(&rs[1..2], |r| r.cavity_robots.map(|n| n as f64)),
            None
        );
        assert_eq!(mean_of(&[], |r| r.path_efficiency), None);
    }
}
