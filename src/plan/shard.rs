//! Splitting the runs of one or more studies into N shards of about equal expected cost, for
//! `slamlab run --shard I/N` (one task of a Slurm job array per shard).
//!
//! The partition depends only on the plans (their content hashes and expected costs), never on
//! the cache or the clock: every task of an array, started at any time on any node, computes the
//! same partition, so every run is computed by exactly one task. Runs that share a content hash
//! (within a study or across studies) are one item: computed once, by one shard.
//!
//! The split is the longest-processing-time-first rule (Graham 1969): items in decreasing
//! expected cost (ties by hash), each to the shard with the least expected cost so far (ties to
//! the lowest index). Its makespan is at most 4/3 of the optimum.

use std::collections::BTreeMap;
use std::fmt;
use std::str::FromStr;

/// Shard `index` (1-based, as Slurm's array task ids are written) of `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

/// The most shards accepted (a Slurm array is limited by `MaxArraySize`, 1001 by default).
pub const MAX_SHARDS: usize = 100_000;

impl FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| format!("`{s}` is not I/N (e.g. 3/8: the third of eight shards)"))?;
        let parse = |x: &str, what: &str| {
            x.trim()
                .parse::<usize>()
                .map_err(|_| format!("`{s}`: {what} `{x}` is not a whole number"))
        };
        let (index, count) = (parse(i, "I")?, parse(n, "N")?);
        if count == 0 || count > MAX_SHARDS {
            return Err(format!("`{s}`: N must be between 1 and {MAX_SHARDS}"));
        }
        if index == 0 || index > count {
            return Err(format!(
                "`{s}`: I must be between 1 and N = {count} (shards are numbered from 1)"
            ));
        }
        Ok(Shard { index, count })
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Assigns each distinct hash of `items` (hash, expected cost) to one of `count` shards; returns
/// hash → shard index (1-based). A hash listed twice keeps its largest cost (identical inputs
/// have identical costs, so this only matters for malformed input).
pub fn partition<'a>(
    items: impl IntoIterator<Item = (&'a str, f64)>,
    count: usize,
) -> BTreeMap<&'a str, usize> {
    assert!(count >= 1, "at least one shard");
    let mut cost: BTreeMap<&str, f64> = BTreeMap::new();
    for (hash, c) in items {
        let c = if c.is_finite() && c > 0.0 { c } else { 0.0 };
        let e = cost.entry(hash).or_insert(c);
        *e = e.max(c);
    }
    let mut order: Vec<(&str, f64)> = cost.into_iter().collect();
    order.sort_by(|a, b| b.1.total_cmp(&a.1).then_with(|| a.0.cmp(b.0)));
    let mut load = vec![0.0f64; count];
    let mut out = BTreeMap::new();
    for (hash, c) in order {
        // the least loaded shard, the lowest index among equals
        let (k, _) = load
            .iter()
            .enumerate()
            .fold((0, f64::INFINITY), |best, (k, &l)| if l < best.1 { (k, l) } else { best });
        load[k] += c;
        out.insert(hash, k + 1);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_as_slurm_writes_them() {
        assert_eq!("3/8".parse::<Shard>(), Ok(Shard { index: 3, count: 8 }));
        assert_eq!("1/1".parse::<Shard>().unwrap().to_string(), "1/1");
        for bad in ["0/4", "5/4", "1/0", "3", "a/4", "1/b", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad} must be refused");
        }
    }

    #[test]
    fn every_hash_goes_to_exactly_one_shard_whatever_the_order() {
        let items: Vec<(String, f64)> =
            (0..200).map(|i| (format!("h{i:03}"), 1.0 + (i * 37 % 11) as f64)).collect();
        let a = partition(items.iter().map(|(h, c)| (h.as_str(), *c)), 7);
        let b = partition(items.iter().rev().map(|(h, c)| (h.as_str(), *c)), 7);
        assert_eq!(a, b, "the partition must not depend on the order the plans list the runs");
        assert_eq!(a.len(), 200);
        assert!(a.values().all(|&k| (1..=7).contains(&k)));
    }

    #[test]
    fn shards_are_balanced_by_cost_not_by_count() {
        // one expensive run and many cheap ones: the expensive one is a shard of its own
        let mut items = vec![("big".to_string(), 100.0)];
        items.extend((0..100).map(|i| (format!("small{i:03}"), 1.0)));
        let p = partition(items.iter().map(|(h, c)| (h.as_str(), *c)), 2);
        let load = |k: usize| {
            items.iter().filter(|(h, _)| p[h.as_str()] == k).map(|(_, c)| c).sum::<f64>()
        };
        assert_eq!(p["big"], 1);
        assert_eq!(
            items.iter().filter(|(h, _)| p[h.as_str()] == 1).count(),
            1,
            "the big run alone fills shard 1"
        );
        assert_eq!((load(1), load(2)), (100.0, 100.0));
    }

    #[test]
    fn lpt_stays_within_four_thirds_of_a_perfect_split() {
        let items: Vec<(String, f64)> =
            (0..57).map(|i| (format!("r{i}"), ((i * 7919) % 97 + 1) as f64)).collect();
        for n in [2, 3, 4, 8] {
            let p = partition(items.iter().map(|(h, c)| (h.as_str(), *c)), n);
            let mut load = vec![0.0; n];
            for (h, c) in &items {
                load[p[h.as_str()] - 1] += c;
            }
            let total: f64 = load.iter().sum();
            let max = load.iter().cloned().fold(0.0, f64::max);
            let largest = items.iter().map(|x| x.1).fold(0.0, f64::max);
            assert!(max <= (4.0 / 3.0) * (total / n as f64).max(largest), "n = {n}: {load:?}");
        }
    }

    #[test]
    fn more_shards_than_runs_leaves_some_empty() {
        let p = partition([("a", 1.0), ("b", 2.0)], 4);
        assert_eq!(p["b"], 1);
        assert_eq!(p["a"], 2);
    }
}
