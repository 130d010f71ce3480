//! `saddleflow surface generate | stats`: self-affine random surfaces to files, statistics of
//! any height file; and the `--surface FILE` input that `solve`, `leakage` and `critical` share.
//! Each command prints one JSON object on stdout.
//!
//! Files (the `formats` crate): `.h5`/`.hdf5` (dataset `height`, root attributes `lx`, `ly`, the
//! layout `solve --out` writes too), `.npy` (2-D float64/float32; the cell size is not stored,
//! give `--lx --ly` when reading it back), anything else as text (a height matrix, one line per x
//! index; or `x y z` columns with `--columns`). Errors name the file and what is wrong; a field
//! larger than `--max-nodes` is refused from its header with the memory it would need.

use crate::guard::Output;
use anyhow::{Context, Result, bail};
use formats::{Detrend, ReadOptions, Reading, TextLayout};
use serde_json::{Value, json};
use std::io::Write;
use std::path::{Path, PathBuf};
use store::{Provenance, fields};
use surface::{Amplitudes, HeightField, Normalisation, SelfAffine};

/// Version of what `surface generate` writes; bump when its results change.
const CODE_VERSION: u64 = 1;

/// Bins of the isotropic PSD in the statistics.
const PSD_BINS: usize = 24;

/// Bytes per node a contact solve needs at its peak (README: 9.1 f64 per node), rounded up.
const SOLVE_BYTES_PER_NODE: f64 = 80.0;

#[derive(clap::Subcommand)]
pub enum Command {
    /// Generate a self-affine Gaussian random surface (periodic, 2^n × 2^n) and write it.
    Generate(GenerateArgs),
    /// Statistics of a height file (moments, rms slope and curvature, Nayak, isotropic PSD).
    Stats(StatsArgs),
}

#[derive(clap::Args)]
pub struct GenerateArgs {
    /// Grid exponent: 2^n × 2^n nodes.
    #[arg(long)]
    n: u32,
    /// Hurst exponent H in (0, 1].
    #[arg(long)]
    hurst: f64,
    /// Roll-off wavenumber q_r in units of 2π/L (≥ 1).
    #[arg(long)]
    qr: f64,
    /// Short-wavelength cutoff q_s in units of 2π/L (q_r ≤ q_s ≤ 2^n / 2).
    #[arg(long)]
    qs: f64,
    /// rms height (units of the heights).
    #[arg(
        long,
        conflicts_with = "rms_slope",
        required_unless_present = "rms_slope"
    )]
    rms_height: Option<f64>,
    /// rms slope √⟨|∇h|²⟩.
    #[arg(long)]
    rms_slope: Option<f64>,
    /// Fourier amplitudes: exact (|H| = √C, random phases) or gaussian (filtered noise).
    #[arg(long, default_value = "exact")]
    amplitudes: String,
    /// Seed of the ChaCha8 stream.
    #[arg(long)]
    seed: u64,
    /// Cell side L (the cell is square).
    #[arg(long, default_value_t = 1.0)]
    length: f64,
    /// Output file: .h5 (with lx, ly and provenance), .npy, or text (.txt, a height matrix).
    #[arg(long)]
    out: PathBuf,
}

#[derive(clap::Args)]
pub struct StatsArgs {
    /// The height file.
    file: PathBuf,
    #[command(flatten)]
    read: ReadArgs,
}

/// How a height file is read (shared by every command that takes one).
#[derive(clap::Args, Clone, Debug)]
pub struct ReadArgs {
    /// Cell size along x (required for .npy and text matrices; replaces the HDF5 attribute).
    #[arg(long)]
    pub lx: Option<f64>,
    /// Cell size along y.
    #[arg(long)]
    pub ly: Option<f64>,
    /// Factor applied to the heights (a unit conversion), > 0.
    #[arg(long, default_value_t = 1.0)]
    pub height_scale: f64,
    /// Remove the mean (mean) or the least-squares plane (plane) before use; never done
    /// silently (what was removed is reported).
    #[arg(long, default_value = "none")]
    pub detrend: String,
    /// Text files hold `x y z` columns on a regular grid instead of a height matrix.
    #[arg(long)]
    pub columns: bool,
    /// Largest number of nodes accepted (default 2^26, the project's largest grid).
    #[arg(long, default_value_t = formats::DEFAULT_MAX_NODES)]
    pub max_nodes: usize,
}

impl ReadArgs {
    fn options(&self) -> Result<ReadOptions> {
        let cell = match (self.lx, self.ly) {
            (Some(lx), Some(ly)) => {
                for (name, v) in [("--lx", lx), ("--ly", ly)] {
                    if !(v.is_finite() && v > 0.0) {
                        bail!("{name} {v:?}: allowed a finite number > 0");
                    }
                }
                Some((lx, ly))
            }
            (None, None) => None,
            _ => bail!("--lx and --ly go together: give both or neither"),
        };
        let detrend: Detrend = self
            .detrend
            .parse()
            .map_err(|e| anyhow::anyhow!("--detrend {e}"))?;
        if self.max_nodes == 0 {
            bail!("--max-nodes 0: allowed an integer ≥ 1");
        }
        Ok(ReadOptions {
            cell,
            height_scale: self.height_scale,
            detrend,
            text_layout: TextLayout::of(self.columns),
            max_nodes: self.max_nodes,
        })
    }
}

/// Reads a height file for a command (`what` names the option, e.g. `--surface`).
pub fn read_surface(what: &str, path: &Path, args: &ReadArgs) -> Result<Reading> {
    let opts = args.options()?;
    let r = formats::read(path, &opts).with_context(|| what.to_string())?;
    if let Some(p) = r.removed {
        eprintln!(
            "note: {what} `{}`: detrended ({}): removed {:.6e} + {:.6e} x + {:.6e} y",
            path.display(),
            args.detrend,
            p.offset,
            p.slope_x,
            p.slope_y
        );
    }
    Ok(r)
}

/// Refuses a solve whose working memory exceeds what the machine has, naming the cost (called
/// after reading the heights, before the solver allocates).
pub fn check_solve_memory(what: &str, path: &Path, field: &HeightField) -> Result<()> {
    let nodes = field.grid.len() as f64;
    let need = nodes * SOLVE_BYTES_PER_NODE;
    if let Some(avail) = mem_available()
        && need > avail
    {
        bail!(
            "{what} `{}`: a contact solve on {} × {} nodes needs about {:.2} GiB ({} bytes \
                 per node), more than the {:.2} GiB available; crop or coarsen the field",
            path.display(),
            field.grid.nx,
            field.grid.ny,
            need / (1u64 << 30) as f64,
            SOLVE_BYTES_PER_NODE,
            avail / (1u64 << 30) as f64
        );
    }
    Ok(())
}

/// MemAvailable of /proc/meminfo in bytes (None where unknown).
fn mem_available() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = s.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024.0)
}

/// Summary of a field as JSON: moments, spectral statistics and the isotropic PSD.
pub fn field_json(f: &HeightField) -> Value {
    let st = f.statistics();
    let spectrum = f.spectrum();
    let sp = spectrum.statistics();
    let psd = spectrum.isotropic_psd(PSD_BINS);
    json!({
        "nx": f.grid.nx,
        "ny": f.grid.ny,
        "lx": f.grid.lx,
        "ly": f.grid.ly,
        "mean": st.mean,
        "min": st.min,
        "max": st.max,
        "rms_height": st.rms,
        "skewness": st.skewness,
        "excess_kurtosis": st.excess_kurtosis,
        "rms_slope": sp.rms_slope,
        "rms_curvature": sp.rms_curvature,
        "nayak": sp.nayak,
        "psd": {
            "q": psd.iter().map(|b| b.q).collect::<Vec<_>>(),
            "c": psd.iter().map(|b| b.c).collect::<Vec<_>>(),
            "count": psd.iter().map(|b| b.count).collect::<Vec<_>>(),
        },
    })
}

pub fn run(cmd: Command) -> Result<()> {
    match cmd {
        Command::Generate(a) => generate(a),
        Command::Stats(a) => stats(a),
    }
}

/// What kind of file an output path names.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Hdf5,
    Npy,
    Text,
}

fn kind(path: &Path) -> Kind {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("h5" | "hdf5") => Kind::Hdf5,
        Some("npy") => Kind::Npy,
        _ => Kind::Text,
    }
}

fn generate(a: GenerateArgs) -> Result<()> {
    let out = Output::check("--out", &a.out, &[])?;
    // Refuse a grid beyond the project's largest before anything is allocated, with its cost:
    // the heights (8 bytes) and the complex spectrum (16 bytes) per node.
    if !(surface::N_MIN..=surface::N_MAX).contains(&a.n) {
        let nodes = 2f64.powi(2 * a.n.min(40) as i32);
        bail!(
            "--n {}: allowed {}..={}; a 2^{} × 2^{} surface would need {:.2} GiB to generate \
             (24 bytes per node) and about {:.1} GiB to solve",
            a.n,
            surface::N_MIN,
            surface::N_MAX,
            a.n,
            a.n,
            nodes * 24.0 / (1u64 << 30) as f64,
            nodes * SOLVE_BYTES_PER_NODE / (1u64 << 30) as f64
        );
    }
    let amplitudes = match a.amplitudes.as_str() {
        "exact" => Amplitudes::Exact,
        "gaussian" => Amplitudes::Gaussian,
        other => bail!("--amplitudes {other:?}: allowed exact, gaussian"),
    };
    let normalisation = match (a.rms_height, a.rms_slope) {
        (Some(r), None) => Normalisation::RmsHeight(r),
        (None, Some(s)) => Normalisation::RmsSlope(s),
        _ => bail!("give exactly one of --rms-height and --rms-slope"),
    };
    let params = SelfAffine {
        n: a.n,
        length: a.length,
        hurst: a.hurst,
        q_r: a.qr,
        q_s: a.qs,
        normalisation,
        amplitudes,
        seed: a.seed,
    };
    params.validate().map_err(|e| {
        anyhow::anyhow!(
            "{}",
            e.to_string()
                .replace("q_r =", "--qr")
                .replace("q_s =", "--qs")
                .replace("hurst =", "--hurst")
                .replace("length =", "--length")
                .replace("rms =", "--rms-height/--rms-slope")
        )
    })?;
    let t0 = std::time::Instant::now();
    let field = params.generate()?;
    let mut summary = field_json(&field);
    let q0 = 2.0 * std::f64::consts::PI / a.length;
    let slope = surface::spectrum::psd_slope(
        &field.spectrum().isotropic_psd(PSD_BINS),
        a.qr * q0,
        a.qs * q0,
    );
    let obj = summary.as_object_mut().expect("object");
    obj.insert("psd_slope".into(), json!(slope));
    obj.insert("psd_slope_model".into(), json!(-2.0 * (1.0 + a.hurst)));
    let generator = json!({
        "n": a.n, "length": a.length, "hurst": a.hurst, "q_r": a.qr, "q_s": a.qs,
        "rms_height": a.rms_height, "rms_slope": a.rms_slope, "amplitudes": a.amplitudes,
        "seed": a.seed, "rng": "ChaCha8 (rand_chacha), seed_from_u64",
    });
    obj.insert("generator".into(), generator.clone());
    let written = write_field(&out, &a.out, &field, generator)?;
    obj.insert("out".into(), json!(written.display().to_string()));
    obj.insert("wall_s".into(), json!(t0.elapsed().as_secs_f64()));
    println!("{}", serde_json::to_string(&summary)?);
    Ok(())
}

/// Writes a field through the output rule: HDF5 as an artefact (height, lx, ly, provenance),
/// `.npy` and text to a temporary next to the output, renamed over it.
fn write_field(out: &Output, path: &Path, field: &HeightField, params: Value) -> Result<PathBuf> {
    match kind(path) {
        Kind::Hdf5 => {
            let mut prov = Provenance::for_command("surface generate", CODE_VERSION, params)?;
            prov.wall_s = 0.0;
            let mut w = out.create()?;
            w.set_cell(field.grid.lx, field.grid.ly)?;
            w.write_f64_2d(fields::HEIGHT, field.heights.view())?;
            w.write_provenance(&prov)?;
            out.publish(w)
        }
        k => {
            fsutil_check(path)?;
            let tmp = store::fsutil::temp_path_for(path)?;
            let written = (|| -> Result<()> {
                if k == Kind::Npy {
                    formats::npy::write(&tmp, field)?;
                } else {
                    write_text(&tmp, field)?;
                }
                store::fsutil::commit_rename(&tmp, path)
            })();
            if written.is_err() {
                store::fsutil::remove_temp(&tmp);
            }
            written.with_context(|| format!("--out `{}`", path.display()))?;
            Ok(path.to_path_buf())
        }
    }
}

fn fsutil_check(path: &Path) -> Result<()> {
    store::fsutil::check_output_path("--out", path, &[])
}

/// A height matrix, one line per x index, full precision (`{:e}` round-trips every double),
/// with the cell size in a comment line.
fn write_text(path: &Path, field: &HeightField) -> Result<()> {
    let f = std::fs::File::create(path)
        .with_context(|| format!("cannot create `{}`", path.display()))?;
    let mut w = std::io::BufWriter::new(f);
    writeln!(
        w,
        "# height matrix, {} lines (x) of {} values (y); cell lx = {:e}, ly = {:e}",
        field.grid.nx, field.grid.ny, field.grid.lx, field.grid.ly
    )?;
    let mut line = String::new();
    for row in field.heights.rows() {
        line.clear();
        for (k, v) in row.iter().enumerate() {
            if k > 0 {
                line.push(' ');
            }
            line.push_str(&format!("{v:e}"));
        }
        writeln!(w, "{line}")?;
    }
    w.flush()?;
    Ok(())
}

fn stats(a: StatsArgs) -> Result<()> {
    let r = read_surface("surface stats", &a.file, &a.read)?;
    let mut v = field_json(&r.field);
    let obj = v.as_object_mut().expect("object");
    obj.insert("file".into(), json!(a.file.display().to_string()));
    obj.insert(
        "detrended".into(),
        r.removed.map_or(Value::Null, |p| {
            json!({"how": a.read.detrend, "offset": p.offset, "slope_x": p.slope_x, "slope_y": p.slope_y})
        }),
    );
    println!("{}", serde_json::to_string(&v)?);
    Ok(())
}
