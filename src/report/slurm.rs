//! `slamlab slurm`: renders the two sbatch scripts that run studies on a Slurm cluster — a job array whose
//! task I runs `slamlab run --shard I/N` into the shared cache, and an assembling job that
//! depends on it (`afterok`) and writes the results and reports. The scripts are rendered from
//! `templates/slurm-*.sbatch.j2`; this module only fills them (no IO).

use minijinja::{Environment, UndefinedBehavior, context};
use serde::Serialize;

/// The runs script's template (task I runs shard I/N).
pub const RUNS_TEMPLATE: &str = include_str!("../../templates/slurm-runs.sbatch.j2");
/// The assembling job's template.
pub const ASSEMBLE_TEMPLATE: &str = include_str!("../../templates/slurm-assemble.sbatch.j2");

/// The resources each job asks for.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Resources {
    pub tasks: usize,
    pub cpus: usize,
    /// `--mem`, as sbatch reads it (e.g. `4G`).
    pub mem: String,
    /// `--time`, as sbatch reads it (e.g. `02:00:00`).
    pub time: String,
    pub partition: Option<String>,
}

/// What the scripts run, where (absolute paths: the jobs run on other machines).
#[derive(Debug, Clone, PartialEq)]
pub struct Job {
    pub repo: String,
    pub bin: String,
    pub specs: Vec<String>,
    pub maps: String,
    /// The folders of external algorithms' descriptors (`--algorithms`).
    pub algorithms: Vec<String>,
    pub cache: String,
    pub results: String,
    /// Render the reports here after the runs (none: results only).
    pub reports: Option<String>,
    /// `report --specs`: studies with a spec but no results keep their previous report.
    pub keep_specs: Option<String>,
    /// Where the jobs' logs go.
    pub logs: String,
    /// The runs script's own path, for the resubmission hint in its header.
    pub runs_script: String,
}

/// The plan's figures shown in the runs script's header.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    pub studies: Vec<String>,
    pub runs: usize,
    pub unique: usize,
    pub to_compute: usize,
    /// Expected cost [s] of all runs and of the largest shard.
    pub cost_total_s: f64,
    pub cost_max_s: f64,
}

/// Quotes `s` for a POSIX shell when it needs it (single quotes; `'` as `'\''`).
pub fn shell_quote(s: &str) -> String {
    let plain =
        !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c));
    if plain { s.to_string() } else { format!("'{}'", s.replace('\'', r"'\''")) }
}

/// Checks `--mem` and `--time` as sbatch would read them, so a typo fails here and not after the
/// job waited in the queue.
pub fn validate(r: &Resources) -> Result<(), String> {
    if r.tasks == 0 || r.tasks > crate::plan::shard::MAX_SHARDS {
        return Err(format!("--tasks must be between 1 and {}", crate::plan::shard::MAX_SHARDS));
    }
    if r.cpus == 0 {
        return Err("--cpus must be at least 1".into());
    }
    let mem = r.mem.trim_end_matches(['K', 'M', 'G', 'T']);
    if mem.is_empty() || !mem.chars().all(|c| c.is_ascii_digit()) || r.mem.len() - mem.len() > 1 {
        return Err(format!(
            "--mem `{}` is not a size sbatch reads (a whole number with an optional K, M, G or T, e.g. 4G)",
            r.mem
        ));
    }
    // [days-]hours:minutes:seconds, minutes, minutes:seconds, hours:minutes:seconds, days-hours…
    let (days, rest) =
        r.time.split_once('-').map_or((None, r.time.as_str()), |(d, t)| (Some(d), t));
    let whole = |x: &str| !x.is_empty() && x.len() <= 4 && x.chars().all(|c| c.is_ascii_digit());
    let parts: Vec<&str> = rest.split(':').collect();
    if !days.is_none_or(whole)
        || parts.len() > 3
        || !parts.iter().all(|p| whole(p))
        || r.time == "0"
    {
        return Err(format!(
            "--time `{}` is not a time limit sbatch reads (minutes, MM:SS, HH:MM:SS or D-HH:MM:SS)",
            r.time
        ));
    }
    if let Some(p) = &r.partition {
        if p.is_empty() || !p.chars().all(|c| c.is_ascii_alphanumeric() || "-_.,".contains(c)) {
            return Err(format!("--partition `{p}` is not a partition name"));
        }
    }
    Ok(())
}

/// The runs script and the assembling script.
pub fn scripts(
    job: &Job,
    resources: &Resources,
    summary: &Summary,
) -> Result<(String, String), minijinja::Error> {
    let mut env = Environment::new();
    env.set_undefined_behavior(UndefinedBehavior::Strict);
    env.set_keep_trailing_newline(true);
    env.add_template("runs", RUNS_TEMPLATE)?;
    env.add_template("assemble", ASSEMBLE_TEMPLATE)?;
    let q = |s: &str| shell_quote(s);
    let specs: Vec<String> = job.specs.iter().map(|s| q(s)).collect();
    let ctx = context! {
        version => format!("slamlab {}", env!("CARGO_PKG_VERSION")),
        tasks => resources.tasks,
        cpus => resources.cpus,
        mem => resources.mem,
        time => resources.time,
        partition => resources.partition,
        repo => q(&job.repo),
        bin => q(&job.bin),
        specs => specs,
        maps => q(&job.maps),
        algorithms => job.algorithms.iter().map(|a| format!("--algorithms {}", q(a))).collect::<Vec<_>>(),
        cache => q(&job.cache),
        results => q(&job.results),
        reports => job.reports.as_deref().map(q),
        keep_specs => job.keep_specs.as_deref().map(q),
        logs => q(&job.logs),
        self => q(&job.runs_script),
        studies => summary.studies,
        runs => summary.runs,
        unique => summary.unique,
        to_compute => summary.to_compute,
        cost_total => format!("{:.0}", summary.cost_total_s),
        cost_max => format!("{:.0}", summary.cost_max_s),
    };
    Ok((env.get_template("runs")?.render(&ctx)?, env.get_template("assemble")?.render(&ctx)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job() -> (Job, Resources, Summary) {
        (
            Job {
                repo: "/shared/slam lab".into(),
                bin: "/shared/slam lab/target/release/slamlab".into(),
                specs: vec!["experiments/smoke.toml".into(), "experiments/ft-dmax.toml".into()],
                maps: "data/maps".into(),
                algorithms: vec!["data/algorithms".into(), "/home/me/my algorithms".into()],
                cache: "data/cache".into(),
                results: "data/results".into(),
                reports: Some("reports".into()),
                keep_specs: Some("experiments".into()),
                logs: "data/slurm/logs".into(),
                runs_script: "data/slurm/runs.sbatch".into(),
            },
            Resources {
                tasks: 4,
                cpus: 2,
                mem: "4G".into(),
                time: "01:30:00".into(),
                partition: Some("short".into()),
            },
            Summary {
                studies: vec!["smoke".into(), "ft-dmax".into()],
                runs: 120,
                unique: 118,
                to_compute: 118,
                cost_total_s: 600.4,
                cost_max_s: 151.0,
            },
        )
    }

    #[test]
    fn shell_quoting_survives_spaces_and_quotes() {
        assert_eq!(shell_quote("experiments/ft-dmax.toml"), "experiments/ft-dmax.toml");
        assert_eq!(shell_quote("/a b"), "'/a b'");
        assert_eq!(shell_quote("it's"), r"'it'\''s'");
        assert_eq!(shell_quote(""), "''");
        assert_eq!(shell_quote("$HOME"), "'$HOME'");
    }

    #[test]
    fn the_runs_script_is_an_array_of_shards_and_the_assembler_renders() {
        let (j, r, s) = job();
        let (runs, assemble) = scripts(&j, &r, &s).unwrap();
        for line in [
            "#SBATCH --array=1-4",
            "#SBATCH --cpus-per-task=2",
            "#SBATCH --mem=4G",
            "#SBATCH --time=01:30:00",
            "#SBATCH --partition=short",
            "cd '/shared/slam lab'",
        ] {
            assert!(runs.contains(line), "runs script lacks `{line}`:\n{runs}");
        }
        assert!(runs.contains(r#"run --shard "${SLURM_ARRAY_TASK_ID}/4""#), "{runs}");
        assert!(runs.contains("experiments/smoke.toml experiments/ft-dmax.toml"), "{runs}");
        // the external algorithms' folders go with every run, quoted
        for script in [&runs, &assemble] {
            assert!(
                script
                    .contains("--algorithms data/algorithms --algorithms '/home/me/my algorithms'"),
                "{script}"
            );
        }
        assert!(
            runs.contains("118 not yet in the cache")
                && runs.contains("600 s of one core of the reference machine in all, 151 s in the"),
            "{runs}"
        );
        assert!(!assemble.contains("--array") && !assemble.contains("--shard"), "{assemble}");
        assert!(
            assemble.contains("--results data/results")
                && assemble
                    .contains("report --results data/results --out reports --specs experiments"),
            "{assemble}"
        );
        assert!(runs.starts_with("#!/bin/bash\n") && assemble.starts_with("#!/bin/bash\n"));
    }

    #[test]
    fn no_partition_line_without_a_partition_and_no_report_without_reports() {
        let (mut j, mut r, s) = job();
        r.partition = None;
        j.reports = None;
        let (runs, assemble) = scripts(&j, &r, &s).unwrap();
        assert!(!runs.contains("--partition") && !assemble.contains("--partition"));
        assert!(!assemble.contains(" report "), "{assemble}");
    }

    #[test]
    fn resources_are_checked_as_sbatch_reads_them() {
        let (_, r, _) = job();
        assert_eq!(validate(&r), Ok(()));
        for time in ["90", "30:00", "1-12:00:00", "2-0"] {
            assert_eq!(validate(&Resources { time: time.into(), ..r.clone() }), Ok(()), "{time}");
        }
        for time in ["1h", "", "1:2:3:4", "0", "a-1"] {
            assert!(validate(&Resources { time: time.into(), ..r.clone() }).is_err(), "{time}");
        }
        for mem in ["4GB", "G", "", "1.5G"] {
            assert!(validate(&Resources { mem: mem.into(), ..r.clone() }).is_err(), "{mem}");
        }
        assert!(validate(&Resources { tasks: 0, ..r.clone() }).is_err());
        assert!(validate(&Resources { cpus: 0, ..r.clone() }).is_err());
        assert!(validate(&Resources { partition: Some("a b".into()), ..r.clone() }).is_err());
    }
}
