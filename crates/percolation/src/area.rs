//! Relative contact area, raw and perimeter-corrected.

use ndarray::ArrayView2;

/// The perimeter correction constant `c = (π − 1 + ln 2)/24 ≈ 0.118` of Yastrebov, Anciaux and
/// Molinari (Tribol. Int. 2017): counting contact nodes overestimates the true area by about
/// `c` node areas per grid face on the contact boundary.
pub const PERIMETER_CORRECTION: f64 = (std::f64::consts::PI - 1.0 + std::f64::consts::LN_2) / 24.0;

/// Contact area of a periodic contact mask.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactArea {
    /// Number of grid nodes N = nx·ny.
    pub n_nodes: usize,
    /// Number of contact nodes.
    pub n_contact: usize,
    /// Number of grid faces between a contact and a non-contact node (periodic; on a 2-wide
    /// grid the two faces between the same pair of nodes both count).
    pub n_perimeter_edges: usize,
    /// `n_contact / n_nodes`.
    pub raw: f64,
    /// `(n_contact − c · n_perimeter_edges) / n_nodes` with `c` = [`PERIMETER_CORRECTION`].
    pub corrected: f64,
}

/// Raw and perimeter-corrected relative contact area of a periodic mask (`true` = contact).
/// An empty mask gives NaN areas.
pub fn contact_area(contact: ArrayView2<bool>) -> ContactArea {
    let (nx, ny) = contact.dim();
    let mut n_contact = 0usize;
    let mut n_edges = 0usize;
    for i in 0..nx {
        let ip = (i + 1) % nx;
        for j in 0..ny {
            let jp = (j + 1) % ny;
            let c = contact[[i, j]];
            n_contact += c as usize;
            n_edges += (c != contact[[ip, j]]) as usize;
            n_edges += (c != contact[[i, jp]]) as usize;
        }
    }
    let n = (nx * ny) as f64;
    ContactArea {
        n_nodes: nx * ny,
        n_contact,
        n_perimeter_edges: n_edges,
        raw: n_contact as f64 / n,
        corrected: (n_contact as f64 - PERIMETER_CORRECTION * n_edges as f64) / n,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array2;

    #[test]
    fn counts() {
        assert!((PERIMETER_CORRECTION - 0.118_114_159_6).abs() < 1e-9);
        let mut m = Array2::from_elem((8, 8), false);
        let a = contact_area(m.view());
        assert_eq!(
            (a.n_contact, a.n_perimeter_edges, a.raw, a.corrected),
            (0, 0, 0.0, 0.0)
        );
        m[[0, 0]] = true; // on the corner: its faces cross the seams
        let a = contact_area(m.view());
        assert_eq!((a.n_contact, a.n_perimeter_edges), (1, 4));
        assert!((a.corrected - (1.0 - 4.0 * PERIMETER_CORRECTION) / 64.0).abs() < 1e-15);
        // A band along x, 2 rows: 2 faces per column.
        let mut m = Array2::from_elem((8, 8), false);
        for i in 0..8 {
            m[[i, 3]] = true;
            m[[i, 4]] = true;
        }
        let a = contact_area(m.view());
        assert_eq!((a.n_contact, a.n_perimeter_edges), (16, 16));
        let full = Array2::from_elem((4, 4), true);
        let a = contact_area(full.view());
        assert_eq!((a.raw, a.corrected, a.n_perimeter_edges), (1.0, 1.0, 0));
        // Two-wide periodic grid: the pair (0, j), (1, j) shares two faces.
        let m = Array2::from_shape_fn((2, 1), |(i, _)| i == 0);
        assert_eq!(contact_area(m.view()).n_perimeter_edges, 2);
        assert!(
            contact_area(Array2::<bool>::from_elem((0, 3), true).view())
                .raw
                .is_nan()
        );
    }
}
