//! Every scene renders from small synthetic data to a PNG and an SVG that are complete,
//! decodable, of the expected size, not blank, and carry their labels.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use figures::scenes::{convergence, fig2, fig3, fig5, fig6, maps, tradeoff};
use figures::{Figure, demo};
use ndarray::Array2;

struct Checked {
    png: image::RgbImage,
    svg: String,
}

/// Checks the two files of one render and returns their contents.
fn check(paths: &[PathBuf], stem: &Path, fig: &Figure) -> Checked {
    assert_eq!(paths.len(), 2);
    assert_eq!(paths[0], stem.with_extension("png"));
    assert_eq!(paths[1], stem.with_extension("svg"));
    for p in paths {
        let meta = std::fs::metadata(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        assert!(meta.len() > 1000, "{} is too small", p.display());
    }
    let png = image::open(&paths[0]).expect("PNG decodes").to_rgb8();
    assert_eq!(png.dimensions(), fig.png_size());
    let colours: HashSet<[u8; 3]> = png.pixels().map(|p| p.0).collect();
    assert!(
        colours.len() > 50,
        "{}: only {} distinct colours",
        paths[0].display(),
        colours.len()
    );
    // mostly white background around the plot, but not blank
    let white = png.pixels().filter(|p| p.0 == [255, 255, 255]).count();
    assert!(white < png.pixels().len() * 98 / 100);
    let svg = std::fs::read_to_string(&paths[1]).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    // plotters writes each text on its own line after the tag
    let svg = svg.replace(">\n", ">");
    // no temporary files left next to the outputs
    for e in std::fs::read_dir(stem.parent().unwrap()).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.ends_with(".tmp"), "left-over temporary file {name}");
    }
    Checked { png, svg }
}

fn contains_all(svg: &str, texts: &[&str]) {
    for t in texts {
        assert!(svg.contains(t), "SVG lacks {t:?}");
    }
}

#[test]
fn fig2_renders_with_labels_and_legend() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("fig2");
    let data = demo::fig2();
    let fig = fig2::figure(&data).unwrap();
    let paths = fig2::render(&data, &stem).unwrap();
    let c = check(&paths, &stem, &fig);
    contains_all(
        &c.svg,
        &[
            "mean pressure",
            "relative contact area",
            ">loading",
            ">unloading",
            ">hard wall",
            ">Gaussian repulsion",
            ">jump",
            "DejaVu Sans",
        ],
    );
    // both branch colours appear in the raster
    let has = |rgb: [u8; 3]| c.png.pixels().any(|p| p.0 == rgb);
    let red = figures::style::RED;
    let blue = figures::style::BLUE;
    assert!(has([red.0, red.1, red.2]), "no loading red");
    assert!(has([blue.0, blue.1, blue.2]), "no unloading blue");
}

#[test]
fn fig2_log_area_variant_renders() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("fig2-log");
    let mut data = demo::fig2();
    data.log_area = true;
    data.pressure_range = Some((-1.0, 3.0));
    let fig = fig2::figure(&data).unwrap();
    let c = check(&fig2::render(&data, &stem).unwrap(), &stem, &fig);
    contains_all(&c.svg, &["relative contact area", ">10"]);
}

#[test]
fn fig2_rejects_ragged_data_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mut data = demo::fig2();
    data.adhesion.loading.area.pop();
    let err = fig2::render(&data, &dir.path().join("fig2")).unwrap_err();
    assert!(format!("{err:#}").contains("adhesion loading"), "{err:#}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn rerender_replaces_files_atomically() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("sub/dir/fig2");
    let data = demo::fig2();
    let first = fig2::render(&data, &stem).unwrap();
    let before = std::fs::read(&first[1]).unwrap();
    let mut changed = data.clone();
    changed.adhesion_label = "something else".into();
    fig2::render(&changed, &stem).unwrap();
    let after = std::fs::read_to_string(&first[1]).unwrap();
    assert_ne!(before, after.as_bytes());
    assert!(after.contains("something else"));
    let names: Vec<_> = std::fs::read_dir(stem.parent().unwrap())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
}

#[test]
fn fig1_and_fig4_render_three_maps() {
    let dir = tempfile::tempdir().unwrap();
    for (name, data, cmap) in [
        ("fig1", demo::fig1(48), figures::Colormap::Inferno),
        ("fig4", demo::fig4(48), figures::Colormap::Viridis),
    ] {
        let stem = dir.path().join(name);
        let fig = maps::figure(&data, cmap).unwrap();
        let paths = if name == "fig1" {
            maps::render_fig1(&data, &stem).unwrap()
        } else {
            maps::render_fig4(&data, &stem).unwrap()
        };
        let c = check(&paths, &stem, &fig);
        contains_all(&c.svg, &[">Hexagonal", ">Square", ">Triangular"]);
        // the heat maps are embedded as images, not one element per pixel
        assert_eq!(c.svg.matches("<image").count(), 6, "3 maps + 3 colour bars");
        assert!(c.svg.len() < 3_000_000);
    }
}

#[test]
fn fig3_fig5_fig6_render() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("fig3");
    let d3 = demo::fig3();
    let c = check(
        &fig3::render(&d3, &stem).unwrap(),
        &stem,
        &fig3::figure(&d3).unwrap(),
    );
    contains_all(
        &c.svg,
        &[
            "surface energy",
            ">hexagonal",
            ">square",
            ">triangular",
            "increasing",
        ],
    );

    let stem = dir.path().join("fig5");
    let d5 = demo::fig5();
    let c = check(
        &fig5::render(&d5, &stem).unwrap(),
        &stem,
        &fig5::figure(&d5).unwrap(),
    );
    contains_all(&c.svg, &[">(a)", ">(b)", "distance / |", ">hexagonal"]);

    let stem = dir.path().join("fig6");
    let d6 = demo::fig6(40);
    let c = check(
        &fig6::render(&d6, &stem).unwrap(),
        &stem,
        &fig6::figure(&d6).unwrap(),
    );
    contains_all(
        &c.svg,
        &[">(a)", ">(b)", ">(c)", ">flux", "= 3.45 ± 0.05", ">square"],
    );
}

#[test]
fn convergence_and_tradeoff_render() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("conv");
    let d = demo::convergence();
    let c = check(
        &convergence::render(&d, &stem).unwrap(),
        &stem,
        &convergence::figure(&d).unwrap(),
    );
    contains_all(&c.svg, &["grid spacing", ">square", "paper: 0.40185(6)"]);

    let stem = dir.path().join("trade");
    let d = demo::tradeoff();
    let c = check(
        &tradeoff::render(&d, &stem).unwrap(),
        &stem,
        &tradeoff::figure(&d).unwrap(),
    );
    contains_all(
        &c.svg,
        &["wall time (s)", "relative error", ">target", "256²"],
    );
}

/// A heat map fills the canvas the right way round: x to the right, y upwards, masked nodes
/// in the mask colour.
#[test]
fn heatmap_orientation_and_mask() {
    use figures::{ColorbarPos, HeatmapPanel, Rect};
    let n = 16;
    let field = Array2::from_shape_fn((n, n), |(i, _)| i as f64);
    let mut h = HeatmapPanel::new(field, 1.0, 1.0);
    h.show_ticks = false;
    h.x_label.clear();
    h.y_label.clear();
    h.colorbar = ColorbarPos::None;
    let mut fy = h.clone();
    fy.field = Array2::from_shape_fn((n, n), |(_, j)| j as f64);
    let mut mask = Array2::from_elem((n, n), false);
    mask[[n / 2, n / 2]] = true;
    h.mask = Some(mask);
    let size = 200.0;
    for (panel, axis) in [(h, 'x'), (fy, 'y')] {
        let mut f = Figure::new(size, size);
        f.heatmap(Rect::new(0.0, 0.0, size, size), panel);
        let img = image::load_from_memory(&f.render_png().unwrap())
            .unwrap()
            .to_rgb8();
        let (w, hgt) = img.dimensions();
        let lum = |x: u32, y: u32| {
            let p = img.get_pixel(x, y).0;
            0.3 * p[0] as f64 + 0.6 * p[1] as f64 + 0.1 * p[2] as f64
        };
        match axis {
            // viridis: dark at low values, bright at high
            'x' => {
                assert!(lum(w / 10, hgt / 3) < lum(9 * w / 10, hgt / 3));
                // node (n/2, n/2) sits at the centre of the cell: masked white
                let centre = img.get_pixel(w / 2, hgt / 2).0;
                assert_eq!(centre, [255, 255, 255], "masked node not white");
            }
            _ => assert!(
                lum(w / 2, hgt / 10) > lum(w / 2, 9 * hgt / 10),
                "y does not point upwards"
            ),
        }
    }
}

/// Text is drawn with the embedded font (no system fonts needed): a text-only figure has
/// dark pixels.
#[test]
fn embedded_font_renders_text() {
    use figures::{Panel, Rect, TextOpts};
    let mut f = Figure::new(200.0, 60.0);
    f.panels.push((
        Rect::new(10.0, 10.0, 180.0, 40.0),
        Panel::Text(
            "$γ$_0 = 0.2, $L$_c − $L$".into(),
            TextOpts::new(20.0).align(figures::HAlign::Left, figures::VAlign::Top),
        ),
    ));
    let img = image::load_from_memory(&f.render_png().unwrap())
        .unwrap()
        .to_rgb8();
    let dark = img.pixels().filter(|p| p.0[0] < 100).count();
    assert!(dark > 200, "only {dark} dark pixels: text not rendered");
    let svg = f.render_svg().unwrap().replace(">\n", ">");
    assert!(svg.contains(">γ") && svg.contains("font-style=\"italic\""));
}
