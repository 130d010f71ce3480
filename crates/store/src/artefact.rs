//! HDF5 artefacts: an atomic writer and a tolerant reader.
//!
//! Layout conventions (ARCHITECTURE.md): 2-D fields are `f64` datasets of shape `(nx, ny)`, the
//! first index being x; root attributes `lx`, `ly` give the cell size; field names are
//! [`fields`]. Every artefact the pipeline writes also carries a `/provenance` group (see
//! [`crate::Provenance`]) and, written last, the root attribute [`COMPLETE_ATTR`] = `true`.
//!
//! Publication is atomic: [`ArtefactWriter`] writes to a temporary file in the final folder,
//! [`ArtefactWriter::publish`] marks it complete, closes it, fsyncs it, renames it over the final
//! path and fsyncs the folder. Dropping an unpublished writer deletes its temporary file; a
//! process killed mid-write leaves only a hidden `.<name>.tmp-<pid>-<n>` file, which no reader
//! looks at and `saddleflow gc` deletes.
//!
//! Bytes are reproducible: object time stamps are switched off on the file, every group and
//! every dataset, so identical content gives identical files.
//!
//! HDF5's own file locking (1.10+, `flock` on every open file) is switched off: published files
//! are immutable and temporaries private, so it protects nothing here, and its locks leak into
//! child processes (HDF5 opens files without `O_CLOEXEC`) and fail on some network file systems.

use anyhow::{Context, Result, anyhow, bail};
use fsutil;
use hdf5::types::{VarLenAscii, VarLenUnicode};
use ndarray::{Array1, Array2, ArrayView2};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// Name of the root attribute that marks a finished artefact; written last, just before close.
pub const COMPLETE_ATTR: &str = "complete";

/// Standard dataset names of 2-D fields (ARCHITECTURE.md).
pub mod fields {
    /// Substrate heights h(x, y).
    pub const HEIGHT: &str = "height";
    /// Elastic surface displacement u(x, y).
    pub const DISPLACEMENT: &str = "displacement";
    /// Gap g(x, y).
    pub const GAP: &str = "gap";
    /// Contact pressure p(x, y).
    pub const PRESSURE: &str = "pressure";
    /// Reynolds current density, x component.
    pub const CURRENT_X: &str = "current_x";
    /// Reynolds current density, y component.
    pub const CURRENT_Y: &str = "current_y";
    /// Root attribute: cell size along x.
    pub const LX: &str = "lx";
    /// Root attribute: cell size along y.
    pub const LY: &str = "ly";
}

/// Switches HDF5's automatic error printing to stderr off (idempotent). hdf5-metno already does
/// so when it initialises; calling this again costs nothing and documents the intent.
pub fn silence_hdf5() {
    hdf5::silence_errors(true);
}

/// A scalar attribute value.
#[derive(Clone, Debug, PartialEq)]
pub enum AttrValue {
    /// 64-bit float.
    F64(f64),
    /// Signed 64-bit integer.
    I64(i64),
    /// Unsigned 64-bit integer.
    U64(u64),
    /// Boolean (HDF5 enum, read by h5py as `numpy.bool_`).
    Bool(bool),
    /// UTF-8 variable-length string.
    Str(String),
    /// JSON value, stored as its compact JSON text in a UTF-8 string.
    Json(Value),
}

impl From<f64> for AttrValue {
    fn from(v: f64) -> Self {
        Self::F64(v)
    }
}
impl From<i64> for AttrValue {
    fn from(v: i64) -> Self {
        Self::I64(v)
    }
}
impl From<u64> for AttrValue {
    fn from(v: u64) -> Self {
        Self::U64(v)
    }
}
impl From<bool> for AttrValue {
    fn from(v: bool) -> Self {
        Self::Bool(v)
    }
}
impl From<&str> for AttrValue {
    fn from(v: &str) -> Self {
        Self::Str(v.to_string())
    }
}
impl From<String> for AttrValue {
    fn from(v: String) -> Self {
        Self::Str(v)
    }
}
impl From<Value> for AttrValue {
    fn from(v: Value) -> Self {
        Self::Json(v)
    }
}

fn vlu(s: &str) -> Result<VarLenUnicode> {
    VarLenUnicode::from_str(s).map_err(|e| anyhow!("string cannot be stored in HDF5: {e}"))
}

fn write_attr(loc: &hdf5::Location, name: &str, value: &AttrValue) -> Result<()> {
    if loc.attr(name).is_ok() {
        loc.delete_attr(name)?;
    }
    match value {
        AttrValue::F64(v) => loc.new_attr::<f64>().create(name)?.write_scalar(v)?,
        AttrValue::I64(v) => loc.new_attr::<i64>().create(name)?.write_scalar(v)?,
        AttrValue::U64(v) => loc.new_attr::<u64>().create(name)?.write_scalar(v)?,
        AttrValue::Bool(v) => loc.new_attr::<bool>().create(name)?.write_scalar(v)?,
        AttrValue::Str(s) => loc
            .new_attr::<VarLenUnicode>()
            .create(name)?
            .write_scalar(&vlu(s)?)?,
        AttrValue::Json(v) => {
            let s = serde_json::to_string(v)?;
            loc.new_attr::<VarLenUnicode>()
                .create(name)?
                .write_scalar(&vlu(&s)?)?
        }
    }
    Ok(())
}

/// Writes one HDF5 artefact to a temporary file and publishes it atomically.
///
/// Object paths (`"branch/loading/area"`) may name groups that do not exist yet; they are
/// created (without time stamps).
pub struct ArtefactWriter {
    file: Option<hdf5::File>,
    tmp: PathBuf,
    final_path: PathBuf,
}

impl ArtefactWriter {
    /// Starts an artefact that [`publish`](Self::publish) will move to `final_path`. The folder
    /// is created if needed; the temporary file lives next to the final path.
    pub fn create(final_path: impl AsRef<Path>) -> Result<Self> {
        silence_hdf5();
        let final_path = final_path.as_ref().to_path_buf();
        fsutil::ensure_parent(&final_path)?;
        let tmp = fsutil::temp_path_for(&final_path)?;
        let file = hdf5::File::with_options()
            .with_fcpl(|p| p.obj_track_times(false))
            .with_fapl(|p| p.file_locking(false))
            .create_excl(&tmp)
            .with_context(|| format!("cannot create HDF5 file `{}`", tmp.display()))?;
        Ok(Self {
            file: Some(file),
            tmp,
            final_path,
        })
    }

    /// Where the artefact will be published.
    pub fn final_path(&self) -> &Path {
        &self.final_path
    }

    /// Where it is being written now.
    pub fn temp_path(&self) -> &Path {
        &self.tmp
    }

    fn file(&self) -> Result<&hdf5::File> {
        self.file
            .as_ref()
            .ok_or_else(|| anyhow!("artefact writer already closed"))
    }

    /// The group at `path` ("" or "/" is the root), created with its parents if missing.
    fn ensure_group(&self, path: &str) -> Result<hdf5::Group> {
        let mut group: hdf5::Group = (**self.file()?).clone();
        for part in path.split('/').filter(|p| !p.is_empty()) {
            group = if group.link_exists(part) {
                group
                    .group(part)
                    .with_context(|| format!("`{part}` in `{path}` exists and is not a group"))?
            } else {
                group
                    .create_group_builder()
                    .obj_track_times(false)
                    .create(part)
                    .with_context(|| format!("cannot create group `{path}`"))?
            };
        }
        Ok(group)
    }

    fn split(path: &str) -> Result<(&str, &str)> {
        let path = path.trim_start_matches('/');
        let (parent, name) = path.rsplit_once('/').unwrap_or(("", path));
        if name.is_empty() {
            bail!("empty object name in path `{path}`");
        }
        Ok((parent, name))
    }

    /// Creates a group (and its parents).
    pub fn create_group(&mut self, path: &str) -> Result<()> {
        self.ensure_group(path).map(|_| ())
    }

    /// Sets a root attribute.
    pub fn set_attr(&mut self, name: &str, value: impl Into<AttrValue>) -> Result<()> {
        self.set_attr_at("", name, value)
    }

    /// Sets an attribute on the group or dataset at `object` ("" is the root; a missing group is
    /// created).
    pub fn set_attr_at(
        &mut self,
        object: &str,
        name: &str,
        value: impl Into<AttrValue>,
    ) -> Result<()> {
        let value = value.into();
        let obj = object.trim_matches('/');
        let file = self.file()?;
        let result = if !obj.is_empty() && file.link_exists(obj) && file.dataset(obj).is_ok() {
            let ds = file.dataset(obj)?;
            write_attr(&ds, name, &value)
        } else {
            let g = self.ensure_group(obj)?;
            write_attr(&g, name, &value)
        };
        result.with_context(|| format!("cannot write attribute `{name}` on `/{obj}`"))
    }

    /// Sets the root attributes `lx`, `ly` (cell size).
    pub fn set_cell(&mut self, lx: f64, ly: f64) -> Result<()> {
        self.set_attr(fields::LX, lx)?;
        self.set_attr(fields::LY, ly)
    }

    /// Writes a 2-D `f64` dataset of shape `(nx, ny)` (first index x).
    pub fn write_f64_2d(&mut self, path: &str, data: ArrayView2<'_, f64>) -> Result<()> {
        let (parent, name) = Self::split(path)?;
        let g = self.ensure_group(parent)?;
        let data = data.as_standard_layout();
        g.new_dataset_builder()
            .with_data(&data)
            .obj_track_times(false)
            .create(name)
            .with_context(|| format!("cannot write dataset `{path}`"))?;
        Ok(())
    }

    /// Writes a 1-D `f64` dataset.
    pub fn write_f64_1d(&mut self, path: &str, data: &[f64]) -> Result<()> {
        self.write_1d(path, data)
    }

    /// Writes a 1-D `i64` dataset.
    pub fn write_i64_1d(&mut self, path: &str, data: &[i64]) -> Result<()> {
        self.write_1d(path, data)
    }

    /// Writes a 1-D `u8` dataset (e.g. boolean flags per step).
    pub fn write_u8_1d(&mut self, path: &str, data: &[u8]) -> Result<()> {
        self.write_1d(path, data)
    }

    fn write_1d<T: hdf5::H5Type>(&mut self, path: &str, data: &[T]) -> Result<()> {
        let (parent, name) = Self::split(path)?;
        let g = self.ensure_group(parent)?;
        g.new_dataset_builder()
            .with_data(data)
            .obj_track_times(false)
            .create(name)
            .with_context(|| format!("cannot write dataset `{path}`"))?;
        Ok(())
    }

    /// Writes a 1-D dataset of UTF-8 variable-length strings.
    pub fn write_strings<S: AsRef<str>>(&mut self, path: &str, data: &[S]) -> Result<()> {
        let v: Vec<VarLenUnicode> = data
            .iter()
            .map(|s| vlu(s.as_ref()))
            .collect::<Result<_>>()?;
        self.write_1d(path, &v)
    }

    /// Writes a scalar string dataset (e.g. a long JSON document).
    pub fn write_string(&mut self, path: &str, text: &str) -> Result<()> {
        let (parent, name) = Self::split(path)?;
        let g = self.ensure_group(parent)?;
        let ds = g
            .new_dataset::<VarLenUnicode>()
            .obj_track_times(false)
            .create(name)
            .with_context(|| format!("cannot write dataset `{path}`"))?;
        ds.write_scalar(&vlu(text)?)?;
        Ok(())
    }

    /// Writes the `/provenance` group (see [`crate::Provenance`]).
    pub fn write_provenance(&mut self, prov: &crate::Provenance) -> Result<()> {
        prov.write_to(self)
    }

    /// Records the content digest ([`crate::digest`]), marks the file complete, closes it, fsyncs it, renames it to the final path (replacing
    /// any file there) and fsyncs the folder. Returns the final path.
    pub fn publish(mut self) -> Result<PathBuf> {
        let digest = crate::digest::digest_for(self.file()?, crate::clock::Purpose::Publish)
            .with_context(|| format!("cannot hash the content of `{}`", self.tmp.display()))?;
        self.set_attr(crate::digest::CONTENT_ATTR, digest)?;
        self.set_attr(COMPLETE_ATTR, true)?;
        let file = self
            .file
            .take()
            .ok_or_else(|| anyhow!("artefact writer already closed"))?;
        file.flush()
            .with_context(|| format!("cannot flush `{}`", self.tmp.display()))?;
        file.close()
            .with_context(|| format!("cannot close `{}`", self.tmp.display()))?;
        // the whole file's checksum beside it, written before the rename: readers check the
        // bytes before handing them to the HDF5 library (which can crash on corrupt metadata)
        let sum = crate::digest::file_checksum(&self.tmp, crate::clock::Purpose::Publish)
            .with_context(|| format!("cannot hash `{}`", self.tmp.display()))?;
        let head = crate::digest::head_checksum(&self.tmp)
            .with_context(|| format!("cannot hash `{}`", self.tmp.display()))?;
        let len = std::fs::metadata(&self.tmp)
            .with_context(|| format!("cannot stat `{}`", self.tmp.display()))?
            .len();
        fsutil::write_atomic(
            &crate::digest::checksum_path(&self.final_path),
            format!("{sum} {len} {head}").as_bytes(),
        )?;
        fsutil::commit_rename(&self.tmp, &self.final_path)?;
        Ok(self.final_path.clone())
    }
}

impl Drop for ArtefactWriter {
    fn drop(&mut self) {
        if let Some(file) = self.file.take() {
            let _ = file.close();
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Reads an HDF5 file: ours or anyone's.
pub struct ArtefactReader {
    file: hdf5::File,
    path: PathBuf,
}

impl ArtefactReader {
    /// Opens any readable HDF5 file (a complete mark is not required: files written by other
    /// tools are welcome as inputs). See [`open_complete`](Self::open_complete) for cache entries.
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        silence_hdf5();
        let path = path.as_ref().to_path_buf();
        if !path.is_file() {
            bail!("`{}` does not exist or is not a file", path.display());
        }
        let file = hdf5::File::with_options()
            .with_fapl(|p| p.file_locking(false))
            .open(&path)
            .map_err(|e| {
                anyhow!(
                    "`{}` is not a readable HDF5 file (truncated or corrupt?): {e}",
                    path.display()
                )
            })?;
        Ok(Self { file, path })
    }

    /// Opens a file and requires the complete mark (a published artefact).
    pub fn open_complete(path: impl AsRef<Path>) -> Result<Self> {
        let r = Self::open(path)?;
        if !r.is_complete() {
            bail!(
                "`{}` is incomplete: it lacks the `{COMPLETE_ATTR}` mark",
                r.path.display()
            );
        }
        Ok(r)
    }

    /// Whether `path` is a published, complete artefact: exists, opens as HDF5 (HDF5 checks the
    /// superblock's end-of-file address against the file size, which catches truncation) and has
    /// the complete mark. Never panics; prints nothing.
    pub fn is_valid(path: impl AsRef<Path>) -> bool {
        let path = path.as_ref();
        std::panic::catch_unwind(|| Self::open_complete(path).is_ok()).unwrap_or(false)
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The underlying HDF5 file, for anything this API does not cover.
    pub fn hdf5(&self) -> &hdf5::File {
        &self.file
    }

    /// Whether the root carries `complete = true`.
    pub fn is_complete(&self) -> bool {
        self.file
            .attr(COMPLETE_ATTR)
            .and_then(|a| a.read_scalar::<bool>())
            .unwrap_or(false)
    }

    fn location(&self, object: &str) -> Result<hdf5::Location> {
        let obj = object.trim_matches('/');
        if obj.is_empty() {
            return Ok((**self.file).clone());
        }
        if let Ok(ds) = self.file.dataset(obj) {
            return Ok((**ds).clone());
        }
        let g = self
            .file
            .group(obj)
            .with_context(|| format!("`{}` has no object `/{obj}`", self.path.display()))?;
        Ok((*g).clone())
    }

    fn attr_of(&self, object: &str, name: &str) -> Result<hdf5::Attribute> {
        self.location(object)?.attr(name).with_context(|| {
            format!(
                "`{}`: no attribute `{name}` on `/{}`",
                self.path.display(),
                object.trim_matches('/')
            )
        })
    }

    /// Whether the root has attribute `name`.
    pub fn has_attr(&self, name: &str) -> bool {
        self.file.attr(name).is_ok()
    }

    /// Names of the attributes of `object` ("" = root).
    pub fn attr_names(&self, object: &str) -> Result<Vec<String>> {
        Ok(self.location(object)?.attr_names()?)
    }

    /// Reads a numeric root attribute as `f64` (integers convert).
    pub fn attr_f64(&self, name: &str) -> Result<f64> {
        self.attr_f64_at("", name)
    }

    /// Reads a numeric attribute of `object` as `f64`.
    pub fn attr_f64_at(&self, object: &str, name: &str) -> Result<f64> {
        self.attr_of(object, name)?
            .read_scalar::<f64>()
            .with_context(|| {
                format!(
                    "`{}`: attribute `{name}` is not a number",
                    self.path.display()
                )
            })
    }

    /// Reads an integer root attribute as `i64`.
    pub fn attr_i64(&self, name: &str) -> Result<i64> {
        self.attr_i64_at("", name)
    }

    /// Reads an integer attribute of `object` as `i64`.
    pub fn attr_i64_at(&self, object: &str, name: &str) -> Result<i64> {
        self.attr_of(object, name)?
            .read_scalar::<i64>()
            .with_context(|| {
                format!(
                    "`{}`: attribute `{name}` is not an integer",
                    self.path.display()
                )
            })
    }

    /// Reads an unsigned integer root attribute.
    pub fn attr_u64(&self, name: &str) -> Result<u64> {
        self.attr_of("", name)?
            .read_scalar::<u64>()
            .with_context(|| {
                format!(
                    "`{}`: attribute `{name}` is not an unsigned integer",
                    self.path.display()
                )
            })
    }

    /// Reads a boolean root attribute (an HDF5 bool enum or an integer, non-zero = true).
    pub fn attr_bool(&self, name: &str) -> Result<bool> {
        self.attr_bool_at("", name)
    }

    /// Reads a boolean attribute of `object`.
    pub fn attr_bool_at(&self, object: &str, name: &str) -> Result<bool> {
        let a = self.attr_of(object, name)?;
        if let Ok(b) = a.read_scalar::<bool>() {
            return Ok(b);
        }
        a.read_scalar::<i64>().map(|i| i != 0).with_context(|| {
            format!(
                "`{}`: attribute `{name}` is not a boolean",
                self.path.display()
            )
        })
    }

    /// Reads a string root attribute (variable-length UTF-8 or ASCII).
    pub fn attr_str(&self, name: &str) -> Result<String> {
        self.attr_str_at("", name)
    }

    /// Reads a string attribute of `object`.
    pub fn attr_str_at(&self, object: &str, name: &str) -> Result<String> {
        let a = self.attr_of(object, name)?;
        if let Ok(s) = a.read_scalar::<VarLenUnicode>() {
            return Ok(s.as_str().to_string());
        }
        a.read_scalar::<VarLenAscii>()
            .map(|s| s.as_str().to_string())
            .with_context(|| {
                format!(
                    "`{}`: attribute `{name}` is not a string",
                    self.path.display()
                )
            })
    }

    /// Reads a JSON-as-string root attribute.
    pub fn attr_json(&self, name: &str) -> Result<Value> {
        self.attr_json_at("", name)
    }

    /// Reads a JSON-as-string attribute of `object`.
    pub fn attr_json_at(&self, object: &str, name: &str) -> Result<Value> {
        let s = self.attr_str_at(object, name)?;
        serde_json::from_str(&s).with_context(|| {
            format!(
                "`{}`: attribute `{name}` is not valid JSON",
                self.path.display()
            )
        })
    }

    /// Whether a dataset exists at `path`.
    pub fn has_dataset(&self, path: &str) -> bool {
        self.file.dataset(path.trim_start_matches('/')).is_ok()
    }

    fn dataset(&self, path: &str) -> Result<hdf5::Dataset> {
        self.file
            .dataset(path.trim_start_matches('/'))
            .with_context(|| format!("`{}` has no dataset `{path}`", self.path.display()))
    }

    /// Shape of the dataset at `path`.
    pub fn shape(&self, path: &str) -> Result<Vec<usize>> {
        Ok(self.dataset(path)?.shape())
    }

    /// Reads a 2-D `f64` dataset, shape `(nx, ny)`.
    pub fn read_f64_2d(&self, path: &str) -> Result<Array2<f64>> {
        self.dataset(path)?.read_2d::<f64>().with_context(|| {
            format!(
                "`{}`: cannot read `{path}` as a 2-D f64 array",
                self.path.display()
            )
        })
    }

    /// Reads a 1-D `f64` dataset.
    pub fn read_f64_1d(&self, path: &str) -> Result<Vec<f64>> {
        self.read_1d(path)
    }

    /// Reads a 1-D `i64` dataset.
    pub fn read_i64_1d(&self, path: &str) -> Result<Vec<i64>> {
        self.read_1d(path)
    }

    /// Reads a 1-D `u8` dataset.
    pub fn read_u8_1d(&self, path: &str) -> Result<Vec<u8>> {
        self.read_1d(path)
    }

    fn read_1d<T: hdf5::H5Type>(&self, path: &str) -> Result<Vec<T>> {
        let a: Array1<T> = self.dataset(path)?.read_1d::<T>().with_context(|| {
            format!(
                "`{}`: cannot read `{path}` as a 1-D array",
                self.path.display()
            )
        })?;
        Ok(a.into_raw_vec_and_offset().0)
    }

    /// Reads a 1-D string dataset.
    pub fn read_strings(&self, path: &str) -> Result<Vec<String>> {
        let ds = self.dataset(path)?;
        if let Ok(v) = ds.read_raw::<VarLenUnicode>() {
            return Ok(v.iter().map(|s| s.as_str().to_string()).collect());
        }
        let v = ds.read_raw::<VarLenAscii>().with_context(|| {
            format!("`{}`: cannot read `{path}` as strings", self.path.display())
        })?;
        Ok(v.iter().map(|s| s.as_str().to_string()).collect())
    }

    /// Reads a scalar string dataset.
    pub fn read_string(&self, path: &str) -> Result<String> {
        let ds = self.dataset(path)?;
        if let Ok(s) = ds.read_scalar::<VarLenUnicode>() {
            return Ok(s.as_str().to_string());
        }
        ds.read_scalar::<VarLenAscii>()
            .map(|s| s.as_str().to_string())
            .with_context(|| format!("`{}`: `{path}` is not a string", self.path.display()))
    }

    /// Names of the members (groups and datasets) of the group at `path` ("" = root).
    pub fn members(&self, path: &str) -> Result<Vec<String>> {
        let p = path.trim_matches('/');
        let g = if p.is_empty() {
            (*self.file).clone()
        } else {
            self.file.group(p)?
        };
        Ok(g.member_names()?)
    }

    /// The root attributes `(lx, ly)`.
    pub fn cell(&self) -> Result<(f64, f64)> {
        Ok((self.attr_f64(fields::LX)?, self.attr_f64(fields::LY)?))
    }

    /// Reads the `/provenance` group.
    pub fn provenance(&self) -> Result<crate::Provenance> {
        crate::Provenance::read_from(self)
    }
}
