//! Renders every scene from synthetic data: `cargo run -p figures --example gallery -- DIR`.
use std::path::PathBuf;
use std::time::Instant;

use figures::{demo, scenes};

fn main() -> anyhow::Result<()> {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "/tmp/figures-gallery".into()),
    );
    let timed = |name: &str, f: &dyn Fn() -> anyhow::Result<Vec<PathBuf>>| -> anyhow::Result<()> {
        let t = Instant::now();
        let paths = f()?;
        eprintln!(
            "{name}: {:.2} s → {}",
            t.elapsed().as_secs_f64(),
            paths[0].display()
        );
        Ok(())
    };
    timed("fig1", &|| {
        scenes::maps::render_fig1(&demo::fig1(256), &dir.join("fig1"))
    })?;
    timed("fig2", &|| {
        scenes::fig2::render(&demo::fig2(), &dir.join("fig2"))
    })?;
    timed("fig2-log", &|| {
        let mut d = demo::fig2();
        d.log_area = true;
        scenes::fig2::render(&d, &dir.join("fig2-log"))
    })?;
    timed("fig3", &|| {
        scenes::fig3::render(&demo::fig3(), &dir.join("fig3"))
    })?;
    timed("fig4", &|| {
        scenes::maps::render_fig4(&demo::fig4(256), &dir.join("fig4"))
    })?;
    timed("fig5", &|| {
        scenes::fig5::render(&demo::fig5(), &dir.join("fig5"))
    })?;
    timed("fig6", &|| {
        scenes::fig6::render(&demo::fig6(256), &dir.join("fig6"))
    })?;
    timed("convergence", &|| {
        scenes::convergence::render(&demo::convergence(), &dir.join("convergence"))
    })?;
    timed("tradeoff", &|| {
        scenes::tradeoff::render(&demo::tradeoff(), &dir.join("tradeoff"))
    })?;
    Ok(())
}
