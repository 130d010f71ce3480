//! reynolds
