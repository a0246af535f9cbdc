//! A scan-matching study's diagnostics ([`crate::scanmatch::diagnose`]), made once its runs are
//! done: the run the report's trajectory figure shows (first map, the base or middle sweep point,
//! the median replicate), two of its matches re-run with observers, and every algorithm's
//! incremental map of that run's cell.
//!
//! Which matches: by the final f of the study's first scan matcher in that run, the match of
//! median f (a typical one) and the match of largest finite f (the worst fit; [EP] shows a low-
//! and a high-error step, 2 and 78, the latter chosen as the largest f of its run).

use super::world_of;
use crate::plan::ExperimentPlan;
use crate::scanmatch::diagnose::{self, Diagnostics, IncrementalMap, Subject};
use crate::scanmatch::track;
use crate::store::select;
use crate::store::{MatchRows, RunRow, TraceRows};
use crate::trace::MatchRecord;
use crate::world::laser::Scan;

/// The study's diagnostics, or `None` when it has no scan matcher or no successful run to show;
/// `Err` says why they could not be made (the study is written without them).
pub fn build(
    plan: &ExperimentPlan,
    resolved: &crate::store::ResolvedStudy,
    rows: &[RunRow],
    load: &dyn Fn(&str) -> Option<crate::store::RunParts>,
) -> Result<Option<Diagnostics>, String> {
    let spec = &plan.spec.spec;
    let catalogue = &plan.spec.catalogue;
    let Some(chooser) =
        spec.algorithms.iter().map(|a| catalogue.algorithm(a)).find(|a| a.is_scan_matcher())
    else {
        return Ok(None);
    };
    let Some(first) = spec.algorithms.first() else { return Ok(None) };
    let kinds: Vec<crate::world::WorldKind> = crate::world::WorldKind::ALL
        .into_iter()
        .filter(|k| plan.maps.iter().any(|m| m.world_kind() == *k))
        .collect();
    let base = select::read_base(spec, catalogue, &kinds);
    let Some(point) = select::reference_point(&resolved.points, &base) else { return Ok(None) };
    let headline = select::headline(spec);
    let Some((map_index, shown)) = plan.maps.iter().enumerate().find_map(|(i, m)| {
        select::median_run(rows, &m.name, first.as_str(), &point.label, headline).map(|r| (i, r))
    }) else {
        return Ok(None);
    };
    let map = &plan.maps[map_index].name;
    let cell: Vec<&RunRow> = spec
        .algorithms
        .iter()
        .filter_map(|a| {
            rows.iter().find(|r| {
                &r.map == map
                    && r.algorithm == a.as_str()
                    && r.point == point.label
                    && r.replicate == shown.replicate
            })
        })
        .collect();
    // the traces and matches of the shown cell's runs (the only ones diagnosed), read once
    let (traces, matches): (Vec<TraceRows>, Vec<MatchRows>) =
        cell.iter().filter_map(|r| load(&r.run_id)).map(|p| (p.trace, p.matches)).unzip();
    let matches_of = |run: &RunRow| {
        matches.iter().find(|m| m.run_id == run.run_id).map_or(&[][..], |m| m.matches.as_slice())
    };
    let Some(chooser_run) = cell.iter().find(|r| r.algorithm == chooser.name()) else {
        return Ok(None);
    };
    let records = matches_of(chooser_run);
    let chosen = choose(records);
    if chosen.is_empty() {
        return Ok(None);
    }
    let spec_of = |run: &RunRow| plan.runs.iter().find(|s| s.run_id == run.run_id);
    let run_spec = spec_of(chooser_run).ok_or("the chosen run is not in the plan")?;
    let world = world_of(plan, run_spec).map_err(|e| e.to_string())?;
    let geometry = world.laser.ok_or("the world has no laser")?;
    let params = &plan.points[run_spec.point].params;
    let scan_at = |step: usize| world.scans.iter().find(|s| s.step == step);
    let chooser_title = chooser.title();

    let mut diagnosed = Vec::new();
    for (k, why) in chosen {
        let m = &records[k];
        let (Some(reference), Some(current)) = (scan_at(m.reference_step), scan_at(m.current_step))
        else {
            return Err(format!("match {} has no scans", k + 1));
        };
        let (seg, geo) = (params.scan_matching.segmentation.clone(), geometry);
        let common = (track::prepared(reference, &geo, &seg), track::prepared(current, &geo, &seg));
        // every scan matcher of the cell, on its own preparation of the same two scans
        let mut prepared = Vec::new();
        for run in cell.iter().filter(|r| r.algorithm != "odometry") {
            let Some(kind) = catalogue.get(&run.algorithm) else { continue };
            let Some(stored) = matches_of(run).get(k).filter(|s| {
                s.reference_step == m.reference_step && s.current_step == m.current_step
            }) else {
                continue;
            };
            let Some(rs) = spec_of(run) else { continue };
            let run_params = &plan.points[rs.point].params;
            // a matcher slamlab can re-run one match of (not an external program)
            let Some(matcher) = kind.matcher(run_params) else { continue };
            let (seg, geo) = track::preparation(matcher, &run_params.scan_matching, geometry);
            prepared.push((
                kind,
                matcher,
                track::match_seed(rs.filter_seed, k),
                stored.estimate,
                track::prepared(reference, &geo, &seg),
                track::prepared(current, &geo, &seg),
            ));
        }
        let subjects: Vec<Subject<'_>> = prepared
            .iter()
            .map(|(kind, matcher, seed, stored, r, c)| Subject {
                algorithm: kind.name().to_string(),
                matcher: *matcher,
                seed: *seed,
                reference: r,
                current: c,
                stored: *stored,
            })
            .collect();
        let why = format!("{why} of {chooser_title} in this run");
        diagnosed.push(diagnose::diagnose(
            k + 1,
            why,
            (m.reference_step, m.current_step),
            (&common.0, &common.1),
            m.truth,
            m.initial,
            &subjects,
            &params.scan_matching.objective,
        ));
    }

    // The incremental maps: the scans the chooser matched, at each algorithm's estimates.
    let steps = track::matched_steps(records);
    let scans: Vec<&Scan> = steps.iter().filter_map(|&s| scan_at(s)).collect();
    let maps: Vec<IncrementalMap> = cell
        .iter()
        .filter_map(|run| {
            let trace = traces.iter().find(|t| t.run_id == run.run_id)?;
            let placed: Vec<(&[Option<f64>], crate::geom::Pose2)> = scans
                .iter()
                .filter_map(|s| trace.estimate.get(s.step).map(|p| (s.ranges_m.as_slice(), *p)))
                .collect();
            Some(diagnose::incremental_map(&run.algorithm, &placed, &geometry))
        })
        .collect();
    Ok(Some(Diagnostics {
        map: map.clone(),
        point: point.label.clone(),
        replicate: shown.replicate,
        matches: diagnosed,
        maps,
    }))
}

/// The matches to diagnose (index, why): the median and the largest finite f; one when they
/// coincide, none when no match has a finite f.
fn choose(records: &[MatchRecord]) -> Vec<(usize, &'static str)> {
    let mut finite: Vec<(usize, f64)> = records
        .iter()
        .enumerate()
        .filter(|(_, m)| m.f.is_finite())
        .map(|(k, m)| (k, m.f))
        .collect();
    finite.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    let (Some(median), Some(largest)) =
        (finite.get(finite.len().saturating_sub(1) / 2), finite.last())
    else {
        return Vec::new();
    };
    if median.0 == largest.0 {
        vec![(largest.0, "the largest final f")]
    } else {
        vec![(median.0, "the median final f"), (largest.0, "the largest final f")]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Pose2;

    fn record(f: f64) -> MatchRecord {
        let p = Pose2::new(0.0, 0.0, 0.0);
        MatchRecord {
            reference_step: 0,
            current_step: 1,
            truth: p,
            initial: p,
            estimate: p,
            f,
            f_initial: f,
            pairs: 0,
            iterations: 0,
            evaluations: 0,
            fallback: false,
            stop: String::new(),
            time_s: 0.0,
        }
    }

    #[test]
    fn chooses_the_median_and_the_largest_finite_f() {
        let r: Vec<MatchRecord> =
            [3.0, f64::INFINITY, 1.0, 9.0, 2.0].into_iter().map(record).collect();
        // finite f sorted: 1 (k=2), 2 (k=4), 3 (k=0), 9 (k=3): the lower median is k=4
        assert_eq!(choose(&r), vec![(4, "the median final f"), (3, "the largest final f")]);
        assert_eq!(choose(&r[..1]), vec![(0, "the largest final f")]);
        assert!(choose(&[record(f64::NAN)]).is_empty());
    }
}
