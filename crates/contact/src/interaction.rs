//! Interactions between the surfaces, always on top of the hard wall g ≥ 0 (PHYSICS.md).
//!
//! Each interaction is a surface energy density γ(g) per unit area (units E* h0²/λ); its
//! derivative dγ/dg is a pressure. Attraction lowers γ as the gap closes (dγ/dg > 0).

use crate::ContactError;

/// Interaction law between the surfaces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Interaction {
    /// Hard-wall repulsion only: g ≥ 0.
    HardWall,
    /// Exponential adhesion γ(g) = −γ0 exp(−g/ρ), plus the hard wall.
    Adhesion {
        /// Surface energy γ0 ≥ 0 (E* h0²/λ).
        gamma0: f64,
        /// Range ρ > 0 (h0).
        rho: f64,
    },
    /// Gaussian repulsion γ(g) = +γr exp(−g²/2ρ²), plus the hard wall: zero force at contact, a
    /// barrier of height γr/ρ·e^(−1/2) (pressure) at g = ρ.
    Repulsion {
        /// Barrier energy γr ≥ 0 (E* h0²/λ).
        gamma_r: f64,
        /// Range ρ > 0 (h0).
        rho: f64,
    },
}

impl Interaction {
    /// Checks the parameters: finite, γ ≥ 0, ρ > 0.
    pub fn validate(&self) -> Result<(), ContactError> {
        let (name, gamma, rho) = match *self {
            Interaction::HardWall => return Ok(()),
            Interaction::Adhesion { gamma0, rho } => ("gamma0", gamma0, rho),
            Interaction::Repulsion { gamma_r, rho } => ("gamma_r", gamma_r, rho),
        };
        if !(gamma.is_finite() && gamma >= 0.0) {
            return Err(ContactError::parameter(
                name,
                gamma,
                "finite and ≥ 0 (E* h0²/λ)",
            ));
        }
        if !(rho.is_finite() && rho > 0.0) {
            return Err(ContactError::parameter("rho", rho, "finite and > 0 (h0)"));
        }
        Ok(())
    }

    /// Short name used in files and on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            Interaction::HardWall => "hardwall",
            Interaction::Adhesion { .. } => "adhesion",
            Interaction::Repulsion { .. } => "repulsion",
        }
    }

    /// True when there is no finite-range part (the problem is convex).
    pub fn is_hard_wall(&self) -> bool {
        match *self {
            Interaction::HardWall => true,
            Interaction::Adhesion { gamma0, .. } => gamma0 == 0.0,
            Interaction::Repulsion { gamma_r, .. } => gamma_r == 0.0,
        }
    }

    /// Range ρ (0 for the hard wall).
    pub fn range(&self) -> f64 {
        match *self {
            Interaction::HardWall => 0.0,
            Interaction::Adhesion { rho, .. } | Interaction::Repulsion { rho, .. } => rho,
        }
    }

    /// Cohesive-zone length ρ² E*/γ (λ), the length a grid must resolve; None without a
    /// finite-range part.
    pub fn cohesive_zone_length(&self, e_star: f64) -> Option<f64> {
        match *self {
            Interaction::HardWall => None,
            Interaction::Adhesion { gamma0: g, rho }
            | Interaction::Repulsion { gamma_r: g, rho } => {
                (g > 0.0).then(|| rho * rho * e_star / g)
            }
        }
    }

    /// Energy density γ(g).
    #[inline]
    pub fn energy(&self, g: f64) -> f64 {
        match *self {
            Interaction::HardWall => 0.0,
            Interaction::Adhesion { gamma0, rho } => -gamma0 * (-g / rho).exp(),
            Interaction::Repulsion { gamma_r, rho } => gamma_r * (-0.5 * g * g / (rho * rho)).exp(),
        }
    }

    /// dγ/dg (a pressure; > 0 attracts).
    #[inline]
    pub fn derivative(&self, g: f64) -> f64 {
        match *self {
            Interaction::HardWall => 0.0,
            Interaction::Adhesion { gamma0, rho } => gamma0 / rho * (-g / rho).exp(),
            Interaction::Repulsion { gamma_r, rho } => {
                let r2 = rho * rho;
                -gamma_r * g / r2 * (-0.5 * g * g / r2).exp()
            }
        }
    }

    /// Largest |d²γ/dg²| over g ≥ 0: the stiffest the interaction gets.
    pub fn max_curvature(&self) -> f64 {
        match *self {
            Interaction::HardWall => 0.0,
            Interaction::Adhesion { gamma0, rho } => gamma0 / (rho * rho),
            Interaction::Repulsion { gamma_r, rho } => gamma_r / (rho * rho),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_match_finite_differences() {
        let laws = [
            Interaction::Adhesion {
                gamma0: 0.2,
                rho: 0.04,
            },
            Interaction::Repulsion {
                gamma_r: 0.2,
                rho: 0.04,
            },
        ];
        for law in laws {
            for &g in &[0.0, 0.01, 0.04, 0.1] {
                let e = 1e-7;
                let fd =
                    (law.energy(g + e) - law.energy((g - e).max(0.0))) / (g + e - (g - e).max(0.0));
                assert!(
                    (law.derivative(g) - fd).abs() < 1e-4 * law.max_curvature(),
                    "{law:?} g={g}"
                );
            }
        }
        // Repulsion pushes apart away from contact and not at contact; adhesion attracts.
        let rep = laws[1];
        assert_eq!(rep.derivative(0.0), 0.0);
        assert!(rep.derivative(0.04) < 0.0);
        assert!(laws[0].derivative(0.04) > 0.0);
    }

    #[test]
    fn bad_parameters_are_rejected_with_the_allowed_range() {
        let e = Interaction::Adhesion {
            gamma0: 0.2,
            rho: 0.0,
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("rho") && e.contains("> 0"), "{e}");
        let e = Interaction::Adhesion {
            gamma0: -1.0,
            rho: 0.1,
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("gamma0") && e.contains("-1"), "{e}");
        assert!(
            Interaction::Repulsion {
                gamma_r: f64::NAN,
                rho: 0.1
            }
            .validate()
            .is_err()
        );
        assert!(
            Interaction::Adhesion {
                gamma0: 0.0,
                rho: 0.1
            }
            .is_hard_wall()
        );
    }

    #[test]
    fn cohesive_zone_of_the_defaults() {
        let l = Interaction::Adhesion {
            gamma0: 0.2,
            rho: 0.04,
        }
        .cohesive_zone_length(1.0)
        .unwrap();
        assert!((l - 0.008).abs() < 1e-15);
    }
}
