//! Pictures that show how filters differ: RGBA images with text set in a
//! real font (DejaVu Sans through ab_glyph), labelled contact sheets,
//! colour-coded error images with a colour bar, SVG plots (plotters) and the
//! demo's HTML page.

pub mod html;
pub mod plots;
pub mod text;

use text::Typeface;

/// An RGBA8 image, row-major from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<u8>,
}

impl Image {
    /// A canvas filled with one colour.
    pub fn filled(width: u32, height: u32, rgb: [u8; 3]) -> Image {
        let mut rgba = Vec::with_capacity(width as usize * height as usize * 4);
        for _ in 0..width as usize * height as usize {
            rgba.extend_from_slice(&[rgb[0], rgb[1], rgb[2], 255]);
        }
        Image { width, height, rgba }
    }

    /// Wraps pixels (length width x height x 4).
    pub fn from_rgba(width: u32, height: u32, rgba: Vec<u8>) -> Image {
        assert_eq!(rgba.len(), width as usize * height as usize * 4, "RGBA length must be width x height x 4");
        Image { width, height, rgba }
    }

    /// The pixel at (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 4] {
        let i = (y as usize * self.width as usize + x as usize) * 4;
        [self.rgba[i], self.rgba[i + 1], self.rgba[i + 2], self.rgba[i + 3]]
    }

    /// Blends `rgb` over the pixel at (x, y) with coverage `a` in [0, 1];
    /// outside the image nothing happens.
    pub fn blend(&mut self, x: i64, y: i64, rgb: [u8; 3], a: f32) {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return;
        }
        let i = (y as usize * self.width as usize + x as usize) * 4;
        let a = a.clamp(0.0, 1.0);
        for (dst, &src) in self.rgba[i..i + 3].iter_mut().zip(&rgb) {
            *dst = (*dst as f32 * (1.0 - a) + src as f32 * a).round() as u8;
        }
        self.rgba[i + 3] = 255;
    }

    /// Fills a rectangle (clipped to the image).
    pub fn fill_rect(&mut self, x: i64, y: i64, w: u32, h: u32, rgb: [u8; 3]) {
        for yy in y..y + h as i64 {
            for xx in x..x + w as i64 {
                self.blend(xx, yy, rgb, 1.0);
            }
        }
    }

    /// Copies `src` with its top-left corner at (x, y) (clipped).
    pub fn blit(&mut self, src: &Image, x: i64, y: i64) {
        for sy in 0..src.height {
            for sx in 0..src.width {
                let p = src.pixel(sx, sy);
                self.blend(x + sx as i64, y + sy as i64, [p[0], p[1], p[2]], p[3] as f32 / 255.0);
            }
        }
    }

    /// The w x h window at (x, y), scaled by an integer factor (nearest).
    pub fn crop_zoom(&self, x: u32, y: u32, w: u32, h: u32, zoom: u32) -> Image {
        let mut out = Image::filled(w * zoom, h * zoom, [0, 0, 0]);
        for oy in 0..h * zoom {
            for ox in 0..w * zoom {
                let (sx, sy) = ((x + ox / zoom).min(self.width - 1), (y + oy / zoom).min(self.height - 1));
                let p = self.pixel(sx, sy);
                let i = (oy as usize * out.width as usize + ox as usize) * 4;
                out.rgba[i..i + 4].copy_from_slice(&p);
            }
        }
        out
    }
}

/// One tile of a contact sheet: the picture and the caption lines under it.
pub struct Tile {
    pub image: Image,
    pub caption: Vec<String>,
}

const BACKGROUND: [u8; 3] = [24, 24, 28];
const INK: [u8; 3] = [235, 235, 235];
const MUTED: [u8; 3] = [170, 170, 180];

/// A titled sheet of tiles in `columns` columns, each with its caption set
/// under it (the first caption line bold-sized, the rest smaller).
pub fn contact_sheet(face: &Typeface, title: &str, tiles: &[Tile], columns: usize) -> Image {
    let columns = columns.max(1);
    let tile_w = tiles.iter().map(|t| t.image.width).max().unwrap_or(1);
    let tile_h = tiles.iter().map(|t| t.image.height).max().unwrap_or(1);
    let lines = tiles.iter().map(|t| t.caption.len()).max().unwrap_or(0) as u32;
    let (pad, title_px, head_px, line_px) = (12u32, 26.0f32, 17.0f32, 14.0f32);
    let caption_h = if lines == 0 { 0 } else { head_px as u32 + 6 + (lines - 1) * (line_px as u32 + 4) + pad };
    let rows = tiles.len().div_ceil(columns) as u32;
    let title_h = title_px as u32 + 2 * pad;
    let width = columns as u32 * (tile_w + pad) + pad;
    let height = title_h + rows * (tile_h + caption_h + pad);
    let mut sheet = Image::filled(width, height, BACKGROUND);
    // A long title is set smaller so it fits the sheet.
    let room = (width - 2 * pad) as f32;
    let fitted = title_px * (room / face.width(title_px, title).max(1.0)).min(1.0);
    face.draw(&mut sheet, pad as f32, pad as f32 + (title_px - fitted) / 2.0, fitted, title, INK);
    for (i, t) in tiles.iter().enumerate() {
        let (col, row) = ((i % columns) as u32, (i / columns) as u32);
        let x = pad + col * (tile_w + pad);
        let y = title_h + row * (tile_h + caption_h + pad);
        sheet.blit(&t.image, x as i64, y as i64);
        let mut ty = (y + tile_h + 6) as f32;
        for (k, line) in t.caption.iter().enumerate() {
            let (px, ink) = if k == 0 { (head_px, INK) } else { (line_px, MUTED) };
            face.draw(&mut sheet, x as f32, ty, px, line, ink);
            ty += px + 4.0;
        }
    }
    sheet
}

/// A perceptually ordered colour map (viridis, 9 control points, linear in
/// between): 0 dark blue-violet, 1 yellow.
pub fn colormap(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 1.0 };
    let f = t * (STOPS.len() - 1) as f64;
    let i = (f.floor() as usize).min(STOPS.len() - 2);
    let u = f - i as f64;
    std::array::from_fn(|c| (STOPS[i][c] * (1.0 - u) + STOPS[i + 1][c] * u).round() as u8)
}

/// A colour-coded image of `values` (row-major, width x height) on the
/// scale [0, max], with a labelled vertical colour bar at the right.
pub fn error_image(face: &Typeface, values: &[f64], width: u32, height: u32, max: f64, label: &str) -> Image {
    assert_eq!(values.len(), width as usize * height as usize, "one value per pixel");
    let bar_w = 18u32;
    let gap = 8u32;
    let text_w = 70u32;
    let mut img = Image::filled(width + gap + bar_w + gap + text_w, height, BACKGROUND);
    let scale = if max > 0.0 { max } else { 1.0 };
    for y in 0..height {
        for x in 0..width {
            let c = colormap(values[(y * width + x) as usize] / scale);
            img.blend(x as i64, y as i64, c, 1.0);
        }
    }
    let bx = (width + gap) as i64;
    for y in 0..height {
        let t = 1.0 - y as f64 / (height.max(2) - 1) as f64;
        img.fill_rect(bx, y as i64, bar_w, 1, colormap(t));
    }
    let tx = (width + gap + bar_w + 4) as f32;
    face.draw(&mut img, tx, 2.0, 12.0, &format!("{max:.2e}"), INK);
    face.draw(&mut img, tx, (height as f32 / 2.0) - 6.0, 12.0, &format!("{:.2e}", max / 2.0), INK);
    face.draw(&mut img, tx, height as f32 - 16.0, 12.0, "0", INK);
    face.draw(&mut img, tx, height as f32 / 2.0 + 12.0, 11.0, label, MUTED);
    img
}

/// Writes an [`Image`] as PNG (atomically, like the renders).
pub fn write_png(path: &std::path::Path, img: &Image) -> std::io::Result<()> {
    crate::render::iso::write_png(path, img.width, img.height, &img.rgba)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colormap_runs_from_dark_to_bright() {
        let lum = |c: [u8; 3]| 0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64;
        let mut last = -1.0;
        for i in 0..=20 {
            let l = lum(colormap(i as f64 / 20.0));
            assert!(l > last, "luminance rises along the map");
            last = l;
        }
        assert_eq!(colormap(f64::NAN), colormap(1.0));
        assert_eq!(colormap(-3.0), colormap(0.0));
    }

    #[test]
    fn sheets_place_tiles_and_set_captions() {
        let face = Typeface::dejavu();
        let red = Image::filled(40, 30, [255, 0, 0]);
        let tiles: Vec<Tile> =
            (0..3).map(|i| Tile { image: red.clone(), caption: vec![format!("tile {i}"), "x".into()] }).collect();
        let s = contact_sheet(&face, "Title", &tiles, 2);
        // Two columns, two rows; the first tile's pixels are where they belong.
        assert!(s.width >= 2 * 40 && s.height >= 2 * 30);
        let reds = s.rgba.chunks(4).filter(|p| p[0] == 255 && p[1] == 0 && p[2] == 0).count();
        assert_eq!(reds, 3 * 40 * 30);
        // Text was set: bright pixels exist outside the tiles.
        let ink = s.rgba.chunks(4).filter(|p| p[0] > 200 && p[1] > 200 && p[2] > 200).count();
        assert!(ink > 50, "{ink} text pixels");
    }

    #[test]
    fn error_images_colour_by_value_with_a_bar() {
        let face = Typeface::dejavu();
        let values: Vec<f64> = (0..100).map(|i| (i % 10) as f64).collect();
        let img = error_image(&face, &values, 10, 10, 9.0, "|err|");
        assert_eq!(img.pixel(0, 0)[..3], colormap(0.0));
        assert_eq!(img.pixel(9, 0)[..3], colormap(1.0));
        assert!(img.width > 10 + 18);
    }

    #[test]
    fn crop_zoom_scales_by_nearest_neighbour() {
        let mut img = Image::filled(4, 4, [0, 0, 0]);
        img.fill_rect(1, 1, 1, 1, [9, 9, 9]);
        let z = img.crop_zoom(1, 1, 2, 2, 3);
        assert_eq!((z.width, z.height), (6, 6));
        assert_eq!(z.pixel(2, 2)[..3], [9, 9, 9]);
        assert_eq!(z.pixel(3, 3)[..3], [0, 0, 0]);
    }
}
