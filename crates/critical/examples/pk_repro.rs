//! Reproduction for the contact crate: Polonsky–Keer (aef36a7) stops after 2 iterations ("stagnation": line-search
//! denominator ≤ 0) from a warm start whose pressure interpolates two converged solutions.
use contact::{Interaction, Lattice, Method, Model, SolverOptions, Surface};
fn main() {
    let s = Surface::new(Lattice::Square, 6).unwrap();
    let mut m = Model::new(&s).unwrap();
    let o = SolverOptions {
        method: Method::PolonskyKeer,
        ..Default::default()
    };
    let (la, lb, lm) = (1.436834681907683, 1.4369476317293879, 1.4368911568185354);
    let a = m.solve(Interaction::HardWall, la, &o, None).unwrap();
    let b = m.solve(Interaction::HardWall, lb, &o, None).unwrap();
    println!(
        "a: {} contact {} | b: {} contact {}",
        a.stats.converged,
        a.contact_area * 4096.0,
        b.stats.converged,
        b.contact_area * 4096.0
    );
    let t = (lm - la) / (lb - la);
    let mut w = a.clone();
    w.pressure
        .zip_mut_with(&b.pressure, |p, q| *p += t * (q - *p));
    let c = m.solve(Interaction::HardWall, lm, &o, Some(&w)).unwrap();
    println!(
        "interp: conv {} it {} viol {:e} reason {:?}",
        c.stats.converged,
        c.stats.iterations,
        c.stats.max_violation,
        c.stats.reason.map(|r| format!("{r:?}"))
    );
    let c = m.solve(Interaction::HardWall, lm, &o, Some(&a)).unwrap();
    println!(
        "from a: conv {} it {} viol {:e}",
        c.stats.converged, c.stats.iterations, c.stats.max_violation
    );
    let c = m.solve(Interaction::HardWall, lm, &o, Some(&b)).unwrap();
    println!(
        "from b: conv {} it {} viol {:e}",
        c.stats.converged, c.stats.iterations, c.stats.max_violation
    );
    let c = m.solve(Interaction::HardWall, lm, &o, None).unwrap();
    println!(
        "cold: conv {} it {} viol {:e}",
        c.stats.converged, c.stats.iterations, c.stats.max_violation
    );
}
