//! The SLURM executor's policy with a fake scheduler: a stage is done when its artefact is
//! published; timeouts are resubmitted with twice the time and out-of-memory with twice the
//! memory, up to the retry limit; a stage error is final and names its job; live jobs of an
//! earlier controller on the same results folder are adopted, not submitted again; a scheduler
//! that stops answering fails the stage after a bounded number of rounds. (The real cluster is
//! tested in crates/cli/tests/slurm_executor.rs.)

mod common;

use anyhow::{Result, anyhow};
use common::{Add, PIPELINE, Project, registry};
use orchestrator::slurm::{JobSpec, JobState, Resources, Scheduler, Slurm, SlurmOptions};
use orchestrator::{Plan, Workspace};
use std::collections::BTreeSet;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// What the n-th submitted job does.
#[derive(Clone, Debug)]
enum Outcome {
    /// Runs the stage (as `run-stage` would) and completes.
    Publish,
    /// Ends in this state without publishing.
    End(&'static str),
}

struct Fake {
    script: Mutex<Vec<Outcome>>,
    submitted: Mutex<Vec<JobSpec>>,
    jobs: Mutex<Vec<JobState>>,
    live_elsewhere: Vec<JobState>,
    queries: AtomicUsize,
    silent: bool,
    ws: Workspace,
    plan: Plan,
}

impl Fake {
    fn new(p: &Project, add: &Add, script: Vec<Outcome>) -> Self {
        Self {
            script: Mutex::new(script),
            submitted: Mutex::default(),
            jobs: Mutex::default(),
            live_elsewhere: Vec::new(),
            queries: AtomicUsize::new(0),
            silent: false,
            ws: p.ws(),
            plan: p.plan(&registry(add)),
        }
    }
    fn publish(&self, key: &str) {
        let opts = common::quiet();
        orchestrator::run_stage(&self.ws, &self.plan, key, false, &opts).unwrap();
    }
}

fn key_of(comment: &str) -> String {
    let rest = comment.strip_prefix("saddleflow:").unwrap();
    rest.split_once('@').unwrap().0.to_string()
}

impl Scheduler for Fake {
    fn submit(&self, job: &JobSpec) -> Result<String> {
        let mut subs = self.submitted.lock().unwrap();
        subs.push(job.clone());
        let id = subs.len().to_string();
        let outcome = self.script.lock().unwrap().remove(0);
        let state = match outcome {
            Outcome::Publish => {
                self.publish(&key_of(&job.comment));
                "COMPLETED"
            }
            Outcome::End(s) => s,
        };
        self.jobs.lock().unwrap().push(JobState {
            id: id.clone(),
            name: job.name.clone(),
            state: state.into(),
            comment: job.comment.clone(),
        });
        Ok(id)
    }
    fn jobs_named(&self, names: &[String]) -> Result<Vec<JobState>> {
        self.queries.fetch_add(1, Ordering::SeqCst);
        if self.silent {
            return Err(anyhow!(
                "slurm_load_jobs error: Unable to contact slurm controller"
            ));
        }
        let names: BTreeSet<&String> = names.iter().collect();
        Ok(self
            .jobs
            .lock()
            .unwrap()
            .iter()
            .filter(|j| names.contains(&j.name))
            .cloned()
            .collect())
    }
    fn own_live_jobs(&self) -> Result<Vec<JobState>> {
        Ok(self.live_elsewhere.clone())
    }
    fn final_state(&self, _id: &str) -> Option<String> {
        None
    }
    fn cancel(&self, _name: &str) -> Result<()> {
        Ok(())
    }
}

fn options(retries: u32) -> SlurmOptions {
    let mut o = SlurmOptions::new("saddleflow".into(), "p.toml".into(), "x.toml".into());
    o.retries = retries;
    o.poll_s = 0.02;
    o.defaults = Resources {
        cpus: 1,
        mem_mib: 100,
        time_min: 3,
    };
    o
}

/// Runs stage `a` of the standard pipeline through a controller on `fake`.
fn execute_a(p: &Project, fake: Arc<Fake>, retries: u32) -> (Result<String>, Arc<Fake>) {
    let add = Add::new();
    let plan = p.plan(&registry(&add));
    let ws = p.ws();
    let slurm = Arc::new(Slurm::new(fake.clone(), options(retries), &ws, "test").unwrap());
    let keys: BTreeSet<String> = plan.stages.iter().map(|s| s.key.clone()).collect();
    slurm.adopt_live_jobs(&keys).unwrap();
    let m = slurm.clone();
    let monitor = std::thread::spawn(move || m.monitor());
    let s = plan.stage("a").unwrap();
    let r = slurm.execute(&ws, s, &|_, _, _, _, _| {});
    slurm.shutdown();
    monitor.join().unwrap();
    (r, fake)
}

#[test]
fn timeout_is_resubmitted_with_twice_the_time() {
    let p = Project::new(PIPELINE, "");
    let fake = Arc::new(Fake::new(
        &p,
        &Add::new(),
        vec![Outcome::End("TIMEOUT"), Outcome::Publish],
    ));
    let (r, fake) = execute_a(&p, fake, 1);
    assert_eq!(r.unwrap(), "2");
    let subs = fake.submitted.lock().unwrap();
    assert_eq!(subs.len(), 2);
    assert_eq!(subs[1].resources.time_min, 2 * subs[0].resources.time_min);
    assert_eq!(subs[1].resources.mem_mib, subs[0].resources.mem_mib);
    assert!(subs[0].log != subs[1].log, "each attempt keeps its own log");
}

#[test]
fn out_of_memory_twice_fails_naming_the_job() {
    let p = Project::new(PIPELINE, "");
    let fake = Arc::new(Fake::new(
        &p,
        &Add::new(),
        vec![Outcome::End("OUT_OF_MEMORY"), Outcome::End("OUT_OF_MEMORY")],
    ));
    let (r, fake) = execute_a(&p, fake, 1);
    let msg = format!("{:#}", r.unwrap_err());
    assert!(
        msg.contains("job 2") && msg.contains("ran out of memory"),
        "{msg}"
    );
    let subs = fake.submitted.lock().unwrap();
    assert_eq!(subs[1].resources.mem_mib, 2 * subs[0].resources.mem_mib);
}

#[test]
fn stage_error_is_final() {
    let p = Project::new(PIPELINE, "");
    let fake = Arc::new(Fake::new(
        &p,
        &Add::new(),
        vec![Outcome::End("FAILED"), Outcome::Publish],
    ));
    let (r, fake) = execute_a(&p, fake, 3);
    let msg = format!("{:#}", r.unwrap_err());
    assert!(
        msg.contains("job 1") && msg.contains("stage error"),
        "{msg}"
    );
    assert_eq!(fake.submitted.lock().unwrap().len(), 1);
}

#[test]
fn live_job_of_an_earlier_controller_is_adopted_not_resubmitted() {
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let plan = p.plan(&registry(&add));
    let key = plan.stage("a").unwrap().key.clone();
    let root = std::env::current_dir().unwrap().join(p.root());
    let mut fake = Fake::new(&p, &add, vec![]);
    let live = |id: &str, root: &std::path::Path| JobState {
        id: id.into(),
        name: "saddleflow-earlier".into(),
        state: "RUNNING".into(),
        comment: format!("saddleflow:{key}@{}", root.display()),
    };
    // a job of another results folder with the same key is not ours
    fake.live_elsewhere = vec![
        live("77", &root),
        live("78", std::path::Path::new("/elsewhere")),
    ];
    fake.jobs.lock().unwrap().push(live("77", &root));
    let fake = Arc::new(fake);
    // the earlier job publishes a moment later and leaves the queue
    let f = fake.clone();
    let k = key.clone();
    let finisher = std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_millis(200));
        f.publish(&k);
        f.jobs.lock().unwrap()[0].state = "COMPLETED".into();
    });
    let (r, fake) = execute_a(&p, fake, 1);
    finisher.join().unwrap();
    assert_eq!(r.unwrap(), "77");
    assert!(fake.submitted.lock().unwrap().is_empty());
}

#[test]
fn silent_scheduler_fails_after_bounded_rounds() {
    let p = Project::new(PIPELINE, "");
    let mut fake = Fake::new(&p, &Add::new(), vec![Outcome::End("RUNNING")]);
    fake.silent = true;
    let (r, fake) = execute_a(&p, Arc::new(fake), 1);
    let msg = format!("{:#}", r.unwrap_err());
    assert!(msg.contains("has not answered"), "{msg}");
    // it gives up after MAX_SILENT_ROUNDS rounds (one more may start before the loop stops)
    let q = fake.queries.load(Ordering::SeqCst) as u32;
    let max = orchestrator::slurm::MAX_SILENT_ROUNDS;
    assert!((max..=max + 1).contains(&q), "{q} queries");
}

#[test]
fn whole_runs_through_the_fake_agree_with_local_runs() {
    // the runner's bookkeeping is shared by both executors; here only check that a stage
    // published by a "job" is recognised as valid by the local runner afterwards
    let p = Project::new(PIPELINE, "");
    let fake = Arc::new(Fake::new(&p, &Add::new(), vec![Outcome::Publish]));
    let (r, _) = execute_a(&p, fake, 0);
    r.unwrap();
    let add = Add::new();
    let s = p.run(&registry(&add), &common::quiet());
    assert!(s.cached.contains(&"a".to_string()), "{:?}", s.cached);
}

#[test]
fn resources_set_by_hand_win_stage_over_kind_over_estimate() {
    use orchestrator::slurm::ResourceOverride;
    let p = Project::new(PIPELINE, "");
    let add = Add::new();
    let plan = p.plan(&registry(&add));
    let mut o = options(0);
    o.overrides.insert(
        "add".into(),
        ResourceOverride {
            cpus: Some(4),
            mem_mib: Some(1000),
            time_min: None,
        },
    );
    o.overrides.insert(
        "b".into(),
        ResourceOverride {
            mem_mib: Some(5000),
            ..Default::default()
        },
    );
    let fake = Arc::new(Fake::new(&p, &add, vec![]));
    let slurm = Slurm::new(fake, o, &p.ws(), "test").unwrap();
    let r = |name: &str| slurm.resources(&p.ws(), plan.stage(name).unwrap());
    assert_eq!(
        r("a"),
        Resources {
            cpus: 4,
            mem_mib: 1000,
            time_min: 3
        }
    );
    assert_eq!(
        r("b"),
        Resources {
            cpus: 4,
            mem_mib: 5000,
            time_min: 3
        }
    );
}
