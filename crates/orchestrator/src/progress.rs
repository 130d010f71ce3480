//! Progress on stderr: an overall bar with ETA (weighted by the stages' cost hints) and one bar
//! per running stage when stderr is a terminal; otherwise one log line per finished stage.

use crate::kind::ProgressSink;
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// When to draw bars.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ProgressMode {
    /// Bars if stderr is a terminal, log lines otherwise.
    #[default]
    Auto,
    /// Log lines only.
    Lines,
    /// Nothing at all (tests).
    Silent,
}

const SCALE: f64 = 1000.0;

/// The runner's progress display.
pub struct Progress {
    mode: ProgressMode,
    bars: bool,
    multi: MultiProgress,
    total: ProgressBar,
    state: Arc<Mutex<Totals>>,
    done: Mutex<usize>,
    count: usize,
}

#[derive(Default)]
struct Totals {
    finished: f64,
    running: Vec<(String, f64, f64)>, // name, cost, fraction
}

impl Progress {
    /// Progress over `count` stages of total cost `total_cost`.
    pub fn new(mode: ProgressMode, count: usize, total_cost: f64) -> Self {
        let bars = mode == ProgressMode::Auto && std::io::stderr().is_terminal();
        let multi = MultiProgress::with_draw_target(if bars {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        });
        let total = multi.add(ProgressBar::new((total_cost * SCALE).max(1.0) as u64));
        total.set_style(
            ProgressStyle::with_template(
                "{prefix:>8} [{wide_bar:.cyan/blue}] {msg} {elapsed_precise} ETA {eta}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        total.set_prefix("stages");
        total.set_message(format!("0/{count}"));
        if bars {
            total.enable_steady_tick(Duration::from_millis(250));
        }
        Self {
            mode,
            bars,
            multi,
            total,
            state: Arc::new(Mutex::new(Totals::default())),
            done: Mutex::new(0),
            count,
        }
    }

    fn update_total(state: &Mutex<Totals>, total: &ProgressBar) {
        if let Ok(s) = state.lock() {
            let pos = s.finished + s.running.iter().map(|(_, c, f)| c * f).sum::<f64>();
            total.set_position((pos * SCALE) as u64);
        }
    }

    /// A stage starts; returns the sink its context reports to.
    pub fn started(&self, name: &str, kind: &str, cost: f64) -> Arc<dyn ProgressSink> {
        if let Ok(mut s) = self.state.lock() {
            s.running.push((name.to_string(), cost, 0.0));
        }
        let bar = if self.bars {
            let b = self.multi.add(ProgressBar::new(1000));
            b.set_style(
                ProgressStyle::with_template(
                    "{prefix:>8.bold} [{bar:30}] {percent:>3}% {msg} ({elapsed})",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
            );
            b.set_prefix(kind.to_string());
            b.set_message(name.to_string());
            b.enable_steady_tick(Duration::from_millis(250));
            Some(b)
        } else {
            None
        };
        Arc::new(StageBar {
            name: name.to_string(),
            bar,
            state: self.state.clone(),
            total: self.total.clone(),
        })
    }

    /// A stage is done (any outcome); `line` is logged.
    pub fn finished(&self, name: &str, cost: f64, line: &str) {
        if let Ok(mut s) = self.state.lock() {
            s.running.retain(|(n, _, _)| n != name);
            s.finished += cost;
        }
        Self::update_total(&self.state, &self.total);
        let done = {
            let mut d = self.done.lock().unwrap_or_else(|e| e.into_inner());
            *d += 1;
            *d
        };
        self.total.set_message(format!("{done}/{}", self.count));
        self.log(&format!("[{done}/{}] {line}", self.count));
    }

    /// A line on stderr (above the bars when drawing them).
    pub fn log(&self, line: &str) {
        match self.mode {
            ProgressMode::Silent => {}
            _ if self.bars => {
                let _ = self.multi.println(line);
            }
            _ => eprintln!("{line}"),
        }
    }

    /// Removes the bars.
    pub fn finish(&self) {
        self.total.finish_and_clear();
        let _ = self.multi.clear();
    }
}

struct StageBar {
    name: String,
    bar: Option<ProgressBar>,
    state: Arc<Mutex<Totals>>,
    total: ProgressBar,
}

impl ProgressSink for StageBar {
    fn progress(&self, fraction: f64, message: &str) {
        if let Some(b) = &self.bar {
            b.set_position((fraction * 1000.0) as u64);
            if !message.is_empty() {
                b.set_message(format!("{}: {message}", self.name));
            }
        }
        if let Ok(mut s) = self.state.lock()
            && let Some(r) = s.running.iter_mut().find(|(n, _, _)| *n == self.name)
        {
            r.2 = fraction;
        }
        Progress::update_total(&self.state, &self.total);
    }
}

impl Drop for StageBar {
    fn drop(&mut self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}
