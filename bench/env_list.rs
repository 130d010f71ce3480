//! Shared by the solver benchmarks (`crates/*/benches`, included with `#[path]`): a
//! comma-separated list from an environment variable, or a default.

/// The values of `name` (comma-separated), or of `default` if unset; panics naming the variable
/// on a value that does not parse.
pub fn env_list<T: std::str::FromStr>(name: &str, default: &str) -> Vec<T> {
    std::env::var(name)
        .unwrap_or_else(|_| default.to_string())
        .split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| {
            s.trim()
                .parse()
                .unwrap_or_else(|_| panic!("{name}: cannot parse {s:?}"))
        })
        .collect()
}
