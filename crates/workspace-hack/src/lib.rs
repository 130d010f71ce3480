//! Feature unification only (see Cargo.toml): no code. The binary depends on this crate so that
//! its build requests the features the test builds turn on through dev-dependencies.
