//! Text in images: DejaVu Sans (embedded by the `dejavu` crate) rasterised
//! with ab_glyph's outline coverage, blended into an [`Image`].

use super::Image;
use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};

/// A loaded typeface.
pub struct Typeface {
    font: FontRef<'static>,
}

impl Typeface {
    /// DejaVu Sans Regular.
    pub fn dejavu() -> Typeface {
        Typeface {
            font: FontRef::try_from_slice(dejavu::sans::regular())
                .expect("the dejavu crate embeds a valid TrueType font"),
        }
    }

    /// The TrueType bytes (for plotters' font registry).
    pub fn bytes() -> &'static [u8] {
        dejavu::sans::regular()
    }

    /// Advance width of `text` at `px` pixels.
    pub fn width(&self, px: f32, text: &str) -> f32 {
        let f = self.font.as_scaled(PxScale::from(px));
        let mut w = 0.0;
        let mut prev = None;
        for c in text.chars() {
            let id = f.glyph_id(c);
            if let Some(p) = prev {
                w += f.kern(p, id);
            }
            w += f.h_advance(id);
            prev = Some(id);
        }
        w
    }

    /// Sets `text` with its top-left corner at (x, y), `px` pixels high.
    pub fn draw(&self, img: &mut Image, x: f32, y: f32, px: f32, text: &str, rgb: [u8; 3]) {
        let f = self.font.as_scaled(PxScale::from(px));
        let baseline = y + f.ascent();
        let mut caret = x;
        let mut prev = None;
        for c in text.chars() {
            let id = f.glyph_id(c);
            if let Some(p) = prev {
                caret += f.kern(p, id);
            }
            let glyph = id.with_scale_and_position(PxScale::from(px), point(caret, baseline));
            caret += f.h_advance(id);
            prev = Some(id);
            if let Some(outline) = self.font.outline_glyph(glyph) {
                let b = outline.px_bounds();
                outline.draw(|gx, gy, coverage| {
                    img.blend(b.min.x as i64 + gx as i64, b.min.y as i64 + gy as i64, rgb, coverage);
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Glyphs cover pixels where the text is and nowhere else; longer text
    /// is wider.
    #[test]
    fn text_is_rasterised_where_it_is_set() {
        let face = Typeface::dejavu();
        let mut img = Image::filled(120, 30, [0, 0, 0]);
        face.draw(&mut img, 5.0, 5.0, 16.0, "bcc7 RMS", [255, 255, 255]);
        let lit: Vec<(u32, u32)> =
            (0..30).flat_map(|y| (0..120).map(move |x| (x, y))).filter(|&(x, y)| img.pixel(x, y)[0] > 128).collect();
        assert!(lit.len() > 40, "{} pixels", lit.len());
        assert!(lit.iter().all(|&(x, y)| x >= 4 && y >= 4 && (x as f32) < 6.0 + face.width(16.0, "bcc7 RMS")));
        assert!(face.width(16.0, "bcc7 RMS error") > face.width(16.0, "bcc7"));
    }
}
