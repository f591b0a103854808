//! MAT-files, level 5 (the binary format MATLAB writes with `save -v6`/`-v7` and GNU Octave with
//! `save -mat`/`-v7`): the reader of the numeric variables of a file, for records given as `.mat`
//! beside CSV (docs/matlab.md), and the format's numbers that the writer (in the presentation
//! layer, `pumpcyl_present::matfile`) shares with it.
//!
//! The format is MathWorks' "MAT-File Format" (Version 5 MAT-files): a 128-byte header (116
//! bytes of text, 8 bytes of subsystem offset, the version 0x0100 and the endian indicator `IM`),
//! then data elements, each an 8-byte tag (type, byte count) and its data padded to 8 bytes; a
//! tag whose upper 16 bits are non-zero is the "small element" form (type and count in 4 bytes,
//! up to 4 bytes of data in the next 4). A variable is a `miMATRIX` element holding the array
//! flags (`miUINT32`: class, complex, logical), the dimensions (`miINT32`), the name (`miINT8`)
//! and the real (and imaginary) parts in any numeric storage type. `miCOMPRESSED` elements (what
//! `save -v7` writes) hold one zlib-compressed element.
//!
//! The reader accepts both byte orders, the small
//! element form and compressed variables, converts every numeric class and storage type to f64
//! and describes the other classes (char, cell, struct, sparse, complex) without reading them.
//! Every size taken from a file is checked against the bytes that are there, and decompression
//! stops at [`MAX_DECOMPRESSED_BYTES`].

/// Largest decompressed size of the compressed variables of one file, together (bytes): 1 GiB,
/// 1.3·10⁸ doubles.
pub const MAX_DECOMPRESSED_BYTES: usize = 1 << 30;
/// Largest number of dimensions of a variable (MATLAB arrays have 2 or more).
pub const MAX_DIMS: usize = 32;

/// The header's length (text, subsystem offset, version, endian indicator).
pub const HEADER_BYTES: usize = 128;

/// Data type `miINT8` (the format's data types follow).
pub const MI_INT8: u32 = 1;
/// Data type `miUINT8`.
pub const MI_UINT8: u32 = 2;
/// Data type `miINT16`.
pub const MI_INT16: u32 = 3;
/// Data type `miUINT16`.
pub const MI_UINT16: u32 = 4;
/// Data type `miINT32`.
pub const MI_INT32: u32 = 5;
/// Data type `miUINT32`.
pub const MI_UINT32: u32 = 6;
/// Data type `miSINGLE`.
pub const MI_SINGLE: u32 = 7;
/// Data type `miDOUBLE`.
pub const MI_DOUBLE: u32 = 9;
/// Data type `miINT64`.
pub const MI_INT64: u32 = 12;
/// Data type `miUINT64`.
pub const MI_UINT64: u32 = 13;
/// Data type `miMATRIX`.
pub const MI_MATRIX: u32 = 14;
/// Data type `miCOMPRESSED`.
pub const MI_COMPRESSED: u32 = 15;
/// Data type `miUTF8`.
pub const MI_UTF8: u32 = 16;
/// The last data type of the format (`miUTF32`).
pub const MI_UTF32: u32 = 18;

/// Array class `mxCHAR`.
pub const MX_CHAR: u8 = 4;
/// Array class `mxDOUBLE`.
pub const MX_DOUBLE: u8 = 6;
const FLAG_COMPLEX: u32 = 0x0800;

/// Errors reading a MAT-file; the message says where in the file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct MatError(pub String);

fn bad<T>(msg: impl Into<String>) -> Result<T, MatError> {
    Err(MatError(msg.into()))
}

/// What a variable holds.
#[derive(Debug, Clone, PartialEq)]
pub enum Data {
    /// A real numeric array (any class), as f64 in column-major order.
    Real(Vec<f64>),
    /// Anything else, described in words (`char array`, `complex array`, `struct`, ...).
    Other(&'static str),
}

/// A variable read from a MAT-file.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Its name.
    pub name: String,
    /// Its dimensions (at least 2).
    pub dims: Vec<usize>,
    /// Its values.
    pub data: Data,
}

impl Variable {
    /// The values of a real vector (one dimension may be longer than 1), or why it is not one.
    pub fn vector(&self) -> Result<&[f64], MatError> {
        match &self.data {
            Data::Real(v) if self.dims.iter().filter(|&&d| d != 1).count() <= 1 => Ok(v),
            Data::Real(_) => Err(MatError(format!(
                "is a {} matrix, not a vector",
                self.dims
                    .iter()
                    .map(usize::to_string)
                    .collect::<Vec<_>>()
                    .join("x")
            ))),
            Data::Other(what) => Err(MatError(format!("is a {what}, not a real numeric vector"))),
        }
    }
}

/// Byte order of a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Endian {
    Little,
    Big,
}

impl Endian {
    fn u32(self, b: &[u8]) -> u32 {
        let a = [b[0], b[1], b[2], b[3]];
        match self {
            Endian::Little => u32::from_le_bytes(a),
            Endian::Big => u32::from_be_bytes(a),
        }
    }
}

/// The byte order of a file from its 128-byte header, or why the header is no level-5 header.
fn header(bytes: &[u8]) -> Result<Endian, MatError> {
    if bytes.len() < HEADER_BYTES {
        return bad(format!(
            "{} bytes: too short for a MAT-file (a level-5 MAT-file starts with a 128-byte header)",
            bytes.len()
        ));
    }
    let endian = match &bytes[126..128] {
        b"IM" => Endian::Little,
        b"MI" => Endian::Big,
        _ => {
            return bad(
                "not a level-5 MAT-file (no `IM`/`MI` endian indicator at byte 126); save it \
                 with MATLAB's `save -v7` or Octave's `save -mat`",
            )
        }
    };
    let version = match endian {
        Endian::Little => u16::from_le_bytes([bytes[124], bytes[125]]),
        Endian::Big => u16::from_be_bytes([bytes[124], bytes[125]]),
    };
    if version == 0x0200 {
        return bad(
            "a MAT-file version 7.3 (HDF5), which pumpcyl does not read: save it with `save -v7`",
        );
    }
    Ok(endian)
}

/// Every variable of a level-5 MAT-file, in file order.
pub fn read(bytes: &[u8]) -> Result<Vec<Variable>, MatError> {
    let endian = header(bytes)?;
    let mut out = Vec::new();
    let mut budget = MAX_DECOMPRESSED_BYTES;
    let mut pos = HEADER_BYTES;
    while pos < bytes.len() {
        let (el, next) = next_element(bytes, pos, endian)?;
        match el.data_type {
            MI_MATRIX => out.extend(matrix(el.data, endian, el.offset)?),
            MI_COMPRESSED => {
                let inner = inflate(el.data, el.offset, budget)?;
                budget -= inner.len();
                let (el2, _) = next_element(&inner, 0, endian).map_err(|e| {
                    MatError(format!("compressed element at byte {}: {e}", el.offset))
                })?;
                if el2.data_type != MI_MATRIX {
                    return bad(format!(
                        "compressed element at byte {} holds type {}, not a variable",
                        el.offset, el2.data_type
                    ));
                }
                out.extend(matrix(el2.data, endian, el.offset)?);
            }
            _ => {} // other top-level elements are not variables
        }
        pos = next;
    }
    Ok(out)
}

/// Why a MAT-file could not be read from a stream.
#[derive(Debug, thiserror::Error)]
pub enum StreamError {
    /// The stream failed.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// What was read is no MAT-file, or its elements would pass the size limit.
    #[error("{0}")]
    Mat(#[from] MatError),
}

/// The bytes of a MAT-file read from `stream`, element by element: the header is checked
/// first, then each top-level element's tag (its type must be one of the format's, its size
/// must fit in `max_bytes` with what came before) before its data is read. A stream that never
/// ends (a link to `/dev/zero` or `/dev/urandom`, a pipe) is refused at its first element that is
/// not one, not after `max_bytes` of it. The bytes are then given to [`read`].
pub fn read_stream(stream: &mut dyn std::io::Read, max_bytes: u64) -> Result<Vec<u8>, StreamError> {
    let mut bytes = Vec::new();
    take_into(stream, HEADER_BYTES as u64, &mut bytes)?;
    let endian = header(&bytes)?;
    loop {
        let pos = bytes.len();
        if take_into(stream, 8, &mut bytes)? == 0 {
            return Ok(bytes);
        }
        if bytes.len() - pos < 8 {
            let cut = format!("byte {pos}: a data element cut short (an 8-byte tag expected)");
            return Err(MatError(cut).into());
        }
        let first = endian.u32(&bytes[pos..]);
        if first >> 16 != 0 {
            continue; // a small element lives in its tag
        }
        if !(MI_INT8..=MI_UTF32).contains(&first) {
            return Err(MatError(format!(
                "byte {pos}: no MAT-file data element (type {first}; a level-5 element's type is \
                 1 to 18)"
            ))
            .into());
        }
        let n = u64::from(endian.u32(&bytes[pos + 4..]));
        let padded = if first == MI_COMPRESSED {
            n
        } else {
            n.div_ceil(8) * 8
        };
        if bytes.len() as u64 + padded > max_bytes {
            return Err(MatError(format!(
                "byte {pos}: a data element of {n} bytes passes {} MiB, the limit for a MAT-file",
                max_bytes >> 20
            ))
            .into());
        }
        take_into(stream, padded, &mut bytes)?;
    }
}

/// Append up to `n` bytes of `stream` to `bytes`; the number appended.
fn take_into(stream: &mut dyn std::io::Read, n: u64, bytes: &mut Vec<u8>) -> std::io::Result<u64> {
    use std::io::Read;
    let before = bytes.len();
    stream.take(n).read_to_end(bytes)?;
    Ok((bytes.len() - before) as u64)
}

/// A data element: its type, data and where it starts (for messages).
struct Element<'a> {
    data_type: u32,
    data: &'a [u8],
    offset: usize,
}

/// The element at `pos` and where the next one starts (after the padding).
fn next_element(
    bytes: &[u8],
    pos: usize,
    endian: Endian,
) -> Result<(Element<'_>, usize), MatError> {
    let rest = bytes.len() - pos.min(bytes.len());
    if rest < 8 {
        return bad(format!(
            "byte {pos}: a data element cut short ({rest} bytes left of an 8-byte tag)"
        ));
    }
    let first = endian.u32(&bytes[pos..]);
    if first >> 16 != 0 {
        // small element: type in the low 16 bits, count in the high 16, data in the next 4
        let n = (first >> 16) as usize;
        if n > 4 {
            return bad(format!(
                "byte {pos}: a small data element of {n} bytes (at most 4)"
            ));
        }
        let data_start = pos + 4;
        return Ok((
            Element {
                data_type: first & 0xffff,
                data: &bytes[data_start..data_start + n],
                offset: pos,
            },
            pos + 8,
        ));
    }
    let n = endian.u32(&bytes[pos + 4..]) as usize;
    let start = pos + 8;
    if n > bytes.len() - start {
        return bad(format!(
            "byte {pos}: a data element of {n} bytes, but only {} remain",
            bytes.len() - start
        ));
    }
    let padded = if first == MI_COMPRESSED {
        n
    } else {
        n.div_ceil(8) * 8
    };
    Ok((
        Element {
            data_type: first,
            data: &bytes[start..start + n],
            offset: pos,
        },
        (start + padded).min(bytes.len()),
    ))
}

/// Decompress one `miCOMPRESSED` element (zlib) to at most `limit` bytes.
fn inflate(data: &[u8], offset: usize, limit: usize) -> Result<Vec<u8>, MatError> {
    miniz_oxide::inflate::decompress_to_vec_zlib_with_limit(data, limit).map_err(|e| {
        MatError(match e.status {
            miniz_oxide::inflate::TINFLStatus::HasMoreOutput => format!(
                "compressed element at byte {offset}: the compressed variables expand beyond \
                     {MAX_DECOMPRESSED_BYTES} bytes (the limit)"
            ),
            s => format!("compressed element at byte {offset}: bad zlib data ({s:?})"),
        })
    })
}

/// A variable from the contents of a `miMATRIX` element (`None` for an empty element).
fn matrix(body: &[u8], endian: Endian, offset: usize) -> Result<Option<Variable>, MatError> {
    if body.is_empty() {
        return Ok(None);
    }
    let at = |what: &str| format!("variable at byte {offset}: {what}");
    let mut pos = 0;
    let mut sub = |what: &str| -> Result<Element<'_>, MatError> {
        let (el, next) =
            next_element(body, pos, endian).map_err(|e| MatError(at(&format!("{what}: {e}"))))?;
        pos = next;
        Ok(el)
    };
    let flags = sub("array flags")?;
    if flags.data_type != MI_UINT32 || flags.data.len() < 4 {
        return bad(at("array flags are not a miUINT32 element"));
    }
    let flag_word = endian.u32(flags.data);
    let class = (flag_word & 0xff) as u8;
    let dims_el = sub("dimensions")?;
    if dims_el.data_type != MI_INT32 || dims_el.data.len() % 4 != 0 {
        return bad(at("dimensions are not a miINT32 element"));
    }
    let ndims = dims_el.data.len() / 4;
    if !(2..=MAX_DIMS).contains(&ndims) {
        return bad(at(&format!("{ndims} dimensions (2 to {MAX_DIMS} allowed)")));
    }
    let dims: Vec<usize> = dims_el
        .data
        .chunks_exact(4)
        .map(|c| endian.u32(c) as i32)
        .map(|d| usize::try_from(d).map_err(|_| MatError(at(&format!("dimension {d} < 0")))))
        .collect::<Result<_, _>>()?;
    let count = dims
        .iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .ok_or_else(|| MatError(at("dimensions overflow")))?;
    let name_el = sub("name")?;
    if name_el.data_type != MI_INT8 && name_el.data_type != MI_UINT8 {
        return bad(at("the name is not a miINT8 element"));
    }
    let name = String::from_utf8_lossy(name_el.data).into_owned();
    let other = match class {
        1 => Some("cell array"),
        2 => Some("struct"),
        3 => Some("object"),
        MX_CHAR => Some("char array"),
        5 => Some("sparse matrix"),
        6..=15 if flag_word & FLAG_COMPLEX != 0 => Some("complex array"),
        6..=15 => None,
        _ => Some("value of an unknown class"),
    };
    if let Some(what) = other {
        return Ok(Some(Variable {
            name,
            dims,
            data: Data::Other(what),
        }));
    }
    let real = sub("real part")?;
    let values = numbers(real.data_type, real.data, endian).ok_or_else(|| {
        MatError(at(&format!(
            "`{name}`: data of storage type {} is not numeric",
            real.data_type
        )))
    })?;
    if values.len() != count {
        return bad(at(&format!(
            "`{name}`: {} values for dimensions {:?} ({count} expected)",
            values.len(),
            dims
        )));
    }
    Ok(Some(Variable {
        name,
        dims,
        data: Data::Real(values),
    }))
}

/// Numbers of any numeric storage type as f64 (`None` for a non-numeric type).
fn numbers(data_type: u32, data: &[u8], endian: Endian) -> Option<Vec<f64>> {
    macro_rules! conv {
        ($t:ty, $n:expr) => {
            data.chunks_exact($n)
                .map(|c| {
                    let a: [u8; $n] = c.try_into().expect("chunk size");
                    (match endian {
                        Endian::Little => <$t>::from_le_bytes(a),
                        Endian::Big => <$t>::from_be_bytes(a),
                    }) as f64
                })
                .collect()
        };
    }
    let width = match data_type {
        MI_INT8 | MI_UINT8 | MI_UTF8 => 1,
        MI_INT16 | MI_UINT16 => 2,
        MI_INT32 | MI_UINT32 | MI_SINGLE => 4,
        MI_DOUBLE | MI_INT64 | MI_UINT64 => 8,
        _ => return None,
    };
    if !data.len().is_multiple_of(width) {
        return None;
    }
    Some(match data_type {
        MI_INT8 => conv!(i8, 1),
        MI_UINT8 | MI_UTF8 => conv!(u8, 1),
        MI_INT16 => conv!(i16, 2),
        MI_UINT16 => conv!(u16, 2),
        MI_INT32 => conv!(i32, 4),
        MI_UINT32 => conv!(u32, 4),
        MI_SINGLE => conv!(f32, 4),
        MI_DOUBLE => conv!(f64, 8),
        MI_INT64 => conv!(i64, 8),
        _ => conv!(u64, 8),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A variable as MATLAB writes small ones: big endian, small-element name, int16 storage of
    /// a double, inside a compressed element.
    #[test]
    fn reads_big_endian_small_elements_narrow_storage_and_compression() {
        let mut body = Vec::new();
        let be = |v: u32| v.to_be_bytes();
        body.extend([be(MI_UINT32), be(8), be(6), be(0)].concat()); // flags: double
        body.extend([be(MI_INT32), be(8), be(3), be(1)].concat()); // dims 3x1
        body.extend(be((4 << 16) | MI_INT8)); // small element: the name "x_mm"
        body.extend(b"x_mm");
        body.extend([be(MI_INT16), be(6)].concat());
        body.extend(
            [
                (-2i16).to_be_bytes(),
                7i16.to_be_bytes(),
                300i16.to_be_bytes(),
            ]
            .concat(),
        );
        body.extend([0, 0]); // padding
        let mut el = [be(MI_MATRIX), be(body.len() as u32)].concat();
        el.extend(&body);
        let z = miniz_oxide::deflate::compress_to_vec_zlib(&el, 6);
        let mut file = vec![b' '; 124];
        file.extend([0x01, 0x00]);
        file.extend(b"MI");
        file.extend([be(MI_COMPRESSED), be(z.len() as u32)].concat());
        file.extend(&z);
        let vars = read(&file).unwrap();
        assert_eq!(vars.len(), 1);
        assert_eq!(vars[0].name, "x_mm");
        assert_eq!(vars[0].vector().unwrap(), [-2.0, 7.0, 300.0]);
    }
}
