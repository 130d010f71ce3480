//! percolation
