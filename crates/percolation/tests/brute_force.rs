//! Property tests of the union–find labelling against brute-force oracles:
//! - clusters: breadth-first flood fill over all neighbours on the torus;
//! - wrapping: flood fill on a k-fold periodic cover of the mask along one axis (k a prime larger
//!   than any winding a cluster of the mask can have, 2N + 1): a cluster wraps along x iff, in the
//!   cover, the copy of one of its nodes in tile 0 is connected to its copy in tile 1;
//! - full winding (rank and direction, hence "cuts"): breadth-first spanning tree with image
//!   offsets, every non-tree edge's closed-path winding collected.

use ndarray::Array2;
use percolation::{Axis, Connectivity, NO_CLUSTER, Winding, contact_area, dual_percolation, label};
use proptest::prelude::*;
use std::collections::VecDeque;

fn steps(conn: Connectivity) -> Vec<(isize, isize)> {
    let mut s = vec![(1, 0), (-1, 0), (0, 1), (0, -1)];
    if conn == Connectivity::Eight {
        s.extend([(1, 1), (1, -1), (-1, 1), (-1, -1)]);
    }
    s
}

/// Flood fill on the torus: cluster index per node (None for false) and cluster sizes.
fn flood_fill(m: &Array2<bool>, conn: Connectivity) -> (Array2<Option<usize>>, Vec<usize>) {
    let (nx, ny) = m.dim();
    let mut lab = Array2::from_elem((nx, ny), None);
    let mut sizes = Vec::new();
    for i0 in 0..nx {
        for j0 in 0..ny {
            if !m[[i0, j0]] || lab[[i0, j0]].is_some() {
                continue;
            }
            let id = sizes.len();
            let mut size = 0;
            let mut q = VecDeque::from([(i0, j0)]);
            lab[[i0, j0]] = Some(id);
            while let Some((i, j)) = q.pop_front() {
                size += 1;
                for (dx, dy) in steps(conn) {
                    let u = (
                        (i as isize + dx).rem_euclid(nx as isize) as usize,
                        (j as isize + dy).rem_euclid(ny as isize) as usize,
                    );
                    if m[u] && lab[u].is_none() {
                        lab[u] = Some(id);
                        q.push_back(u);
                    }
                }
            }
            sizes.push(size);
        }
    }
    (lab, sizes)
}

fn next_prime_above(n: usize) -> usize {
    let mut k = n + 1;
    loop {
        if k >= 2
            && (2..)
                .take_while(|d| d * d <= k)
                .all(|d| !k.is_multiple_of(d))
        {
            return k;
        }
        k += 1;
    }
}

/// Does the cluster through `(i0, j0)` wrap along `axis`? Flood fill on the k-fold cover.
fn cover_wraps(m: &Array2<bool>, conn: Connectivity, i0: usize, j0: usize, axis: Axis) -> bool {
    let (nx, ny) = m.dim();
    let k = next_prime_above(2 * nx * ny + 1);
    let (cx, cy) = match axis {
        Axis::X => (k * nx, ny),
        Axis::Y => (nx, k * ny),
    };
    let mut seen = Array2::from_elem((cx, cy), false);
    let mut q = VecDeque::from([(i0, j0)]);
    seen[[i0, j0]] = true;
    while let Some((i, j)) = q.pop_front() {
        for (dx, dy) in steps(conn) {
            let u = (
                (i as isize + dx).rem_euclid(cx as isize) as usize,
                (j as isize + dy).rem_euclid(cy as isize) as usize,
            );
            if m[[u.0 % nx, u.1 % ny]] && !seen[u] {
                seen[u] = true;
                q.push_back(u);
            }
        }
    }
    match axis {
        Axis::X => seen[[i0 + nx, j0]],
        Axis::Y => seen[[i0, j0 + ny]],
    }
}

/// Winding content of the cluster through `(i0, j0)`: BFS tree with images, all edges checked.
fn bfs_winding(m: &Array2<bool>, conn: Connectivity, i0: usize, j0: usize) -> Winding {
    let (nx, ny) = m.dim();
    let mut img: Array2<Option<(i64, i64)>> = Array2::from_elem((nx, ny), None);
    img[[i0, j0]] = Some((0, 0));
    let mut q = VecDeque::from([(i0, j0)]);
    let mut w = Winding::None;
    while let Some((i, j)) = q.pop_front() {
        let (ai, aj) = img[[i, j]].unwrap();
        for (dx, dy) in steps(conn) {
            let (ti, tj) = (i as isize + dx, j as isize + dy);
            let u = (
                ti.rem_euclid(nx as isize) as usize,
                tj.rem_euclid(ny as isize) as usize,
            );
            if !m[u] {
                continue;
            }
            let lift = (
                ai + ti.div_euclid(nx as isize) as i64,
                aj + tj.div_euclid(ny as isize) as i64,
            );
            match img[u] {
                None => {
                    img[u] = Some(lift);
                    q.push_back(u);
                }
                Some(b) => w = w.with(lift.0 - b.0, lift.1 - b.1),
            }
        }
    }
    w
}

fn check_against_oracles(m: &Array2<bool>, conn: Connectivity) -> Result<(), TestCaseError> {
    let (nx, ny) = m.dim();
    let l = label(m.view(), conn);
    let (bl, bsizes) = flood_fill(m, conn);
    prop_assert_eq!(l.len(), bsizes.len());
    // Labels agree up to renaming: build the map brute → fast and check it is a bijection.
    let mut map = vec![None; bsizes.len()];
    let mut first_node = vec![(0, 0); l.len()];
    for i in 0..nx {
        for j in 0..ny {
            match bl[[i, j]] {
                None => prop_assert_eq!(l.labels[[i, j]], NO_CLUSTER),
                Some(b) => {
                    let f = l.labels[[i, j]];
                    prop_assert!(f != NO_CLUSTER);
                    match map[b] {
                        None => {
                            map[b] = Some(f);
                            first_node[f as usize] = (i, j);
                        }
                        Some(g) => prop_assert_eq!(g, f),
                    }
                }
            }
        }
    }
    let mut targets: Vec<u32> = map.iter().map(|x| x.unwrap()).collect();
    for (b, &f) in targets.iter().enumerate() {
        prop_assert_eq!(l.clusters[f as usize].size, bsizes[b]);
    }
    targets.sort_unstable();
    targets.dedup();
    prop_assert_eq!(targets.len(), l.len());
    // Wrapping against the cover, full winding against the BFS tree.
    for (f, c) in l.clusters.iter().enumerate() {
        let (i0, j0) = first_node[f];
        prop_assert_eq!(
            c.wraps_x,
            cover_wraps(m, conn, i0, j0, Axis::X),
            "x, cluster {}",
            f
        );
        prop_assert_eq!(
            c.wraps_y,
            cover_wraps(m, conn, i0, j0, Axis::Y),
            "y, cluster {}",
            f
        );
        prop_assert_eq!(c.winding, bfs_winding(m, conn, i0, j0));
    }
    Ok(())
}

fn check_dual(m: &Array2<bool>) -> Result<(), TestCaseError> {
    let d = dual_percolation(m.view());
    for axis in [Axis::X, Axis::Y] {
        // Exactly one: fluid flows along the axis, or contact blocks it.
        prop_assert!(
            d.fluid_percolates(axis) != d.contact_blocks(axis),
            "{:?}",
            axis
        );
        // Roles swapped.
        prop_assert!(
            d.contact_summary.wraps(axis) != d.fluid_summary.cuts(axis),
            "{:?}",
            axis
        );
    }
    let a = contact_area(m.view());
    prop_assert_eq!(a.n_contact, d.contact_summary.n_nodes);
    prop_assert_eq!(a.n_contact + d.fluid_summary.n_nodes, a.n_nodes);
    Ok(())
}

fn random_mask() -> impl Strategy<Value = Array2<bool>> {
    (1usize..10, 1usize..10, 0.15f64..0.85).prop_flat_map(|(nx, ny, p)| {
        proptest::collection::vec(proptest::bool::weighted(p), nx * ny)
            .prop_map(move |v| Array2::from_shape_vec((nx, ny), v).unwrap())
    })
}

/// Thick straight stripes of winding (p, q) at a random offset: they wrap only through the seams.
fn stripe_mask() -> impl Strategy<Value = Array2<bool>> {
    (
        2usize..12,
        2usize..12,
        -2i32..3,
        -2i32..3,
        0.0f64..1.0,
        0.2f64..1.5,
    )
        .prop_map(|(nx, ny, p, q, off, width)| {
            let (p, q) = if p == 0 && q == 0 { (1, 0) } else { (p, q) };
            let (dx, dy) = (p as f64 * nx as f64, q as f64 * ny as f64);
            let norm = dx.hypot(dy);
            Array2::from_shape_fn((nx, ny), |(i, j)| {
                let mut best = f64::INFINITY;
                for a in -3..=3 {
                    for b in -3..=3 {
                        let x = i as f64 + (a * nx as i32) as f64 - off * nx as f64;
                        let y = j as f64 + (b * ny as i32) as f64;
                        best = best.min((x * dy - y * dx).abs() / norm);
                    }
                }
                best <= width
            })
        })
}

/// Drifting random walks on the torus (spiral-like paths that cross the seams many times).
fn walk_mask() -> impl Strategy<Value = Array2<bool>> {
    (
        3usize..12,
        3usize..12,
        proptest::collection::vec(0u8..8, 5..80),
        0usize..144,
    )
        .prop_map(|(nx, ny, moves, start)| {
            let mut m = Array2::from_elem((nx, ny), false);
            let (mut i, mut j) = (start % nx, (start / nx) % ny);
            m[[i, j]] = true;
            for mv in moves {
                // Biased toward +x, +y so that walks tend to wind.
                let (dx, dy): (isize, isize) = match mv {
                    0 | 1 => (1, 0),
                    2 | 3 => (0, 1),
                    4 => (-1, 0),
                    5 => (0, -1),
                    6 => (1, 1),
                    _ => (1, -1),
                };
                i = (i as isize + dx).rem_euclid(nx as isize) as usize;
                j = (j as isize + dy).rem_euclid(ny as isize) as usize;
                m[[i, j]] = true;
            }
            m
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn random_masks_match_flood_fill(m in random_mask()) {
        check_against_oracles(&m, Connectivity::Four)?;
        check_against_oracles(&m, Connectivity::Eight)?;
        check_dual(&m)?;
    }

    #[test]
    fn stripes_match_flood_fill(m in stripe_mask()) {
        check_against_oracles(&m, Connectivity::Four)?;
        check_against_oracles(&m, Connectivity::Eight)?;
        check_dual(&m)?;
        let fluid = m.mapv(|b| !b);
        check_against_oracles(&fluid, Connectivity::Four)?;
        check_against_oracles(&fluid, Connectivity::Eight)?;
    }

    #[test]
    fn walks_match_flood_fill(m in walk_mask()) {
        check_against_oracles(&m, Connectivity::Four)?;
        check_against_oracles(&m, Connectivity::Eight)?;
        check_dual(&m)?;
    }

    #[test]
    fn transposition_swaps_axes(m in random_mask()) {
        let t = m.t().to_owned();
        for conn in [Connectivity::Four, Connectivity::Eight] {
            let a = label(m.view(), conn);
            let b = label(t.view(), conn);
            prop_assert_eq!(a.len(), b.len());
            prop_assert_eq!(a.percolates(Axis::X), b.percolates(Axis::Y));
            prop_assert_eq!(a.percolates(Axis::Y), b.percolates(Axis::X));
            prop_assert_eq!(a.cuts(Axis::X), b.cuts(Axis::Y));
        }
    }
}

#[test]
fn seam_cases_by_hand() {
    // A band crossing the x seam (columns nx-1 and 0), along y: wraps y only.
    let (nx, ny) = (7, 5);
    let m = Array2::from_shape_fn((nx, ny), |(i, _)| i == 0 || i == nx - 1);
    let l = label(m.view(), Connectivity::Four);
    assert_eq!(l.len(), 1);
    assert_eq!(l.clusters[0].winding, Winding::Line { p: 0, q: 1 });
    // A spiral-like staircase of winding (1, 2) on an 8 x 8 grid, 4-connected: column x holds
    // y = 2x, 2x + 1, 2x + 2, and the step to column x + 1 is at y = 2x + 2.
    let mut m = Array2::from_elem((8, 8), false);
    for x in 0..8 {
        for dy in 0..3 {
            m[[x, (2 * x + dy) % 8]] = true;
        }
    }
    let l = label(m.view(), Connectivity::Four);
    assert_eq!(l.len(), 1);
    assert_eq!(l.clusters[0].winding, Winding::Line { p: 1, q: 2 });
    assert!(l.clusters[0].wraps_x && l.clusters[0].wraps_y);
    assert!(!l.clusters[0].cuts(Axis::X) && !l.clusters[0].cuts(Axis::Y));
    let d = dual_percolation(m.view());
    assert!(d.fluid_percolates(Axis::X) && d.fluid_percolates(Axis::Y));
}

#[test]
fn large_grid_is_linear_time() {
    // 1024 x 1024 at the 4-connected site threshold (p ≈ 0.5927), a cheap LCG for the mask.
    let (nx, ny) = (1024, 1024);
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    let m = Array2::from_shape_fn((nx, ny), |_| {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((s >> 11) as f64 / (1u64 << 53) as f64) < 0.5927
    });
    let t = std::time::Instant::now();
    let l = label(m.view(), Connectivity::Four);
    let d = dual_percolation(m.view());
    let dt = t.elapsed().as_secs_f64();
    eprintln!(
        "1024^2: label + dual labelling in {dt:.3} s, {} clusters",
        l.len()
    );
    let total: usize = l.clusters.iter().map(|c| c.size).sum();
    assert_eq!(total, m.iter().filter(|&&b| b).count());
    for axis in [Axis::X, Axis::Y] {
        assert!(d.fluid_percolates(axis) != d.contact_blocks(axis));
    }
    assert!(dt < 5.0, "labelling took {dt} s");
}
