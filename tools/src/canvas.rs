//! A small RGB raster with world (metre) coordinates: filled and outlined rotated
//! rectangles, thick polylines, discs, a 5x7 pixel font for labels, and PNG encoding.
//!
//! Knows pixels and metres only, nothing about runs or messages.

/// An RGB colour.
pub type Rgb = [u8; 3];

/// An RGB image mapping the world rectangle `[x0, x0 + w/ppm] x [y0, y0 + h/ppm]` onto
/// its pixels, y up.
#[derive(Debug, Clone, PartialEq)]
pub struct Canvas {
    pub width: u32,
    pub height: u32,
    pixels: Vec<u8>,
    x0: f64,
    y0: f64,
    ppm: f64,
}

#[derive(Debug, thiserror::Error)]
pub enum CanvasError {
    #[error("image of {width} x {height} pixels is empty or larger than 16384 on a side")]
    BadSize { width: f64, height: f64 },
    #[error("png: {0}")]
    Png(#[from] png::EncodingError),
}

impl Canvas {
    /// A canvas covering `width_m` x `height_m` metres from `(x0, y0)` at `ppm` pixels per
    /// metre, filled with `background`.
    pub fn new(
        x0: f64,
        y0: f64,
        width_m: f64,
        height_m: f64,
        ppm: f64,
        background: Rgb,
    ) -> Result<Self, CanvasError> {
        let (w, h) = ((width_m * ppm).round(), (height_m * ppm).round());
        if !(w >= 1.0 && h >= 1.0 && w <= 16384.0 && h <= 16384.0) {
            return Err(CanvasError::BadSize {
                width: w,
                height: h,
            });
        }
        let (width, height) = (w as u32, h as u32);
        let mut pixels = Vec::with_capacity(width as usize * height as usize * 3);
        for _ in 0..width as usize * height as usize {
            pixels.extend_from_slice(&background);
        }
        Ok(Self {
            width,
            height,
            pixels,
            x0,
            y0,
            ppm,
        })
    }

    pub fn pixels(&self) -> &[u8] {
        &self.pixels
    }

    /// World point -> pixel coordinates (continuous, y down).
    pub fn to_px(&self, x: f64, y: f64) -> (f64, f64) {
        (
            (x - self.x0) * self.ppm,
            self.height as f64 - (y - self.y0) * self.ppm,
        )
    }

    /// Pixel centre -> world point.
    pub fn to_world(&self, px: u32, py: u32) -> (f64, f64) {
        (
            self.x0 + (px as f64 + 0.5) / self.ppm,
            self.y0 + (self.height as f64 - py as f64 - 0.5) / self.ppm,
        )
    }

    pub fn get(&self, px: u32, py: u32) -> Option<Rgb> {
        if px >= self.width || py >= self.height {
            return None;
        }
        let i = (py as usize * self.width as usize + px as usize) * 3;
        Some([self.pixels[i], self.pixels[i + 1], self.pixels[i + 2]])
    }

    /// Blends `c` over the pixel with opacity `alpha` (0..1).
    pub fn blend(&mut self, px: i64, py: i64, c: Rgb, alpha: f64) {
        if px < 0 || py < 0 || px >= i64::from(self.width) || py >= i64::from(self.height) {
            return;
        }
        let i = (py as usize * self.width as usize + px as usize) * 3;
        for (p, new) in self.pixels[i..i + 3].iter_mut().zip(c) {
            let old = f64::from(*p);
            *p = (old + (f64::from(new) - old) * alpha).round() as u8;
        }
    }

    pub fn set(&mut self, px: i64, py: i64, c: Rgb) {
        self.blend(px, py, c, 1.0);
    }

    /// Fills a rotated rectangle, blending with opacity `alpha`.
    pub fn fill_rect(&mut self, r: Rect, c: Rgb, alpha: f64) {
        let corners = r.corners();
        let px: Vec<(f64, f64)> = corners.iter().map(|&(a, b)| self.to_px(a, b)).collect();
        let (minx, maxx) = bounds(px.iter().map(|p| p.0));
        let (miny, maxy) = bounds(px.iter().map(|p| p.1));
        let (c_, s_) = (r.theta.cos(), r.theta.sin());
        let ys = miny.floor().max(0.0) as i64..=maxy.ceil().min(f64::from(self.height)) as i64;
        for py in ys {
            let xs = minx.floor().max(0.0) as i64..=maxx.ceil().min(f64::from(self.width)) as i64;
            for pxi in xs {
                let (wx, wy) = self.to_world(pxi as u32, py as u32);
                let (dx, dy) = (wx - r.x, wy - r.y);
                let (lx, ly) = (c_ * dx + s_ * dy, -s_ * dx + c_ * dy);
                if lx.abs() <= r.length / 2.0 && ly.abs() <= r.width / 2.0 {
                    self.blend(pxi, py, c, alpha);
                }
            }
        }
    }

    /// Outlines a rotated rectangle with a line `px_width` pixels thick.
    pub fn stroke_rect(&mut self, r: Rect, px_width: f64, c: Rgb) {
        let mut corners = r.corners().to_vec();
        corners.push(corners[0]);
        self.polyline(&corners, px_width, c, 1.0);
    }

    /// A disc of `radius_px` pixels around a world point.
    pub fn disc(&mut self, x: f64, y: f64, radius_px: f64, c: Rgb, alpha: f64) {
        let (cx, cy) = self.to_px(x, y);
        self.disc_px(cx, cy, radius_px, c, alpha);
    }

    fn disc_px(&mut self, cx: f64, cy: f64, r: f64, c: Rgb, alpha: f64) {
        let r2 = r * r;
        for py in (cy - r).floor() as i64..=(cy + r).ceil() as i64 {
            for px in (cx - r).floor() as i64..=(cx + r).ceil() as i64 {
                let (dx, dy) = (px as f64 + 0.5 - cx, py as f64 + 0.5 - cy);
                if dx * dx + dy * dy <= r2 {
                    self.blend(px, py, c, alpha);
                }
            }
        }
    }

    /// A polyline through world points, `px_width` pixels thick.
    pub fn polyline(&mut self, pts: &[(f64, f64)], px_width: f64, c: Rgb, alpha: f64) {
        let r = (px_width / 2.0).max(0.5);
        for w in pts.windows(2) {
            let (ax, ay) = self.to_px(w[0].0, w[0].1);
            let (bx, by) = self.to_px(w[1].0, w[1].1);
            if !(ax.is_finite() && ay.is_finite() && bx.is_finite() && by.is_finite()) {
                continue;
            }
            let len = (bx - ax).hypot(by - ay);
            // Lines far outside the image are skipped rather than walked pixel by pixel.
            if len > 4.0 * f64::from(self.width + self.height) {
                continue;
            }
            let steps = (len / (r * 0.5).max(0.5)).ceil().max(1.0) as usize;
            for i in 0..=steps {
                let t = i as f64 / steps as f64;
                self.disc_px(ax + (bx - ax) * t, ay + (by - ay) * t, r, c, alpha);
            }
        }
    }

    /// Writes `text` (upper-case letters, digits, a few signs) with its top-left corner
    /// at pixel `(px, py)`, `scale` pixels per font pixel.
    pub fn text(&mut self, px: i64, py: i64, text: &str, scale: i64, c: Rgb) {
        let mut x = px;
        for ch in text.chars() {
            let rows = glyph(ch.to_ascii_uppercase());
            for (ry, bits) in rows.iter().enumerate() {
                for rx in 0..5 {
                    if bits & (0x10 >> rx) != 0 {
                        for sy in 0..scale {
                            for sx in 0..scale {
                                self.set(x + rx * scale + sx, py + ry as i64 * scale + sy, c);
                            }
                        }
                    }
                }
            }
            x += 6 * scale;
        }
    }

    /// Encodes the image as an 8-bit RGB PNG.
    pub fn png(&self) -> Result<Vec<u8>, CanvasError> {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, self.width, self.height);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut w = enc.write_header()?;
            w.write_image_data(&self.pixels)?;
            w.finish()?;
        }
        Ok(out)
    }
}

fn bounds(v: impl Iterator<Item = f64>) -> (f64, f64) {
    v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
        (a.min(x), b.max(x))
    })
}

/// A rectangle in the world: centre, heading, `length` along the heading, `width` across.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    pub x: f64,
    pub y: f64,
    pub theta: f64,
    pub length: f64,
    pub width: f64,
}

impl Rect {
    fn corners(&self) -> [(f64, f64); 4] {
        let (c, s) = (self.theta.cos(), self.theta.sin());
        let (hl, hw) = (self.length / 2.0, self.width / 2.0);
        [(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)]
            .map(|(a, b)| (self.x + c * a - s * b, self.y + s * a + c * b))
    }
}

/// 5x7 glyphs (one byte per row, low 5 bits, MSB left).
fn glyph(c: char) -> [u8; 7] {
    match c {
        'A' => [0x0e, 0x11, 0x11, 0x1f, 0x11, 0x11, 0x11],
        'B' => [0x1e, 0x11, 0x11, 0x1e, 0x11, 0x11, 0x1e],
        'C' => [0x0e, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0e],
        'D' => [0x1e, 0x11, 0x11, 0x11, 0x11, 0x11, 0x1e],
        'E' => [0x1f, 0x10, 0x10, 0x1e, 0x10, 0x10, 0x1f],
        'F' => [0x1f, 0x10, 0x10, 0x1e, 0x10, 0x10, 0x10],
        'G' => [0x0e, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0f],
        'H' => [0x11, 0x11, 0x11, 0x1f, 0x11, 0x11, 0x11],
        'I' => [0x0e, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0e],
        'J' => [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0c],
        'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1f],
        'M' => [0x11, 0x1b, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0e, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0e],
        'P' => [0x1e, 0x11, 0x11, 0x1e, 0x10, 0x10, 0x10],
        'Q' => [0x0e, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0d],
        'R' => [0x1e, 0x11, 0x11, 0x1e, 0x14, 0x12, 0x11],
        'S' => [0x0f, 0x10, 0x10, 0x0e, 0x01, 0x01, 0x1e],
        'T' => [0x1f, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0e],
        'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0a, 0x04],
        'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0a],
        'X' => [0x11, 0x11, 0x0a, 0x04, 0x0a, 0x11, 0x11],
        'Y' => [0x11, 0x11, 0x0a, 0x04, 0x04, 0x04, 0x04],
        'Z' => [0x1f, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1f],
        '0' => [0x0e, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0e],
        '1' => [0x04, 0x0c, 0x04, 0x04, 0x04, 0x04, 0x0e],
        '2' => [0x0e, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1f],
        '3' => [0x1f, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0e],
        '4' => [0x02, 0x06, 0x0a, 0x12, 0x1f, 0x02, 0x02],
        '5' => [0x1f, 0x10, 0x1e, 0x01, 0x01, 0x11, 0x0e],
        '6' => [0x06, 0x08, 0x10, 0x1e, 0x11, 0x11, 0x0e],
        '7' => [0x1f, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0e, 0x11, 0x11, 0x0e, 0x11, 0x11, 0x0e],
        '9' => [0x0e, 0x11, 0x11, 0x0f, 0x01, 0x02, 0x0c],
        '.' => [0, 0, 0, 0, 0, 0x0c, 0x0c],
        ',' => [0, 0, 0, 0, 0x0c, 0x04, 0x08],
        ':' => [0, 0x0c, 0x0c, 0, 0x0c, 0x0c, 0],
        '-' => [0, 0, 0, 0x1f, 0, 0, 0],
        '+' => [0, 0x04, 0x04, 0x1f, 0x04, 0x04, 0],
        '/' => [0x01, 0x01, 0x02, 0x04, 0x08, 0x10, 0x10],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        '=' => [0, 0, 0x1f, 0, 0x1f, 0, 0],
        _ => [0; 7],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn world_and_pixel_coordinates_agree() {
        let c = Canvas::new(-5.0, -10.0, 20.0, 30.0, 10.0, [255; 3]).unwrap();
        assert_eq!((c.width, c.height), (200, 300));
        let (x, y) = c.to_world(0, 299);
        assert!((x + 4.95).abs() < 1e-9 && (y + 9.95).abs() < 1e-9);
        let (px, py) = c.to_px(x, y);
        assert!((px - 0.5).abs() < 1e-9 && (py - 299.5).abs() < 1e-9);
        assert!(Canvas::new(0.0, 0.0, 0.0, 1.0, 10.0, [0; 3]).is_err());
        assert!(Canvas::new(0.0, 0.0, f64::NAN, 1.0, 10.0, [0; 3]).is_err());
    }

    #[test]
    fn shapes_land_where_they_should() {
        let mut c = Canvas::new(0.0, 0.0, 10.0, 10.0, 10.0, [255; 3]).unwrap();
        let r = Rect {
            x: 5.0,
            y: 5.0,
            theta: 0.0,
            length: 2.0,
            width: 1.0,
        };
        c.fill_rect(r, [0, 0, 0], 1.0);
        assert_eq!(c.get(50, 50), Some([0, 0, 0]));
        assert_eq!(
            c.get(50, 44),
            Some([255; 3]),
            "1 m wide: 0.5 m above is clear"
        );
        assert_eq!(c.get(41, 50), Some([0, 0, 0]));
        c.polyline(&[(1.0, 1.0), (9.0, 1.0)], 3.0, [255, 0, 0], 1.0);
        assert_eq!(c.get(50, 90), Some([255, 0, 0]));
        // A line through infinity or far away does not hang or panic.
        c.polyline(&[(1.0, 1.0), (f64::INFINITY, 1.0)], 3.0, [255, 0, 0], 1.0);
        c.polyline(&[(1.0, 1.0), (1e12, 1.0)], 3.0, [255, 0, 0], 1.0);
        c.text(2, 2, "AB 1.5", 1, [0, 0, 255]);
        assert_eq!(c.get(4, 2), Some([0, 0, 255]), "top bar of the A");
        let png = c.png().unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }
}
