//! Guards every command shares: the thread count, the files a user names as outputs, and the
//! process's signals (a closed stdout, Ctrl-C).
//!
//! Outputs follow the rule of [`store::fsutil::check_output_path`]: checked before any work
//! (the folder exists, the path is absent or a regular file, it is not an input), written to a
//! temporary next to it and renamed over it at the end; a failure at any step deletes the
//! temporary, and so does an interruption (see [`install_signal_handlers`]).

use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use store::{ArtefactWriter, fsutil};

/// Most threads per available core that `--threads` accepts. Every solver here is bound by
/// memory bandwidth and FFTs: more threads than cores only add switching, and a few times the
/// cores covers hyper-threading and over-subscription experiments.
pub const THREADS_PER_CORE_MAX: usize = 4;

/// A rayon pool of `threads` threads (`None`: one per available core). Refuses 0 and more than
/// [`THREADS_PER_CORE_MAX`] × the available cores, naming the range.
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let max = THREADS_PER_CORE_MAX * cores;
    let n = match threads {
        None => cores,
        Some(t) if (1..=max).contains(&t) => t,
        Some(t) => bail!(
            "--threads {t}: allowed 1..={max} (at most {THREADS_PER_CORE_MAX} × the {cores} \
             available cores); omit it to use one thread per core"
        ),
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .context("cannot start the thread pool")
}

/// A user-named output file: checked when the command starts, published when it ends.
pub struct Output<'a> {
    what: &'a str,
    path: &'a Path,
    inputs: Vec<(&'a str, &'a Path)>,
}

impl<'a> Output<'a> {
    /// Checks `path` (named by option `what`, e.g. `--out`) against the output rule and the
    /// command's `inputs` (option, path): call before any work, so that a bad path costs nothing.
    pub fn check(what: &'a str, path: &'a Path, inputs: &[(&'a str, &'a Path)]) -> Result<Self> {
        fsutil::check_output_path(what, path, inputs)?;
        Ok(Output {
            what,
            path,
            inputs: inputs.to_vec(),
        })
    }

    /// Starts the artefact (a temporary next to the output).
    pub fn create(&self) -> Result<ArtefactWriter> {
        // checked again: the folder may have gone during the computation, and the writer would
        // create it silently
        fsutil::check_output_path(self.what, self.path, &self.inputs)?;
        ArtefactWriter::create(self.path)
            .with_context(|| format!("{} `{}`", self.what, self.path.display()))
    }

    /// Publishes `w` over the output, checking the rule once more (the path may have changed
    /// while the command ran). On any failure the temporary is deleted.
    pub fn publish(&self, w: ArtefactWriter) -> Result<PathBuf> {
        let tmp = w.temp_path().to_path_buf();
        let published = fsutil::check_output_path(self.what, self.path, &self.inputs)
            .and_then(|()| w.publish())
            .with_context(|| format!("{} `{}`", self.what, self.path.display()));
        if published.is_err() {
            fsutil::remove_temp(&tmp);
        }
        published
    }
}

/// Restores the Unix behaviour on a closed stdout and reports interruptions.
///
/// - SIGPIPE: Rust ignores it, so a write to a closed pipe fails and `println!` panics
///   (`saddleflow status | head -1`). Its default action is restored, as every Unix filter has it:
///   the process ends quietly when the reader goes away. Every output file is published by an
///   atomic rename, so ending at any point leaves no partial file.
/// - SIGINT, SIGTERM, SIGHUP: a watcher thread deletes this process's unpublished temporaries,
///   cancels the jobs of a running SLURM controller, prints `interrupted` on stderr and ends the process by the same signal (so callers see the
///   usual status, 130 for Ctrl-C).
///
/// Best effort: if a handler cannot be installed the default behaviour stays.
pub fn install_signal_handlers() {
    use signal_hook::consts::signal::{SIGHUP, SIGINT, SIGPIPE, SIGTERM};
    use std::sync::Arc;
    use std::sync::atomic::AtomicBool;
    let _ =
        signal_hook::flag::register_conditional_default(SIGPIPE, Arc::new(AtomicBool::new(true)));
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(sig) = signals.forever().next() {
            let removed = fsutil::remove_live_temps();
            let cancelled = stages::orchestrator::slurm::cancel_active_runs();
            let name = signal_hook::low_level::signal_name(sig).unwrap_or("a signal");
            let mut note = if removed > 0 {
                format!("; {removed} unfinished file(s) deleted")
            } else {
                String::new()
            };
            if !cancelled.is_empty() {
                note.push_str(&format!(
                    "; SLURM jobs cancelled (scancel --name={})",
                    cancelled.join(",")
                ));
            }
            // stderr may be closed too: never panic here
            let _ = std::io::Write::write_all(
                &mut std::io::stderr(),
                format!("\nsaddleflow: interrupted ({name}){note}\n").as_bytes(),
            );
            let _ = signal_hook::low_level::emulate_default_handler(sig);
        }
    });
}
