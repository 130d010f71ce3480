//! `saddleflow run --executor slurm`: the command-line options of the SLURM executor and its
//! profile files (`params/cluster/*.toml`, an `[executor]` table). Command-line options override
//! the profile; the profile overrides the defaults of [`orchestrator::slurm::SlurmOptions`].

use anyhow::{Context, Result, bail};
use serde::Deserialize;
use stages::orchestrator::Executor;
use stages::orchestrator::slurm::{ResourceOverride, SlurmOptions};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Where stages run.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ExecutorKind {
    /// In this process.
    Local,
    /// As SLURM batch jobs (`saddleflow run-stage KEY` each), submitted when their inputs are
    /// published.
    Slurm,
}

/// Executor options of `saddleflow run`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct ClusterArgs {
    /// Where stages run [default: local, or the profile's].
    #[arg(long, value_enum)]
    executor: Option<ExecutorKind>,
    /// A profile file with an `[executor]` table (kind, jobs, partition, account, extra, retries,
    /// poll_s, cpus, mem_mib, time_min) and optional `[resources.STAGE_OR_KIND]` tables (cpus,
    /// mem_mib, time_min), e.g. params/cluster/local.toml.
    #[arg(long, value_name = "FILE")]
    cluster_profile: Option<PathBuf>,
    /// SLURM partition.
    #[arg(long, value_name = "P")]
    slurm_partition: Option<String>,
    /// SLURM account.
    #[arg(long, value_name = "A")]
    slurm_account: Option<String>,
    /// More sbatch arguments, one string split as a shell would ("--qos=short --exclusive").
    #[arg(long, value_name = "ARGS")]
    slurm_extra: Option<String>,
    /// Resubmissions of a job that timed out (twice the time), ran out of memory (twice the
    /// memory) or lost its node [default: 1].
    #[arg(long, value_name = "N")]
    slurm_retries: Option<u32>,
    /// Seconds between status queries (≥ 1; backs off to 4× while nothing changes) [default: 5].
    #[arg(long, value_name = "S")]
    slurm_poll: Option<f64>,
}

/// The `[executor]` table of a profile file.
#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields)]
struct ProfileExecutor {
    kind: Option<ExecutorKind>,
    jobs: Option<usize>,
    partition: Option<String>,
    account: Option<String>,
    extra: Option<Vec<String>>,
    retries: Option<u32>,
    poll_s: Option<f64>,
    cpus: Option<u32>,
    mem_mib: Option<u64>,
    time_min: Option<u64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct Profile {
    executor: ProfileExecutor,
    /// `[resources.NAME]`: cores, memory, time of a stage (by name) or of every stage of a kind.
    #[serde(default)]
    resources: BTreeMap<String, ResourceOverride>,
}

fn read_profile(path: &Path) -> Result<Profile> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read the cluster profile `{}`", path.display()))?;
    toml::from_str(&text).with_context(|| format!("cluster profile `{}`", path.display()))
}

fn in_range<T: PartialOrd + std::fmt::Display>(
    what: &str,
    v: T,
    lo: T,
    hi: T,
    unit: &str,
) -> Result<T> {
    if !(v >= lo && v <= hi) {
        bail!("{what} = {v} is out of range: allowed {lo} to {hi}{unit}");
    }
    Ok(v)
}

impl ClusterArgs {
    /// The executor and the number of stages in flight: `jobs` from the command line, else the
    /// profile's, else 1.
    pub fn executor(
        &self,
        pipeline: &Path,
        params: &Path,
        jobs: Option<usize>,
    ) -> Result<(Executor, usize)> {
        let (prof, overrides) = match &self.cluster_profile {
            Some(p) => {
                let p = read_profile(p)?;
                (p.executor, p.resources)
            }
            None => (ProfileExecutor::default(), BTreeMap::new()),
        };
        let kind = self.executor.or(prof.kind).unwrap_or(ExecutorKind::Local);
        let jobs = jobs.or(prof.jobs).unwrap_or(1);
        if kind == ExecutorKind::Local {
            let slurm_only = self.slurm_partition.is_some()
                || self.slurm_account.is_some()
                || self.slurm_extra.is_some()
                || self.slurm_retries.is_some()
                || self.slurm_poll.is_some();
            if slurm_only {
                bail!(
                    "--slurm-* options need `--executor slurm` (or kind = \"slurm\" in a profile)"
                );
            }
            return Ok((Executor::Local, jobs));
        }
        let absolute = |p: &Path| {
            std::fs::canonicalize(p).with_context(|| format!("cannot find `{}`", p.display()))
        };
        let program = std::env::current_exe().context("cannot locate the saddleflow binary")?;
        let mut o = SlurmOptions::new(program, absolute(pipeline)?, absolute(params)?);
        o.partition = self.slurm_partition.clone().or(prof.partition);
        o.account = self.slurm_account.clone().or(prof.account);
        o.extra = match &self.slurm_extra {
            Some(s) => shlex::split(s)
                .with_context(|| format!("--slurm-extra {s:?}: unbalanced quotes"))?,
            None => prof.extra.unwrap_or_default(),
        };
        o.retries = in_range(
            "retries",
            self.slurm_retries.or(prof.retries).unwrap_or(o.retries),
            0,
            10,
            "",
        )?;
        o.poll_s = in_range(
            "poll interval",
            self.slurm_poll.or(prof.poll_s).unwrap_or(o.poll_s),
            1.0,
            600.0,
            " s",
        )?;
        o.defaults.cpus = in_range("cpus", prof.cpus.unwrap_or(o.defaults.cpus), 1, 1024, "")?;
        o.defaults.mem_mib = in_range(
            "mem_mib",
            prof.mem_mib.unwrap_or(o.defaults.mem_mib),
            64,
            1 << 24,
            " MiB",
        )?;
        o.defaults.time_min = in_range(
            "time_min",
            prof.time_min.unwrap_or(o.defaults.time_min),
            1,
            60 * 24 * 30,
            " min",
        )?;
        o.overrides = overrides;
        Ok((
            Executor::Slurm(Box::new(o)),
            in_range("jobs", jobs, 1, 10_000, "")?,
        ))
    }
}
