//! Starts an external algorithm's program for one run (docs/src/guide/external-algorithms.md): writes the
//! input files into a fresh private folder, runs the command with `{input}` and `{output}`
//! replaced, kills it (and anything it started) past its timeout, and reads its output files
//! back. What goes wrong becomes the run's error, with the tail of the program's standard error;
//! the folders are removed either way.

use crate::algo::{Launch, Launched};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Lines of standard error quoted in a failed run's reason.
const STDERR_LINES: usize = 12;
/// … and at most this many characters of them.
const STDERR_CHARS: usize = 1500;

/// Runs `launch` for the run `run_id`.
pub fn launch(launch: &Launch<'_>, run_id: &str) -> Result<Launched, String> {
    let dir = scratch(run_id)?;
    let result = launch_in(&dir, launch);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

/// A new folder of its own under the system's temporary folder.
fn scratch(run_id: &str) -> Result<PathBuf, String> {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let safe: String = run_id
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' })
        .take(80)
        .collect();
    loop {
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("slamlab-{}-{n}-{safe}", std::process::id()));
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => {
                return Err(format!(
                    "cannot make a folder for its files in {}: {e}",
                    dir.display()
                ));
            }
        }
    }
}

fn launch_in(dir: &Path, launch: &Launch<'_>) -> Result<Launched, String> {
    let (input, output) = (dir.join("input"), dir.join("output"));
    for d in [&input, &output] {
        std::fs::create_dir(d).map_err(|e| format!("cannot make {}: {e}", d.display()))?;
    }
    for (name, text) in &launch.inputs {
        std::fs::write(input.join(name), text)
            .map_err(|e| format!("cannot write its input {name}: {e}"))?;
    }
    let args: Vec<String> = launch
        .command
        .iter()
        .map(|a| {
            a.replace("{input}", &input.to_string_lossy())
                .replace("{output}", &output.to_string_lossy())
        })
        .collect();
    let Some((program, rest)) = args.split_first() else {
        return Err("its command is empty".into());
    };
    let stderr_path = dir.join("stderr.txt");
    let file = |p: PathBuf| {
        std::fs::File::create(&p).map_err(|e| format!("cannot make {}: {e}", p.display()))
    };
    let mut command = Command::new(program);
    command
        .args(rest)
        .stdin(Stdio::null())
        .stdout(file(dir.join("stdout.txt"))?)
        .stderr(file(stderr_path.clone())?);
    #[cfg(unix)]
    {
        // its own process group, so that a timeout kills what it started too
        use std::os::unix::process::CommandExt;
        command.process_group(0);
    }
    let mut child = command.spawn().map_err(|e| format!("cannot start `{program}`: {e}"))?;
    let status =
        wait(&mut child, launch.timeout_s).map_err(|why| format!("{why}{}", tail(&stderr_path)))?;
    if !status.success() {
        return Err(format!("{}{}", exit_text(status), tail(&stderr_path)));
    }
    launch
        .outputs
        .iter()
        .map(|&name| match std::fs::read(output.join(name)) {
            Ok(bytes) => String::from_utf8(bytes)
                .map(|t| (name, Some(t)))
                .map_err(|_| format!("its {name} is not UTF-8 text")),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok((name, None)),
            Err(e) => Err(format!("cannot read its {name}: {e}")),
        })
        .collect()
}

/// Waits for `child` at most `timeout_s`; past it, kills its process group.
fn wait(child: &mut Child, timeout_s: f64) -> Result<ExitStatus, String> {
    let deadline = Instant::now() + Duration::from_secs_f64(timeout_s);
    let mut pause = Duration::from_millis(1);
    loop {
        if let Some(status) = child.try_wait().map_err(|e| format!("cannot wait for it: {e}"))? {
            return Ok(status);
        }
        if Instant::now() >= deadline {
            kill(child);
            return Err(format!(
                "did not finish within its timeout of {timeout_s} s and was killed"
            ));
        }
        std::thread::sleep(pause);
        pause = (pause * 2).min(Duration::from_millis(50));
    }
}

fn kill(child: &mut Child) {
    #[cfg(unix)]
    {
        let group = format!("-{}", child.id());
        let _ = Command::new("kill").args(["-KILL", "--", &group]).stderr(Stdio::null()).status();
    }
    let _ = child.kill();
    let _ = child.wait();
}

fn exit_text(status: ExitStatus) -> String {
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(signal) = status.signal() {
            return format!("was killed by signal {signal}");
        }
    }
    match status.code() {
        Some(code) => format!("exited with status {code}"),
        None => "exited abnormally".into(),
    }
}

/// The last lines of the program's standard error, as the end of a reason (empty when it wrote
/// none).
fn tail(path: &Path) -> String {
    let text =
        std::fs::read(path).map(|b| String::from_utf8_lossy(&b).into_owned()).unwrap_or_default();
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    if lines.is_empty() {
        return String::new();
    }
    let mut shown = lines[lines.len().saturating_sub(STDERR_LINES)..].join("\n");
    if shown.chars().count() > STDERR_CHARS {
        shown = format!(
            "…{}",
            shown
                .chars()
                .rev()
                .take(STDERR_CHARS)
                .collect::<Vec<_>>()
                .into_iter()
                .rev()
                .collect::<String>()
        );
    }
    format!("; its standard error ends:\n{shown}")
}
