//! Netpbm greyscale images: read P5 (binary, 8 or 16 bit) and P2 (ASCII); write P5.
//!
//! Written here rather than pulled from a crate: the format is a short header and a
//! raster. Rows are stored top first. Errors name the file and the header line or the
//! reason; nothing panics on malformed input. Knows nothing of occupancy.

use crate::error::MapError;
use std::path::Path;

/// Images beyond this many pixels are refused before anything is allocated.
pub const MAX_PIXELS: usize = 1 << 26;

/// A decoded greyscale image: `pixels[row * width + col]`, row 0 at the top.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pgm {
    pub width: usize,
    pub height: usize,
    pub maxval: u16,
    pub pixels: Vec<u16>,
}

/// A cursor over the header that knows the line it is on.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> Cursor<'a> {
    /// Skips whitespace and `#` comments (comments run to the end of the line).
    fn skip_blank(&mut self) {
        while let Some(&b) = self.bytes.get(self.pos) {
            if b == b'#' {
                while let Some(&c) = self.bytes.get(self.pos) {
                    if c == b'\n' {
                        break;
                    }
                    self.pos += 1;
                }
            } else if b.is_ascii_whitespace() {
                if b == b'\n' {
                    self.line += 1;
                }
                self.pos += 1;
            } else {
                break;
            }
        }
    }

    /// The next decimal number; `what` names it in errors (built only on failure).
    fn number(&mut self, file: &Path, what: impl Fn() -> String) -> Result<u64, MapError> {
        self.skip_blank();
        let start = self.pos;
        while self.bytes.get(self.pos).is_some_and(u8::is_ascii_digit) {
            self.pos += 1;
        }
        let line = Some(self.line);
        if start == self.pos {
            let found = match self.bytes.get(self.pos) {
                None => "the end of the file".to_string(),
                Some(b) => format!("byte {b:#04x}"),
            };
            return Err(MapError::ros(
                file,
                line,
                None,
                format!("expected the {}, found {found}", what()),
            ));
        }
        // Digits only, so the text is ASCII; overflow is the only failure.
        std::str::from_utf8(&self.bytes[start..self.pos])
            .ok()
            .and_then(|s| s.parse::<u64>().ok())
            .ok_or_else(|| MapError::ros(file, line, None, format!("the {} is too large", what())))
    }
}

/// The numbers of the header, checked.
struct Header {
    width: u64,
    height: u64,
    maxval: u64,
    /// Pixel count, at most [`MAX_PIXELS`].
    n: usize,
}

/// Decodes a P5 or P2 image.
pub fn parse_pgm(file: &Path, bytes: &[u8]) -> Result<Pgm, MapError> {
    let binary = is_binary(file, bytes)?;
    let mut cur = Cursor {
        bytes,
        pos: 2,
        line: 1,
    };
    let h = header(file, &mut cur)?;
    let mut pixels = Vec::with_capacity(h.n);
    if binary {
        binary_raster(file, &cur, &h, &mut pixels)?;
    } else {
        for i in 0..h.n {
            let v = cur.number(file, || format!("value of pixel {i}"))?;
            pixels.push(v.min(u64::from(u16::MAX)) as u16);
        }
    }
    let maxval = h.maxval;
    if let Some((i, v)) = pixels
        .iter()
        .enumerate()
        .find(|&(_, &v)| u64::from(v) > maxval)
    {
        return Err(MapError::ros(
            file,
            None,
            None,
            format!("pixel {i} has value {v}, above the maximum {maxval}"),
        ));
    }
    Ok(Pgm {
        width: h.width as usize,
        height: h.height as usize,
        maxval: maxval as u16,
        pixels,
    })
}

/// Whether the magic number says binary (`P5`) or ASCII (`P2`).
fn is_binary(file: &Path, bytes: &[u8]) -> Result<bool, MapError> {
    match bytes.get(..2) {
        Some(b"P5") => Ok(true),
        Some(b"P2") => Ok(false),
        _ => Err(MapError::ros(
            file,
            Some(1),
            None,
            "not a PGM image: expected `P5` or `P2` at the start",
        )),
    }
}

/// Reads width, height and maximum grey value, and refuses an empty image, one beyond
/// [`MAX_PIXELS`] and a maximum outside 1..=65535.
fn header(file: &Path, cur: &mut Cursor) -> Result<Header, MapError> {
    let width = cur.number(file, || "width".into())?;
    let height = cur.number(file, || "height".into())?;
    let maxval = cur.number(file, || "maximum grey value".into())?;
    if width == 0 || height == 0 {
        return Err(MapError::ros(
            file,
            Some(cur.line),
            None,
            format!("image is {width} x {height}: empty"),
        ));
    }
    let n = width
        .checked_mul(height)
        .filter(|&n| n <= MAX_PIXELS as u64)
        .ok_or_else(|| {
            MapError::ros(
                file,
                Some(cur.line),
                None,
                format!("image of {width} x {height} pixels is too large (at most {MAX_PIXELS})"),
            )
        })? as usize;
    if !(1..=65535).contains(&maxval) {
        return Err(MapError::ros(
            file,
            Some(cur.line),
            None,
            format!("maximum grey value {maxval} is not in 1..=65535"),
        ));
    }
    Ok(Header {
        width,
        height,
        maxval,
        n,
    })
}

/// The P5 raster after the header: one or two bytes (big endian) per pixel.
fn binary_raster(
    file: &Path,
    cur: &Cursor,
    h: &Header,
    pixels: &mut Vec<u16>,
) -> Result<(), MapError> {
    // Exactly one whitespace byte separates the header from the raster.
    if !cur.bytes.get(cur.pos).is_some_and(u8::is_ascii_whitespace) {
        return Err(MapError::ros(
            file,
            Some(cur.line),
            None,
            "expected one whitespace byte after the maximum grey value",
        ));
    }
    let (n, width, height) = (h.n, h.width, h.height);
    let data = &cur.bytes[cur.pos + 1..];
    let depth = if h.maxval < 256 { 1 } else { 2 };
    if data.len() < n * depth {
        return Err(MapError::ros(
            file,
            None,
            None,
            format!(
                "image data is {} bytes, {width} x {height} at {depth} byte(s) per pixel needs {}",
                data.len(),
                n * depth
            ),
        ));
    }
    if depth == 1 {
        pixels.extend(data[..n].iter().map(|&b| u16::from(b)));
    } else {
        pixels.extend(
            data[..2 * n]
                .chunks_exact(2)
                .map(|c| u16::from_be_bytes([c[0], c[1]])),
        );
    }
    Ok(())
}

/// A binary (P5) 8-bit image, rows top first.
pub fn encode_p5(width: usize, height: usize, pixels: &[u8]) -> Vec<u8> {
    let header = format!("P5\n# CREATOR: aisle-mapper\n{width} {height}\n255\n");
    let mut out = Vec::with_capacity(header.len() + pixels.len());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(pixels);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(bytes: &[u8]) -> String {
        parse_pgm(Path::new("img.pgm"), bytes)
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn p5_round_trips_and_p2_reads() {
        let px = [0u8, 254, 205, 0, 254, 254];
        let bytes = encode_p5(3, 2, &px);
        let img = parse_pgm(Path::new("a.pgm"), &bytes).unwrap();
        assert_eq!((img.width, img.height, img.maxval), (3, 2, 255));
        assert_eq!(
            img.pixels,
            px.iter().map(|&p| u16::from(p)).collect::<Vec<_>>()
        );
        let p2 = b"P2\n# a comment\n3 2\n# another\n255\n0 254 205\n0 254 254\n";
        assert_eq!(parse_pgm(Path::new("b.pgm"), p2).unwrap(), img);
        let p5_16 = [b"P5 1 2 1000\n".as_slice(), &[0x03, 0xE8, 0x00, 0x01]].concat();
        let img16 = parse_pgm(Path::new("c.pgm"), &p5_16).unwrap();
        assert_eq!(img16.pixels, vec![1000, 1]);
    }

    #[test]
    fn malformed_images_are_errors_naming_the_file() {
        assert!(err(b"").starts_with("img.pgm:1:"));
        assert!(err(b"P6\n1 1\n255\n\0").contains("not a PGM"));
        let e = err(b"P5\n# c\n3 x\n255\n");
        assert!(e.starts_with("img.pgm:3:") && e.contains("height"), "{e}");
        assert!(err(b"P5 0 2 255\n").contains("empty"));
        assert!(err(b"P5 2 2 0\n").contains("maximum grey value 0"));
        assert!(err(b"P5 2 2 255\n\x01\x02").contains("needs 4"));
        assert!(err(b"P5 99999999999 99999999999 255\n").contains("too large"));
        assert!(err(b"P5 2 2 255").contains("whitespace"));
        assert!(err(b"P2 2 1 10\n3 11\n").contains("above the maximum"));
        assert!(err(b"P2 2 1 10\n3\n").contains("pixel 1"));
        assert!(err(b"P5 999999999999999999999999 1 255\n").contains("too large"));
    }
}
