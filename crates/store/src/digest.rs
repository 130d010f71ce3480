//! Content digests of artefacts: what makes a cached file trustworthy.
//!
//! [`content_digest`] is a BLAKE3 hash over everything an artefact holds, in a fixed order:
//! groups depth-first with members sorted by name, and for every group and dataset its
//! attributes sorted by name. Each object contributes a tag, its path, its type and shape and
//! its values (numbers as little-endian bytes, strings as UTF-8); every variable part is
//! length-prefixed, so no two different contents encode alike. Two root attributes are left
//! out: the complete mark and the digest itself ([`CONTENT_ATTR`]), both written after it.
//!
//! [`crate::ArtefactWriter::publish`] stores the digest as the root attribute
//! [`CONTENT_ATTR`]; [`check`] re-reads the whole file and compares, and also compares the key
//! stored in the provenance with the key the file is expected to hold (its file name in the
//! cache). A byte flip inside a dataset, a truncated file, or another stage's artefact copied
//! under this name is thus caught before any value is used.
//!
//! Cost: one sequential read of the file plus BLAKE3 (several GB/s per core); the HDF5 read
//! dominates. Exact: any change of a value, name, shape or type changes the digest; the file's
//! layout bytes (B-trees, free space) are not hashed, as they do not carry results (HDF5's own
//! checks catch most damage there; the rest shows as a read error, which counts as invalid).

use crate::artefact::{ArtefactReader, COMPLETE_ATTR};
use crate::clock::{Purpose, Timer};
use anyhow::{Result, anyhow, bail};
use hdf5::types::{FloatSize, IntSize, TypeDescriptor, VarLenAscii, VarLenUnicode};
use std::path::Path;

/// Root attribute holding the content digest (64 hex digits).
pub const CONTENT_ATTR: &str = "content_blake3";

/// BLAKE3 and the number of bytes fed to it (for [`crate::clock`]).
struct Sink {
    h: blake3::Hasher,
    bytes: u64,
}

impl Sink {
    fn update(&mut self, b: &[u8]) {
        self.bytes += b.len() as u64;
        self.h.update(b);
    }
}

fn put(h: &mut Sink, bytes: &[u8]) {
    h.update(&(bytes.len() as u64).to_le_bytes());
    h.update(bytes);
}

fn le<T: Copy, const N: usize>(h: &mut Sink, v: &[T], f: impl Fn(T) -> [u8; N]) {
    h.update(&(v.len() as u64).to_le_bytes());
    for x in v {
        h.update(&f(*x));
    }
}

/// Hashes the type, shape and values of a dataset or attribute.
fn values(h: &mut Sink, c: &hdf5::Container, what: &str) -> Result<()> {
    let td = c.dtype()?.to_descriptor()?;
    put(h, td.to_string().as_bytes());
    let shape = c.shape();
    le(h, &shape, |n| (n as u64).to_le_bytes());
    match td {
        TypeDescriptor::Float(FloatSize::U8) => le(h, &c.read_raw::<f64>()?, f64::to_le_bytes),
        TypeDescriptor::Float(FloatSize::U4) => le(h, &c.read_raw::<f32>()?, f32::to_le_bytes),
        TypeDescriptor::Integer(IntSize::U8) => le(h, &c.read_raw::<i64>()?, i64::to_le_bytes),
        TypeDescriptor::Integer(IntSize::U4) => le(h, &c.read_raw::<i32>()?, i32::to_le_bytes),
        TypeDescriptor::Integer(IntSize::U1) => le(h, &c.read_raw::<i8>()?, i8::to_le_bytes),
        TypeDescriptor::Unsigned(IntSize::U8) => le(h, &c.read_raw::<u64>()?, u64::to_le_bytes),
        TypeDescriptor::Unsigned(IntSize::U4) => le(h, &c.read_raw::<u32>()?, u32::to_le_bytes),
        TypeDescriptor::Unsigned(IntSize::U1) => le(h, &c.read_raw::<u8>()?, u8::to_le_bytes),
        TypeDescriptor::Boolean | TypeDescriptor::Enum(_) => {
            le(h, &c.read_raw::<bool>()?, |b| [b as u8])
        }
        TypeDescriptor::VarLenUnicode => {
            for s in c.read_raw::<VarLenUnicode>()? {
                put(h, s.as_str().as_bytes());
            }
        }
        TypeDescriptor::VarLenAscii => {
            for s in c.read_raw::<VarLenAscii>()? {
                put(h, s.as_str().as_bytes());
            }
        }
        other => bail!("{what}: type {other} has no content digest"),
    }
    Ok(())
}

fn attrs(h: &mut Sink, loc: &hdf5::Location, path: &str) -> Result<()> {
    let mut names = loc.attr_names()?;
    names.sort();
    for name in names {
        if path.is_empty() && (name == COMPLETE_ATTR || name == CONTENT_ATTR) {
            continue;
        }
        h.update(b"A");
        put(h, name.as_bytes());
        let a = loc.attr(&name)?;
        values(h, &a, &format!("attribute `{name}` of `/{path}`"))?;
    }
    Ok(())
}

fn group(h: &mut Sink, g: &hdf5::Group, path: &str) -> Result<()> {
    h.update(b"G");
    put(h, path.as_bytes());
    attrs(h, g, path)?;
    let mut members = g.member_names()?;
    members.sort();
    for m in members {
        let child = if path.is_empty() {
            m.clone()
        } else {
            format!("{path}/{m}")
        };
        if let Ok(ds) = g.dataset(&m) {
            h.update(b"D");
            put(h, child.as_bytes());
            values(h, &ds, &format!("dataset `/{child}`"))?;
            attrs(h, &ds, &child)?;
        } else {
            let sub = g
                .group(&m)
                .map_err(|e| anyhow!("`/{child}` is neither a dataset nor a group: {e}"))?;
            group(h, &sub, &child)?;
        }
    }
    Ok(())
}

/// The content digest of an open HDF5 file (see the module docs), 64 hex digits. Its time
/// counts as verification in [`crate::clock`].
pub fn content_digest(file: &hdf5::File) -> Result<String> {
    digest_for(file, Purpose::Verify)
}

/// [`content_digest`], its time counted under `purpose`.
pub(crate) fn digest_for(file: &hdf5::File, purpose: Purpose) -> Result<String> {
    let timer = Timer::start(purpose);
    let mut h = Sink {
        h: blake3::Hasher::new(),
        bytes: 0,
    };
    h.update(b"saddleflow-content-v1");
    group(&mut h, file, "")?;
    timer.done(h.bytes);
    Ok(h.h.finalize().to_hex().to_string())
}

/// The verdict on a cache entry.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Integrity {
    /// Complete, holds the expected key, content matches its digest.
    Valid,
    /// No file at the path.
    Missing,
    /// Unreadable, truncated or unfinished (no complete mark).
    Invalid(String),
    /// Readable and complete, but the key or the content digest does not match.
    Damaged(String),
}

impl Integrity {
    /// Whether the entry can be used.
    pub fn is_valid(&self) -> bool {
        *self == Self::Valid
    }
    /// Why not (empty when valid or missing).
    pub fn detail(&self) -> &str {
        match self {
            Self::Invalid(s) | Self::Damaged(s) => s,
            _ => "",
        }
    }
}

impl ArtefactReader {
    /// Recomputes the content digest and compares it with the stored one.
    pub fn verify_content(&self) -> Result<()> {
        let stored = self.attr_str(CONTENT_ATTR).map_err(|_| {
            anyhow!(
                "`{}` carries no content digest (`{CONTENT_ATTR}`): not written by this saddleflow",
                self.path().display()
            )
        })?;
        let now = content_digest(self.hdf5()).map_err(|e| {
            anyhow!(
                "`{}`: cannot hash the content: {e:#}",
                self.path().display()
            )
        })?;
        if now != stored {
            bail!(
                "`{}` is damaged: its content hashes to {} but {} was recorded at publication",
                self.path().display(),
                &now[..12],
                &stored[..stored.len().min(12)]
            );
        }
        Ok(())
    }

    /// Compares the key in the provenance with `expected`.
    pub fn verify_key(&self, expected: &str) -> Result<()> {
        let stored = self
            .attr_str_at(crate::PROVENANCE_GROUP, "key")
            .map_err(|_| anyhow!("`{}` has no provenance key", self.path().display()))?;
        if stored != expected {
            bail!(
                "`{}` holds the artefact of key {} where key {} was expected (a foreign file under this name)",
                self.path().display(),
                &stored[..stored.len().min(12)],
                &expected[..expected.len().min(12)]
            );
        }
        Ok(())
    }

    /// Opens a cache entry and checks it all: complete mark, key, content digest.
    pub fn open_verified(path: impl AsRef<Path>, expected_key: &str) -> Result<Self> {
        let r = Self::open_complete(path)?;
        r.verify_key(expected_key)?;
        r.verify_content()?;
        Ok(r)
    }
}

/// Checks the cache entry at `path` expected to hold key `expected_key`. Never panics; prints
/// nothing.
pub fn check(path: &Path, expected_key: &str) -> Integrity {
    if !path.exists() {
        return Integrity::Missing;
    }
    // the file's bytes against the publisher's checksum first: the HDF5 library can crash
    // (not fail) on corrupted metadata, so a damaged file must be caught before it is opened
    let whole = match file_checksum_matches(path) {
        Ok(ok) => ok,
        Err(verdict) => return verdict,
    };
    let verdict = std::panic::catch_unwind(|| {
        let r = match ArtefactReader::open_complete(path) {
            Ok(r) => r,
            Err(e) => return Integrity::Invalid(format!("{e:#}")),
        };
        // with the whole file's bytes as published, the content digest (over the same bytes'
        // datasets and attributes) cannot differ: only the key is left to check
        let checked = if whole {
            r.verify_key(expected_key)
        } else {
            r.verify_key(expected_key).and_then(|()| r.verify_content())
        };
        match checked {
            Ok(()) => Integrity::Valid,
            Err(e) => Integrity::Damaged(format!("{e:#}")),
        }
    });
    verdict
        .unwrap_or_else(|_| Integrity::Invalid(format!("`{}`: reading panicked", path.display())))
}

/// The whole-file checksum beside an artefact: `<file>.b3`, the BLAKE3 hex of the file's bytes
/// as published, their number, and the BLAKE3 hex of the first [`HEAD_BYTES`]
/// (`<hex> <bytes> <head hex>`; the head tells a truncated copy from another file).
pub fn checksum_path(path: &Path) -> std::path::PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".b3");
    std::path::PathBuf::from(s)
}

/// How many leading bytes [`head_checksum`] covers.
pub const HEAD_BYTES: u64 = 4096;

/// BLAKE3 hex of a file's first [`HEAD_BYTES`] bytes (fewer if it is shorter).
pub fn head_checksum(path: &Path) -> std::io::Result<String> {
    use std::io::Read;
    let mut h = blake3::Hasher::new();
    std::io::copy(&mut std::fs::File::open(path)?.take(HEAD_BYTES), &mut h)?;
    Ok(h.finalize().to_hex().to_string())
}

/// BLAKE3 hex of a file's bytes, its time counted under `purpose`.
pub fn file_checksum(path: &Path, purpose: crate::clock::Purpose) -> std::io::Result<String> {
    let t = crate::clock::Timer::start(purpose);
    let mut h = blake3::Hasher::new();
    let mut f = std::fs::File::open(path)?;
    let n = std::io::copy(&mut f, &mut h)?;
    t.done(n);
    Ok(h.finalize().to_hex().to_string())
}

/// `Ok(true)`: the file's bytes match its checksum file; `Ok(false)`: there is no checksum
/// file (an artefact written before checksums, or by hand): the content digest decides;
/// `Err`: they differ (the verdict names the file).
fn file_checksum_matches(path: &Path) -> Result<bool, Integrity> {
    let Ok(want) = std::fs::read_to_string(checksum_path(path)) else {
        return Ok(false);
    };
    let mut parts = want.split_whitespace();
    let (hash, size, head) = (parts.next().unwrap_or(""), parts.next(), parts.next());
    let len = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    // shorter than published with the published first bytes (HDF5's superblock, which records
    // the file's end): a truncated copy of this entry, not another file
    if let Some(size) = size.and_then(|s| s.parse::<u64>().ok())
        && len < size
        && head.is_some_and(|h| head_checksum(path).is_ok_and(|got| got == h))
    {
        return Err(Integrity::Invalid(format!(
            "`{}` is truncated: {len} of the {size} bytes published",
            path.display()
        )));
    }
    match file_checksum(path, crate::clock::Purpose::Verify) {
        Ok(got) if got == hash => Ok(true),
        Ok(_) => Err(Integrity::Damaged(format!(
            "`{}`: its bytes differ from the checksum written at publication ({}): damaged, or a foreign file copied over it",
            path.display(),
            checksum_path(path).display()
        ))),
        Err(e) => Err(Integrity::Invalid(format!(
            "`{}`: cannot read: {e}",
            path.display()
        ))),
    }
}
