//! Command line: `slamlab run|report|validate|plan|diff|algorithms|export-tum`. Flags change how things run
//! (threads, cache, directories), never what is computed: the spec is the complete record.
//! Exit status: 0 success, 2 invalid input (spec or map), 1 any other failure.

use crate::plan::{self, ExperimentPlan};
use crate::run::{self, Provenance, Reason, RunOptions};
use crate::spec::{self, InputErrors};
use crate::store::{self, tum};
use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "slamlab",
    version,
    about = "Reproducible parameter studies of 2-D SLAM: TOML specs → seeded runs → Parquet → HTML/LaTeX reports"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run studies (cached runs are reused) and write data/results/<study>/.
    Run {
        /// Study spec files (e.g. experiments/*.toml).
        #[arg(required = true)]
        specs: Vec<PathBuf>,
        #[command(flatten)]
        dirs: Dirs,
        /// Worker threads (default: all cores). Results do not depend on it.
        #[arg(long, short = 'j')]
        threads: Option<usize>,
        /// Recompute every run, ignoring the cache.
        #[arg(long)]
        force: bool,
        /// No progress output.
        #[arg(long, short)]
        quiet: bool,
        /// Compute only shard I of N of the runs (1 ≤ I ≤ N) into the cache, and write no study
        /// results: one task of a cluster job array (`slamlab slurm`). The shards split the
        /// distinct runs of all SPECS by expected cost; once all are done, `run` without
        /// `--shard` finds every run cached and writes the results.
        #[arg(long, value_name = "I/N")]
        shard: Option<crate::plan::shard::Shard>,
    },
    /// Write (and with --submit, submit) the sbatch scripts that run studies on a Slurm cluster: a
    /// job array whose task I runs `run --shard I/N`, and a job that waits for all of them
    /// (afterok), then writes the results and renders the reports. The repository, the binary
    /// and the cache must be on a filesystem every node sees.
    Slurm {
        /// Study spec files (e.g. experiments/*.toml).
        #[arg(required = true)]
        specs: Vec<PathBuf>,
        #[command(flatten)]
        dirs: Dirs,
        /// Tasks of the job array (shards).
        #[arg(long, default_value_t = 8)]
        tasks: usize,
        /// CPUs per task (each runs that many runs at a time).
        #[arg(long, default_value_t = 1)]
        cpus: usize,
        /// Memory per task, as sbatch reads it.
        #[arg(long, default_value = "4G")]
        mem: String,
        /// Time limit per task (and for the assembling job), as sbatch reads it.
        #[arg(long, default_value = "04:00:00")]
        time: String,
        /// Partition to submit to (default: the cluster's default partition).
        #[arg(long)]
        partition: Option<String>,
        /// Folder for the scripts and the jobs' logs.
        #[arg(long, default_value = "data/slurm")]
        out: PathBuf,
        /// Reports folder the assembling job renders into.
        #[arg(long, default_value = "reports")]
        reports: PathBuf,
        /// Submit the two jobs with sbatch (else only write the scripts and print how to submit).
        #[arg(long)]
        submit: bool,
    },
    /// Render every study found in the results directory into reports/.
    Report {
        /// Results directory holding <study>/ folders.
        #[arg(long, default_value = "data/results")]
        results: PathBuf,
        /// Output directory (replaced as a whole).
        #[arg(long, default_value = "reports")]
        out: PathBuf,
        /// Studies with a spec in this folder but no results (real data absent on this machine)
        /// keep their previous report instead of losing it.
        #[arg(long)]
        specs: Option<PathBuf>,
        /// Published result items classified by the fidelity scoreboard (`reports/fidelity/`);
        /// the default file is skipped when absent.
        #[arg(long)]
        published: Option<PathBuf>,
        /// Remove the reports of studies whose spec was deleted: no results and no spec in
        /// --specs (which it needs). Without it, such a replacement is refused and nothing is
        /// written. Each removed report is named.
        #[arg(long, requires = "specs")]
        prune: bool,
    },
    /// List the algorithms a study can name: the built-ins and the external programs declared in
    /// the --algorithms folders (docs/src/guide/external-algorithms.md).
    Algorithms {
        /// A Markdown table (the book's, docs/src/reference/algorithms.md) instead of one line each.
        #[arg(long)]
        markdown: bool,
        /// Directory of external algorithms' descriptors (<name>.toml); repeatable.
        #[arg(long, default_value = "data/algorithms")]
        algorithms: Vec<PathBuf>,
    },
    /// Check specs (and the maps they name) without running anything.
    Validate {
        #[arg(required = true)]
        /// Experiment specs (TOML files named after their study id, e.g. experiments/ft-dmax.toml).
        specs: Vec<PathBuf>,
        #[arg(long, default_value = "data/maps")]
        maps: PathBuf,
        /// Directory of external algorithms' descriptors (<name>.toml); repeatable.
        #[arg(long, default_value = "data/algorithms")]
        algorithms: Vec<PathBuf>,
        /// Refuse a spec that expands to more runs than this.
        #[arg(long, default_value_t = plan::DEFAULT_MAX_RUNS)]
        max_runs: u64,
    },
    /// List the runs a spec expands to and whether each will run (new / parameters changed /
    /// code version changed / cached). Never runs anything.
    Plan {
        /// The experiment specs to expand (TOML files named after their study ids).
        #[arg(required = true)]
        specs: Vec<PathBuf>,
        /// Only list (always the case; accepted for clarity in scripts).
        #[arg(long)]
        dry_run: bool,
        #[command(flatten)]
        dirs: Dirs,
        /// Show what `run --force` would do.
        #[arg(long)]
        force: bool,
        /// Also split the runs of all SPECS into N shards as `run --shard I/N` does: each run's
        /// shard, and per shard the runs, those still to compute and their expected cost.
        #[arg(long, value_name = "N")]
        shards: Option<usize>,
    },
    /// Compare two result sets (e.g. from two branches): parameter differences, then one row per
    /// (study, cell, metric) with paired statistics and a verdict. Exit status 0 whatever the
    /// verdicts (use the output, e.g. `--md` in a pull request).
    Diff {
        /// BASE results: a results root (holding <study>/ folders) or one study's folder.
        base: PathBuf,
        /// NEW results, likewise.
        new: PathBuf,
        /// Markdown instead of the terminal table.
        #[arg(long)]
        md: bool,
        /// Significance level of the Holm-adjusted p-values.
        #[arg(long, default_value_t = 0.05)]
        alpha: f64,
        /// Smallest change that counts, as a fraction of |BASE mean|.
        #[arg(long, default_value_t = 0.01)]
        min_effect: f64,
        /// Compare every stored metric, not only each study's report metrics.
        #[arg(long)]
        all_metrics: bool,
        /// Also write an HTML and LaTeX diff report with BASE-vs-NEW plots into this folder.
        #[arg(long)]
        report: Option<PathBuf>,
    },
    /// Write the laser scans of one scan-matching run (scans.txt), the pairs it matched with their
    /// initial guesses (pairs.txt) and slamlab's estimates (matches.txt), as plain text a peer
    /// implementation can match (e.g. Diosi's PSM program). Recomputes the run; writes nothing
    /// into the results or the cache.
    ExportScans {
        /// The scan-matching study's spec.
        spec: PathBuf,
        /// The run id (`slamlab plan SPEC` lists them).
        #[arg(long = "run")]
        run_id: String,
        /// Folder to write scans.txt, pairs.txt and matches.txt into (created if absent).
        out_dir: PathBuf,
        /// Directory of map files (<name>.toml).
        #[arg(long, default_value = "data/maps")]
        maps: PathBuf,
        /// Directory of external algorithms' descriptors (<name>.toml); repeatable.
        #[arg(long, default_value = "data/algorithms")]
        algorithms: Vec<PathBuf>,
    },
    /// Write the book's generated reference chapters into OUT (`docs/src/reference`): the
    /// command line (cli.md, from this program's own help), the algorithms (algorithms.md, from
    /// the registry), the modelling choices at the defaults (modelling-defaults.md, from each
    /// model's describe()) and every parameter (parameters-generated.md, from the doc comments of
    /// the parameter structs). `make docs` runs it; `make check-docs` fails when they differ.
    Docs {
        /// Folder to write the chapters into.
        out: PathBuf,
        /// Directory of external algorithms' descriptors (<name>.toml); repeatable.
        #[arg(long, default_value = "data/algorithms")]
        algorithms: Vec<PathBuf>,
    },
    /// Write <run-id>.gt.tum and <run-id>.est.tum for every run of a study (or of every study
    /// under a results root), for evaluation with evo.
    ExportTum {
        /// A study's results directory (data/results/<study>) or the results root.
        results_dir: PathBuf,
        /// Folder to write the .tum files into (created if absent).
        out_dir: PathBuf,
        /// Only these run ids (repeatable).
        #[arg(long = "run")]
        runs: Vec<String>,
    },
}

#[derive(Args, Clone)]
struct Dirs {
    /// Directory of map files (<name>.toml).
    #[arg(long, default_value = "data/maps")]
    maps: PathBuf,
    /// Directory of external algorithms' descriptors (<name>.toml; docs/src/guide/external-algorithms.md);
    /// repeatable.
    #[arg(long, default_value = "data/algorithms")]
    algorithms: Vec<PathBuf>,
    /// Results directory.
    #[arg(long, default_value = "data/results")]
    results: PathBuf,
    /// Run cache directory.
    #[arg(long, default_value = "data/cache")]
    cache: PathBuf,
    /// Refuse a spec that expands to more runs than this (counted before expanding it).
    #[arg(long, default_value_t = plan::DEFAULT_MAX_RUNS)]
    max_runs: u64,
}

/// A usage error found after parsing (a folder that does not exist, a bad value): exit status 2,
/// like clap's own, and nothing was written.
#[derive(Debug)]
struct Usage(String);

impl std::fmt::Display for Usage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
    }
}
impl std::error::Error for Usage {}

/// Invalid specs or maps: exit status 2, and nothing was written.
#[derive(Debug)]
struct InvalidInput(InputErrors);

impl std::fmt::Display for InvalidInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
    }
}
impl std::error::Error for InvalidInput {}

/// The published result items the scoreboard classifies, relative to the working folder.
const DEFAULT_PUBLISHED: &str = "data/reference/published-results.toml";

/// The book's command-line chapter: every subcommand's full help, as `slamlab help CMD` prints
/// it, at a fixed width (the same text on every terminal).
fn cli_reference() -> String {
    use clap::CommandFactory;
    let mut root = Cli::command().term_width(100).max_term_width(100);
    let mut out = String::from(GENERATED_NOTE);
    out.push_str("# Command line\n\n");
    out.push_str(
        "Every subcommand's full help, as `slamlab help <command>` prints it. Exit status: ",
    );
    out.push_str(
        "0 success, 2 invalid input (a spec, a map, or a usage error; nothing is written), ",
    );
    out.push_str("1 any other failure.\n\n```text\n");
    out.push_str(&root.render_long_help().to_string());
    out.push_str("```\n");
    for sub in root.get_subcommands_mut() {
        let name = sub.get_name().to_string();
        let help =
            sub.clone().term_width(100).max_term_width(100).bin_name(format!("slamlab {name}"));
        out.push_str(&format!(
            "\n## `slamlab {name}`\n\n```text\n{}```\n",
            help.clone().render_long_help()
        ));
    }
    out
}

/// The book's algorithm chapter: the registry's table (`slamlab algorithms --markdown`).
fn algorithms_chapter(catalogue: &crate::algo::Catalogue) -> String {
    format!(
        "{GENERATED_NOTE}# Algorithms\n\nEvery algorithm a study can name in `algorithms = [...]`: the built-ins, \
         then the external programs declared in `data/algorithms/` ([Adding an algorithm](../guide/adding-an-algorithm.md)). \
         \"Reads\" is the kind of world it runs on; its own `[base]` sections are the parameters only it reads.\n\n{}",
        crate::algo::markdown_table(catalogue)
    )
}

/// The book's chapter of modelling choices at the defaults (every model's own `describe()`).
fn modelling_defaults_chapter(catalogue: &crate::algo::Catalogue) -> String {
    format!(
        "{GENERATED_NOTE}# Modelling choices at the defaults\n\nWhat each model states about itself \
         (its `describe()`), at the default parameters: a study's report states the same sentences \
         from the parameters its runs used. Why each choice was made: [Modelling choices](../models.md).\n\n{}",
        crate::algo::modelling_defaults_markdown(catalogue)
    )
}

/// The book's parameter reference: every `[base]` key's type, default and doc comment.
fn parameters_chapter() -> String {
    format!(
        "{GENERATED_NOTE}# Every parameter\n\nEvery key a study may set under `[base]` (or sweep by its dotted \
         name, e.g. `fastslam.particles`): its type, its default and the documentation of its field in the \
         code, with the symbol, unit and source the code gives. An external algorithm's own \
         `[base.external.<name>]` table is the program's (its descriptor documents it). How to read and \
         choose them: [Parameters](parameters.md).\n\n{}",
        crate::report::parameters::markdown()
    )
}

/// First line of every generated chapter.
const GENERATED_NOTE: &str =
    "<!-- generated by `slamlab docs docs/src/reference` (make docs); do not edit -->\n\n";

pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match dispatch(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            if let Some(invalid) = e.downcast_ref::<InvalidInput>() {
                eprintln!("error: invalid input, nothing was written:\n{invalid}");
                ExitCode::from(2)
            } else if let Some(usage) = e.downcast_ref::<Usage>() {
                eprintln!("error: {usage}; nothing was written");
                ExitCode::from(2)
            } else {
                eprintln!("error: {e:#}");
                ExitCode::FAILURE
            }
        }
    }
}

fn dispatch(command: Command) -> Result<()> {
    match command {
        Command::Run { specs, dirs, threads, force, quiet, shard: None } => {
            cmd_run(&specs, &dirs, threads, force, quiet)
        }
        Command::Run { specs, dirs, threads, force, quiet, shard: Some(shard) } => {
            cmd_run_shard(&specs, &dirs, threads, force, quiet, shard)
        }
        Command::Slurm { specs, dirs, tasks, cpus, mem, time, partition, out, reports, submit } => {
            let resources = crate::report::slurm::Resources { tasks, cpus, mem, time, partition };
            cmd_slurm(&specs, &dirs, &resources, &out, &reports, submit)
        }
        Command::Report { results, out, specs, published, prune } => {
            // a mistyped folder must never be read as "no studies" (and prune every report)
            for (flag, dir) in [("--results", Some(&results)), ("--specs", specs.as_ref())] {
                if let Some(dir) = dir.filter(|d| !d.is_dir()) {
                    return Err(Usage(format!("{flag} {}: no such folder", dir.display())).into());
                }
            }
            let keep: Vec<String> = specs.as_deref().map(spec_ids).unwrap_or_default();
            let default = PathBuf::from(DEFAULT_PUBLISHED);
            let published = published.or_else(|| default.is_file().then_some(default));
            let summary =
                crate::report::render_all(&results, &out, &keep, published.as_deref(), prune)
                    .context("rendering reports")?;
            eprintln!("rendered {} studies into {}", summary.studies.len(), out.display());
            let timed = crate::report::write_timings(&summary.timing_pages);
            if !timed.written.is_empty() {
                eprintln!(
                    "timing pages (machine-dependent, not in the reports): {}/<study>/{} for {}",
                    results.display(),
                    crate::report::TIMINGS,
                    timed.written.join(", ")
                );
            }
            for (study, why) in &timed.unwritable {
                eprintln!(
                    "warning: no timing page for {study} (its results folder is read-only?): {why}"
                );
            }
            if !summary.kept.is_empty() {
                eprintln!("{}", kept_line(&summary.kept));
            }
            for id in &summary.pruned {
                eprintln!("pruned {id}: no results and no spec in the --specs folder");
            }
            Ok(())
        }
        Command::Diff { base, new, md, alpha, min_effect, all_metrics, report } => {
            if !(alpha > 0.0 && alpha < 1.0) || !(min_effect >= 0.0) {
                return Err(Usage("--alpha must be in (0, 1) and --min-effect ≥ 0".into()).into());
            }
            let opts = crate::diff::DiffOptions {
                alpha,
                min_effect_rel: min_effect,
                all_metrics,
                ..crate::diff::DiffOptions::default()
            };
            let d = crate::diff::diff(&base, &new, &opts)?;
            print!("{}", if md { crate::diff::to_markdown(&d) } else { crate::diff::to_text(&d) });
            if let Some(out) = report {
                crate::report::diff_page::render_diff(&d, &out)
                    .context("writing the diff report")?;
                eprintln!("diff report written to {}", out.display());
            }
            Ok(())
        }
        Command::Docs { out, algorithms } => {
            let catalogue = spec::algorithms::catalogue(&algorithms).map_err(InvalidInput)?;
            std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
            let chapters = [
                ("cli.md", cli_reference()),
                ("algorithms.md", algorithms_chapter(&catalogue)),
                ("modelling-defaults.md", modelling_defaults_chapter(&catalogue)),
                ("parameters-generated.md", parameters_chapter()),
            ];
            for (name, text) in chapters {
                let (path, tmp) = (out.join(name), out.join(format!("{name}.tmp")));
                std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
                std::fs::rename(&tmp, &path)
                    .with_context(|| format!("writing {}", path.display()))?;
                println!("{}", path.display());
            }
            Ok(())
        }
        Command::Algorithms { markdown, algorithms } => {
            let catalogue = spec::algorithms::catalogue(&algorithms).map_err(InvalidInput)?;
            if markdown {
                print!("{}", crate::algo::markdown_table(&catalogue));
            } else {
                for a in catalogue.all() {
                    println!("{:<18} {}", a.name(), a.title());
                }
            }
            Ok(())
        }
        Command::Validate { specs, maps, algorithms, max_runs } => {
            let mut absent = Vec::new();
            for plan in load_plans(&specs, &maps, &algorithms, max_runs)? {
                match plan.maps.iter().find_map(|m| m.missing_data.as_ref()) {
                    // a valid spec whose real data is not on this machine: `run` would skip it
                    Some(why) => {
                        eprintln!(
                            "{}: valid, but its data is absent, so `run` skips it: {why}",
                            plan.spec.path.display()
                        );
                        absent.push(plan.id().to_string());
                    }
                    None => println!(
                        "ok: {} ({}: {} points, {}{} runs)",
                        plan.spec.path.display(),
                        plan.id(),
                        plan.points.len(),
                        if plan.spec.spec.looks().is_some() { "at most " } else { "" },
                        plan.runs.len()
                    ),
                }
            }
            if !absent.is_empty() {
                bail!(
                    "the data of {} is absent on this machine ({})",
                    if absent.len() == 1 {
                        "one study".to_string()
                    } else {
                        format!("{} studies", absent.len())
                    },
                    absent.join(", ")
                );
            }
            Ok(())
        }
        Command::Plan { specs, dry_run: _, dirs, force, shards } => {
            cmd_plan(&specs, &dirs, force, shards)
        }
        Command::ExportTum { results_dir, out_dir, runs } => {
            cmd_export_tum(&results_dir, &out_dir, &runs)
        }
        Command::ExportScans { spec, run_id, out_dir, maps, algorithms } => {
            cmd_export_scans(&spec, &run_id, &out_dir, &maps, &algorithms)
        }
    }
}

/// Loads and plans every spec; all errors of all files are reported together.
/// Plans from this many runs on announce themselves before expanding.
const LARGE_PLAN: u64 = 100_000;
/// Seconds to expand and check one run of a plan, measured on the 2-core reference machine
/// (`validate` of a 1 000 × 1 000 FastSLAM grid, 10⁶ runs: 8.4 s; docs/src/development/benchmarks.md).
const PLAN_S_PER_RUN: f64 = 1e-5;

fn load_plans(
    specs: &[PathBuf],
    maps: &Path,
    algorithms: &[PathBuf],
    max_runs: u64,
) -> Result<Vec<ExperimentPlan>> {
    let catalogue = spec::algorithms::catalogue(algorithms).map_err(InvalidInput)?;
    let mut plans = Vec::new();
    let mut errors = Vec::new();
    for path in specs {
        match spec::load(path, &catalogue).map_err(InputErrors::from).and_then(|s| {
            // a large plan takes a while to expand and check: say so before the silence
            let planned = plan::planned_runs(&s);
            if planned > LARGE_PLAN && planned <= max_runs {
                eprintln!(
                    "{}: expanding and checking {planned} runs (about {} s; --max-runs {max_runs})",
                    path.display(),
                    (planned as f64 * PLAN_S_PER_RUN).ceil()
                );
            }
            // past a second, a line a second on how far it has got
            let start = std::time::Instant::now();
            let shown = std::cell::Cell::new(0u64);
            let progress = |stage: plan::Stage, done: usize, total: usize| {
                let secs = start.elapsed().as_secs();
                if secs >= 1 && secs > shown.get() {
                    shown.set(secs);
                    eprintln!(
                        "{}: {done} of {total} {} ({secs} s)",
                        path.display(),
                        stage.as_str()
                    );
                }
            };
            plan::build_observed(s, maps, max_runs, &progress)
        }) {
            Ok(p) => plans.push(p),
            Err(e) => errors.extend(e.0),
        }
    }
    for (i, p) in plans.iter().enumerate() {
        if let Some(other) = plans[..i].iter().find(|o| o.id() == p.id()) {
            errors.push(spec::SpecError::new(
                &p.spec.path,
                vec![p.spec.error_at(
                    "id",
                    format!("study id `{}` is also used by {}", p.id(), other.spec.path.display()),
                )],
            ));
        }
    }
    if !errors.is_empty() {
        return Err(InvalidInput(InputErrors(errors)).into());
    }
    Ok(plans)
}

/// The most worker threads `--threads` accepts.
const MAX_THREADS: usize = 1024;

fn options(dirs: &Dirs, threads: Option<usize>, force: bool, quiet: bool) -> Result<RunOptions> {
    let threads = match threads {
        Some(0) => return Err(Usage("--threads must be at least 1".into()).into()),
        Some(n) if n > MAX_THREADS => return Err(Usage(format!(
            "--threads {n} is more than {MAX_THREADS}: each worker is an OS thread with its own stack; use at most the machine's cores (results do not depend on the count)"
        ))
        .into()),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    Ok(RunOptions {
        threads,
        force,
        results_dir: dirs.results.clone(),
        cache_dir: dirs.cache.clone(),
        progress: !quiet,
    })
}

fn cmd_run(
    specs: &[PathBuf],
    dirs: &Dirs,
    threads: Option<usize>,
    force: bool,
    quiet: bool,
) -> Result<()> {
    let plans = load_plans(specs, &dirs.maps, &dirs.algorithms, dirs.max_runs)?;
    let opts = options(dirs, threads, force, quiet)?;
    let provenance = Provenance::collect(Path::new("."));
    if provenance.git_dirty && !quiet {
        eprintln!(
            "note: inputs have uncommitted changes; results are marked dirty (commit first for clean provenance)"
        );
    }
    // A results folder that cannot be written is found now, not after hours of runs.
    let ids: Vec<&str> = plans.iter().map(|p| p.id()).collect();
    store::check_writable(&opts.results_dir, &ids)
        .map_err(|e| anyhow::anyhow!("cannot write results: {e}; nothing was run"))?;
    let mut problems = 0;
    let mut skipped = Vec::new();
    for plan in &plans {
        if let Some(why) = plan.maps.iter().find_map(|m| m.missing_data.as_ref()) {
            // Real data that is not on this machine: nothing to compute; stored results stay.
            eprintln!("{}: skipped: {why}", plan.id());
            skipped.push(plan.id().to_string());
            continue;
        }
        let s = run::run_study(plan, &opts, &provenance)
            .with_context(|| format!("running study {}", plan.id()))?;
        let bad = s.failed + s.diverged;
        problems += bad;
        eprintln!(
            "{}: {} runs ({} computed, {} cached), {} failed, {} diverged → {}",
            s.study,
            s.runs,
            s.computed,
            s.runs - s.computed,
            s.failed,
            s.diverged,
            s.dir.display()
        );
        if s.recomputed_corrupt > 0 {
            eprintln!(
                "{}: {} cache entries failed verification (a file changed after it was written) and were recomputed",
                s.study, s.recomputed_corrupt
            );
        }
    }
    if problems > 0 {
        eprintln!(
            "warning: {problems} runs failed or diverged; they are recorded with their status and shown in the reports"
        );
    }
    if !skipped.is_empty() && skipped.len() == plans.len() {
        bail!(
            "every study was skipped (its data is absent): {}; nothing was run or written",
            skipped.join(", ")
        );
    }
    if !skipped.is_empty() {
        eprintln!(
            "skipped (data absent on this machine; their stored results and reports stay): {}",
            skipped.join(", ")
        );
    }
    Ok(())
}

/// The study ids of the `*.toml` specs in `dir` (their file names), sorted.
/// One line for the reports kept without results (a Quick start that ran one study keeps 44).
fn kept_line(kept: &[String]) -> String {
    const NAMED: usize = 5;
    let names = kept.iter().take(NAMED).cloned().collect::<Vec<_>>().join(", ");
    let more = kept.len().saturating_sub(NAMED);
    format!(
        "{} {} no results here; {} previous report{} kept: {names}{}",
        kept.len(),
        if kept.len() == 1 { "study has" } else { "studies have" },
        if kept.len() == 1 { "its" } else { "their" },
        if kept.len() == 1 { " is" } else { "s are" },
        if more > 0 { format!(" and {more} more") } else { String::new() }
    )
}

fn spec_ids(dir: &Path) -> Vec<String> {
    let mut ids: Vec<String> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| e.path().extension().is_some_and(|x| x == "toml"))
        .filter_map(|e| e.path().file_stem().map(|s| s.to_string_lossy().into_owned()))
        .collect();
    ids.sort();
    ids
}

fn cmd_plan(spec_paths: &[PathBuf], dirs: &Dirs, force: bool, shards: Option<usize>) -> Result<()> {
    if let Some(n) = shards {
        if n == 0 || n > crate::plan::shard::MAX_SHARDS {
            return Err(Usage(format!(
                "--shards must be between 1 and {}",
                crate::plan::shard::MAX_SHARDS
            ))
            .into());
        }
    }
    let plans = load_plans(spec_paths, &dirs.maps, &dirs.algorithms, dirs.max_runs)?;
    let opts = options(dirs, Some(1), force, true)?;
    let owner = shards.map(|n| run::shards(&plans, n));
    for plan in &plans {
        let reasons = run::reasons(plan, &opts);
        let spec = &plan.spec.spec;
        match spec.looks() {
            None => println!(
                "study {}: {} points × {} maps × {} algorithms × {} replicates = {} runs",
                plan.id(),
                plan.points.len(),
                plan.maps.len(),
                spec.algorithms.len(),
                spec.replicates,
                plan.runs.len()
            ),
            Some(looks) => println!(
                "study {}: {} points × {} maps × {} algorithms × {} to {} replicates = at most {} runs (sequential: looks at {}; `run` adds each stage only to the cells of undecided claims{}, so the runs below beyond the first {} replicates run only if a look asks for them)",
                plan.id(),
                plan.points.len(),
                plan.maps.len(),
                spec.algorithms.len(),
                spec.replicates,
                spec.replicate_budget(),
                plan.runs.len(),
                looks.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(", "),
                if plan.items.is_empty() {
                    String::new()
                } else {
                    format!(
                        " and of unresolved published items ({})",
                        plan.items.iter().map(|i| i.id.as_str()).collect::<Vec<_>>().join(", ")
                    )
                },
                spec.replicates
            ),
        }
        if run::skipped(plan) {
            println!(
                "(its data is absent on this machine: `run` skips it{})",
                if owner.is_some() { ", and no shard gets its runs" } else { "" }
            );
        }
        let previous = store::read_runs(&opts.results_dir.join(plan.id())).unwrap_or_default();
        for (r, reason) in plan.runs.iter().zip(&reasons) {
            let changed = match reason {
                Reason::ParametersChanged | Reason::ParametersAndCodeVersionChanged => previous
                    .iter()
                    .find(|p| p.run_id == r.run_id)
                    .map(|p| run::changed_parameters(plan, r, p))
                    .filter(|c| !c.is_empty())
                    .map_or(String::new(), |c| format!(" ({})", c.join("; "))),
                _ => String::new(),
            };
            match owner.as_ref().and_then(|o| o.get(r.hash.as_str())) {
                Some(&k) => {
                    let n = shards.unwrap_or(1);
                    println!(
                        "{:<36} {:<width$} {}{changed}",
                        reason.as_str(),
                        format!("{k}/{n}"),
                        r.run_id,
                        width = 2 * n.to_string().len() + 1
                    );
                }
                None => println!("{:<36} {}{changed}", reason.as_str(), r.run_id),
            }
        }
        let count = |x: Reason| reasons.iter().filter(|r| **r == x).count();
        println!(
            "to run: {} (new {}, parameters changed {}, code version changed {}, both changed {}, cache entry missing {}, forced {}); cached: {}",
            reasons.iter().filter(|r| **r != Reason::Cached).count(),
            count(Reason::New),
            count(Reason::ParametersChanged),
            count(Reason::CodeVersionChanged),
            count(Reason::ParametersAndCodeVersionChanged),
            count(Reason::CacheMissing),
            count(Reason::Forced),
            count(Reason::Cached)
        );
    }
    if let (Some(n), Some(owner)) = (shards, &owner) {
        let cache = store::Cache::new(&opts.cache_dir);
        let table = run::shard_loads(&plans, owner, n, &|h| !force && cache.contains(h));
        let studies = plans.iter().filter(|p| !run::skipped(p)).count();
        println!(
            "\nshards of the runs of {studies} {} (`run --shard I/{n}`; runs that share a content hash are one run; expected cost in seconds of one core of the reference machine, docs/src/guide/cluster.md):",
            if studies == 1 { "study" } else { "studies" }
        );
        println!(
            "{:<12} {:>8} {:>12} {:>14} {:>22}",
            "shard", "runs", "to compute", "expected [s]", "to compute, exp. [s]"
        );
        for (k, t) in table.iter().enumerate() {
            println!(
                "{:<12} {:>8} {:>12} {:>14.1} {:>22.1}",
                format!("{}/{n}", k + 1),
                t.runs,
                t.to_compute,
                t.cost_s,
                t.to_compute_s
            );
        }
        let total = |f: fn(&run::ShardLoad) -> f64| table.iter().map(f).sum::<f64>();
        println!(
            "{:<12} {:>8} {:>12} {:>14.1} {:>22.1}",
            "all",
            total(|t| t.runs as f64),
            total(|t| t.to_compute as f64),
            total(|t| t.cost_s),
            total(|t| t.to_compute_s)
        );
    }
    Ok(())
}

fn cmd_run_shard(
    specs: &[PathBuf],
    dirs: &Dirs,
    threads: Option<usize>,
    force: bool,
    quiet: bool,
    shard: crate::plan::shard::Shard,
) -> Result<()> {
    let plans = load_plans(specs, &dirs.maps, &dirs.algorithms, dirs.max_runs)?;
    let opts = options(dirs, threads, force, quiet)?;
    for plan in plans.iter().filter(|p| run::skipped(p)) {
        let why = plan.maps.iter().find_map(|m| m.missing_data.as_ref()).map_or("", String::as_str);
        eprintln!("{}: skipped: {why}", plan.id());
    }
    if plans.iter().all(run::skipped) {
        bail!("every study was skipped (its data is absent); nothing was run");
    }
    let s = run::run_shard(&plans, shard, &opts).context("running the shard")?;
    eprintln!(
        "shard {shard}: {} runs (expected {:.0} s): {} computed, {} cached, {} failed or diverged → {} (no study results: `slamlab run` without --shard writes them once every shard is done)",
        s.runs,
        s.expected_s,
        s.computed,
        s.cached,
        s.failed,
        opts.cache_dir.display()
    );
    Ok(())
}

fn cmd_slurm(
    specs: &[PathBuf],
    dirs: &Dirs,
    resources: &crate::report::slurm::Resources,
    out: &Path,
    reports: &Path,
    submit: bool,
) -> Result<()> {
    crate::report::slurm::validate(resources).map_err(Usage)?;
    // Every path goes into a shell or sbatch script: it must be text the script can hold as it
    // is (no newline or other control character, which would end a comment or an #SBATCH line,
    // and no invalid UTF-8, which would silently become another folder).
    let repo = std::env::current_dir().context("reading the working directory")?;
    let bin = std::env::current_exe().context("finding slamlab's own path")?;
    let mut paths: Vec<(&str, &Path)> = vec![
        ("--out", out),
        ("--reports", reports),
        ("--maps", &dirs.maps),
        ("--cache", &dirs.cache),
        ("--results", &dirs.results),
        ("the working directory", &repo),
        ("slamlab's own path", &bin),
    ];
    paths.extend(dirs.algorithms.iter().map(|a| ("--algorithms", a.as_path())));
    paths.extend(specs.iter().map(|s| ("a spec path", s.as_path())));
    for (what, path) in paths {
        match path.to_str() {
            None => {
                return Err(Usage(format!(
                    "{what} {}: not valid UTF-8, which a batch script cannot name as it is",
                    path.display()
                ))
                .into());
            }
            Some(t) if t.chars().any(char::is_control) => {
                return Err(Usage(format!(
                    "{what} {t:?}: holds a newline or another control character, which a batch script cannot hold"
                ))
                .into());
            }
            Some(_) => {}
        }
    }
    let plans = load_plans(specs, &dirs.maps, &dirs.algorithms, dirs.max_runs)?;
    let opts = options(dirs, Some(1), false, true)?;
    let owner = run::shards(&plans, resources.tasks);
    let cache = store::Cache::new(&opts.cache_dir);
    let loads = run::shard_loads(&plans, &owner, resources.tasks, &|h| cache.contains(h));
    let runs: usize = plans.iter().filter(|p| !run::skipped(p)).map(|p| p.runs.len()).sum();
    let absolute = |p: &Path| if p.is_absolute() { p.to_path_buf() } else { repo.join(p) };
    let text = |p: &Path| p.to_string_lossy().into_owned();
    let out = absolute(out);
    let logs = out.join("logs");
    let runs_path = out.join("runs.sbatch");
    // `report --specs`: the specs' folder when they share one (studies without results keep their report)
    let folders: std::collections::BTreeSet<PathBuf> =
        specs.iter().map(|s| s.parent().unwrap_or(Path::new("")).to_path_buf()).collect();
    let keep_specs = (folders.len() == 1)
        .then(|| folders.into_iter().next().unwrap_or_default())
        .filter(|f| !f.as_os_str().is_empty())
        .map(|f| text(&f));
    let job = crate::report::slurm::Job {
        repo: text(&repo),
        bin: text(&bin),
        specs: specs.iter().map(|s| text(s)).collect(),
        maps: text(&dirs.maps),
        algorithms: dirs.algorithms.iter().map(|a| text(a)).collect(),
        cache: text(&dirs.cache),
        results: text(&dirs.results),
        reports: Some(text(reports)),
        keep_specs,
        logs: text(&logs),
        runs_script: text(&runs_path),
    };
    let summary = crate::report::slurm::Summary {
        studies: plans.iter().filter(|p| !run::skipped(p)).map(|p| p.id().to_string()).collect(),
        runs,
        unique: loads.iter().map(|l| l.runs).sum(),
        to_compute: loads.iter().map(|l| l.to_compute).sum(),
        cost_total_s: loads.iter().map(|l| l.cost_s).sum(),
        cost_max_s: loads.iter().map(|l| l.cost_s).fold(0.0, f64::max),
    };
    let (runs_script, assemble_script) = crate::report::slurm::scripts(&job, resources, &summary)
        .context("rendering the sbatch scripts")?;
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    let assemble_path = out.join("assemble.sbatch");
    for (path, body) in [(&runs_path, &runs_script), (&assemble_path, &assemble_script)] {
        let tmp = path.with_extension("sbatch.tmp");
        std::fs::write(&tmp, body).with_context(|| format!("writing {}", tmp.display()))?;
        std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))?;
    }
    eprintln!(
        "wrote {} ({} tasks; {} runs, {} distinct, {} to compute; expected {:.0} s in all, {:.0} s in the largest shard) and {}",
        runs_path.display(),
        resources.tasks,
        summary.runs,
        summary.unique,
        summary.to_compute,
        summary.cost_total_s,
        summary.cost_max_s,
        assemble_path.display()
    );
    if !submit {
        eprintln!(
            "submit with:\n  jobid=$(sbatch --parsable {}) && sbatch --dependency=afterok:${{jobid%%;*}} {}",
            crate::report::slurm::shell_quote(&text(&runs_path)),
            crate::report::slurm::shell_quote(&text(&assemble_path))
        );
        return Ok(());
    }
    let sbatch = |args: &[&str]| -> Result<String> {
        let output = std::process::Command::new("sbatch")
            .arg("--parsable")
            .args(args)
            .output()
            .context("starting sbatch (is Slurm installed here?)")?;
        if !output.status.success() {
            bail!(
                "sbatch {} failed: {}",
                args.join(" "),
                String::from_utf8_lossy(&output.stderr).trim()
            );
        }
        // --parsable prints `jobid` or `jobid;cluster`
        let id = String::from_utf8_lossy(&output.stdout)
            .trim()
            .split(';')
            .next()
            .unwrap_or_default()
            .to_string();
        if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
            bail!("sbatch printed no job id: {:?}", String::from_utf8_lossy(&output.stdout));
        }
        Ok(id)
    };
    let runs_id = sbatch(&[&text(&runs_path)])?;
    let assemble_id = sbatch(&[&format!("--dependency=afterok:{runs_id}"), &text(&assemble_path)])?;
    println!("{runs_id} {assemble_id}");
    eprintln!(
        "submitted the runs as array job {runs_id} (tasks 1-{}) and the assembling job {assemble_id} (after all of them succeed); logs in {}",
        resources.tasks,
        logs.display()
    );
    Ok(())
}

fn cmd_export_scans(
    spec_path: &Path,
    run_id: &str,
    out_dir: &Path,
    maps: &Path,
    algorithms: &[PathBuf],
) -> Result<()> {
    let plans = load_plans(
        std::slice::from_ref(&spec_path.to_path_buf()),
        maps,
        algorithms,
        plan::DEFAULT_MAX_RUNS,
    )?;
    let plan = &plans[0];
    let Some(run) = plan.runs.iter().find(|r| r.run_id == run_id) else {
        bail!(
            "{}: no run `{run_id}` in study {} (`slamlab plan {}` lists its runs)",
            spec_path.display(),
            plan.id(),
            spec_path.display()
        );
    };
    let params = &plan.points[run.point].params;
    let Some(matcher) = plan.algorithm(run).matcher(params) else {
        bail!(
            "run `{run_id}` is {}, not a built-in scan matcher: it has no scan pairs",
            run.algorithm
        );
    };
    let world = run::world_of(plan, run).map_err(|e| anyhow::anyhow!("run `{run_id}`: {e}"))?;
    let geometry = world.laser.context("the run's world has no laser")?;
    let mut clock = || 0.0;
    let tracked = crate::scanmatch::track::track(
        &world,
        matcher,
        &params.scan_matching,
        run.filter_seed,
        &mut clock,
    )
    .map_err(|e| anyhow::anyhow!("run `{run_id}`: {e}"))?;
    std::fs::create_dir_all(out_dir).with_context(|| format!("creating {}", out_dir.display()))?;
    let files = [
        ("scans.txt", crate::world::laser::scans_text(&geometry, &world.scans)),
        ("pairs.txt", store::scans::pairs_text(&tracked.trace.matches)),
        ("matches.txt", store::scans::matches_text(&tracked.trace.matches)),
    ];
    for (name, text) in files {
        let (path, tmp) = (out_dir.join(name), out_dir.join(format!(".{name}.tmp")));
        std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
        std::fs::rename(&tmp, &path).with_context(|| format!("writing {}", path.display()))?;
    }
    eprintln!(
        "wrote {} scans and {} pairs of {run_id} into {}",
        world.scans.len(),
        tracked.trace.matches.len(),
        out_dir.display()
    );
    Ok(())
}

fn cmd_export_tum(results_dir: &Path, out_dir: &Path, only: &[String]) -> Result<()> {
    let studies: Vec<PathBuf> = if results_dir.join("traces.parquet").is_file() {
        vec![results_dir.to_path_buf()]
    } else {
        let all = store::list_studies(results_dir)?;
        if all.is_empty() {
            bail!(
                "{}: no traces.parquet here and no study directories below",
                results_dir.display()
            );
        }
        all
    };
    let nested = studies.len() > 1 || !results_dir.join("traces.parquet").is_file();
    let mut written = 0;
    for dir in &studies {
        let traces =
            store::read_traces(dir, &|id| only.is_empty() || only.iter().any(|o| o == id))?;
        let target = if nested {
            out_dir.join(dir.file_name().unwrap_or_default())
        } else {
            out_dir.to_path_buf()
        };
        std::fs::create_dir_all(&target)
            .with_context(|| format!("creating {}", target.display()))?;
        for t in traces.iter().filter(|t| !t.truth.is_empty()) {
            // both files at the steps with truth (and an estimate): evo rejects NaN lines
            let known = |k: usize| {
                t.truth.get(k).is_some_and(|p| p.is_finite())
                    && t.estimate.get(k).is_some_and(|p| p.is_finite())
            };
            let skipped = (0..t.truth.len()).filter(|&k| !known(k)).count();
            if skipped > 0 {
                eprintln!(
                    "{}: {skipped} of {} steps have no truth or no finite estimate; both files leave them out",
                    t.run_id,
                    t.truth.len()
                );
            }
            for (suffix, poses) in [("gt", &t.truth), ("est", &t.estimate)] {
                // a long run id (a many-parameter sweep point) gets a short, stable file name
                let name = store::short_name(&t.run_id);
                let path = target.join(format!("{name}.{suffix}.tum"));
                let tmp = target.join(format!(".{name}.{suffix}.tum.tmp"));
                std::fs::write(&tmp, tum::tum_text(t.dt_s, poses, &known))
                    .with_context(|| format!("writing {}", tmp.display()))?;
                std::fs::rename(&tmp, &path)
                    .with_context(|| format!("writing {}", path.display()))?;
                written += 1;
            }
        }
    }
    if !only.is_empty() && written == 0 {
        bail!("none of the requested runs ({}) was found", only.join(", "));
    }
    eprintln!("wrote {written} TUM files into {}", out_dir.display());
    Ok(())
}
