//! The MAT-file writer (level 5, docs/matlab.md): real double matrices and character rows, in
//! uncompressed little-endian files that MATLAB (`load`) and GNU Octave read. The format and its
//! reader are in the core ([`pumpcyl::matfile`]); records are read there.

use pumpcyl::matfile::{
    MI_DOUBLE, MI_INT32, MI_INT8, MI_MATRIX, MI_UINT16, MI_UINT32, MX_CHAR, MX_DOUBLE,
};

/// A MAT-file being built: variables in the order added.
#[derive(Debug, Clone)]
pub struct MatWriter {
    bytes: Vec<u8>,
}

impl MatWriter {
    /// An empty file whose header text says what wrote it (`description`, cut to fit).
    pub fn new(description: &str) -> MatWriter {
        let mut text = format!("MATLAB 5.0 MAT-file, Platform: pumpcyl, {description}");
        text.truncate(116);
        while !text.is_char_boundary(text.len()) {
            text.pop();
        }
        let mut bytes = text.into_bytes();
        bytes.resize(116, b' ');
        bytes.extend_from_slice(&[0; 8]); // no subsystem data
        bytes.extend_from_slice(&0x0100u16.to_le_bytes());
        bytes.extend_from_slice(b"IM");
        MatWriter { bytes }
    }

    /// A real double matrix `rows` × `cols` from its values in column-major order (MATLAB's).
    ///
    /// # Panics
    /// If `name` is not a MATLAB variable name ([`is_var_name`]) or the sizes disagree: both are
    /// the caller's bug, never the user's input.
    pub fn matrix(&mut self, name: &str, rows: usize, cols: usize, col_major: &[f64]) -> &mut Self {
        assert_eq!(rows * cols, col_major.len(), "{name}: size");
        let data: Vec<u8> = col_major.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.variable(name, MX_DOUBLE, [rows, cols], MI_DOUBLE, &data)
    }

    /// A matrix from its rows (all of one length).
    pub fn rows(&mut self, name: &str, rows: &[Vec<f64>]) -> &mut Self {
        let cols = rows.first().map_or(0, Vec::len);
        let col_major: Vec<f64> = (0..cols)
            .flat_map(|j| rows.iter().map(move |r| r[j]))
            .collect();
        self.matrix(name, rows.len(), cols, &col_major)
    }

    /// A column vector.
    pub fn column(&mut self, name: &str, values: &[f64]) -> &mut Self {
        self.matrix(name, values.len(), 1, values)
    }

    /// A 1 × 1 double.
    pub fn scalar(&mut self, name: &str, value: f64) -> &mut Self {
        self.matrix(name, 1, 1, &[value])
    }

    /// A character row vector (UTF-16 code units, as MATLAB stores `char`).
    pub fn text(&mut self, name: &str, text: &str) -> &mut Self {
        let units: Vec<u16> = text.encode_utf16().collect();
        let data: Vec<u8> = units.iter().flat_map(|u| u.to_le_bytes()).collect();
        self.variable(name, MX_CHAR, [1, units.len()], MI_UINT16, &data)
    }

    /// The file's bytes.
    pub fn into_bytes(self) -> Vec<u8> {
        self.bytes
    }

    fn variable(
        &mut self,
        name: &str,
        class: u8,
        dims: [usize; 2],
        data_type: u32,
        data: &[u8],
    ) -> &mut Self {
        assert!(is_var_name(name), "`{name}` is not a MATLAB variable name");
        let mut body = Vec::new();
        element(
            &mut body,
            MI_UINT32,
            &[u32::from(class).to_le_bytes(), [0; 4]].concat(),
        );
        let dims: Vec<u8> = dims
            .iter()
            .flat_map(|&d| {
                i32::try_from(d)
                    .expect("dimension below 2^31")
                    .to_le_bytes()
            })
            .collect();
        element(&mut body, MI_INT32, &dims);
        element(&mut body, MI_INT8, name.as_bytes());
        element(&mut body, data_type, data);
        element(&mut self.bytes, MI_MATRIX, &body);
        self
    }
}

/// Append one data element (tag, data, padding to 8 bytes), little endian.
fn element(out: &mut Vec<u8>, data_type: u32, data: &[u8]) {
    out.extend_from_slice(&data_type.to_le_bytes());
    let n = u32::try_from(data.len()).expect("a MAT-file element below 4 GiB");
    out.extend_from_slice(&n.to_le_bytes());
    out.extend_from_slice(data);
    out.resize(out.len() + (8 - data.len() % 8) % 8, 0);
}

/// Whether `name` is a MATLAB variable name: a letter, then letters, digits or `_`, at most 63.
pub fn is_var_name(name: &str) -> bool {
    let mut chars = name.chars();
    name.len() <= 63
        && chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// A MATLAB variable name made from any label: other characters become `_`, a leading
/// non-letter gets a `v` in front, and the result is cut to 63 characters.
pub fn var_name(label: &str) -> String {
    let mut s: String = label
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if !s.starts_with(|c: char| c.is_ascii_alphabetic()) {
        s.insert(0, 'v');
    }
    s.truncate(63);
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumpcyl::matfile::read_stream;
    use pumpcyl::matfile::{read, Data, Variable, HEADER_BYTES, MI_MATRIX};

    fn real(v: &Variable) -> &[f64] {
        match &v.data {
            Data::Real(x) => x,
            Data::Other(w) => panic!("{w}"),
        }
    }

    #[test]
    fn written_variables_read_back_exactly() {
        let mut w = MatWriter::new("test");
        w.rows("A", &[vec![1.0, 2.0, 3.0], vec![4.0, 5.0, 6.0]])
            .column("x_mm", &[0.1, f64::MIN_POSITIVE, -1e300])
            .scalar("k", std::f64::consts::PI)
            .text("note", "bar, rad/s, N·m");
        let bytes = w.into_bytes();
        assert_eq!(&bytes[126..128], b"IM");
        assert_eq!(bytes.len() % 8, 0);
        let vars = read(&bytes).unwrap();
        let names: Vec<&str> = vars.iter().map(|v| v.name.as_str()).collect();
        assert_eq!(names, ["A", "x_mm", "k", "note"]);
        assert_eq!(vars[0].dims, [2, 3]);
        assert_eq!(real(&vars[0]), [1.0, 4.0, 2.0, 5.0, 3.0, 6.0]); // column-major
        assert_eq!(real(&vars[1]), [0.1, f64::MIN_POSITIVE, -1e300]);
        assert_eq!(vars[1].dims, [3, 1]);
        assert_eq!(real(&vars[2]), [std::f64::consts::PI]);
        assert_eq!(vars[3].data, Data::Other("char array"));
        assert_eq!(vars[3].dims, [1, 15]);
        assert!(vars[3].vector().unwrap_err().0.contains("char"));
        assert!(vars[0].vector().unwrap_err().0.contains("2x3"));
    }

    #[test]
    fn broken_files_are_errors_not_panics() {
        let mut w = MatWriter::new("t");
        w.column("time_s", &[0.0, 1.0, 2.0]);
        let good = w.into_bytes();
        assert!(read(&good[..100]).unwrap_err().0.contains("128-byte"));
        for cut in 129..good.len() {
            let _ = read(&good[..cut]); // never panics
        }
        let mut huge = good.clone();
        huge[132..136].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(read(&huge).unwrap_err().0.contains("remain"));
        let mut text = good.clone();
        text[126..128].copy_from_slice(b"xx");
        assert!(read(&text).unwrap_err().0.contains("level-5"));
        // a compression bomb stops at the limit (a small stand-in: the limit is checked)
        let zeros = vec![0u8; 1 << 20];
        let z = miniz_oxide::deflate::compress_to_vec_zlib(&zeros, 9);
        assert!(miniz_oxide::inflate::decompress_to_vec_zlib_with_limit(&z, 1000).is_err());
    }

    /// A reader that yields `head` and then `tail` forever.
    struct Endless {
        head: std::io::Cursor<Vec<u8>>,
        tail: Box<dyn FnMut() -> u8>,
        served: u64,
    }

    impl std::io::Read for Endless {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let n = self.head.read(buf)?;
            if n > 0 {
                return Ok(n);
            }
            buf.iter_mut().for_each(|b| *b = (self.tail)());
            self.served += buf.len() as u64;
            Ok(buf.len())
        }
    }

    fn endless(head: Vec<u8>, tail: impl FnMut() -> u8 + 'static) -> Endless {
        Endless {
            head: std::io::Cursor::new(head),
            tail: Box::new(tail),
            served: 0,
        }
    }

    #[test]
    fn a_stream_is_read_whole_and_an_endless_one_refused_at_its_first_wrong_tag() {
        let mut w = MatWriter::new("t");
        w.column("time_s", &[0.0, 1.0, 2.0]).text("note", "ab");
        let good = w.into_bytes();
        let read_back = read_stream(&mut std::io::Cursor::new(good.clone()), 1 << 20).unwrap();
        assert_eq!(read_back, good);
        // a valid header and then zeros for ever (a link to /dev/zero after a header)
        let header = good[..HEADER_BYTES].to_vec();
        let mut zeros = endless(header.clone(), || 0);
        let e = read_stream(&mut zeros, 2 << 30).unwrap_err().to_string();
        assert!(e.contains("byte 128") && e.contains("type 0"), "{e}");
        assert!(
            zeros.served < 1 << 16,
            "read {} bytes of zeros",
            zeros.served
        );
        // a valid file and then random bytes (an LCG): refused within a few elements
        let mut state = 12345u64;
        let mut noise = endless(good.clone(), move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 56) as u8
        });
        assert!(read_stream(&mut noise, 2 << 30).is_err());
        assert!(
            noise.served < 1 << 20,
            "read {} bytes of noise",
            noise.served
        );
        // an element whose declared size passes the limit is refused before it is read
        let mut big = header.clone();
        big.extend(MI_MATRIX.to_le_bytes());
        big.extend(u32::MAX.to_le_bytes());
        let mut stream = endless(big, || 0);
        let e = read_stream(&mut stream, 1 << 20).unwrap_err().to_string();
        assert!(e.contains("limit"), "{e}");
        assert_eq!(stream.served, 0);
        // a file cut inside a tag, and a header that is not one
        let cut = read_stream(
            &mut std::io::Cursor::new(good[..HEADER_BYTES + 4].to_vec()),
            1 << 20,
        );
        assert!(cut.unwrap_err().to_string().contains("cut short"));
        let spaces = [b' '; 200];
        assert!(read_stream(&mut spaces.as_slice(), 1 << 20)
            .unwrap_err()
            .to_string()
            .contains("level-5"));
    }

    /// A fuzz-like property on the stable toolchain (the coverage-guided search is the
    /// `record_mat` fuzz target): any edit of a valid file, plain or compressed (the edit made
    /// before compressing, so it reaches the inner parser), gives an answer or an error, never
    /// a panic.
    mod mutations {
        use super::super::*;
        use proptest::prelude::*;
        use pumpcyl::matfile::{read, MI_COMPRESSED};

        fn plain() -> Vec<u8> {
            let mut w = MatWriter::new("p");
            w.column("time_s", &[0.0, 0.01, 0.02])
                .rows("x_mm", &[vec![1.0, 2.0]])
                .text("note", "ab");
            w.into_bytes()
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(400))]
            #[test]
            fn edited_files_never_panic(
                edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..6),
                cut in any::<usize>(),
                compress in any::<bool>(),
            ) {
                let mut bytes = plain();
                for (at, b) in &edits {
                    let i = 128 + at % (bytes.len() - 128);
                    bytes[i] = *b;
                }
                bytes.truncate(128 + cut % (bytes.len() - 127));
                if compress {
                    let z = miniz_oxide::deflate::compress_to_vec_zlib(&bytes[128..], 1);
                    bytes.truncate(128);
                    bytes.extend(MI_COMPRESSED.to_le_bytes());
                    bytes.extend((z.len() as u32).to_le_bytes());
                    bytes.extend(z);
                }
                let _ = read(&bytes);
                let _ = pumpcyl::record::Record::parse_mat(&bytes, "m.mat");
            }
        }
    }

    #[test]
    fn variable_names() {
        assert!(is_var_name("x_ref_mm") && !is_var_name("1x") && !is_var_name("a-b"));
        assert_eq!(var_name("beta_bar=37.8"), "beta_bar_37_8");
        assert_eq!(var_name("0.2 Hz"), "v0_2_Hz");
        assert!(is_var_name(&var_name(&"é".repeat(80))));
    }
}
