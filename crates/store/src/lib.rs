//! store: HDF5 artefacts with provenance, atomic publication, canonical hashing.
//!
//! - [`ArtefactWriter`] writes an HDF5 file to a temporary path and [`publish`]es it atomically
//!   (complete mark, fsync, rename, fsync of the folder); dropping it unpublished removes the
//!   temporary file.
//! - [`ArtefactReader`] opens any HDF5 file; [`ArtefactReader::is_valid`] tells a published,
//!   complete artefact from a missing, truncated, unreadable or unfinished one, silently.
//! - [`digest`]: a BLAKE3 digest over every dataset and attribute, stored at publication;
//!   [`digest::check`] tells a valid cache entry (complete, expected key, matching content) from
//!   a missing, invalid or damaged one.
//! - [`Provenance`] is written on every pipeline artefact and read back.
//! - [`clock`] counts the time this process spends hashing (publication, verification, files).
//! - [`canonical`] renders JSON canonically and hashes it with BLAKE3 (cache keys).
//! - [`fsutil`] publishes plain files (figures, CSV) atomically too.
//!
//! ```no_run
//! use store::{ArtefactWriter, ArtefactReader, Provenance, fields};
//! let mut w = ArtefactWriter::create("results/demo.h5")?;
//! w.set_cell(1.0, 1.0)?;
//! w.write_f64_2d(fields::GAP, ndarray::Array2::<f64>::zeros((8, 8)).view())?;
//! w.write_provenance(&Provenance::for_command("demo", 1, serde_json::json!({"n": 3}))?)?;
//! let path = w.publish()?;
//! assert!(ArtefactReader::is_valid(&path));
//! # anyhow::Ok(())
//! ```
//!
//! [`publish`]: ArtefactWriter::publish

pub mod artefact;
pub mod canonical;
pub mod clock;
pub mod digest;
pub use fsutil;
pub mod provenance;

pub use artefact::{
    ArtefactReader, ArtefactWriter, AttrValue, COMPLETE_ATTR, fields, silence_hdf5,
};
pub use canonical::{canonical_json, hash_bytes, hash_json, is_key};
pub use clock::HashStats;
pub use digest::{CONTENT_ATTR, Integrity, content_digest};
pub use provenance::{PROVENANCE_GROUP, Provenance, SADDLEFLOW_VERSION, SideOutput};
