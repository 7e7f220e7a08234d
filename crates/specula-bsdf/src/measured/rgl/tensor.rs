//! Reader for Mitsuba's `tensor_file` container (the format of RGL `.bsdf` files).
//!
//! Layout (little endian):
//! - 12 bytes magic `"tensor_file\0"`, then the version as two bytes (major 1, minor 0);
//! - `u32` number of fields;
//! - per field: `u16` name length and the UTF-8 name, `u16` rank, `u8` dtype code
//!   (1 = u8, 2 = i8, 3 = u16, 4 = i16, 5 = u32, 6 = i32, 7 = u64, 8 = i64, 9 = f16,
//!   10 = f32, 11 = f64), `u64` byte offset of the data, `rank × u64` shape;
//! - the field data, each contiguous, row-major (last dimension fastest).
//!
//! Every problem is reported as a [`TensorError`] naming the file; nothing panics on bad input.

use std::fmt;
use std::path::{Path, PathBuf};

/// Element type of a tensor field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DType {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    U64,
    I64,
    F16,
    F32,
    F64,
}

impl DType {
    /// The type for a code as stored in the file.
    pub fn from_code(code: u8) -> Option<DType> {
        Some(match code {
            1 => DType::U8,
            2 => DType::I8,
            3 => DType::U16,
            4 => DType::I16,
            5 => DType::U32,
            6 => DType::I32,
            7 => DType::U64,
            8 => DType::I64,
            9 => DType::F16,
            10 => DType::F32,
            11 => DType::F64,
            _ => return None,
        })
    }

    /// Size of one element in bytes.
    pub fn size(self) -> usize {
        match self {
            DType::U8 | DType::I8 => 1,
            DType::U16 | DType::I16 | DType::F16 => 2,
            DType::U32 | DType::I32 | DType::F32 => 4,
            DType::U64 | DType::I64 | DType::F64 => 8,
        }
    }
}

impl fmt::Display for DType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            DType::U8 => "uint8",
            DType::I8 => "int8",
            DType::U16 => "uint16",
            DType::I16 => "int16",
            DType::U32 => "uint32",
            DType::I32 => "int32",
            DType::U64 => "uint64",
            DType::I64 => "int64",
            DType::F16 => "float16",
            DType::F32 => "float32",
            DType::F64 => "float64",
        };
        f.write_str(s)
    }
}

/// Errors from reading a tensor file or building a material from one.
#[derive(Debug, thiserror::Error)]
pub enum TensorError {
    #[error("{path}: cannot read file: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: bad magic: not a Mitsuba tensor_file")]
    BadMagic { path: PathBuf },
    #[error("{path}: unsupported tensor_file version {major}.{minor} (expected 1.0)")]
    BadVersion { path: PathBuf, major: u8, minor: u8 },
    #[error("{path}: truncated file: header ends while reading {what} at byte {at}")]
    Truncated {
        path: PathBuf,
        what: String,
        at: usize,
    },
    #[error("{path}: field '{field}': unknown dtype code {code}")]
    UnknownDtype {
        path: PathBuf,
        field: String,
        code: u8,
    },
    #[error("{path}: field '{field}': data [{offset}, {end}) lies past the end of the file ({len} bytes)")]
    OffsetPastEnd {
        path: PathBuf,
        field: String,
        offset: u64,
        end: u128,
        len: usize,
    },
    #[error("{path}: field name is not valid UTF-8")]
    BadName { path: PathBuf },
    #[error("{path}: duplicate field '{field}'")]
    DuplicateField { path: PathBuf, field: String },
    #[error("{path}: missing required field '{field}'")]
    MissingField { path: PathBuf, field: String },
    #[error(
        "{path}: field '{field}': expected {expected}, found dtype {dtype} with shape {shape:?}"
    )]
    WrongLayout {
        path: PathBuf,
        field: String,
        expected: String,
        dtype: DType,
        shape: Vec<usize>,
    },
    #[error("{path}: field '{field}': non-finite value (NaN or infinity) at element {index}")]
    NonFinite {
        path: PathBuf,
        field: String,
        index: usize,
    },
    #[error("{path}: {problem}")]
    Invalid { path: PathBuf, problem: String },
}

/// One named array in a tensor file.
#[derive(Clone, Debug)]
pub struct TensorField {
    pub name: String,
    pub dtype: DType,
    pub shape: Vec<usize>,
    /// Byte range of the data within the file.
    offset: usize,
    len: usize,
}

impl TensorField {
    /// Number of elements.
    pub fn len(&self) -> usize {
        self.shape.iter().product()
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A parsed tensor file: the raw bytes and the field table.
#[derive(Clone, Debug)]
pub struct TensorFile {
    path: PathBuf,
    bytes: Vec<u8>,
    fields: Vec<TensorField>,
}

struct Cursor<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    pos: usize,
}

impl Cursor<'_> {
    fn take(&mut self, n: usize, what: &str) -> Result<&[u8], TensorError> {
        match self.pos.checked_add(n) {
            Some(end) if end <= self.bytes.len() => {
                let s = &self.bytes[self.pos..end];
                self.pos = end;
                Ok(s)
            }
            _ => Err(TensorError::Truncated {
                path: self.path.to_path_buf(),
                what: what.to_string(),
                at: self.pos,
            }),
        }
    }
    fn u8(&mut self, what: &str) -> Result<u8, TensorError> {
        Ok(self.take(1, what)?[0])
    }
    fn u16(&mut self, what: &str) -> Result<u16, TensorError> {
        let b = self.take(2, what)?;
        Ok(u16::from_le_bytes([b[0], b[1]]))
    }
    fn u32(&mut self, what: &str) -> Result<u32, TensorError> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn u64(&mut self, what: &str) -> Result<u64, TensorError> {
        let b = self.take(8, what)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_le_bytes(a))
    }
}

const MAGIC: &[u8; 12] = b"tensor_file\0";

impl TensorFile {
    /// Read and parse a file.
    pub fn open(path: impl AsRef<Path>) -> Result<TensorFile, TensorError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|source| TensorError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_bytes(path, bytes)
    }

    /// Parse an in-memory file; `path` is only used in error messages.
    pub fn from_bytes(path: impl AsRef<Path>, bytes: Vec<u8>) -> Result<TensorFile, TensorError> {
        let path = path.as_ref().to_path_buf();
        let mut c = Cursor {
            path: &path,
            bytes: &bytes,
            pos: 0,
        };
        let magic = c
            .take(12, "magic")
            .map_err(|_| TensorError::BadMagic { path: path.clone() })?;
        if magic != MAGIC {
            return Err(TensorError::BadMagic { path: path.clone() });
        }
        let major = c.u8("version")?;
        let minor = c.u8("version")?;
        if (major, minor) != (1, 0) {
            return Err(TensorError::BadVersion {
                path: path.clone(),
                major,
                minor,
            });
        }
        let count = c.u32("field count")?;
        let mut headers: Vec<(String, DType, u64, Vec<u64>)> = Vec::new();
        for i in 0..count {
            let what = format!("field #{i} header");
            let name_len = c.u16(&what)? as usize;
            let name = std::str::from_utf8(c.take(name_len, &what)?)
                .map_err(|_| TensorError::BadName { path: path.clone() })?
                .to_string();
            let what = format!("header of field '{name}'");
            let ndim = c.u16(&what)? as usize;
            let code = c.u8(&what)?;
            let offset = c.u64(&what)?;
            let mut shape = Vec::with_capacity(ndim.min(16));
            for _ in 0..ndim {
                shape.push(c.u64(&what)?);
            }
            let dtype = DType::from_code(code).ok_or_else(|| TensorError::UnknownDtype {
                path: path.clone(),
                field: name.clone(),
                code,
            })?;
            if headers.iter().any(|h| h.0 == name) {
                return Err(TensorError::DuplicateField {
                    path: path.clone(),
                    field: name,
                });
            }
            headers.push((name, dtype, offset, shape));
        }
        // Only once the whole header is read: check that each field's data lies in the file.
        let mut fields = Vec::with_capacity(headers.len());
        for (name, dtype, offset, shape) in headers {
            // byte length, computed without overflow
            let mut nbytes: u128 = dtype.size() as u128;
            for &s in &shape {
                nbytes = nbytes.saturating_mul(s as u128);
            }
            let end = (offset as u128).saturating_add(nbytes);
            if end > bytes.len() as u128 {
                return Err(TensorError::OffsetPastEnd {
                    path: path.clone(),
                    field: name,
                    offset,
                    end,
                    len: bytes.len(),
                });
            }
            fields.push(TensorField {
                name,
                dtype,
                // fits: the data lies inside the file
                shape: shape.iter().map(|&s| s as usize).collect(),
                offset: offset as usize,
                len: nbytes as usize,
            });
        }
        Ok(TensorFile {
            path,
            bytes,
            fields,
        })
    }

    /// The file name used in error messages.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// All fields, in file order.
    pub fn fields(&self) -> &[TensorField] {
        &self.fields
    }

    pub fn has_field(&self, name: &str) -> bool {
        self.fields.iter().any(|f| f.name == name)
    }

    /// A field by name, or [`TensorError::MissingField`].
    pub fn field(&self, name: &str) -> Result<&TensorField, TensorError> {
        self.fields
            .iter()
            .find(|f| f.name == name)
            .ok_or_else(|| TensorError::MissingField {
                path: self.path.clone(),
                field: name.to_string(),
            })
    }

    fn raw(&self, f: &TensorField) -> &[u8] {
        &self.bytes[f.offset..f.offset + f.len]
    }

    fn check_layout(
        &self,
        f: &TensorField,
        dtype: DType,
        ndim: Option<usize>,
    ) -> Result<(), TensorError> {
        if f.dtype != dtype || ndim.is_some_and(|n| n != f.shape.len()) {
            let expected = match ndim {
                Some(n) => format!("dtype {dtype} with {n} dimension(s)"),
                None => format!("dtype {dtype}"),
            };
            return Err(TensorError::WrongLayout {
                path: self.path.clone(),
                field: f.name.clone(),
                expected,
                dtype: f.dtype,
                shape: f.shape.clone(),
            });
        }
        Ok(())
    }

    /// The bytes of a `uint8` field (optionally of a given rank).
    pub fn u8_data(&self, name: &str, ndim: Option<usize>) -> Result<&[u8], TensorError> {
        let f = self.field(name)?;
        self.check_layout(f, DType::U8, ndim)?;
        Ok(self.raw(f))
    }

    /// The values of a `float32` field (optionally of a given rank), checked to be finite.
    /// Returns the shape and the data (row-major).
    pub fn f32_data(
        &self,
        name: &str,
        ndim: Option<usize>,
    ) -> Result<(Vec<usize>, Vec<f32>), TensorError> {
        let f = self.field(name)?;
        self.check_layout(f, DType::F32, ndim)?;
        let data: Vec<f32> = self
            .raw(f)
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        if let Some(index) = data.iter().position(|v| !v.is_finite()) {
            return Err(TensorError::NonFinite {
                path: self.path.clone(),
                field: name.to_string(),
                index,
            });
        }
        Ok((f.shape.clone(), data))
    }

    /// An error about this file's content.
    pub fn invalid(&self, problem: impl Into<String>) -> TensorError {
        TensorError::Invalid {
            path: self.path.clone(),
            problem: problem.into(),
        }
    }
}
