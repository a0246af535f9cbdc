//! The global-sensitivity section of a study report: for each morris / sobol group, per map,
//! algorithm and metric, the indices as a table and a figure, and sentences generated from the
//! numbers (ranking, what clears the noise floor, interactions, where the variance comes from).

use super::figure::{self, IndexBarsFigure, MorrisFigure};
use super::model::{FigureView, SensitivityBlock, SensitivitySection, TableView};
use crate::judge::sensitivity::{Analysis, FAILED, Indices, analyse};
use crate::metrics::MetricDef;
use crate::spec::{SweepKind, SweepSpec};
use crate::stats::sig;
use crate::store::StudyData;

/// ST − S1 above this is called an interaction in words (and only when ST clears the noise).
pub const INTERACTION: f64 = 0.1;

/// The sweep's line in the report's list of sweeps.
pub fn sweep_line(s: &SweepSpec) -> String {
    let mut leaves = Vec::new();
    crate::params::flatten("", &toml::Value::Table(s.ranges.clone()), &mut leaves);
    let ranges: Vec<String> = leaves
        .iter()
        .map(|(k, v)| {
            let b: Vec<String> = v
                .as_array()
                .map(|a| a.iter().map(crate::plan::format_value).collect())
                .unwrap_or_default();
            format!("{k} ∈ [{}]{}", b.join(", "), if s.log.contains(k) { " (log)" } else { "" })
        })
        .collect();
    let tied: Vec<String> =
        s.tied.iter().map(|(k, v)| format!("{k} = {}", v.as_str().unwrap_or("?"))).collect();
    let tied = if tied.is_empty() { String::new() } else { format!("; tied: {}", tied.join(", ")) };
    match s.kind {
        SweepKind::Morris => format!(
            "Morris screening, {} trajectories on {} levels: {}{tied}",
            s.trajectories.unwrap_or(10),
            s.levels.unwrap_or(4),
            ranges.join("; ")
        ),
        _ => format!(
            "Sobol' indices, Saltelli design with N = {} on a scrambled Sobol' sequence: {}{tied}",
            s.samples.unwrap_or(64),
            ranges.join("; ")
        ),
    }
}

/// Last path segment when unique among `params`, else the whole path.
fn short_names(params: &[String]) -> Vec<String> {
    let last = |p: &str| p.rsplit('.').next().unwrap_or(p).to_string();
    params
        .iter()
        .map(|p| {
            if params.iter().filter(|q| last(q) == last(p)).count() == 1 {
                last(p)
            } else {
                p.clone()
            }
        })
        .collect()
}

fn ci(e: &crate::stats::sensitivity::Estimate) -> String {
    if e.low.is_finite() {
        format!("{} [{}, {}]", sig(e.value, 2), sig(e.low, 2), sig(e.high, 2))
    } else {
        sig(e.value, 2)
    }
}

fn pct(x: f64) -> String {
    format!("{:.0} %", 100.0 * x)
}

/// Every design row's output per metric, in design order, for re-analysis with any tool
/// (`sensitivity.csv`; for a sobol group the rows are A₁…A_N, B₁…B_N, then each ABᵢ; SALib
/// wants them per sample as A, AB₁…AB_d, B). Empty when the study has no design group.
pub fn csv(data: &StudyData, analyses: &[Analysis]) -> String {
    if analyses.is_empty() {
        return String::new();
    }
    let names = metric_names(analyses);
    // a metric analysed on a log scale is exported as what was analysed: ln of the replicates' values, averaged
    let header: Vec<String> = names
        .iter()
        .map(|m| {
            if data.resolved.spec.report.sensitivity_log.contains(m) {
                format!("ln_{m}")
            } else {
                m.clone()
            }
        })
        .collect();
    let mut out = format!("group,kind,map,algorithm,row,point,role,{}\n", header.join(","));
    for (gi, group) in data.resolved.groups.iter().enumerate() {
        let Some(design) = &group.design else { continue };
        let d = group.params.len();
        for map in &data.resolved.spec.maps {
            for alg in &data.resolved.spec.algorithms {
                let mine: Vec<&Analysis> = analyses
                    .iter()
                    .filter(|a| a.group == gi && &a.map == map && a.algorithm == alg.as_str())
                    .collect();
                for (row, label) in design.rows.iter().enumerate() {
                    let role = match group.kind {
                        SweepKind::Sobol => match row / design.size {
                            0 => format!("A{}", row % design.size),
                            1 => format!("B{}", row % design.size),
                            b => format!("AB{}:{}", row % design.size, group.params[b - 2]),
                        },
                        _ => format!("t{}:{}", row / (d + 1), row % (d + 1)),
                    };
                    let values: Vec<String> = names
                        .iter()
                        .map(|m| {
                            mine.iter()
                                .find(|a| &a.metric == m)
                                .and_then(|a| a.rows.get(row))
                                .filter(|v| v.is_finite())
                                .map_or(String::new(), |v| crate::stats::sig_ascii(*v, 9))
                        })
                        .collect();
                    out.push_str(&format!(
                        "{gi},{},{map},{},{row},{label},{role},{}\n",
                        if group.kind == SweepKind::Sobol { "sobol" } else { "morris" },
                        alg.as_str(),
                        values.join(",")
                    ));
                }
            }
        }
    }
    out
}

/// The analyses a report shows and exports: the report's metrics and [`FAILED`], once.
pub fn analyses(data: &StudyData, metrics: &[&MetricDef]) -> Vec<Analysis> {
    let mut names: Vec<String> = metrics.iter().map(|m| m.name.to_string()).collect();
    names.push(FAILED.to_string());
    analyse(data, &names)
}

/// The analysed metrics, in the order they were asked for.
fn metric_names(analyses: &[Analysis]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for a in analyses {
        if !names.contains(&a.metric) {
            names.push(a.metric.clone());
        }
    }
    names
}

/// The report section; [`FAILED`] is shown only where some run of the group failed.
pub fn build(
    data: &StudyData,
    analyses: &[Analysis],
    metrics: &[&MetricDef],
) -> Vec<SensitivitySection> {
    let spec = &data.resolved.spec;
    let mut sections = Vec::new();
    for (gi, group) in data.resolved.groups.iter().enumerate() {
        let Some(design) = &group.design else { continue };
        let mine: Vec<&Analysis> = analyses
            .iter()
            .filter(|a| a.group == gi && (a.metric != FAILED || a.failed > 0))
            .collect();
        let kind =
            if group.kind == SweepKind::Morris { "Morris screening" } else { "Sobol' indices" };
        let distinct = design.rows.iter().collect::<std::collections::BTreeSet<_>>().len();
        let mut intro = vec![match group.kind {
            SweepKind::Morris => format!(
                "{} trajectories of {} points each ({} design rows, {distinct} distinct parameter sets) over {} parameters, each run {} times (replicate k of every point sees the same world): μ* ranks the parameters by their mean absolute elementary effect (in the metric's unit per full range), σ shows non-linearity or interaction. Intervals: 95 % percentile bootstrap over trajectories.",
                design.size,
                group.params.len() + 1,
                design.rows.len(),
                group.params.len(),
                spec.replicates
            ),
            _ => format!(
                "Saltelli's design with N = {} base samples ({} design rows, {distinct} distinct parameter sets) over {} parameters, each run {} times (replicate k of every point sees the same world); indices computed on the replicates' mean: S1 (Saltelli et al. 2010's estimator, outputs centred) is the share of variance a parameter explains alone, ST (Jansen 1999) its share including every interaction. Intervals: 95 % percentile bootstrap over the samples.",
                design.size,
                design.rows.len(),
                group.params.len(),
                spec.replicates
            ),
        }];
        intro.push(
            "Noise floor: run-to-run noise independent between points adds to every parameter's estimate — to ST about σ²/(R·V), to μ* about √(2σ²/R)·√(2/π)/Δ, with σ² the residual mean square of the points × replicates ANOVA — so an index whose interval does not clear it cannot be told apart from simulation noise.".into(),
        );
        let short = short_names(&group.params);
        let blocks = mine.into_iter().map(|a| block(data, a, &short, metrics, gi)).collect();
        sections.push(SensitivitySection {
            title: format!("{kind}: {}", group.params.join(", ")),
            intro,
            blocks,
        });
    }
    sections
}

fn block(
    data: &StudyData,
    a: &Analysis,
    short: &[String],
    metrics: &[&MetricDef],
    gi: usize,
) -> SensitivityBlock {
    let spec = &data.resolved.spec;
    let unit =
        metrics.iter().find(|m| m.name == a.metric).map_or("share of runs".to_string(), |m| {
            if a.log { format!("ln {}", m.unit) } else { m.unit.to_string() }
        });
    let alg =
        if spec.algorithms.len() > 1 { format!(" · {}", a.algorithm) } else { String::new() };
    let shown = if a.log { format!("ln {}", a.metric) } else { a.metric.clone() };
    let title = format!("{} · {shown}{alg}", a.map);
    let mut findings = Vec::new();
    let file_stem = format!(
        "sensitivity-g{gi}-{}-{}-{}{}",
        a.map,
        a.algorithm,
        if a.log { "ln-" } else { "" },
        a.metric
    )
    .replace('_', "-");
    let file = crate::store::short_name(&file_stem);
    let empty = TableView { columns: Vec::new(), rows: Vec::new(), align: String::new() };
    let Some(indices) = &a.indices else {
        findings.push(format!("No indices: {}.", a.note));
        return SensitivityBlock { title, findings, table: empty, figure: None };
    };
    let floor = a.noise_floor;
    let floor_text = |f: Option<f64>| {
        f.map_or("unknown (one replicate: no residual)".to_string(), |f| sig(f, 2))
    };
    // each parameter's own noise term (measured across the replicates; under common random
    // numbers it vanishes where a parameter changes nothing), else the independence floor
    let term = |i: usize| a.noise.as_ref().map(|n| n[i]).or(floor);
    let clears = |i: usize, low: f64| term(i).is_none_or(|f| low > f);
    let terms_text = |short: &[String]| -> String {
        a.noise.as_ref().map_or(String::new(), |n| {
            format!(
                " Each parameter's own noise term (what the noise adds to its index, measured from its differences across the replicates): {}.",
                short.iter().zip(n).map(|(p, t)| format!("{p} {}", sig(*t, 2))).collect::<Vec<_>>().join(", ")
            )
        })
    };
    let (table, figure) = match indices {
        Indices::Sobol(x) => {
            let (s1, st) = (&x.s1, &x.st);
            let inter: Vec<crate::stats::sensitivity::Estimate> = (0..short.len())
                .map(|i| {
                    let (value, boot) = x.interaction(i);
                    crate::stats::sensitivity::percentile_interval(value, &boot)
                })
                .collect();
            let mut order: Vec<usize> = (0..short.len()).collect();
            order.sort_by(|&i, &j| st[j].value.total_cmp(&st[i].value).then(i.cmp(&j)));
            let ranked: Vec<String> =
                order.iter().map(|&i| format!("{} {}", short[i], sig(st[i].value, 2))).collect();
            findings.push(format!("Ranking by ST: {}.", ranked.join(" > ")));
            let above: Vec<&str> = order
                .iter()
                .filter(|&&i| clears(i, st[i].low))
                .map(|&i| short[i].as_str())
                .collect();
            let below: Vec<&str> = order
                .iter()
                .filter(|&&i| !clears(i, st[i].low))
                .map(|&i| short[i].as_str())
                .collect();
            findings.push(match floor {
                None => format!("Noise floor of ST: {}: which indices exceed the simulation's noise cannot be told.", floor_text(floor)),
                Some(_) => format!(
                    "Noise floor of ST (were the noise independent between points): {}.{} {}{}",
                    floor_text(floor),
                    terms_text(&short),
                    if above.is_empty() { "No parameter's ST interval clears its noise.".to_string() } else { format!("ST clears its noise for {}.", above.join(", ")) },
                    if below.is_empty() { String::new() } else { format!(" Not distinguishable from noise: {}.", below.join(", ")) }
                ),
            });
            let sum_s1: f64 = s1.iter().map(|e| e.value).sum();
            // ΣS1's own interval, from the same resamples
            let resamples = x.boot_s1.first().map_or(0, Vec::len);
            let sums: Vec<f64> =
                (0..resamples).map(|b| x.boot_s1.iter().map(|r| r[b]).sum()).collect();
            let total = crate::stats::sensitivity::percentile_interval(sum_s1, &sums);
            findings.push(format!(
                "ΣS1 = {}: {}",
                ci(&total),
                if total.low >= 0.7 {
                    format!("the parameters act mostly alone (additively): at most {} of the variance comes from interactions.", pct(1.0 - total.low))
                } else if total.high < 0.9 {
                    format!("at least {} of the variance comes from interactions between parameters (or from noise).", pct(1.0 - total.high))
                } else {
                    "too uncertain at this N to say how much of the variance comes from interactions.".to_string()
                }
            ));
            let interacting: Vec<String> = order
                .iter()
                .filter(|&&i| {
                    // noise raises ST and not S1: ST − S1 must clear the parameter's term
                    inter[i].value > INTERACTION
                        && inter[i].low > term(i).unwrap_or(0.0)
                        && clears(i, st[i].low)
                })
                .map(|&i| {
                    format!(
                        "{} (ST − S1 = {}, S1 {}, ST {})",
                        short[i],
                        ci(&inter[i]),
                        sig(s1[i].value, 2),
                        sig(st[i].value, 2)
                    )
                })
                .collect();
            if interacting.is_empty() {
                findings.push(format!("No parameter acts measurably through interactions (ST − S1 above {INTERACTION} with an interval above the parameter's noise term)."));
            } else {
                findings.push(format!("Acting through interactions (ST − S1 above {INTERACTION}, interval above the parameter's noise term): {}.", interacting.join("; ")));
            }
            let rows = order
                .iter()
                .enumerate()
                .map(|(rank, &i)| {
                    vec![
                        a.params[i].clone(),
                        ci(&s1[i]),
                        ci(&st[i]),
                        ci(&inter[i]),
                        (rank + 1).to_string(),
                    ]
                })
                .collect();
            let table = TableView {
                columns: vec![
                    "Parameter".into(),
                    "S1 [95 % CI]".into(),
                    "ST [95 % CI]".into(),
                    "ST − S1 [95 % CI]".into(),
                    "Rank (ST)".into(),
                ],
                rows,
                align: "lrrrr".into(),
            };
            let fig = IndexBarsFigure {
                params: short.to_vec(),
                s1: s1.iter().map(|e| (e.value, e.low, e.high)).collect(),
                st: st.iter().map(|e| (e.value, e.low, e.high)).collect(),
                noise_floor: floor,
            };
            let caption = format!(
                "Sobol' indices of {shown} on {}: S1 and ST with 95 % bootstrap intervals; dashed: the noise floor of ST.",
                a.map
            );
            (
                table,
                FigureView {
                    file,
                    caption,
                    svg: figure::index_bars_svg(&fig),
                    pgf: super::pgf::index_bars_pgf(&fig),
                    panel: false,
                },
            )
        }
        Indices::Morris(s) => {
            let mut order: Vec<usize> = (0..short.len()).collect();
            order.sort_by(|&i, &j| {
                s[j].mu_star.value.total_cmp(&s[i].mu_star.value).then(i.cmp(&j))
            });
            let ranked: Vec<String> = order
                .iter()
                .map(|&i| format!("{} {}", short[i], sig(s[i].mu_star.value, 2)))
                .collect();
            findings
                .push(format!("Ranking by μ* [{unit} per full range]: {}.", ranked.join(" > ")));
            let below: Vec<&str> = order
                .iter()
                .filter(|&&i| !clears(i, s[i].mu_star.low))
                .map(|&i| short[i].as_str())
                .collect();
            findings.push(match floor {
                None => format!("Noise floor of μ*: {}: which effects exceed the simulation's noise cannot be told.", floor_text(floor)),
                Some(_) => format!(
                    "Noise floor of μ* (were the noise independent between points): {}.{}{}",
                    floor_text(floor),
                    terms_text(&short),
                    if below.is_empty() { " Every parameter's μ* interval clears it.".to_string() } else { format!(" Not distinguishable from noise: {}.", below.join(", ")) }
                ),
            });
            let curved: Vec<String> = order
                .iter()
                .filter(|&&i| s[i].sigma > s[i].mu_star.value && clears(i, s[i].mu_star.low))
                .map(|&i| {
                    format!("{} (σ/μ* = {})", short[i], sig(s[i].sigma / s[i].mu_star.value, 2))
                })
                .collect();
            if !curved.is_empty() {
                findings.push(format!("σ > μ* (effects change sign or size across the space: non-linear or interacting): {}.", curved.join(", ")));
            }
            let dropped: Vec<String> = order
                .iter()
                .filter(|&&i| s[i].dropped > 0)
                .map(|&i| {
                    format!("{} ({} of {})", short[i], s[i].dropped, s[i].dropped + s[i].effects)
                })
                .collect();
            if !dropped.is_empty() {
                findings.push(format!(
                    "Steps that rounding to an integer made vanish (no effect computed): {}.",
                    dropped.join(", ")
                ));
            }
            let rows = order
                .iter()
                .enumerate()
                .map(|(rank, &i)| {
                    let e = &s[i];
                    vec![
                        a.params[i].clone(),
                        sig(e.mu, 2),
                        ci(&e.mu_star),
                        sig(e.sigma, 2),
                        sig(e.sigma / e.mu_star.value, 2),
                        e.effects.to_string(),
                        (rank + 1).to_string(),
                    ]
                })
                .collect();
            let table = TableView {
                columns: vec![
                    "Parameter".into(),
                    "μ".into(),
                    "μ* [95 % CI]".into(),
                    "σ".into(),
                    "σ/μ*".into(),
                    "Effects".into(),
                    "Rank (μ*)".into(),
                ],
                rows,
                align: "lrrrrrr".into(),
            };
            let fig = MorrisFigure {
                params: short.to_vec(),
                mu_star: s.iter().map(|e| e.mu_star.value).collect(),
                sigma: s.iter().map(|e| e.sigma).collect(),
                noise_floor: floor,
                unit: unit.to_string(),
            };
            let caption = format!(
                "Morris screening of {shown} on {}: μ* against σ per parameter; grey: σ = μ*; dashed: the noise floor of μ*.",
                a.map
            );
            (
                table,
                FigureView {
                    file,
                    caption,
                    svg: figure::morris_svg(&fig),
                    pgf: super::pgf::morris_pgf(&fig),
                    panel: false,
                },
            )
        }
    };
    if let Some(sh) = a.shares {
        findings.push(format!(
            "Variance over the design's runs (points × replicates): parameters {}, world seed {}, residual (noise and world × parameter interaction) {}.",
            pct(sh.params),
            pct(sh.world),
            pct(sh.residual)
        ));
    }
    let usage = match a.kind {
        SweepKind::Sobol => format!("{} of {} samples used", a.used, a.size),
        _ => format!("{} of {} trajectories complete", a.used, a.size),
    };
    findings.push(format!("{usage}; {} of {} runs failed.", a.failed, a.runs));
    SensitivityBlock { title, findings, table, figure: Some(figure) }
}
