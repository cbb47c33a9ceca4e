//! SVG plots drawn with plotters (text measured with the embedded DejaVu
//! Sans, registered once as plotters' "sans-serif").

use plotters::prelude::*;
use std::sync::Once;

/// One named curve of (x, y) points.
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The embedded font is valid (Typeface::dejavu parses the same bytes).
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, super::text::Typeface::bytes());
    });
}

/// Why a plot could not be drawn.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PlotError {
    /// No point with a positive x (nothing to draw on a log axis).
    #[error("a log-log plot needs positive x values")]
    NoPositiveX,
    /// No point with a positive y.
    #[error("a log-log plot needs positive y values")]
    NoPositiveY,
    /// No bars, or none positive.
    #[error("a bar chart needs at least one positive value")]
    NoPositiveBar,
    /// plotters failed to lay out or draw the chart.
    #[error("drawing the chart failed: {message}")]
    Draw { message: String },
}

fn draw_error(e: DrawingAreaErrorKind<std::io::Error>) -> PlotError {
    PlotError::Draw { message: e.to_string() }
}

type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

/// A 640 x 420 white SVG canvas handed to `draw`, returned as SVG text.
fn svg(draw: impl FnOnce(&Area) -> Result<(), PlotError>) -> Result<String, PlotError> {
    register_font();
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (640, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_error)?;
        draw(&root)?;
        root.present().map_err(draw_error)?;
    }
    Ok(out)
}

/// The positive range of all points on one axis, padded by a factor for a log axis.
fn log_range(series: &[Series], axis: impl Fn(&(f64, f64)) -> f64) -> Option<(f64, f64)> {
    let vals: Vec<f64> =
        series.iter().flat_map(|s| s.points.iter().map(&axis)).filter(|v| v.is_finite() && *v > 0.0).collect();
    let lo = vals.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = vals.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    (lo.is_finite() && hi.is_finite()).then(|| (lo / 1.3, hi * 1.3))
}

/// A log-log line plot with markers and a legend, as SVG text.
///
/// # Errors
///
/// When no point is positive on both axes (nothing to draw on log axes), or
/// plotters fails to lay the chart out.
pub fn log_log(title: &str, x_label: &str, y_label: &str, series: &[Series]) -> Result<String, PlotError> {
    let (x0, x1) = log_range(series, |p| p.0).ok_or(PlotError::NoPositiveX)?;
    let (y0, y1) = log_range(series, |p| p.1).ok_or(PlotError::NoPositiveY)?;
    svg(|root| {
        let e = draw_error;
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(70)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(e)?;
        for (i, s) in series.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let pts: Vec<(f64, f64)> = s.points.iter().copied().filter(|p| p.0 > 0.0 && p.1 > 0.0).collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(e)?
                .label(s.name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled()))).map_err(e)?;
        }
        chart.configure_series_labels().background_style(WHITE.mix(0.85)).border_style(BLACK).draw().map_err(e)?;
        Ok(())
    })
}

/// A bar chart of named values (linear axis from 0), as SVG text.
///
/// # Errors
///
/// When there are no bars or no positive value, or plotters fails.
pub fn bars(title: &str, y_label: &str, bars: &[(String, f64)]) -> Result<String, PlotError> {
    let top = bars.iter().map(|b| b.1).filter(|v| v.is_finite()).fold(0f64, f64::max);
    if bars.is_empty() || top <= 0.0 {
        return Err(PlotError::NoPositiveBar);
    }
    let n = bars.len();
    svg(|root| {
        let e = draw_error;
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.5f64..n as f64 - 0.5, 0f64..top * 1.15)
            .map_err(e)?;
        let names: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n)
            .x_label_formatter(&|x| {
                let i = x.round();
                if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < names.len() {
                    names[i as usize].clone()
                } else {
                    String::new()
                }
            })
            .y_desc(y_label)
            .y_label_formatter(&|v| format!("{v:.1e}"))
            .draw()
            .map_err(e)?;
        chart
            .draw_series(bars.iter().enumerate().map(|(i, b)| {
                let c = Palette99::pick(i).to_rgba();
                Rectangle::new([(i as f64 - 0.35, 0.0), (i as f64 + 0.35, b.1)], c.filled())
            }))
            .map_err(e)?;
        Ok(())
    })
}

/// Least-squares slope of log y against log x (the measured order of a
/// convergence curve when x is the sample spacing). None with fewer than
/// two positive points.
pub fn log_slope(points: &[(f64, f64)]) -> Option<f64> {
    let l: Vec<(f64, f64)> = points.iter().filter(|p| p.0 > 0.0 && p.1 > 0.0).map(|p| (p.0.ln(), p.1.ln())).collect();
    if l.len() < 2 {
        return None;
    }
    let n = l.len() as f64;
    let (mx, my) = (l.iter().map(|p| p.0).sum::<f64>() / n, l.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = l.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = l.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plots_are_svg_with_their_labels() {
        let s = vec![
            Series { name: "bcc7".into(), points: vec![(10.0, 1e-2), (20.0, 1e-3), (40.0, 1e-4)] },
            Series { name: "fcc6".into(), points: vec![(10.0, 2e-2), (20.0, 4e-3)] },
        ];
        let svg = log_log("RMS vs samples", "samples per axis", "RMS", &s).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("RMS vs samples") && svg.contains("bcc7"));
        assert!(log_log("t", "x", "y", &[Series { name: "z".into(), points: vec![(0.0, 0.0)] }]).is_err());
        let b = bars("evals/s", "evals/s", &[("bcc7".into(), 2.0e7), ("fcc6".into(), 4.0e7)]).unwrap();
        assert!(b.contains("<rect") && b.contains("fcc6"));
        assert!(bars("t", "y", &[]).is_err());
    }

    #[test]
    fn slopes_of_power_laws_are_their_exponents() {
        let pts: Vec<(f64, f64)> = (1..6).map(|i| (i as f64, 3.0 * (i as f64).powi(-4))).collect();
        assert!((log_slope(&pts).unwrap() + 4.0).abs() < 1e-9);
        assert!(log_slope(&pts[..1]).is_none());
    }
}
